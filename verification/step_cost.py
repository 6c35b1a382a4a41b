"""What one time step of a run costs against its own linear algebra: the ratio of a step to
one forward + backward solve of its factor.

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

``--parts``: also the median of each part of a step (each public method timed around its
calls: the solver's step, its right-hand side, the water's rhs and commit, the condensed
Newton's attempt, the factor's halves, the commit, the energy budget with its products, the
run's measures); what no part covers is the run's own Python (``rest``).
``--profile FILE``: the time loop (not set-up or static) under cProfile, stats to FILE.
``--elastic``: the same command on the interface's elastic branch (record x 0.001, no damage).
``--scene NAME --set KEY=VALUE ...``: another scene (its own keys and ``time.duration``; the
Koyna 0.2x f 0.8 keys only for koyna) or further overrides, e.g. ``--scene koyna_engineering
--set solver.bulk=reduced --parts`` (BENCHMARKS.md "Step products and bookkeeping").
Prints one JSON line (times in ms, the machine's load average at the start and the end).

``--compare OLD --repeat N``: alternates N times the old checkout OLD and this one (each in a
subprocess with its own PYTHONPATH): the measurement above, frictional and elastic, and the
whole command ``python -m ngs_driver run koyna ... --quiet`` timed from start to exit; prints
each run and the medians (BENCHMARKS.md "A compiled step").

``--floor --repeat N``: the Koyna 0.2x command with the full and the reduced bulk, alternated N
times (subprocesses, ``--parts``), and the step's floor (``floor_table``): what its compiled
parts alone cost against issue 32's targets 1 and 2 (BENCHMARKS.md "FAST (issue 32)").

    PYTHONPATH=/path/to/checkout python verification/step_cost.py [--duration 4]
    python verification/step_cost.py --compare /path/to/old/checkout --repeat 3
    python verification/step_cost.py --floor --repeat 2
"""
from __future__ import annotations

import argparse
import cProfile
import gc
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

import ngs_driver
from ngs_driver.post.outputs import RunOutputs
from ngs_driver.run.analysis import prepare
from ngs_driver.scene import load_scene
from ngs_driver.solve.damping import LowRankFactor

WARM = 20            # first steps left out (numba compiles, the step's factorisation)
REPS = 400           # forward + backward solves timed


def sets(duration: float, elastic: bool, scene: str = "koyna", extra=()) -> list:
    """The overrides of the measured command (module docstring)."""
    if scene != "koyna":
        return [f"time.duration={duration}", *extra]
    if extra:
        return sets(duration, elastic) + list(extra)
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


def timer(parts: dict, obj, name: str, label: str):
    """Time every call of ``obj.name`` into parts[label] (an instance's or a class's method)."""
    fn = getattr(obj, name)
    out = parts.setdefault(label, [])

    def timed(*args, **kw):
        t0 = time.perf_counter()
        try:
            return fn(*args, **kw)
        finally:
            out.append(1e3 * (time.perf_counter() - t0))
    setattr(obj, name, timed)
    return fn


def wrap_parts(a, parts: dict) -> list:
    """Timers on the parts of a step (``--parts``); returns what to put back."""
    s = a.solver
    undo = []
    for obj, name, label in (
            (s, "right_hand_side", "solver: right-hand side (with the water's)"),
            (s.coupled, "rhs", "  water: rhs (its own solve)"),
            (s.newton, "attempt", "solver: condensed Newton attempt"),
            (LowRankFactor, "forward", "  factor: forward (+ low-rank)"),
            (LowRankFactor, "backward", "  factor: backward"),
            (LowRankFactor, "backward_at", "  factor: backward at the interface"),
            (LowRankFactor, "forward_sparse", "  factor: forward from the interface"),
            (s.control, "solve", "  Newton loop on the gaps"),
            (s, "commit", "solver: commit (with the water's)"),
            (s.coupled, "commit", "  water: commit"),
            (s, "step_products", "run: step products (K u, M v; next rhs' M x, C y, C v)"),
            (a.energy, "step", "run: energy budget"),
            (a.joints, "scan", "run: joints scan"),
            (a.joints, "measures", "run: joints measures"),
            (a.history, "append", "run: history row"),
            (a.safety, "step_measures", "run: safety measures"),
            (a.stop_rule, "check", "run: stop rule"),
            (a.guard, "check", "run: energy guard"),
            (a.pairing, "update", "run: pairing (finite sliding)")):
        if obj is None:
            continue
        undo.append((obj, name, timer(parts, obj, name, label), isinstance(obj, type)))
    if a.reservoir is not None:
        undo.append((a.reservoir, "sample",
                     timer(parts, a.reservoir, "sample", "run: reservoir sample"), False))
    return undo


def prepared_koyna(overrides: list, prefix: str, scene: str = "koyna"):
    """The koyna scene (or ``scene``) with ``overrides`` prepared (no figures) and its static
    state solved, its solver's ``step`` timed into the returned list [ms] (the instance's step:
    the class's method, timed). Also used by verification/bench_step.py."""
    sc = load_scene(scene, overrides)
    out = pathlib.Path(tempfile.mkdtemp(prefix=prefix))
    a = prepare(sc, out, outputs=RunOutputs(plots=False), progress=False,
                log=lambda *x, **k: None)
    a.static()
    timed = {}
    timer(timed, a.solver, "step", "solver step")
    return a, timed["solver step"]


def measure(duration: float, elastic: bool = False, profile: str | None = None,
            parts: bool = False, scene: str = "koyna", extra=()) -> dict:
    t_all = time.perf_counter()
    a, solver_ms = prepared_koyna(sets(duration, elastic, scene, extra), "step_cost_", scene)
    s = a.solver
    run_ms = []
    pt = {}
    undo = wrap_parts(a, pt) if parts else []
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
        for obj, name, fn, cls in undo:
            if cls:
                setattr(obj, name, fn)          # the class's method back
            else:
                delattr(obj, name)              # the instance's timer removed
        a.close()
        gc.unfreeze()
    if prof is not None:
        prof.dump_stats(profile)
    its = sum(r.iterations for r in s.history[1:])
    crest = float(np.abs(s.u).max())
    a.release()
    run = np.asarray(run_ms[WARM:])
    return {"code": str(pathlib.Path(ngs_driver.__file__).parent.parent), "scene": scene,
            "overrides": sets(duration, elastic, scene, extra), "elastic": elastic,
            "duration": duration, "steps": len(run_ms), "newton_iterations": int(its),
            "loop_s": t_loop, "prepare_static_loop_s": time.perf_counter() - t_all,
            "run_step_mean_ms": float(run.mean()), "run_step_median_ms": float(np.median(run)),
            "solver_step_median_ms": float(np.median(solver_ms[WARM:])),
            "fwd_bwd_ms": fb, "ratio_median": float(np.median(run)) / fb,
            "ratio_mean": float(run.mean()) / fb, "crest_u_last": crest,
            **({"parts_median_ms": {k: float(np.median(v[WARM:] if len(v) > 2 * WARM else v))
                                    for k, v in pt.items()},
                "parts_calls": {k: len(v) for k, v in pt.items()}} if parts else {})}


HERE = pathlib.Path(__file__).resolve().parent.parent


def _sub(code, argv) -> tuple[float, str]:
    """(wall [s], stdout) of ``python argv`` with PYTHONPATH = code."""
    env = dict(os.environ, PYTHONPATH=str(code))
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, *argv], env=env, capture_output=True, text=True,
                       check=True)
    return time.perf_counter() - t0, r.stdout


def compare(old: str, repeat: int, duration: float) -> dict:
    """Old and this checkout alternated ``repeat`` times (module docstring)."""
    rows = {}
    for i in range(repeat):
        for tag, code in (("old", old), ("new", HERE)):
            for elastic in (False, True):
                key = f"{tag}{'_elastic' if elastic else ''}"
                _, out = _sub(code, [__file__, "--duration", str(duration)]
                              + (["--elastic"] if elastic else []))
                m = json.loads(out.strip().splitlines()[-1])
                with tempfile.TemporaryDirectory(prefix="step_cost_run_") as d:
                    wall, _ = _sub(code, ["-m", "ngs_driver", "run", "koyna", "--quiet",
                                          "--overwrite", "--out", d]
                                   + [a for x in sets(duration, elastic) for a in ("--set", x)])
                m["whole_run_s"] = wall
                m["load_now"] = os.getloadavg()[0]
                rows.setdefault(key, []).append(m)
                print(json.dumps({"repeat": i, "which": key, **m}), flush=True)
    keys = ("run_step_median_ms", "run_step_mean_ms", "solver_step_median_ms", "fwd_bwd_ms",
            "ratio_median", "ratio_mean", "loop_s", "whole_run_s")
    med = {k: {q: float(np.median([m[q] for m in v])) for q in keys} for k, v in rows.items()}
    for tag in ("old", "new"):
        med[tag]["whole_over_elastic"] = (med[tag]["whole_run_s"]
                                          / med[f"{tag}_elastic"]["whole_run_s"])
        med[tag]["loop_over_elastic"] = med[tag]["loop_s"] / med[f"{tag}_elastic"]["loop_s"]
    print(json.dumps({"medians": med, "old": old, "new": str(HERE), "duration": duration,
                      "repeat": repeat}))
    return med


PRODUCTS = "run: step products (K u, M v; next rhs' M x, C y, C v)"
WATER = ("  water: rhs (its own solve)", "  water: commit")
NEWTON = "  Newton loop on the gaps"


def floor_parts(m: dict) -> dict:
    """One ``--parts`` measurement grouped [ms, medians]: the factor's halves (full and
    partial), the step's products, the water's own solve and commit, the Newton loop on the
    gaps, the energy budget, the run's other parts; ``compiled`` = halves + products + water
    (the linear algebra of the step as it is formulated, each a compiled call)."""
    p = m["parts_median_ms"]
    g = {"halves": sum(v for k, v in p.items() if k.strip().startswith("factor:")),
         "products": p[PRODUCTS],
         "water": sum(p.get(k, 0.0) for k in WATER),
         "newton": p[NEWTON],
         "energy": p["run: energy budget"],
         "run_parts": sum(v for k, v in p.items()
                          if k.startswith("run:") and k not in (PRODUCTS, "run: energy budget"))}
    g["compiled"] = g["halves"] + g["products"] + g["water"]
    return g


def floor_table(full: dict, reduced: dict) -> dict:
    """The floors of issue 32's targets from one full-bulk and one reduced-bulk ``--parts``
    measurement of the same command:

    * target 1 (full step <= 2.5 fb): the full step's compiled parts, and those plus its
      Newton loop, over one forward + backward solve (fb) -- what the step would cost with no
      Python between the calls, no energy budget and no bookkeeping;
    * target 2 (reduced loop <= 0.1 x the full loop): the reduced step's bulk alone (its
      factor's halves and its products: the Craig-Bampton matrices, dense on the joints' DOFs)
      against 0.1 x the full step's median."""
    f, r = floor_parts(full), floor_parts(reduced)
    fb = full["fwd_bwd_ms"]
    budget2 = 0.1 * full["run_step_median_ms"]
    return {"full": f, "reduced": r, "fwd_bwd_ms": fb,
            "full_step_over_fb": full["run_step_median_ms"] / fb,
            "full_compiled_over_fb": f["compiled"] / fb,
            "full_compiled_newton_over_fb": (f["compiled"] + f["newton"]) / fb,
            "target2_step_budget_ms": budget2,
            "reduced_bulk_ms": r["halves"] + r["products"],
            "reduced_bulk_over_budget": (r["halves"] + r["products"]) / budget2,
            "reduced_step_over_full_step": (reduced["run_step_median_ms"]
                                            / full["run_step_median_ms"])}


def floor(repeat: int, duration: float) -> list:
    """``--floor``: full and reduced bulk alternated ``repeat`` times, each a subprocess of
    this script with ``--parts``; one ``floor_table`` per round (printed as JSON lines)."""
    out = []
    for i in range(repeat):
        m = {}
        for bulk in ("full", "reduced"):
            _, o = _sub(HERE, [__file__, "--duration", str(duration), "--parts",
                               "--set", f"solver.bulk={bulk}"])
            m[bulk] = json.loads(o.strip().splitlines()[-1])
        row = {"round": i, **floor_table(m["full"], m["reduced"]),
               "load": [m["full"]["load_start"], m["reduced"]["load_end"]]}
        print(json.dumps(row), flush=True)
        out.append(row)
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--duration", type=float, default=4.0)
    p.add_argument("--elastic", action="store_true")
    p.add_argument("--profile", default=None)
    p.add_argument("--parts", action="store_true")
    p.add_argument("--compare", default=None)
    p.add_argument("--floor", action="store_true")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--scene", default="koyna")
    p.add_argument("--set", action="append", default=[], dest="extra", metavar="KEY=VALUE")
    args = p.parse_args(argv)
    if args.compare:
        return compare(args.compare, args.repeat, args.duration)
    if args.floor:
        return floor(args.repeat, args.duration)
    load0 = os.getloadavg()[0]
    r = measure(args.duration, args.elastic, args.profile, args.parts, args.scene, args.extra)
    r["load_start"], r["load_end"] = load0, os.getloadavg()[0]
    print(json.dumps(r))
    return r


if __name__ == "__main__":
    main()
