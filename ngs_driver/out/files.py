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
           "environment_info", "git_revision", "write_timeseries_csv", "write_damage_csv",
           "read_csv", "write_run_outputs"]


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


def _csv_text(header: list[str], cols: list[np.ndarray], comments=()) -> str:
    lines = [f"# {c}" for c in comments]
    lines.append(",".join(header))
    data = np.column_stack([np.asarray(c, float) for c in cols]) if cols else np.zeros((0, 0))
    for row in data.tolist():            # shortest repr that round-trips: exact values
        lines.append(",".join(map(repr, row)))
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
    """CSV written here -> {column: array} (comment lines skipped)."""
    lines = [ln for ln in pathlib.Path(path).read_text().splitlines() if not ln.startswith("#")]
    header = lines[0].split(",")
    data = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:] if ln.strip()])
    data = data.reshape(-1, len(header))
    return {h: data[:, i] for i, h in enumerate(header)}



def write_run_outputs(out, model, scene, gm, H, snaps, solver, u_static, joints,
                      plots=True, heel=None):
    """CSV + PNG of one run; returns the list of file names written."""
    from ..setup import FORMULATION
    from . import plots as P

    out = pathlib.Path(out)
    lab = gm.label + (" [SYNTHETIC record]" if gm.synthetic else "")
    a = scene.interface.alpha
    cp = model.crest_point
    com = [f"scene {scene.name}, alpha = {a:g}, record: {lab}", f"formulation: {FORMULATION}",
           f"crest = upstream crest corner ({cp[0]:g}, {cp[1]:g}); displacements relative to "
           "the ground, including the static state"]
    files = []
    write_timeseries_csv(out / "crest_displacement.csv", H, ["t", "crest_ux", "crest_uy"], com)
    files.append("crest_displacement.csv")
    write_timeseries_csv(out / "timeseries.csv", H, list(H),
                         com + ["crack_length = sum of w over debonded points of the base; "
                                "crack_length_heel = contiguous debonded length from the heel; "
                                "<joint>_* the same per joint (crack_length_upstream from its "
                                "upstream end); energy terms [J/m] from the static state "
                                "(docs/decisions.md §7.4)"])
    files.append("timeseries.csv")
    iface = model.interface
    for name, sl in zip(joints.names, joints.slices):
        f = "damage_profiles.csv" if name == "base" else f"damage_profiles_{name}.csv"
        write_damage_csv(out / f, iface.x, iface.w, snaps,
                         com + [f"joint {name}: D(x), kappa(x), opening and slip [m] at its "
                                "Gauss points (upstream end first)"], sl=sl)
        files.append(f)
    if not plots:
        return files
    title = f"{scene.name}, alpha = {a:g} -- {lab}"
    t = np.concatenate([[0.0], H["t"]])
    ux = np.concatenate([[u_static[model.crest_dofs[0]]], H["crest_ux"]])
    uy = np.concatenate([[u_static[model.crest_dofs[1]]], H["crest_uy"]])
    files.append(P.plot_crest(out / "fig10_crest_displacement.png",
                            [(f"alpha = {a:g}", t, ux, uy)], title))
    for name, sl in zip(joints.names, joints.slices):
        D = [np.asarray(v)[sl] for v in snaps["D"]]
        x = iface.x[sl]
        f = "fig11_damage_profiles.png" if name == "base" else f"damage_profiles_{name}.png"
        files.append(P.plot_damage_profiles(out / f, [(f"alpha = {a:g}", x, snaps["t"], D)],
                                            title + ("" if name == "base" else
                                                     f" -- joint {name}"),
                                            xmax=P.damage_xmax({"D": D}, x)))
    files.append(P.plot_energy(out / "energy_budget.png", H, joints.names, title))
    files.append(P.plot_crack_length(out / "crack_length.png",
                                   [(f"alpha = {a:g}", H["t"], H["crack_length_heel"],
                                     H["crack_length"])], title))
    if heel is None:
        heel = {"u": solver.u, "t": H["t"][-1] if len(H["t"]) else 0.0, "open": None}
    f = P.plot_heel_von_mises(out / "fig12_heel_von_mises.png", model, heel["u"],
                            title + f"\nt = {heel['t']:.3f} s: largest heel opening "
                            + (f"({1e3 * heel['open']:.3g} mm) " if heel["open"] is not None
                               else "") + "while the base still holds")
    if f:
        files.append(f)
    files.append(P.plot_mesh(out / "fig8b_mesh.png", model,
                           f"mesh: {model.mesh.nv} vertices, {model.mesh.ne} triangles, "
                           f"{model.nfree} free DOFs"))
    return files



