"""Runs of the non-Koyna scene kinds (``kind = "material_point"`` and ``kind = "dcb"``).

A material-point scene never imports NGSolve: it builds only the law its [interface] table asks
for (no friction kernel when friction = 0 or contact = "none", no damage kernel when
damage = false) and drives one point along an ``interfacelaw.drivers`` path. Outputs:
``history.csv``, ``traction_gap.png``, ``summary.json`` (written last, atomically).
"""
from __future__ import annotations

import math
import pathlib
import time

import numpy as np

from interfacelaw import drivers as dr
from interfacelaw.drivers import cycles_to_failure

from ..post.files import atomic_write_json, environment_info
from ..setup import build_law, law_parts


def describe_point(scene) -> dict:
    return {"scene": scene.to_dict(),
            "will_build": {"kind": "material_point", "ngsolve": False,
                           "law": law_parts(scene), "path": scene.path.type}}


def _path_history(law, p):
    c = law.cohesive
    psi = math.radians(p.psi_deg)
    if p.type == "mode_I":
        return dr.mode_I(law, p.n, p.lam_end)
    if p.type == "mode_II":
        return dr.mode_II(law, p.n, p.lam_end)
    if p.type == "mixed":
        return dr.mixed_mode(law, psi, p.n, p.lam_end)
    if p.type == "load_unload_reload":
        return dr.load_unload_reload(law, p.lam_unload, p.lam_end, psi, p.n)
    if p.type == "closure_reopening":
        return dr.closure_reopening(law, p.lam_unload, p.closure, p.lam_end, p.n)
    if p.type == "cycles":
        return dr.constant_amplitude_cycles(law, p.amplitude * c.l_Nc, p.R, p.n_cycles, p.n, psi)
    if p.type == "shear_under_pressure":
        if law.contact is None:
            raise ValueError("path.type = 'shear_under_pressure' needs interface.contact "
                             "'linear' or 'rough'; allowed: a law with contact")
        return dr.shear_under_pressure(law, p.pressure, p.amplitude * c.l_Tc, p.n_cycles, p.n)
    raise ValueError(f"path.type = {p.type!r}: not allowed")     # validated before


def run_point(scene, outdir) -> dict:
    """Drive one interface point along the scene's path; returns the summary dict."""
    t0 = time.perf_counter()
    law = build_law(scene)
    h = _path_history(law, scene.path)
    wall = time.perf_counter() - t0
    out = pathlib.Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    h.to_csv(out / "history.csv")
    files = ["history.csv"]
    try:
        # deferred: matplotlib loads only when a figure is drawn
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(1, 2, figsize=(10, 4))
        for j, lab in enumerate(("N", "T")):
            ax[j].plot(1e3 * h.gap[:, j], 1e-6 * h.traction[:, j], lw=1)
            ax[j].set_xlabel(f"g_{lab} [mm]")
            ax[j].set_ylabel(f"F_{lab} [MPa]")
            ax[j].grid(alpha=0.3)
        fig.suptitle(f"{scene.name}: {scene.path.type} ({law_parts(scene)})", fontsize=7)
        fig.tight_layout()
        fig.savefig(out / "traction_gap.png", dpi=110)
        plt.close(fig)
        files.append("traction_gap.png")
    except ImportError:                     # matplotlib is in the fe extra
        pass
    c = law.cohesive
    res = {"peak_normal_traction": float(np.max(h.traction[:, 0])),
           "peak_shear_traction": float(np.max(np.abs(h.traction[:, 1]))),
           "dissipated_final": float(np.ravel(h.dissipated)[-1]),
           "work_final": float(np.ravel(h.work)[-1]),
           "damage_final": float(np.ravel(h.damage)[-1]),
           "lambda_h_final": float(np.ravel(h.lambda_h)[-1]),
           "converged": bool(h.converged), "message": h.message,
           "G_I": c.G_I, "G_II": c.G_II,
           "G_mixed_at_psi": float(c.G_mixed(math.radians(scene.path.psi_deg)))}
    if scene.path.type == "cycles":
        nf = cycles_to_failure(h)
        res["cycles_to_failure"] = None if not np.isfinite(nf) else float(nf)
    summary = {"scene": scene.to_dict(), "law": law_parts(scene), "results": res,
               "timings": {"path": wall}, "files": files, "environment": environment_info()}
    atomic_write_json(out / "summary.json", summary)
    return summary


