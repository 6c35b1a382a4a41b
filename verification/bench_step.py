"""The median wall time of one solver step and of one run step, on the Koyna 0.2x scene with a
frictional interface, for the code of whatever checkout is first on the import path: run it
once with PYTHONPATH at the old checkout and once at the new one, back to back, to compare a
refactor's speed (BENCHMARKS.md "Step time before and after").

    PYTHONPATH=/path/to/checkout python verification/bench_step.py [--duration 2] [--repeat 1]

The scene is `koyna --set ground_motion.scale=0.2 --set interface.friction=0.8 --set
time.duration=D`; the run is prepared with the run's own set-up (``run.analysis.prepare``,
no plots), its static state solved, then every step is run by ``Analysis.step`` with the
solver's ``step`` timed around each call (the first 20 steps, which compile and factorise,
are left out of the medians). Prints one JSON line: the code's path, the medians [ms], the
steps, the Newton iterations, and the machine's load average at the start and the end.
"""
from __future__ import annotations

import argparse
import gc
import json
import os
import pathlib
import time

import numpy as np

import ngs_driver
# the script's own folder is first on the path: step_cost, beside it, imports the same checkout
from step_cost import prepared_koyna

WARM = 20            # first steps left out (numba compiles, the step's factorisation)


def measure(duration: float) -> dict:
    a, solver_ms = prepared_koyna(["ground_motion.scale=0.2", "interface.friction=0.8",
                                   f"time.duration={duration}"], "bench_step_")
    s = a.solver
    run_ms = []
    gc.freeze()
    try:
        while True:
            t0 = time.perf_counter()
            more = a.step()
            run_ms.append(1e3 * (time.perf_counter() - t0))
            if not more:
                break
    finally:
        a.close()
        gc.unfreeze()
    its = sum(r.iterations for r in s.history[1:])
    a.release()
    return {"code": str(pathlib.Path(ngs_driver.__file__).parent.parent),
            "solver_step_median_ms": float(np.median(solver_ms[WARM:])),
            "run_step_median_ms": float(np.median(run_ms[WARM:])),
            "steps": len(run_ms), "newton_iterations": int(its),
            "crest_u_last": float(np.abs(s.u).max())}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--duration", type=float, default=2.0)
    p.add_argument("--repeat", type=int, default=1)
    args = p.parse_args(argv)
    load0 = os.getloadavg()[0]
    runs = [measure(args.duration) for _ in range(args.repeat)]
    best = min(runs, key=lambda r: r["solver_step_median_ms"])
    best["repeats"] = [r["solver_step_median_ms"] for r in runs]
    best["load_start"], best["load_end"] = load0, os.getloadavg()[0]
    print(json.dumps(best))
    return best


if __name__ == "__main__":
    main()
