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

from interfacelaw.atomic import atomic_write_bytes, atomic_write_text

__all__ = ["atomic_write_bytes", "atomic_write_text", "atomic_write_json", "atomic_savez",
           "environment_info", "git_revision", "write_timeseries_csv", "write_damage_csv",
           "read_csv", "json_text", "npz_bytes"]


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


def _csv_text(header: list[str], cols: list[np.ndarray], comments=()) -> str:
    """Comment lines, the header and one row per index, each value its shortest repr that
    round-trips (exact values). Built column by column: a column with few distinct values
    (counters, flags, constants: about half the history's columns) formats each distinct
    bit pattern once (so -0.0 stays "-0.0")."""
    lines = [f"# {c}" for c in comments]
    lines.append(",".join(header))
    strs = []
    for c in cols:
        c = np.ascontiguousarray(c, dtype=np.float64)
        bits, first, inv = np.unique(c.view(np.int64), return_index=True, return_inverse=True)
        if 4 * bits.size < c.size:
            reprs = np.array(list(map(repr, c[first].tolist())), dtype=object)
            strs.append(reprs[inv.ravel()].tolist())
        else:
            strs.append(list(map(repr, c.tolist())))
    if strs:
        lines.extend(map(",".join, zip(*strs)))
    return "\n".join(lines) + "\n"



def write_timeseries_csv(path, H: dict, keys, comments=()):
    return atomic_write_text(path, _csv_text(list(keys), [H[k] for k in keys], comments))



def write_damage_csv(path, x, w, snaps, comments=(), sl=slice(None)):
    """D, kappa, opening and slip along one joint (points ``sl``) at the snapshot times."""
    ts = snaps["t"]
    header = (["x", "w"] + [f"D_t={t:.4f}" for t in ts] + [f"kappa_t={t:.4f}" for t in ts]
              + [f"opening_t={t:.4f}" for t in ts] + [f"slip_t={t:.4f}" for t in ts])
    cols = [x[sl], w[sl]] + [np.asarray(v)[sl] for key in ("D", "kappa", "opening", "slip")
                             for v in snaps[key]]
    return atomic_write_text(path, _csv_text(header, cols, comments))


def read_csv(path) -> dict:
    """A CSV written here (timeseries.csv, damage_profiles*.csv, ...) -> {column: float array}
    (comment lines "# ..." and blank lines skipped): the one reader of the run's tables."""
    lines = [ln for ln in pathlib.Path(path).read_text().splitlines()
             if ln.strip() and not ln.startswith("#")]
    header = lines[0].split(",")
    data = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:] if ln.strip()])
    data = data.reshape(-1, len(header))
    return {h: data[:, i] for i, h in enumerate(header)}



