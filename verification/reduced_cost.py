"""Issue 32, target 2: the reduced bulk's command against the full bulk's and against the code
of main at 860c990 (the code the issue measured), all timed in one script, alternated.

For the acceptance command ``dam-seismic run koyna --set solver.bulk=B --set
ground_motion.scale=0.2 --set interface.friction=0.8`` (whole record unless ``--duration``):

* new code, ``solver.bulk = "reduced"`` (the default cut-off) and ``"full"``; the OLD checkout
  (``--old``, main at 860c990 checked out beside this one: ``git worktree add --detach DIR
  860c990``) without the key, each as its own process ``python -m ngs_driver run ... --quiet``
  timed from start to exit (the whole run: command to ``summary.json``, figures included);
* before the rounds, one short run of each (not timed): numba's cache of each checkout warm;
* the time loop: ``summary.json`` ``timings.dynamic`` of each run;
* the reduced run's answers against the full bulk's of the same round: the crest displacement
  (``crest_ux``) error over the whole history / its peak (target <= 1 %), and the final heel
  crack (``crack_length_heel``) difference against one heel element (``mesh.h_heel``).

Ratios (target 2): reduced loop / full loop (<= 0.1), reduced whole run / old whole run
(<= 0.25), from the medians over ``--repeat`` rounds; and the reduced command's time outside
its loop (whole - loop: the interpreter, imports, mesh, reduction, static state, figures) over
the old whole run, the whole-run ratio the reduced command would have with a loop of no cost. Prints a JSON line per run and the medians;
``--out`` writes ``reduced_cost.json`` and ``reduced_cost.md``.

    python verification/reduced_cost.py --old /work/wt/old860 --repeat 3 --out D
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

from ngs_driver.post.files import read_csv   # the one reader of a run's tables

HERE = pathlib.Path(__file__).resolve().parent.parent
SETS = ["ground_motion.scale=0.2", "interface.friction=0.8"]


def one(code, bulk, duration) -> dict:
    """One whole command of the checkout ``code`` (bulk None: the key is not given)."""
    sets = SETS + ([f"solver.bulk={bulk}"] if bulk else []) \
        + ([f"time.duration={duration}"] if duration else [])
    d = tempfile.mkdtemp(prefix="reduced_cost_")
    env = dict(os.environ, PYTHONPATH=str(code), OMP_NUM_THREADS="1",
               OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1", MPLBACKEND="Agg")
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "ngs_driver", "run", "koyna", "--quiet", "--out", d,
                    *[a for s in sets for a in ("--set", s)]], env=env, check=True,
                   cwd=str(code))
    wall = time.perf_counter() - t0
    s = json.loads((pathlib.Path(d) / "summary.json").read_text())
    return {"code": str(code), "bulk": bulk or "full (old code)", "whole_s": wall,
            "loop_s": s["timings"]["dynamic"], "outside_s": wall - s["timings"]["dynamic"], "step_median_ms": 1e3 * s["timings"].get(
                "per_step_median", float("nan")), "dofs": (s.get("dofs") or {}).get("nfree"),
            "modes": ((s.get("mesh") or {}).get("bulk") or {}).get("modes_kept"),
            "h_heel": s["scene"]["mesh"]["h_heel"], "load_1min": load, "dir": d}


def accuracy(red, full) -> dict:
    a, b = read_csv(pathlib.Path(red["dir"]) / "timeseries.csv"), \
        read_csv(pathlib.Path(full["dir"]) / "timeseries.csv")
    n = min(a["crest_ux"].size, b["crest_ux"].size)
    err = float(np.max(np.abs(a["crest_ux"][:n] - b["crest_ux"][:n])))
    peak = float(np.max(np.abs(b["crest_ux"][:n])))
    dc = float(abs(a["crack_length_heel"][n - 1] - b["crack_length_heel"][n - 1]))
    return {"crest_err_over_peak": err / peak, "crest_peak_m": peak,
            "heel_crack_reduced_m": float(a["crack_length_heel"][n - 1]),
            "heel_crack_full_m": float(b["crack_length_heel"][n - 1]),
            "heel_crack_diff_m": dc, "heel_crack_ok": bool(dc <= full["h_heel"] * (1 + 1e-9)),
            "crest_ok": bool(err <= 0.01 * peak)}


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--old", required=True, help="checkout of main at 860c990")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--duration", type=float, default=None, help="seconds (default: the record)")
    p.add_argument("--out", default=None)
    a = p.parse_args(argv)
    # a warm-up of each code first (numba compiles into each checkout's own cache on a first
    # run: tens of seconds that no later run pays), not timed
    for code, bulk in ((HERE, "reduced"), (HERE, "full"), (pathlib.Path(a.old), None)):
        one(code, bulk, 0.02)
    runs = []
    for i in range(a.repeat):
        rnd = {}
        for tag, code, bulk in (("reduced", HERE, "reduced"), ("full", HERE, "full"),
                                ("old", pathlib.Path(a.old), None)):
            r = one(code, bulk, a.duration)
            r.update(round=i, which=tag)
            rnd[tag] = r
        rnd["reduced"].update(accuracy(rnd["reduced"], rnd["full"]))
        for r in rnd.values():
            runs.append(r)
            print(json.dumps(r), flush=True)
    med = {t: {k: float(np.median([r[k] for r in runs if r["which"] == t]))
               for k in ("whole_s", "loop_s", "outside_s", "step_median_ms")}
           for t in ("reduced", "full", "old")}
    res = {"medians": med,
           "loop_reduced_over_full": med["reduced"]["loop_s"] / med["full"]["loop_s"],
           "whole_reduced_over_old": med["reduced"]["whole_s"] / med["old"]["whole_s"],
           "outside_reduced_over_old": med["reduced"]["outside_s"] / med["old"]["whole_s"],
           "runs": runs, "old": a.old, "duration": a.duration, "repeat": a.repeat}
    print(json.dumps({k: v for k, v in res.items() if k != "runs"}))
    if a.out:
        out = pathlib.Path(a.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "reduced_cost.json").write_text(json.dumps(res, indent=1))
        L = ["| round | run | DOFs | modes | whole [s] | loop [s] | step median [ms] | "
             "crest err / peak | heel crack red. / full [m] | 1-min load |",
             "|---|---|---|---|---|---|---|---|---|---|"]
        for r in runs:
            acc = (f"{r['crest_err_over_peak']:.1e} | {r['heel_crack_reduced_m']:.3f} / "
                   f"{r['heel_crack_full_m']:.3f}") if "crest_err_over_peak" in r else "– | –"
            L.append(f"| {r['round']} | {r['which']} | {r['dofs']} | {r['modes'] or '–'} | "
                     f"{r['whole_s']:.1f} | {r['loop_s']:.1f} | {r['step_median_ms']:.2f} | "
                     f"{acc} | {r['load_1min']:.2f} |")
        L += ["", f"Medians: reduced loop / full loop = {res['loop_reduced_over_full']:.3f} "
              f"(target ≤ 0.1); reduced whole run / old whole run = "
              f"{res['whole_reduced_over_old']:.3f} (target ≤ 0.25); the reduced run outside "
              f"its loop / old whole run = {res['outside_reduced_over_old']:.3f}."]
        (out / "reduced_cost.md").write_text("\n".join(L) + "\n")
    return res


if __name__ == "__main__":
    main()
