"""One sweep-with-resume for every study that runs many scenes: the IDA (``studies/ida.py``)
and the verification studies (``verification/koyna_studies.py``,
``verification/damage_rate_koyna.py``).

A sweep is a list of *specs*, each a dict with an ``id`` (the run's folder
``<root>/runs/<id>/``) and a ``scene_hash`` (``scene_hash``: every key that changes the
physics). ``task(spec, root) -> result`` does one run and returns its row (a JSON-able dict);
the sweep writes ``result.json`` (the row and the scene hash) atomically, last, in the run's
folder: a run is finished exactly when that file exists with its spec's hash, and the next call
skips it (resume; a changed scene reruns). Runs go ``jobs`` at a time on threads (a task may
start a subprocess) or on a Dask client; a task that raises is retried ``retries`` times (Dask
re-runs it itself, also after a lost worker) and, if it still fails, reported as an error
without ``result.json``, so that the next call tries it again.
"""
from __future__ import annotations

import concurrent.futures as cf
import hashlib
import json
import os
import pathlib
import subprocess
import sys
import threading

from ..apps.dam import run
from ..post.files import atomic_write_json
from ..scene import load_scene

__all__ = ["scene_hash", "finished", "write_result", "Sweep", "RESULT"]

RESULT = "result.json"


def scene_hash(scene, drop=()) -> str:
    """10 hex digits of the SHA-256 of the scene's keys that change the physics: all but
    name, description and output, and the dotted keys ``drop`` (e.g. the record and scale an
    IDA sets per run). ``scene``: a Scene or its ``to_dict()``."""
    d = json.loads(json.dumps(scene if isinstance(scene, dict) else scene.to_dict()))
    for k in ("name", "description", "output"):
        d.pop(k, None)
    for key in drop:
        *path, last = key.split(".")
        t = d
        for p in path:
            t = t.get(p, {}) if isinstance(t, dict) else {}
        if isinstance(t, dict):
            t.pop(last, None)
    txt = json.dumps(d, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(txt.encode()).hexdigest()[:10]


def run_dir(root, spec) -> pathlib.Path:
    return pathlib.Path(root) / "runs" / spec["id"]


def finished(folder, h=None) -> dict | None:
    """The result of a finished run in ``folder`` (its ``result.json``), or None: missing,
    unreadable, or written for another scene hash than ``h`` (when given)."""
    p = pathlib.Path(folder) / RESULT
    try:
        r = json.loads(p.read_text())
    except (OSError, ValueError):
        return None
    if h is not None and r.get("scene_hash") != h:
        return None
    return r


def write_result(folder, result: dict) -> dict:
    """``result.json`` of a run, atomically (the run's commit point: written last)."""
    pathlib.Path(folder).mkdir(parents=True, exist_ok=True)
    atomic_write_json(pathlib.Path(folder) / RESULT, result)
    return result


def _attempt(task, spec, root):
    """One run where it executes (thread or Dask worker): the task, then its result file."""
    r = dict(task(spec, str(root)))
    if spec.get("scene_hash") is not None:
        r["scene_hash"] = spec["scene_hash"]
    return write_result(run_dir(root, spec), r)


class Sweep:
    """The runs of ``specs`` under ``root`` (module docstring).

    task: ``task(spec, root) -> dict``, a module-level function when a Dask client runs it;
    jobs: runs at a time on local threads; client: a dask.distributed Client (then ``jobs``
    is the cluster's business); retries: extra attempts of a task that raised;
    on_result(spec, result) / on_error(spec, message): called in the caller's thread as runs
    finish (one at a time)."""

    def __init__(self, root, task, *, jobs: int = 1, retries: int = 0, client=None,
                 on_result=None, on_error=None, key_prefix: str = "run"):
        self.root = pathlib.Path(root)
        self.task = task
        self.jobs = max(1, int(jobs))
        self.retries = max(0, int(retries))
        self.client = client
        self.on_result, self.on_error = on_result, on_error
        self.key_prefix = key_prefix
        self._lock = threading.Lock()

    def plan(self, specs) -> tuple[dict, list]:
        """({id: result} of the finished runs, [the specs still to run])."""
        done, pending = {}, []
        for s in specs:
            r = finished(run_dir(self.root, s), s.get("scene_hash"))
            if r is not None:
                done[s["id"]] = r
            else:
                pending.append(s)
        return done, pending

    def run(self, specs) -> dict:
        """Run what is not finished. Returns {"results": {id: result} of every finished run
        (earlier ones included), "errors": {id: message}, "ran": n, "reused": n}."""
        done, pending = self.plan(specs)
        reused = len(done)
        errors = {}
        if pending:
            if self.client is not None:
                self._on_dask(pending, done, errors)
            else:
                self._on_threads(pending, done, errors)
        return {"results": done, "errors": errors, "ran": len(pending), "reused": reused}

    def _finish(self, spec, result, done):
        with self._lock:
            done[spec["id"]] = result
            if self.on_result is not None:
                self.on_result(spec, result)

    def _fail(self, spec, exc, errors):
        msg = f"{type(exc).__name__}: {exc}"
        with self._lock:
            errors[spec["id"]] = msg
            if self.on_error is not None:
                self.on_error(spec, msg)

    def _on_threads(self, pending, done, errors):
        def one(spec):
            for k in range(self.retries + 1):
                try:
                    return _attempt(self.task, spec, self.root)
                except Exception:  # noqa: BLE001 -- retried, then reported
                    if k == self.retries:
                        raise

        if self.jobs == 1:
            for s in pending:
                try:
                    self._finish(s, one(s), done)
                except Exception as e:  # noqa: BLE001
                    self._fail(s, e, errors)
            return
        with cf.ThreadPoolExecutor(self.jobs) as ex:
            futs = {ex.submit(one, s): s for s in pending}
            for f in cf.as_completed(futs):
                try:
                    self._finish(futs[f], f.result(), done)
                except Exception as e:  # noqa: BLE001
                    self._fail(futs[f], e, errors)

    def _on_dask(self, pending, done, errors):
        # deferred: Dask is needed only when the study runs
        from dask.distributed import as_completed
        futs = {self.client.submit(_attempt, self.task, s, str(self.root.resolve()),
                                   key=f"{self.key_prefix}-{s['id']}", retries=self.retries,
                                   pure=False): s for s in pending}
        for f in as_completed(list(futs)):
            s = futs[f]
            try:
                r = f.result()
            except Exception as e:  # noqa: BLE001 -- a bug or a worker lost too often
                self._fail(s, e, errors)
                continue
            if finished(run_dir(self.root, s)) is None:   # a worker without the shared disk
                write_result(run_dir(self.root, s), r)
            self._finish(s, r, done)


# ---------------------------------------------------------------------------------------------
# the task of the verification studies: one run of a scene with --set overrides
# ---------------------------------------------------------------------------------------------
def overrides_of(sets: dict) -> list[str]:
    """{key: value} -> ["key=value", ...] (sorted; floats as repr: they round-trip exactly)."""
    return [f"{k}={v!r}" if isinstance(v, float) else f"{k}={v}"
            for k, v in sorted(sets.items())]


def command(scene: str, overrides, out, python: str = "python") -> list[str]:
    """The command line of one run: ``python -m ngs_driver run SCENE --set ... --out OUT``."""
    args = [python, "-m", "ngs_driver", "run", str(scene)]
    for ov in overrides:
        args += ["--set", ov]
    # a task run again (a retry, a sweep resumed) replaces its own folder's earlier attempt
    return args + ["--out", str(out), "--quiet", "--overwrite"]


def run_scene(spec, root) -> dict:
    """Sweep task: run ``spec["scene_name"]`` with ``spec["overrides"]`` into the run's folder,
    without figures. ``spec["in_process"]``: in this process (``run.run``); else the run
    command in a subprocess (one thread for BLAS and numba; ``spec["code"]``: the source tree
    to run, default this one), its output in ``runs/<id>.log``. Returns {"id", "dir"}."""

    d = run_dir(root, spec).resolve()
    d.mkdir(parents=True, exist_ok=True)
    if spec.get("in_process"):
        run(load_scene(spec["scene_name"], spec["overrides"]), d, progress=False, plots=False,
            log=lambda *a, **k: None, overwrite=True)
    else:
        here = pathlib.Path(__file__).resolve().parents[2]
        code = pathlib.Path(spec.get("code") or here)
        env = dict(os.environ)
        for k, v in (("OMP_NUM_THREADS", "1"), ("OPENBLAS_NUM_THREADS", "1"),
                     ("MKL_NUM_THREADS", "1"), ("MPLBACKEND", "Agg"),
                     ("NUMBA_CACHE_DIR", str(here / ".numba_cache"))):
            env.setdefault(k, v)
        env["PYTHONPATH"] = str(code) + os.pathsep + env.get("PYTHONPATH", "")
        log = d.parent / f"{spec['id']}.log"
        with open(log, "w") as fh:
            q = subprocess.run(command(spec["scene_name"], spec["overrides"], d, sys.executable),
                               stdout=fh, stderr=subprocess.STDOUT, cwd=str(code), env=env,
                               check=False)
        if q.returncode != 0:
            raise RuntimeError(f"run {spec['id']} failed (exit {q.returncode}); see {log}")
    return {"id": spec["id"], "dir": str(d)}
