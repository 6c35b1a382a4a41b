"""The cost of the far-field IDA on koyna_engineering (issue 32, target 3), measured and
extrapolated by record length; the reduced bulk's demands against the full bulk's.

Runs a plan of IDA runs -- FEMA P695 far-field components (whole records, ``--window record``),
PGA levels -- one after the other in ONE process through ``studies.ida.execute``, the Dask
task itself (so the model is built once per bulk and reused, ``studies.reuse``, as on a
worker). Each run is measured (wall time of the task: model from the cache or built, static
state, the whole record, demands, ``summary.json``); the plan interleaves runs with
``solver.bulk = "reduced"`` (the default 40 modes) and the same runs with the full bulk.

Extrapolation to the suite (44 components x 10 levels = 440 runs): a least-squares line
wall = a + b T_sim of the reduced runs (T_sim: the simulated seconds, the whole record unless
the run stopped), summed over the 44 components' lengths at 10 levels, as if every run went
to the end of its record (an upper bound: runs that collapse stop early), divided by 2
workers (an even split; one run is at most ~100 s of record). The wall times are those of one
process on the shared 2-core machine; the load (``os.getloadavg``) is written with them.

    python verification/ida_cost.py --out verification/out/ida_cost [--budget SECONDS]
    python verification/ida_cost.py --fast --out D      (koyna_smoke, 0.2 s windows: the test)

``--workers N`` (N >= 2): the runs go to N worker processes at once (``concurrent.futures``,
spawned, one BLAS thread each, each with its own model cache as a Dask worker has), so the
measured walls carry what N simultaneous runs cost each other on the machine's cores; the
extrapolation then divides by N the walls measured that way (no "as if they did not slow each
other"), and the whole batch's elapsed wall is written beside it.

Writes ``runs.jsonl`` (one line per run, appended as it finishes: a cut-off measurement keeps
what it measured), ``ida_cost.md`` (the tables) and ``ida_cost.json``. ``--budget``: no run
is started after this many seconds (the plan is ordered so that a cut leaves both bulks and a
spread of lengths and levels)."""
from __future__ import annotations

import argparse
import concurrent.futures as cf
import json
import math
import multiprocessing as mp
import os
import pathlib
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from ngs_driver.scene import load_scene                      # noqa: E402
from ngs_driver.setup import fema_records as fema             # noqa: E402
from ngs_driver.studies import ida, reuse                     # noqa: E402
from ngs_driver.studies.im import scale_factor                # noqa: E402

SCENE = "koyna_engineering"
LEVELS = tuple(round(0.1 * i, 1) for i in range(1, 11))       # PGA [g]: the 10 stripes
WORKERS = 2
TARGET_H = 2.0
# (record, component, PGA level [g], with the full bulk too): pairs on the shorter records,
# reduced-only on the longer ones; interleaved so that a cut-off budget keeps both kinds
PLAN = [(2, "a", 0.1, True), (22, "b", 0.3, False), (17, "b", 0.3, True), (6, "a", 0.5, False),
        (9, "a", 0.5, True), (14, "b", 0.7, False), (12, "b", 0.7, True), (7, "a", 0.2, False),
        (21, "a", 0.9, True), (4, "b", 0.9, False), (1, "b", 0.2, True), (3, "a", 0.6, False),
        (10, "a", 0.4, True), (11, "a", 0.4, False), (18, "a", 0.6, True), (16, "a", 1.0, False),
        (2, "b", 0.8, True), (15, "b", 0.8, False), (17, "a", 1.0, True), (19, "a", 0.5, False)]
FAST_PLAN = [(2, "a", 0.1, True), (17, "b", 0.3, True)]
FAST_OVERRIDES = ["time.duration=0.2"]
BLOCK = 4


def suite_lengths() -> dict:
    """(record, component) -> the component's length [s] (the whole record's window)."""
    out = {}
    for n in fema.records_of("farfield"):
        for c in fema.COMPONENTS:
            dt, a = fema.read_component("farfield", n, c)
            out[(n, c)] = (a.size - 1) * dt
    return out


def one_run(base, n, comp, level, root, window):
    """One IDA task (``ida.execute``) in this process; returns its measures."""
    address = fema.address("farfield", n, comp)
    unit = ida.run_scene(base, address, 1.0, window)
    im0 = scale_factor(unit, "pga", 1.0)[1]
    sc = ida.run_scene(base, address, level / im0, window)
    rid = ida.run_id("farfield", n, comp, "pga", level, ida.scene_hash(base, window))
    load = os.getloadavg()[0]
    cpu = time.process_time()
    r = ida.execute({"id": rid, "address": address, "scene": sc.to_dict()}, str(root))
    cpu = time.process_time() - cpu         # this process's CPU time: what an idle core gives
    s = json.loads((pathlib.Path(root) / "runs" / rid / "summary.json").read_text()) \
        if r["status"] == "ok" else {}
    steps = (s.get("stopped") or {}).get("step") or s.get("n_steps") or 0
    d = r["demands"]
    return {"record": n, "component": comp, "level_g": level, "scale": level / im0,
            "bulk": sc.solver.bulk, "length_s": sc.time.duration,
            "t_sim_s": steps * sc.time.dt, "status": r["status"], "wall_s": r["wall_s"], "cpu_s": cpu,
            "load_after": os.getloadavg()[0],
            "model_reused": r["model_reused"], "load_1min": load,
            "loop_s": (s.get("timings") or {}).get("dynamic"),
            "slip_residual_m": d["slip_residual_m"], "crack_heel_final_m": d["crack_heel_final_m"],
            "verdict": s.get("verdict"), "id": rid}


_BASES: dict = {}


def worker_run(scene_name, overrides, bulk, n, comp, level, root, window, workers):
    """``one_run`` in a worker process, the base scene loaded once per process and bulk."""
    key = (scene_name, tuple(overrides), bulk)
    if key not in _BASES:
        extra = ['solver.bulk="reduced"'] if bulk == "reduced" else []
        _BASES[key] = load_scene(scene_name, list(overrides) + extra)
    r = one_run(_BASES[key], n, comp, level, root, window)
    r["workers"] = workers
    r["pid"] = os.getpid()
    return r


def fit(rows, key="wall_s"):
    """(a, b) of wall = a + b T_sim by least squares (b alone through 0 with one run);
    key "cpu_s": the process's CPU time instead of the wall time."""
    T = np.array([r["t_sim_s"] for r in rows], float)
    W = np.array([r[key] for r in rows], float)
    if len(rows) < 2 or np.ptp(T) <= 0:
        return 0.0, float(W.sum() / T.sum())
    b, a = np.polyfit(T, W, 1)
    return float(a), float(b)


def extrapolate(rows, lengths, levels=LEVELS, workers=WORKERS, key="wall_s") -> dict:
    a, b = fit(rows, key)
    per_level = sum(a + b * L for L in lengths.values())
    total = per_level * len(levels)
    # the ratio estimator beside the line: sum of the times over sum of the simulated seconds
    ratio = sum(r[key] for r in rows) / sum(r["t_sim_s"] for r in rows)
    return {"a_s": a, "b_s_per_s": b, "runs": len(lengths) * len(levels),
            "ratio_s_per_s": ratio,
            "ratio_h_on_workers": ratio * sum(lengths.values()) * len(levels) / workers / 3600,
            "record_seconds": sum(lengths.values()) * len(levels),
            "sum_wall_s": total, "wall_h_on_workers": total / workers / 3600.0,
            "workers": workers,
            "cost_per_record_s": [r[key] / r["t_sim_s"] for r in rows if r["t_sim_s"]]}


def compare(rows, h_element):
    """The reduced bulk's permanent slip and crack against the full bulk's, run by run."""
    full = {(r["record"], r["component"], r["level_g"]): r for r in rows if r["bulk"] == "full"}
    out = []
    for r in rows:
        f = full.get((r["record"], r["component"], r["level_g"]))
        if r["bulk"] != "reduced" or f is None or "ok" not in (r["status"], f["status"]):
            continue
        ds = abs(r["slip_residual_m"] - f["slip_residual_m"])
        dc = abs(r["crack_heel_final_m"] - f["crack_heel_final_m"])
        out.append({"record": r["record"], "component": r["component"],
                    "level_g": r["level_g"], "slip_full_m": f["slip_residual_m"],
                    "slip_reduced_m": r["slip_residual_m"], "slip_diff_m": ds,
                    "slip_ok": bool(ds <= max(0.02 * abs(f["slip_residual_m"]), 1e-3)),
                    "crack_full_m": f["crack_heel_final_m"],
                    "crack_reduced_m": r["crack_heel_final_m"], "crack_diff_m": dc,
                    "crack_ok": bool(dc <= h_element * (1 + 1e-9)),
                    "wall_full_s": f["wall_s"], "wall_reduced_s": r["wall_s"]})
    return out


def record_row(r, rows, jl):
    """Append a finished run to ``rows`` and to runs.jsonl (a cut-off keeps what it has)."""
    rows.append(r)
    with open(jl, "a", encoding="utf-8") as fh:
        fh.write(json.dumps(r) + "\n")
    print(f"ff{r['record']:02d}{r['component']} {r['level_g']:g} g {r['bulk']}: "
          f"{r['t_sim_s']:.1f} s simulated in {r['wall_s']:.1f} s (load {r['load_1min']:.2f}, "
          f"model reused {r['model_reused']}) slip {r['slip_residual_m']} crack "
          f"{r['crack_heel_final_m']}", flush=True)


def run_workers(todo, a, scene_name, over, out, window, jl, rows, t_start):
    """The runs ``todo`` on ``a.workers`` spawned processes at once (a new run starts when one
    ends, until the budget); returns the batch's elapsed wall [s]."""
    for k in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(k, "1")            # inherited by the spawned workers
    pending = list(todo)
    t0 = time.perf_counter()
    with cf.ProcessPoolExecutor(a.workers, mp_context=mp.get_context("spawn")) as ex:
        running = set()
        while pending or running:
            while pending and len(running) < a.workers:
                if time.perf_counter() - t_start > a.budget:
                    print(f"budget of {a.budget:g} s spent: {len(pending)} runs of the plan "
                          "not started", flush=True)
                    pending = []
                    break
                n, comp, level, bulk = pending.pop(0)
                running.add(ex.submit(worker_run, scene_name, over, bulk, n, comp, level,
                                      str(out / "study"), window, a.workers))
            if not running:
                break
            done, running = cf.wait(running, return_when=cf.FIRST_COMPLETED)
            for f in done:
                record_row(f.result(), rows, jl)
    return time.perf_counter() - t0


def _f(v, spec=".1f"):
    return "-" if v is None else format(v, spec)


def table(rows, ext, cmp_rows, lengths, h_element, command) -> str:
    L = [f"Command: `{command}`", "",
         "| record | length [s] | PGA [g] | scale | bulk | simulated [s] | wall [s] | "
         "wall / simulated s | CPU [s] | model reused | 1-min load before / after | status |",
         "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        L.append(f"| ff{r['record']:02d}{r['component']} | {r['length_s']:.2f} | "
                 f"{r['level_g']:g} | {r['scale']:.3g} | {r['bulk']} | {r['t_sim_s']:.2f} | "
                 f"{r['wall_s']:.1f} | {r['wall_s'] / max(r['t_sim_s'], 1e-9):.3f} | "
                 f"{_f(r.get('cpu_s'))} | "
                 f"{'yes' if r['model_reused'] else 'no'} | {r['load_1min']:.2f} / "
                 f"{_f(r.get('load_after'), '.2f')} | "
                 f"{r['status']} ({r['verdict']}) |")
    L += ["", "Extrapolation (wall or CPU time = a + b T, least squares over the runs of each "
          "bulk, summed "
          f"over the suite's {len(lengths)} lengths ({sum(lengths.values()):.1f} s) x "
          f"{len(LEVELS)} levels, / {WORKERS} workers; every run to the end of its record):", "",
          "| bulk | time | runs fitted | a [s] | b [s per s of record] | 440 runs, sum [h] | "
          f"on {WORKERS} workers [h] | ratio Σtime/ΣT [s per s] | on {WORKERS} workers, ratio "
          f"[h] | target ≤ {TARGET_H:g} h |",
          "|---|---|---|---|---|---|---|---|---|---|"]
    for name, e in ext.items():
        bulk, key = name.split(":")
        worst = max(e["wall_h_on_workers"], e["ratio_h_on_workers"])
        L.append(f"| {bulk} | {'wall' if key == 'wall_s' else 'CPU'} | {e['n']} | "
                 f"{e['a_s']:.2f} | {e['b_s_per_s']:.3f} | "
                 f"{e['sum_wall_s'] / 3600:.2f} | {e['wall_h_on_workers']:.2f} | "
                 f"{e['ratio_s_per_s']:.3f} | {e['ratio_h_on_workers']:.2f} | "
                 f"{'met' if worst <= TARGET_H else 'not met'} |")
    if not cmp_rows:                  # no pair of both bulks (--reduced-only): no table
        return "\n".join(L) + "\n"
    L += ["", f"Reduced against full bulk (slip within 2 % or 1 mm; heel crack within one heel "
          f"element, {h_element:g} m):", "",
          "| record | PGA [g] | slip full [mm] | slip reduced [mm] | diff [mm] | ok | "
          "crack full [m] | crack reduced [m] | ok | wall full / reduced [s] |",
          "|---|---|---|---|---|---|---|---|---|---|"]
    for c in cmp_rows:
        L.append(f"| ff{c['record']:02d}{c['component']} | {c['level_g']:g} | "
                 f"{1e3 * c['slip_full_m']:.3f} | {1e3 * c['slip_reduced_m']:.3f} | "
                 f"{1e3 * c['slip_diff_m']:.3f} | {'yes' if c['slip_ok'] else 'NO'} | "
                 f"{c['crack_full_m']:.3f} | {c['crack_reduced_m']:.3f} | "
                 f"{'yes' if c['crack_ok'] else 'NO'} | {c['wall_full_s']:.1f} / "
                 f"{c['wall_reduced_s']:.1f} |")
    return "\n".join(L) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default=str(ROOT / "verification" / "out" / "ida_cost"))
    p.add_argument("--fast", action="store_true", help="koyna_smoke, 0.2 s windows (tests)")
    p.add_argument("--budget", type=float, default=math.inf,
                   help="no run is started after this many seconds")
    p.add_argument("--first", type=int, default=None, help="only the first N entries of the plan")
    p.add_argument("--reduced-only", action="store_true",
                   help="the plan's runs with the reduced bulk only (a second pass)")
    p.add_argument("--workers", type=int, default=1,
                   help="run N at once in N worker processes (the walls then include what "
                        "simultaneous runs cost each other); 1: one after the other here")
    a = p.parse_args(argv)
    if a.workers < 1:
        p.error(f"--workers {a.workers}: at least 1 is needed")
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    scene_name = "koyna_smoke" if a.fast else SCENE
    plan = FAST_PLAN if a.fast else PLAN
    plan = plan[:a.first] if a.first else plan
    if a.reduced_only:
        plan = [(n, c, lv, False) for n, c, lv, _ in plan]
    window = "scene" if a.fast else "record"
    over = FAST_OVERRIDES if a.fast else []
    bases = {"reduced": load_scene(scene_name, over + ['solver.bulk="reduced"']),
             "full": load_scene(scene_name, over)}
    h_element = bases["full"].mesh.h_heel
    lengths = suite_lengths()
    jl = out / "runs.jsonl"
    rows = [json.loads(x) for x in jl.read_text().splitlines()] if jl.exists() else []
    have = {(r["record"], r["component"], r["level_g"], r["bulk"]) for r in rows}
    t_start = time.perf_counter()
    # in blocks of BLOCK plan entries, the reduced runs first, then the full ones: within a
    # block the model comes from the cache (one scene per process, as on a Dask worker)
    order = [(n, comp, level, bulk) for i in range(0, len(plan), BLOCK)
             for bulk in ("reduced", "full") for n, comp, level, pair in plan[i:i + BLOCK]
             if bulk == "reduced" or pair]
    todo = [o for o in order if o not in have]
    if a.workers > 1:
        batch_wall = run_workers(todo, a, scene_name, over, out, window, jl, rows, t_start)
    else:
        batch_wall = None
        for n, comp, level, bulk in todo:
            if time.perf_counter() - t_start > a.budget:
                print(f"budget of {a.budget:g} s spent: ff{n:02d}{comp} {level:g} g {bulk} "
                      "and the rest of the plan not run", flush=True)
                break
            r = one_run(bases[bulk], n, comp, level, out / "study", window)
            record_row(r, rows, jl)
    if a.fast:     # the fast form extrapolates its own short windows (the arithmetic only)
        lengths = {k: bases["full"].time.duration for k in lengths}
    ext = {}
    for bulk in ("reduced", "full"):
        for key in ("wall_s", "cpu_s"):
            rs = [r for r in rows if r["bulk"] == bulk and r["t_sim_s"] > 0
                  and r.get(key) is not None and r.get("workers", 1) == a.workers]
            hits = [r for r in rs if r["model_reused"]]
            rs = hits if len(hits) >= 2 else rs    # a worker builds its model once in 44 runs
            if rs:
                ext[f"{bulk}:{key}"] = {**extrapolate(rs, lengths, key=key), "n": len(rs)}
    cmp_rows = compare(rows, h_element)
    command = ("python verification/ida_cost.py" + (" --fast" if a.fast else "")
               + f" --out {a.out}" + ("" if math.isinf(a.budget) else f" --budget {a.budget:g}")
               + (" --reduced-only" if a.reduced_only else "")
               + (f" --workers {a.workers}" if a.workers > 1 else ""))
    md = table(rows, ext, cmp_rows, lengths, h_element, command)
    if batch_wall is not None:
        md += (f"\n{a.workers} worker processes at once: this batch's elapsed wall "
               f"{batch_wall:.1f} s for {sum(1 for r in rows if r.get('workers') == a.workers)} "
               "runs (rows with this worker count).\n")
    (out / "ida_cost.md").write_text(md)
    (out / "ida_cost.json").write_text(json.dumps(
        {"rows": rows, "extrapolation": ext, "comparison": cmp_rows, "scene": scene_name,
         "workers": a.workers, "batch_wall_s": batch_wall,
         "levels_g": LEVELS, "h_element_m": h_element, "reuse": reuse.stats()}, indent=1))
    print(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
