"""Stage 2 of the pipeline: scene -> what the FE model and the solver are fed (no NGSolve).

``build_law`` / ``build_scaling`` (``laws``), ``load_ground_motion`` (``records``) and
``validate`` (everything checkable without meshing), ``resolve`` / ``model_inputs`` (the
scene resolved once into what ``fe``, ``solve`` and ``run`` are given: ``inputs``) and
``describe`` (what a run would build: the ``--dry-run`` answer).
"""
from __future__ import annotations

from .inputs import (JointInput, ModelInputs, RunInputs, joint_inputs, k0_from_scene,
                     model_inputs, resolve, window_note)
from .bulk import validate_bulk
from .laws import build_law, build_scaling, characteristic_times, law_parts, validate_laws
from .records import DEFAULT_RECORDS, load_ground_motion
from .sanity import check_scene
from .uplift import describe_uplift, validate_safety

__all__ = ["FORMULATION", "build_law", "build_scaling", "characteristic_times", "law_parts",
           "load_ground_motion", "describe", "validate", "validate_laws", "window_note",
           "DEFAULT_RECORDS", "JointInput", "ModelInputs", "RunInputs", "joint_inputs",
           "k0_from_scene", "model_inputs", "resolve"]

FORMULATION = ("relative (rock bottom fixed, ground acceleration as effective inertial load "
               "-M r a_g(t); displacements relative to the rigid ground motion)")


def validate(scene):
    """Everything that can be checked without meshing (``--dry-run`` and the start of every
    run): the laws of every joint (interfacelaw's own ranges), and the record (the file exists
    and parses, or the named set has the record). The scene schema has already checked the
    profile, the joints and the levels. Returns the loaded ground motion."""
    validate_laws(scene)
    validate_safety(scene)        # uplift, foundation
    validate_bulk(scene)          # solver.bulk: the reduced bulk's combinations, cut-off
    check_scene(scene)            # physical sanity: contact vs weight, joint spacing, unused keys
    try:
        gm = load_ground_motion(scene)
    except (OSError, ValueError, KeyError, IndexError) as e:
        msg = str(e)
        if msg.startswith("ground_motion."):
            raise ValueError(msg) from None
        raise ValueError(f"ground_motion.record = {scene.ground_motion.record!r}: {msg}") \
            from None
    start, end = scene.ground_motion.start, float(gm.t[-1])
    if start >= end:
        raise ValueError(f"ground_motion.start = {start!r}: at or past the end of the record "
                         f"({gm.label}: t = {float(gm.t[0]):g}-{end:g} s); allowed: "
                         f"[0, {end:g}) s")
    return gm


def describe(scene) -> dict:
    """What ``run`` would build (for --dry-run); never imports NGSolve."""
    gm = validate(scene)
    m, t = scene.mesh, scene.time
    sec = scene.section
    n = int(round(t.duration / t.dt))
    l_nc = 2 * scene.interface.G_I / scene.interface.sigma_max
    joints = {"base": {"elevation": 0.0, "length": sec.base_width,
                       "law": law_parts(scene.interface)}}
    for j in scene.joints:
        xu, xd = sec.width_at(j.elevation)
        joints[j.name] = {"elevation": j.elevation, "length": xd - xu, "x_upstream": xu,
                          "law": law_parts(j.interface)}
    return {"scene": scene.to_dict(),
            "will_build": {
                "model": f"{scene.name}: section of {len(sec.vertices)} vertices (base "
                         f"{sec.base_width:g} m, height {sec.height:g} m, area "
                         f"{sec.area:.6g} m^2) on {scene.geometry.foundation} foundation, "
                         f"P{m.order} triangles, h_heel {m.h_heel} m, h_interface "
                         f"{m.h_interface} m, h_coarse {m.h_coarse} m, {m.gauss_points} Gauss "
                         "points/segment (mesh and DOFs: not built in a dry run)",
                "joints": joints,
                "law": law_parts(scene),
                "reference_l_Nc": l_nc,
                "g_max_over_l_Nc": scene.interface.g_max / l_nc,
                "damping": f"{scene.damping.model} {scene.damping.ratio:g} at "
                           + (f"{list(scene.damping.frequencies)} Hz"
                              if scene.damping.frequencies else
                              f"modes {list(scene.damping.modes)}"),
                "ground_motion": {"record": scene.ground_motion.record, "label": gm.label,
                                  "synthetic": bool(gm.synthetic),
                                  "peak_g": [float(v) for v in gm.peak_g()],
                                  "dt": gm.dt, "duration": gm.duration,
                                  "window_note": window_note(scene, gm)},
                "time": f"{n} steps of {t.dt} s to {t.duration} s, " + (
                    f"Newmark beta {t.newmark_beta}, gamma {t.newmark_gamma}"
                    if t.integrator == "newmark" else
                    f"{t.integrator} rho_inf {t.rho_inf}")
                    + f"; collapse limits: slip {t.max_slip} m, rotation {t.max_rotation} rad",
                "formulation": FORMULATION,
                "checkpoint_every": scene.output.checkpoint_every,
                "vtk_every": scene.output.vtk_every,
                "uplift": describe_uplift(scene)}}
