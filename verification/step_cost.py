"""What one time step of a run costs against its own linear algebra (issue FAST, target 1).

For the Koyna 0.2x scene with a frictional interface (``koyna --set ground_motion.scale=0.2
--set interface.friction=0.8 --set time.duration=D``), in one process, for the code of whatever
checkout is first on the import path:

* the run is prepared with the run's own set-up (``run.analysis.prepare``, no plots), its
  static state solved, every step run by ``Analysis.step`` and timed (mean and median of the
  loop's steps, the first WARM left out: numba compiles and the step's factorisation);
* the solver's ``step`` is timed around each call (median);
* after the loop, ONE forward + backward solve of the solver's own factor of the nominal step's
  effective matrix (the sparse LDL^T of ``SparseFactor``; with the deformation damping the
  sparse part A_s that the Woodbury correction wraps) is timed REPS times on a fixed
  right-hand side (median);
* ratio = median run step / median forward+backward (target <= 2.5).

``--profile FILE``: the time loop (not set-up or static) under cProfile, stats to FILE.
``--elastic``: the same command on the interface's elastic branch (record x 0.001, no damage).
Prints one JSON line (times in ms, the machine's load average at the start and the end).

    PYTHONPATH=/path/to/checkout python verification/step_cost.py [--duration 4]
"""
from __future__ import annotations

import argparse
import cProfile
import gc
import json
import os
import pathlib
import tempfile
import time

import numpy as np

import ngs_driver
from ngs_driver.post.outputs import RunOutputs
from ngs_driver.run.analysis import prepare
from ngs_driver.scene import load_scene

WARM = 20            # first steps left out (numba compiles, the step's factorisation)
REPS = 400           # forward + backward solves timed


def sets(duration: float, elastic: bool) -> list:
    if elastic:
        return ["ground_motion.scale=0.001", "interface.friction=0.8", "interface.damage=false",
                f"time.duration={duration}"]
    return ["ground_motion.scale=0.2", "interface.friction=0.8", f"time.duration={duration}"]


def fb_time(factor) -> float:
    """Median [ms] of one forward + backward solve of the sparse factor behind ``factor``."""
    F = getattr(factor, "F", factor)              # LowRankFactor wraps the sparse one
    b = np.random.default_rng(0).standard_normal(F.shape[0])
    F.backward(F.forward(b))                      # compiled already; warm the caches
    ts = []
    for _ in range(REPS):
        t0 = time.perf_counter()
        F.backward(F.forward(b))
        ts.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(ts))


def measure(duration: float, elastic: bool = False, profile: str | None = None) -> dict:
    sc = load_scene("koyna", sets(duration, elastic))
    out = pathlib.Path(tempfile.mkdtemp(prefix="step_cost_"))
    t_all = time.perf_counter()
    a = prepare(sc, out, outputs=RunOutputs(plots=False), progress=False,
                log=lambda *x, **k: None)
    a.static()
    s = a.solver
    solver_ms, run_ms = [], []
    step = s.step

    def timed(*args, **kw):
        t0 = time.perf_counter()
        try:
            return step(*args, **kw)
        finally:
            solver_ms.append(1e3 * (time.perf_counter() - t0))
    s.step = timed                  # the instance's step: the class's method, timed
    prof = cProfile.Profile() if profile else None
    gc.freeze()
    t_loop = time.perf_counter()
    try:
        if prof is not None:
            prof.enable()
        while True:
            t0 = time.perf_counter()
            more = a.step()
            run_ms.append(1e3 * (time.perf_counter() - t0))
            if not more:
                break
        if prof is not None:
            prof.disable()
        t_loop = time.perf_counter() - t_loop
        fb = fb_time(s.newton.steps[float(s.dt)].factor)
    finally:
        a.close()
        gc.unfreeze()
    if prof is not None:
        prof.dump_stats(profile)
    its = sum(r.iterations for r in s.history[1:])
    crest = float(np.abs(s.u).max())
    a.release()
    run = np.asarray(run_ms[WARM:])
    return {"code": str(pathlib.Path(ngs_driver.__file__).parent.parent), "elastic": elastic,
            "duration": duration, "steps": len(run_ms), "newton_iterations": int(its),
            "loop_s": t_loop, "prepare_static_loop_s": time.perf_counter() - t_all,
            "run_step_mean_ms": float(run.mean()), "run_step_median_ms": float(np.median(run)),
            "solver_step_median_ms": float(np.median(solver_ms[WARM:])),
            "fwd_bwd_ms": fb, "ratio_median": float(np.median(run)) / fb,
            "ratio_mean": float(run.mean()) / fb, "crest_u_last": crest}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--duration", type=float, default=4.0)
    p.add_argument("--elastic", action="store_true")
    p.add_argument("--profile", default=None)
    args = p.parse_args(argv)
    load0 = os.getloadavg()[0]
    r = measure(args.duration, args.elastic, args.profile)
    r["load_start"], r["load_end"] = load0, os.getloadavg()[0]
    print(json.dumps(r))
    return r


if __name__ == "__main__":
    main()
