"""The run's own files: JSON and npz written atomically (a temporary name in the same
directory, then ``os.replace``: a killed run never leaves a half-written file under the final
name) and the environment stamp of a summary. The run stage writes its checkpoints, final
state and summary.json with these; the output stage (``post``) and the apps use them too."""
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

from interfacelaw.atomic import atomic_write_bytes, atomic_write_text

__all__ = ["atomic_write_bytes", "atomic_write_text", "atomic_write_json", "atomic_savez",
           "environment_info", "git_revision", "json_text", "npz_bytes"]


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, pathlib.Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def json_text(obj) -> str:
    """The text ``atomic_write_json`` writes."""
    return json.dumps(obj, indent=2, default=_json_default) + "\n"


def atomic_write_json(path, obj) -> pathlib.Path:
    return atomic_write_text(path, json_text(obj))


def npz_bytes(**arrays) -> bytes:
    """The bytes ``atomic_savez`` writes."""
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def atomic_savez(path, **arrays) -> pathlib.Path:
    return atomic_write_bytes(path, npz_bytes(**arrays))


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
