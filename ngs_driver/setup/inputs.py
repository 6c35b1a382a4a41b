"""The scene resolved once: what the model, the solver and the run are given (no NGSolve).

``resolve(scene, gm)`` turns a validated scene into ``RunInputs``; ``model_inputs(scene)`` into
the model's ``ModelInputs``. Below ``setup`` (``fe``, ``solve``, ``run``) nothing reads the raw
scene: they get these typed inputs (``tests/test_pipeline.py`` fails if a module there looks
into a scene). The option tables that are already typed and checked by the scene schema (the
[time], [solver], [output], [damping] tables, a material) are handed on as they are.
"""
from __future__ import annotations

import dataclasses
from typing import Any

from .laws import build_law, characteristic_times, law_parts, paper_k0
from .uplift import heads, joint_extent

__all__ = ["JointInput", "RunInputs", "ModelInputs", "resolve", "model_inputs", "joint_inputs",
           "k0_from_scene", "window_note"]


@dataclasses.dataclass(frozen=True)
class JointInput:
    """One joint of the dam (the base first, then the lift joints bottom up): its law table
    ([interface] or the joint's own), its extent and its uplift table with the water heads
    above it."""

    name: str
    law: Any                  # the law's parameter table (``setup.build_law``)
    cracked: bool             # the joint starts cracked (no cohesion)
    elevation: float          # [m] above the base
    x_upstream: float         # [m] the joint's upstream and downstream ends
    x_downstream: float
    uplift: Any               # the joint's [uplift] table (``setup.uplift``)
    head: float               # [m] headwater and tailwater heads above the joint
    tail: float


@dataclasses.dataclass(frozen=True)
class ModelInputs:
    """What the FE model is built from (``fe.model.build_from_inputs``): plain values."""

    section: Any                          # ``section.Section``
    joints: tuple                         # (name, elevation, h_end, h_joint) of lift joints
    materials: dict                       # region -> (E, nu, rho, plane)
    options: dict                         # the other ``fe.model.build_model`` arguments
    bulk: tuple = ("full", 0, 0.0)        # solver.bulk, bulk_modes, bulk_cutoff_hz (fe/reduction)


@dataclasses.dataclass(frozen=True)
class RunInputs:
    """Everything a dam run takes from its scene (``run.prepare``)."""

    name: str
    scene_dict: dict                      # the scene as written to checkpoints and summary
    label: str                            # the progress bar's
    joints: tuple                         # JointInput, the base first
    rho_g: float                          # water density x gravity [N/m^3]
    water_density: float
    gravity: float
    tailwater: float                      # the base's tailwater level [m]
    time: Any                             # the [time] table: dt, duration, integrator, limits
    solver: Any                           # the [solver] table
    output: Any                           # the [output] table
    damping: Any                          # the [damping] table
    record_start: float                   # [s] where the analysed window starts
    absorbing: bool                       # absorbing rock boundaries (total displacements)
    rock: Any                             # the rock's material (E, nu, rho)
    massless: bool                        # massless foundation (M singular on the rock)
    screening_strength: float | None      # tensile strength of the linear screening, or None
    law: dict                             # the base law's parts (summary.json "law")
    g_max: float                          # the base law's damage g_max [m]
    characteristic_times: dict            # paper Eq. 11 (``setup.characteristic_times``)
    window_note: str | None               # the window runs past the record (else None)


def window_note(scene, gm) -> str | None:
    """A note when the analysed window [start, start + duration] runs past the record's end
    (the ground is at rest after it: zero acceleration), else None."""
    a = scene.ground_motion.start
    b = a + scene.time.duration
    end = float(gm.t[-1])
    if b > end + 1e-9 * max(1.0, end):
        return (f"the analysed window {a:g}-{b:g} s runs past the end of the record ({end:g} "
                f"s): the last {b - end:.4g} s have no ground motion (the ground at rest); "
                "set time.duration (or ground_motion.start) to stay inside the record")
    return None


def joint_inputs(scene) -> tuple:
    """The joints of the scene, the base first (``JointInput``)."""
    uplift = dict(scene.uplift_tables())
    out = []
    for name, tbl in scene.joint_tables():
        y, xu, xd = joint_extent(scene, name)
        up = uplift[name]
        hh, ht = heads(scene, y, up)
        out.append(JointInput(name, tbl, bool(getattr(tbl, "cracked", False)), y, xu, xd,
                              up, hh, ht))
    return tuple(out)


def k0_from_scene(scene) -> tuple[float, float]:
    """(k_N, k_T) [Pa/m] of the bonded base joint under its dam's weight: the compressive
    stiffness ``interface.contact_stiffness`` (the cohesive one without contact) and the
    cohesive shear stiffness (equal to ``solve.joint_laws.law_stiffness`` of the run's base
    law: tests/test_run_loop.py)."""
    i = scene.interface
    kn, kt = paper_k0(i.sigma_max, i.tau_max, i.G_I, i.lambda_max, i.ratio_lTc_lNc)
    if i.contact != "none":
        kn = float(i.contact_stiffness)
    return kn, kt


def resolve(scene, gm=None) -> RunInputs:
    """The run's inputs of a validated scene (``setup.validate``); gm: its ground motion
    (for the window note; None: no note)."""
    l_nc = build_law(scene.interface).cohesive.l_Nc       # the reference law's (unscaled)
    L = scene.loads
    return RunInputs(
        name=scene.name, scene_dict=scene.to_dict(),
        label=f"{scene.name} a={scene.interface.alpha:g}",
        joints=joint_inputs(scene), rho_g=L.water_density * L.gravity,
        water_density=L.water_density, gravity=L.gravity,
        tailwater=float(scene.uplift.tailwater),
        time=scene.time, solver=scene.solver, output=scene.output, damping=scene.damping,
        record_start=float(scene.ground_motion.start),
        absorbing=scene.geometry.rock_sides == "absorbing", rock=scene.materials.rock,
        massless=scene.geometry.foundation == "massless",
        screening_strength=(float(scene.screening.tensile_strength)
                            if scene.screening.enabled else None),
        law=law_parts(scene), g_max=float(scene.interface.g_max),
        characteristic_times=characteristic_times(scene, l_nc),
        window_note=None if gm is None else window_note(scene, gm))


def model_inputs(scene) -> ModelInputs:
    """The FE model's inputs of a scene (``fe.model.build_from_inputs``)."""
    g, m, L = scene.geometry, scene.mesh, scene.loads
    plane = getattr(scene.materials, "plane", "strain")
    mats = {r: (getattr(scene.materials, r).E, getattr(scene.materials, r).nu,
                getattr(scene.materials, r).rho, plane) for r in ("dam", "rock")}
    joints = tuple((j.name, j.elevation, j.h_end or m.h_heel, j.h_joint or m.h_interface)
                   for j in scene.joints)
    sv = getattr(scene, "solver", None)          # a scene-like object may carry no [solver]
    bulk = ("full", 0, 0.0) if sv is None else (sv.bulk, sv.bulk_modes, sv.bulk_cutoff_hz)
    return ModelInputs(section=scene.section, joints=joints, materials=mats, bulk=bulk, options=dict(
        foundation=g.foundation, order=m.order, gauss_points=m.gauss_points,
        gravity=L.gravity, reservoir_level=L.reservoir_level,
        water_density=L.water_density, lumped_mass=m.lumped_mass,
        reservoir=getattr(scene, "reservoir", None),
        rock_sides=g.rock_sides, include_rock_weight=L.rock_weight,
        h_heel=m.h_heel, h_coarse=m.h_coarse, h_interface=m.h_interface,
        heel_zone=m.heel_zone, growth=m.growth, grading=m.grading,
        extent_up=g.extent_up, extent_down=g.extent_down,
        extent_depth=g.extent_depth, matching=g.matching))
