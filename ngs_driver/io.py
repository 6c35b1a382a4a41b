"""Results directory, atomic writes and checkpoints (no NGSolve needed here).

Every file is written to a temporary name in the same directory and moved into place with
``os.replace``, so a killed run never leaves a half-written file under the final name. A run
that has not finished has no ``summary.json``; ``summary.json`` is written last.
"""
from __future__ import annotations

import io
import json
import os
import pathlib
import platform
import subprocess
import time
from importlib import metadata

import numpy as np

from interfacelaw._atomic import atomic_write_bytes, atomic_write_text

__all__ = ["atomic_write_bytes", "atomic_write_text", "atomic_write_json", "atomic_savez",
           "Checkpointer", "environment_info", "git_revision"]


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, pathlib.Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def atomic_write_json(path, obj) -> pathlib.Path:
    return atomic_write_text(path, json.dumps(obj, indent=2, default=_json_default) + "\n")


def atomic_savez(path, **arrays) -> pathlib.Path:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return atomic_write_bytes(path, buf.getvalue())


def git_revision() -> str | None:
    try:
        here = pathlib.Path(__file__).resolve().parent
        out = subprocess.run(["git", "rev-parse", "HEAD"], cwd=here, capture_output=True,
                             text=True, timeout=5)
        if out.returncode == 0:
            dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                                   cwd=here, capture_output=True, text=True, timeout=5)
            return out.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")
    except (OSError, subprocess.SubprocessError):
        pass
    return None


def environment_info() -> dict:
    pk = {}
    for name in ("interfacelaw", "numpy", "numba", "scipy", "ngsolve", "netgen-mesher",
                 "matplotlib", "tqdm"):
        try:
            pk[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            pk[name] = None
    return {"python": platform.python_version(), "machine": platform.machine(),
            "cpus": os.cpu_count(), "packages": pk, "git_revision": git_revision(),
            "date_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}


class Checkpointer:
    """Writes ``checkpoint.npz`` (arrays) + ``checkpoint.json`` (meta) atomically.

    The npz is written first under a step-stamped name, then the json that names it: the json
    is the commit point, so a kill between the two leaves the previous checkpoint valid.
    """

    def __init__(self, directory, every: int):
        if isinstance(every, bool) or not isinstance(every, int) or every < 0:
            raise ValueError(f"output.checkpoint_every = {every!r} is not allowed; allowed: an "
                             "integer >= 0 (0 disables checkpoints)")
        self.dir = pathlib.Path(directory)
        self.every = every

    @property
    def meta_path(self) -> pathlib.Path:
        return self.dir / "checkpoint.json"

    def due(self, step: int) -> bool:
        return self.every > 0 and step > 0 and step % self.every == 0

    def save(self, step: int, meta: dict, **arrays) -> None:
        name = f"checkpoint_{step:07d}.npz"
        atomic_savez(self.dir / name, **arrays)
        old = self.load_meta()
        atomic_write_json(self.meta_path, dict(meta, step=step, arrays=name))
        if old and old.get("arrays") and old["arrays"] != name:
            try:
                (self.dir / old["arrays"]).unlink()
            except FileNotFoundError:
                pass

    def load_meta(self) -> dict | None:
        if not self.meta_path.exists():
            return None
        return json.loads(self.meta_path.read_text())

    def load(self):
        meta = self.load_meta()
        if meta is None:
            raise FileNotFoundError(f"--resume: no checkpoint in {self.dir}; allowed: a results "
                                    "directory of a run started with output.checkpoint_every > 0")
        with np.load(self.dir / meta["arrays"]) as z:
            arrays = {k: z[k] for k in z.files}
        return meta, arrays
