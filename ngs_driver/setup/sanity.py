"""Physical sanity of a scene, checked at ``--dry-run`` (no NGSolve): values each key's range
allows that together make a run absurd or unmeshable (docs/run.md §8).

* The contact stiffness against the static load: under the dam's weight a joint's faces
  overlap by delta = sigma_N / k_c (the penalty contact); delta must stay below
  ``PENETRATION_FRACTION`` of the smallest element on that joint.
* Joints too close to the base, to each other or to the crest for the mesh: the layer between
  two cuts must hold one element of the finer of their end sizes.
* Materials beyond any dam's (``MATERIAL_BOUNDS``): E and rho near 0, nu near 0.5.
* Keys a model does not read, given a value (``uplift.drain_x`` without drains) and a record
  scaled to nothing (``ground_motion.scale = 0``) are refused rather than ignored.
"""
from __future__ import annotations

import numpy as np

from .laws import build_law

__all__ = ["PENETRATION_FRACTION", "check_scene", "static_normal_stress", "joint_spacing"]

# The penalty contact lets a closed joint's faces overlap by delta = sigma_N / k_c; the model
# takes the faces as coincident, so the overlap is geometry the mesh does not have. Kept at 1 %
# of the smallest element on the joint, it stays two orders below the discretisation's own
# length scale; the default k_c = 9e10 Pa/m (the bond's own stiffness) gives 1.6e-5 m under
# Koyna's weight, 1.6e-4 of its 0.1 m heel elements. 1e5 Pa/m would sink the dam 15 m.
PENETRATION_FRACTION = 0.01


def _area_above(sec, y0: float) -> float:
    """Area [m^2] of the section above the elevation y0 (exact: the width is piecewise linear
    in y between the vertices' elevations)."""
    ys = sorted({float(y0), float(sec.height)} | {float(v[1]) for v in sec.vertices
                                                   if y0 < v[1] < sec.height})
    ys = np.array(ys)
    w = np.array([np.subtract(*sec.width_at(min(y, sec.height - 1e-9))[::-1]) for y in ys])
    return float(np.sum(0.5 * (w[1:] + w[:-1]) * np.diff(ys)))


def static_normal_stress(scene, elevation: float) -> float:
    """Mean compression [Pa] of the joint at ``elevation`` under the weight of the dam above
    it (rho g A_above / L: the static load the contact carries without water or uplift)."""
    sec = scene.section
    xu, xd = sec.width_at(elevation) if elevation > 0 else (0.0, float(sec.base_width))
    rho, g = scene.materials.dam.rho, scene.loads.gravity
    return rho * g * _area_above(sec, elevation) / max(xd - xu, 1e-12)


def _cuts(scene):
    """[(key, name, elevation, smallest element on it)] for the base and each lift joint."""
    m = scene.mesh
    out = [("interface", "base", 0.0, min(m.h_heel, m.h_interface))]
    for i, j in enumerate(scene.joints):
        he, hj = j.h_end or m.h_heel, j.h_joint or m.h_interface
        out.append((f"joints[{i}]", j.name, float(j.elevation), min(he, hj)))
    return out


def joint_spacing(scene) -> str | None:
    """Why the joints cannot be meshed apart (None: they can). Between two cuts (the base, the
    joints, the crest) must fit one element of the finer cut's end size: Netgen fails below
    (a joint 0.001 m above the base of koyna_smoke: 'meshing failed') and above it squeezes
    elements of aspect h/d into the layer (measured: it still meshes at 0.01 m, elements of
    aspect 100, whose stresses the joint would read)."""
    cuts = _cuts(scene)
    sec = scene.section
    for (k0, n0, y0, h0), (k1, n1, y1, h1) in zip(cuts[:-1], cuts[1:]):
        need = min(h0, h1)
        if y1 - y0 < need - 1e-12:
            what = "the base" if n0 == "base" else f"joint {n0!r} ({k0})"
            return (f"{k1}.elevation = {y1!r} (joint {n1!r}): {y1 - y0:.4g} m above {what}, "
                    f"closer than the element size there ({need:g} m: mesh.h_heel or the "
                    f"joint's h_end); allowed: at least {need:g} m apart (elevation >= "
                    f"{y0 + need:g} m), or smaller elements there (h_end, mesh.h_heel)")
    if len(cuts) > 1:
        k, n, y, h = cuts[-1]
        if sec.height - y < h - 1e-12:
            return (f"{k}.elevation = {y!r} (joint {n!r}): {sec.height - y:.4g} m below the "
                    f"crest, closer than its element size {h:g} m; allowed: elevation <= "
                    f"{sec.height - h:g} m, or a smaller h_end")
    return None


def _contact(scene) -> str | None:
    for key, name, y, h in _cuts(scene):
        tbl = scene.interface if name == "base" else next(j.interface for j in scene.joints
                                                        if j.name == name)
        if tbl.contact == "none":
            continue
        kc = float(tbl.contact_stiffness)
        sig = static_normal_stress(scene, y)
        delta = sig / kc
        bound = PENETRATION_FRACTION * h
        if delta > bound:
            k_bond = build_law(tbl).cohesive.k_normal
            kmin = sig / bound
            return (f"{key}.contact_stiffness = {kc!r} Pa/m: under the dam's weight (mean "
                    f"compression {sig:.4g} Pa on the {'base' if name == 'base' else 'joint ' + repr(name)}) "
                    f"the joint's faces would overlap by {delta:.4g} m, more than "
                    f"{100 * PENETRATION_FRACTION:g} % of its smallest element ({h:g} m): the "
                    f"penalty contact's overlap is geometry the model does not have; allowed: "
                    f">= {kmin:.3g} Pa/m (the bond's own stiffness sigma_max/(lambda_max l_Nc) "
                    f"is {k_bond:.3g} Pa/m; was the value meant in MPa/m?)")
    return None


def _unused(scene) -> str | None:
    base = scene.uplift
    for i, (name, up) in enumerate(scene.uplift_tables()):
        if up.model == "drains" or up.drain_x == 0.0:
            continue
        if i > 0 and up.drain_x == base.drain_x:
            continue                         # inherited from [uplift], not set on the joint
        key = "uplift" if i == 0 else f"joints[{i - 1}].uplift"
        return (f"{key}.drain_x = {up.drain_x!r} with {key}.model = {up.model!r}: the drain "
                f"line is read only by model = 'drains' (it would be ignored); allowed: "
                f"{key}.model = 'drains', or no drain_x (--set {key}.drain_x=0)")
    if scene.ground_motion.scale == 0.0:
        return ("ground_motion.scale = 0.0: the record scaled to nothing (a run without ground "
                "motion); allowed: (0, 100] (a static check: a small scale such as 1e-3 keeps "
                "the record's shape)")
    return None


# Materials: the schema's open lower bound 0 lets E and rho reach 5e-324 (the factorisation is
# then exactly singular) and nu reach 0.5 - 1e-16 (the modal analysis finds f1 = 0), measured
# by verification/fuzz_edges.py. The floors are far below any dam or foundation material
# (soft clay ~5-20 MPa; rho 1 kg/m^3, about air's, still admits the nearly massless dam of
# tests/test_foundation.py's wave check), the ceiling on nu above any concrete (0.15-0.25) or
# rock (<= 0.4): displacement elements lock volumetrically as nu -> 0.5.
MATERIAL_BOUNDS = {"E": (1e6, None, "Pa", "softer than any soil a dam stands on"),
                   "rho": (1.0, None, "kg/m^3", "lighter than air"),
                   "nu": (None, 0.49, "", "nearly incompressible: the elements lock")}


def _materials(scene) -> str | None:
    for part in ("dam", "rock"):
        mat = getattr(scene.materials, part)
        for name, (lo, hi, unit, why) in MATERIAL_BOUNDS.items():
            v = getattr(mat, name)
            if (lo is not None and v < lo) or (hi is not None and v > hi):
                rng = f">= {lo:g} {unit}" if lo is not None else f"<= {hi:g}"
                return (f"materials.{part}.{name} = {v!r}: {why}; allowed: {rng} "
                        "(docs/run.md §8)")
    return None


def check_scene(scene) -> None:
    """Raise ValueError naming the key, the value and what is allowed (module docstring)."""
    for check in (_materials, _unused, joint_spacing, _contact):
        why = check(scene)
        if why is not None:
            raise ValueError(why)
