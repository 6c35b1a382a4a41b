"""Stage 2 of the pipeline: scene -> what the FE model and the solver are fed (no NGSolve).

``build_law`` / ``build_scaling`` (``laws``), ``load_ground_motion`` (``records``) and
``describe`` (what a run would build: the ``--dry-run`` answer).
"""
from __future__ import annotations

from .laws import build_law, build_scaling, characteristic_times, law_parts
from .records import DEFAULT_RECORDS, load_ground_motion

__all__ = ["FORMULATION", "build_law", "build_scaling", "characteristic_times", "law_parts",
           "load_ground_motion", "describe", "DEFAULT_RECORDS"]

FORMULATION = ("relative (rock bottom fixed, ground acceleration as effective inertial load "
               "-M r a_g(t); displacements relative to the rigid ground motion)")



def describe(scene) -> dict:
    """What ``run`` would build (for --dry-run); never imports NGSolve."""
    m, t = scene.mesh, scene.time
    n = int(round(t.duration / t.dt))
    l_nc = 2 * scene.interface.G_I / scene.interface.sigma_max
    return {"scene": scene.to_dict(),
            "will_build": {
                "model": f"Koyna on {scene.geometry.foundation} foundation, P{m.order} "
                         f"triangles, h_heel {m.h_heel} m, h_interface {m.h_interface} m, "
                         f"h_coarse {m.h_coarse} m, {m.gauss_points} Gauss points/segment "
                         "(mesh and DOFs: not built in a dry run)",
                "law": law_parts(scene),
                "reference_l_Nc": l_nc,
                "g_max_over_l_Nc": scene.interface.g_max / l_nc,
                "damping": f"Rayleigh {scene.damping.ratio:g} at "
                           + (f"{list(scene.damping.frequencies)} Hz"
                              if scene.damping.frequencies else
                              f"modes {list(scene.damping.modes)}"),
                "ground_motion": scene.ground_motion.record
                + (" (shipped SYNTHETIC Koyna-like record)"
                   if scene.ground_motion.record in DEFAULT_RECORDS else ""),
                "time": f"{n} steps of {t.dt} s to {t.duration} s, Newmark beta "
                        f"{t.newmark_beta}, gamma {t.newmark_gamma}",
                "formulation": FORMULATION,
                "checkpoint_every": scene.output.checkpoint_every,
                "vtk_every": scene.output.vtk_every}}
