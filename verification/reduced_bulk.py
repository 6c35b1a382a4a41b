"""Error against run time of the reduced bulk (``solver.bulk = "reduced"``, fe/reduction.py;
docs/reduced_bulk.md): the full and the reduced bulk side by side against the number of
fixed-interface modes kept, on

* Koyna, f = 0.8, 0.2x the synthetic record (``dam-seismic run koyna --set
  ground_motion.scale=0.2 --set interface.friction=0.8``), the whole 10 s of the scene (the
  fast form: koyna_smoke, 0.1 s);
* Koyna, f = 0.8, the full record (the base cracks through at 1.2 s and slides ~0.18 m with
  re-pairings: finite sliding on the reduced bulk), with ``MODES_FULL_INTENSITY``;
* the scenes koyna_engineering (massless rock, drains), koyna_1967 (a lift joint at the neck,
  the finite-rotation kinematics) and pine_flat (Taft, 54 s), as shipped, with
  ``MODES_FULL_INTENSITY``;
* the sliding block (scenes/sliding_block.toml: 40 x 10 m block, cracked base f = 0.5, 0.8 g
  half-sine pulse).

For each: the crest displacement's largest error over the history relative to its peak, the
final crack length from the heel, the permanent slip, the energy residual (largest |residual|
over the history relative to the largest |W_ext|), the time loop's wall time and the whole
run's (build, reduction, modal analysis, static state, loop, outputs: the ``run`` call). Writes
reduced_bulk.md (the table) and reduced_bulk.png.

    python -m verification.run_all --only reduced_bulk            (make verify)
"""
from __future__ import annotations

import os
import pathlib
import time

import numpy as np

from ngs_driver.apps.dam import run
from ngs_driver.post.files import read_csv
from ngs_driver.scene import load_scene

MODES = (10, 20, 40, 80)
MODES_FAST = (5, 20)
MODES_FULL_INTENSITY = (20, 40)


def _one(scene, out):
    t0 = time.perf_counter()
    s = run(scene, out, progress=False, plots=False)
    wall = time.perf_counter() - t0
    h = read_csv(pathlib.Path(out) / "timeseries.csv")
    cols = {k: np.asarray(h[k], float) for k in ("crest_ux", "crest_uy", "base_slip",
                                                  "base_crack_length_upstream", "residual",
                                                  "W_ext")}
    return s, cols, wall


def _row(name, label, s, c, wall, ref=None):
    W = max(np.abs(c["W_ext"]).max(), 1e-300)
    row = {"case": name, "bulk": label,
           "dofs": int(s["dofs"]["nfree"]),
           "modes": (s["mesh"].get("bulk") or {}).get("modes_kept"),
           "f_max_hz": (s["mesh"].get("bulk") or {}).get("highest_mode_hz"),
           "crest_peak_m": float(np.abs(c["crest_ux"]).max()),
           "crest_err": None,
           "crack_m": float(c["base_crack_length_upstream"][-1]),
           "slip_m": float(c["base_slip"][-1]),
           "repairings": int(s["finite_sliding"]["repairings"]),
           "energy_residual": float(np.abs(c["residual"]).max() / W),
           "loop_s": float(s["timings"]["dynamic"]),
           "per_step_ms": 1e3 * float(s["timings"]["per_step_median"]),
           "run_s": float(wall)}
    if ref is not None:
        rc = ref[1]
        n = min(rc["crest_ux"].size, c["crest_ux"].size)
        err = np.abs(c["crest_ux"][:n] - rc["crest_ux"][:n]).max()
        row["crest_err"] = float(err / np.abs(rc["crest_ux"]).max())
    return row


def _fmt(v, f):
    return "-" if v is None else format(v, f)


def main(fast: bool = False, outdir="results/verification/reduced_bulk") -> dict:
    out = pathlib.Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    modes = MODES_FAST if fast else MODES
    koyna = (("koyna_smoke", []) if fast else
             ("koyna", ["ground_motion.scale=0.2", "interface.friction=0.8"]))
    cases = {"koyna_f0.8_0.2x" if not fast else "koyna_smoke": (koyna, modes)}
    if not fast:
        cases["koyna_f0.8_1.0x"] = (("koyna", ["interface.friction=0.8"]), MODES_FULL_INTENSITY)
        for sc_name in ("koyna_engineering", "koyna_1967", "pine_flat"):
            cases[sc_name] = ((sc_name, []), MODES_FULL_INTENSITY)
    cases["sliding_block"] = (("sliding_block", []), modes)
    rows = []
    for name, ((scene_name, sets), counts) in cases.items():
        ref = _one(load_scene(scene_name, sets), out / f"{name}_full")
        rows.append(_row(name, "full", *ref))
        for n in counts:
            r = _one(load_scene(scene_name, sets + ["solver.bulk=reduced",
                                                    f"solver.bulk_modes={n}"]),
                     out / f"{name}_r{n}")
            rows.append(_row(name, "reduced", *r, ref=ref))
    load = os.getloadavg()
    lines = ["# Reduced bulk: error against run time", "",
             "Koyna: `dam-seismic run koyna --set ground_motion.scale=0.2 --set "
             "interface.friction=0.8` (10 s, 5 000 steps); run = the `run` call in one "
             "process (build, reduction, static, loop, outputs without PNGs)" if not fast else
             "Fast form: koyna_smoke (0.1 s).",
             "", f"Load average at the end (1/5/15 min): {load[0]:.2f} / {load[1]:.2f} / "
             f"{load[2]:.2f}; one BLAS thread.", "",
             "| case | bulk | DOFs | modes | f_max [Hz] | crest err / peak | crest peak [m] "
             "| heel crack [m] | slip [m] | re-pairings | energy residual | loop [s] "
             "| step median [ms] | run [s] |", "|" + "---|" * 14]
    for r in rows:
        lines.append(f"| {r['case']} | {r['bulk']} | {r['dofs']} | {_fmt(r['modes'], 'd')} | "
                     f"{_fmt(r['f_max_hz'], '.1f')} | {_fmt(r['crest_err'], '.2e')} | "
                     f"{r['crest_peak_m']:.4e} | {r['crack_m']:.3f} | {r['slip_m']:.4e} | "
                     f"{r['repairings']} | "
                     f"{r['energy_residual']:.1e} | {r['loop_s']:.2f} | "
                     f"{r['per_step_ms']:.2f} | {r['run_s']:.2f} |")
    (out / "reduced_bulk.md").write_text("\n".join(lines) + "\n")
    try:
        import matplotlib.pyplot as plt      # optional: the figure only where it is installed
        fig, ax = plt.subplots(1, 2, figsize=(9, 3.5))
        for name in cases:
            rr = [r for r in rows if r["case"] == name and r["bulk"] == "reduced"]
            full = next(r for r in rows if r["case"] == name and r["bulk"] == "full")
            ax[0].semilogy([r["modes"] for r in rr], [max(r["crest_err"], 1e-16) for r in rr],
                           "o-", label=name)
            ax[1].plot([r["modes"] for r in rr], [r["loop_s"] / full["loop_s"] for r in rr],
                       "o-", label=name)
        ax[0].set_xlabel("modes kept")
        ax[0].set_ylabel("crest error / peak")
        ax[1].set_xlabel("modes kept")
        ax[1].set_ylabel("time loop, reduced / full")
        ax[0].legend()
        fig.tight_layout()
        fig.savefig(out / "reduced_bulk.png", dpi=110)
        plt.close(fig)
    except ImportError:
        pass
    return {"rows": rows, "load": load}
