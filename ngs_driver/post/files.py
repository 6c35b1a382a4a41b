"""The output stage's data files: the time series and damage profiles as CSV, and reading them
back (no NGSolve needed here). The atomic writers and the JSON / npz helpers are the run
stage's (``run/store.py``), re-exported here for the outputs and the apps.

Every file is written to a temporary name in the same directory and moved into place with
``os.replace``, so a killed run never leaves a half-written file under the final name. A run
that has not finished has no ``summary.json``; ``summary.json`` is written last.
"""
from __future__ import annotations

import pathlib

import numpy as np

from ..run.store import (atomic_savez, atomic_write_bytes, atomic_write_json,
                         atomic_write_text, environment_info, git_revision, json_text,
                         npz_bytes)

__all__ = ["atomic_write_bytes", "atomic_write_text", "atomic_write_json", "atomic_savez",
           "environment_info", "git_revision", "write_timeseries_csv", "write_damage_csv",
           "read_csv", "json_text", "npz_bytes"]


def csv_text(header: list[str], cols: list[np.ndarray], comments=()) -> str:
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
    return atomic_write_text(path, csv_text(list(keys), [H[k] for k in keys], comments))


def write_damage_csv(path, x, w, snaps, comments=(), sl=slice(None)):
    """D, kappa, opening and slip along one joint (points ``sl``) at the snapshot times."""
    ts = snaps["t"]
    header = (["x", "w"] + [f"D_t={t:.4f}" for t in ts] + [f"kappa_t={t:.4f}" for t in ts]
              + [f"opening_t={t:.4f}" for t in ts] + [f"slip_t={t:.4f}" for t in ts])
    cols = [x[sl], w[sl]] + [np.asarray(v)[sl] for key in ("D", "kappa", "opening", "slip")
                             for v in snaps[key]]
    return atomic_write_text(path, csv_text(header, cols, comments))


def read_csv(path) -> dict:
    """A CSV written here (timeseries.csv, damage_profiles*.csv, ...) -> {column: float array}
    (comment lines "# ..." and blank lines skipped): the one reader of the run's tables."""
    lines = [ln for ln in pathlib.Path(path).read_text().splitlines()
             if ln.strip() and not ln.startswith("#")]
    header = lines[0].split(",")
    data = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:] if ln.strip()])
    data = data.reshape(-1, len(header))
    return {h: data[:, i] for i, h in enumerate(header)}


