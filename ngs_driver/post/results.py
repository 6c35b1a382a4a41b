"""The result files of one run: CSVs (full precision) and the figures (``plots``)."""
from __future__ import annotations

import pathlib

import numpy as np

from ..setup import FORMULATION
from . import plots as P
from .files import write_damage_csv, write_timeseries_csv

__all__ = ["write_run_outputs"]


def write_run_outputs(out, model, scene, gm, H, snaps, solver, u_static, joints,
                      plots=True, heel=None):
    """CSV + PNG of one run; returns the list of file names written."""

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
                                "(docs/run.md §9)"])
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
    if all(f"{n}_slip" in H for n in joints.names):
        files.append(P.plot_block_motion(out / "sliding_rocking.png", H, joints.names, title))
    files.append(P.plot_crack_length(out / "crack_length.png",
                                   [(f"alpha = {a:g}", H["t"], H["crack_length_heel"],
                                     H["crack_length"])], title))
    if heel is None:
        heel = {"u": solver.u, "t": H["t"][-1] if len(H["t"]) else 0.0, "open": None}
    tri = P.mesh_cells(model)               # the mesh's triangles, for both mesh figures
    f = P.plot_heel_von_mises(out / "fig12_heel_von_mises.png", model, heel["u"],
                            title + f"\nt = {heel['t']:.3f} s: largest heel opening "
                            + (f"({1e3 * heel['open']:.3g} mm) " if heel["open"] is not None
                               else "") + "while the base still holds", triangles=tri)
    if f:
        files.append(f)
    files.append(P.plot_mesh(out / "fig8b_mesh.png", model,
                           f"mesh: {model.mesh.nv} vertices, {model.mesh.ne} triangles, "
                           f"{model.nfree} free DOFs", triangles=tri))
    return files
