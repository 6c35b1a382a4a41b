"""Where a cold-cache ``make test`` spends its time: numba compilations and CPU per test file.

Opt-in (tests/conftest.py installs it when ``NUMBA_COMPILE_LOG`` names a folder); each test
process appends JSON lines to ``<folder>/<pid>.jsonl``:

- one per numba compilation (numba's event API, ``numba:compile``): the function, its type
  signature, the test file that triggered it, and its CPU seconds (``time.process_time``, so
  other jobs on the machine do not inflate it) with the nested compilations of its callees;
- one per test file: the CPU seconds of the worker and of its waited-for subprocesses
  (``getrusage``) while the file ran, and the wall seconds.

A cache hit is not a compilation and is not logged. Subprocesses started by tests (the CLI
and example tests) do not load this module: their compilations are not listed, their CPU is
counted in their test file's (``RUSAGE_CHILDREN``).

Measure (BENCHMARKS.md, "make test on a fresh clone"), then summarise::

    d=$(mktemp -d); NUMBA_CACHE_DIR=$d/cache NUMBA_COMPILE_LOG=$d/log \\
        .venv/bin/python -m pytest -q --benchmark-disable -n 2 --dist loadfile tests
    .venv/bin/python tests/compile_report.py $d/log

and the compile time of one loop, each kind of law and dim in fresh processes with an empty
cache (``taskset -c 1`` keeps it on one core; medians of 3)::

    taskset -c 1 .venv/bin/python tests/compile_report.py --kernels
"""
import collections
import json
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np
from numba.core import event

_state = {"dir": None, "file": "(start-up)", "cpu": 0.0, "wall": 0.0}
_depth = threading.local()


def _cpu():
    own = resource.getrusage(resource.RUSAGE_SELF)
    sub = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + sub.ru_utime + sub.ru_stime


def _write(rec):
    rec["file"] = rec.get("file", _state["file"])
    with open(os.path.join(_state["dir"], f"{os.getpid()}.jsonl"), "a") as f:
        f.write(json.dumps(rec) + "\n")


def install(logdir):
    """Log this process's numba compilations and per-file CPU into ``logdir``."""
    os.makedirs(logdir, exist_ok=True)
    _state.update(dir=logdir, cpu=_cpu(), wall=time.perf_counter())

    class Listener(event.Listener):
        def on_start(self, ev):
            d = getattr(_depth, "d", 0)
            _depth.d = d + 1
            ev.data["_report"] = (time.process_time(), d)

        def on_end(self, ev):
            _depth.d -= 1
            c0, d = ev.data["_report"]
            fn = ev.data["dispatcher"].py_func
            cells = [c.cell_contents for c in fn.__closure__ or ()]
            _write({"kind": "compile", "func": fn.__qualname__, "module": fn.__module__,
                    "closure": [repr(c) for c in cells if isinstance(c, int)],
                    "sig": str(ev.data["args"]), "cpu": time.process_time() - c0,
                    "depth": d, "t0": c0})

    event.register("numba:compile", Listener())


def file_started(path):
    """Called at each test's start: closes the previous file's CPU record on a change."""
    if _state["dir"] is None or path == _state["file"]:
        return
    cpu, wall = _cpu(), time.perf_counter()
    _write({"kind": "file", "cpu": cpu - _state["cpu"], "wall": wall - _state["wall"]})
    _state.update(file=path, cpu=cpu, wall=wall)


def finish():
    """Closes the last file's CPU record (a process that ran no test writes none)."""
    if _state["dir"] is not None and _state["file"] != "(start-up)":
        file_started(None)


# ------------------------------------------------------------------------- summary --------
_LOOPS = {"_run2": "serial", "_run3": "serial", "serial2": "serial", "serial3": "serial",
          "_par2": "parallel", "_par3": "parallel", "parallel2": "parallel",
          "parallel3": "parallel"}


def _category(rec):
    """(row of the table, the specialisation) of one compilation."""
    short = rec["func"].split(".")[-1]
    if short in _LOOPS:
        m = re.search(r"Literal\[int\]\((-?\d+)\)", rec["sig"])
        code = m.group(1) if m else (rec["closure"] or ["?"])[0]
        parts = re.findall(r"(none|UniTuple\(float64, \d+\))",
                           rec["sig"].split("UniTuple(float64, 10)", 1)[1])[:3]
        present = "".join("-" if p == "none" else n for p, n in zip(parts, "CFD"))
        row = f"law loop, {_LOOPS[short]}, {short[-1]}D"
        return row, (code, present)
    if rec["module"].startswith("interfacelaw"):
        return f"interfacelaw.{short}", rec["sig"]
    if rec["module"].startswith(("ngs_driver", "verification")):
        return "ngs_driver kernels (solve/, run/)", (rec["func"], rec["sig"])
    return "numba's own overloads", (rec["func"], rec["sig"])


def summary(logdir):
    recs = []
    for name in sorted(os.listdir(logdir)):
        if name.endswith(".jsonl"):
            pid = name[:-6]
            for line in open(os.path.join(logdir, name)):
                r = json.loads(line)
                r["pid"] = pid
                recs.append(r)
    comp = [r for r in recs if r["kind"] == "compile"]
    # exclusive CPU: minus the nested compilations (depth + 1) inside it, same process
    for r in comp:
        inner = [c for c in comp if c["pid"] == r["pid"] and c["depth"] == r["depth"] + 1
                 and r["t0"] <= c["t0"] <= r["t0"] + r["cpu"]]
        r["own"] = r["cpu"] - sum(c["cpu"] for c in inner)
    rows = collections.defaultdict(lambda: [set(), 0, 0.0, set()])
    seen = collections.Counter()
    twice = 0.0
    for r in sorted(comp, key=lambda r: r["t0"]):
        row, spec = _category(r)
        x = rows[row]
        x[0].add(spec)
        x[1] += 1
        x[2] += r["own"]
        x[3].add(os.path.basename(r["file"]).removeprefix("test_").removesuffix(".py"))
        key = (r["func"], tuple(r["closure"]), r["sig"])
        twice += r["own"] if seen[key] else 0.0
        seen[key] += 1
    out = ["| compiled | specialisations | compilations | CPU s | test files |",
           "|---|---|---|---|---|"]
    for row, (specs, n, cpu, files) in sorted(rows.items(), key=lambda kv: -kv[1][2]):
        out.append(f"| {row} | {len(specs)} | {n} | {cpu:.0f} | {', '.join(sorted(files))} |")
    total = sum(r["own"] for r in comp)
    out.append(f"\ncompilations {len(comp)}, CPU {total:.0f} s; of them repeats of a function "
               f"and signature compiled before (in the other worker, or a numba overload "
               f"per caller): {sum(v - 1 for v in seen.values())} ({twice:.0f} CPU s)")
    files = collections.defaultdict(lambda: [0.0, 0.0])
    workers = collections.defaultdict(float)
    for r in recs:
        if r["kind"] == "file" and r["file"] is not None:
            files[r["file"]][0] += r["cpu"]
            files[r["file"]][1] += r["wall"]
            workers[r["pid"]] += r["cpu"]
    out += ["", "| test file | CPU s | wall s |", "|---|---|---|"]
    for f, (cpu, wall) in sorted(files.items(), key=lambda kv: -kv[1][0]):
        out.append(f"| {f} | {cpu:.1f} | {wall:.1f} |")
    out.append("\nCPU s per process: " + ", ".join(f"{v:.0f}" for v in workers.values()))
    return "\n".join(out)


# ------------------------------------------------------- one loop in a fresh process -------
_LAWS = ("cohesive only", "contact, friction, damage (fast)", "contact, friction, damage (general)")


def _law(kind, parallel):
    """The three kinds of law timed by :func:`kernels` (the test processes' inliner patch on)."""
    # here, not at the top: conftest imports this module before it puts the checkout on
    # sys.path; only the timing process needs the law (and conftest's inliner patch)
    import conftest  # noqa: F401
    from interfacelaw import (CohesiveParams, ContactParams, DamageParams, FrictionParams,
                              InterfaceLaw)
    coh = CohesiveParams(sigma_max=3.0e6, tau_max=2.0e6, l_Nc=1.0e-4, l_Tc=1.5e-4,
                         lambda_max=0.3)
    parts = {_LAWS[0]: (None, None, None),
             _LAWS[1]: (ContactParams("linear"), FrictionParams(0.4), DamageParams(g_max=2e-4)),
             _LAWS[2]: (ContactParams("rough"), FrictionParams(0.4),
                        DamageParams(g_max=1.5e-4, alpha=2.0, beta=1.5, F_th=3e5))}[kind]
    return InterfaceLaw(coh, *parts, parallel=parallel)


def _time_one(kind, dim):
    """CPU seconds of the first call (compile) of the serial loop, then of the parallel one
    (its serial loop already compiled), in this process; the second call for comparison."""
    out = []
    for parallel in (False, True):
        law = _law(kind, parallel)
        gap, st = np.zeros((10, dim)), law.initial_state(10, dim)
        c0 = time.process_time()
        law.evaluate(gap, st)
        c1 = time.process_time()
        law.evaluate(gap, st)
        out += [c1 - c0, time.process_time() - c1]
    print(json.dumps(out))


def kernels(repeats=3):
    """Each kind of law and dim in fresh processes with an empty numba cache, medians."""
    rows = ["| law | dim | serial loop: first call (CPU s) | parallel loop on top (CPU s) "
            "| second call (ms) |", "|---|---|---|---|---|"]
    for kind in _LAWS:
        for dim in (2, 3):
            runs = []
            for _ in range(repeats):
                with tempfile.TemporaryDirectory() as cache:
                    env = dict(os.environ, NUMBA_CACHE_DIR=cache, NUMBA_NUM_THREADS="1")
                    r = subprocess.run([sys.executable, __file__, "--time-one", kind, str(dim)],
                                       env=env, capture_output=True, text=True, check=True)
                    runs.append(json.loads(r.stdout.strip().splitlines()[-1]))
            med = [statistics.median(r[i] for r in runs) for i in range(4)]
            rows.append(f"| {kind} | {dim} | {med[0]:.2f} | {med[2]:.2f} | {med[1] * 1e3:.2f} |")
    return "\n".join(rows)


if __name__ == "__main__":
    if sys.argv[1] == "--time-one":
        _time_one(sys.argv[2], int(sys.argv[3]))
    elif sys.argv[1] == "--kernels":
        print(kernels())
    else:
        print(summary(sys.argv[1]))
