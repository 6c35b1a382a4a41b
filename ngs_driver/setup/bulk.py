"""The reduced bulk's inputs (``solver.bulk``, ``solver.bulk_modes``, ``solver.bulk_cutoff_hz``;
fe/reduction.py, docs/reduced_bulk.md) against the rest of the scene, at ``--dry-run``."""
from __future__ import annotations

import math

__all__ = ["validate_bulk", "resolved_frequency"]

# a mode is resolved by the mesh when its shear wavelength spans at least this many of the
# coarsest elements (the usual 8-10 elements a wavelength for linear elements: Kuhlemeyer &
# Lysmer 1973, J. Soil Mech. Found. Div. 99(SM5):421, ask h <= lambda / 8 .. lambda / 10)
ELEMENTS_PER_WAVELENGTH = 10.0


def resolved_frequency(scene) -> float:
    """The highest frequency [Hz] the mesh resolves: the slowest shear wave speed of the dam and
    the rock over ELEMENTS_PER_WAVELENGTH elements of size mesh.h_coarse."""
    mats = [scene.materials.dam]
    if scene.geometry.foundation != "rigid":
        mats.append(scene.materials.rock)
    cs = min(math.sqrt(m.E / (2.0 * (1.0 + m.nu) * m.rho)) for m in mats)
    return cs / (ELEMENTS_PER_WAVELENGTH * scene.mesh.h_coarse)


def validate_bulk(scene) -> None:
    """Raises ValueError naming the key, the value and what is allowed when the reduced bulk
    is asked for with a combination it does not support or a cut-off the mesh cannot carry."""
    sv = scene.solver
    default_modes = type(sv)().bulk_modes
    if sv.bulk != "reduced":                 # a key that would be ignored (setup/sanity.py)
        for key, val, unset in (("bulk_modes", sv.bulk_modes, default_modes),
                                ("bulk_cutoff_hz", sv.bulk_cutoff_hz, 0.0)):
            if val != unset:
                raise ValueError(f"solver.{key} = {val!r} with solver.bulk = {sv.bulk!r}: read "
                                 f"only by the reduced bulk (it would be ignored); allowed: "
                                 f"solver.bulk = 'reduced', or no solver.{key}")
        return
    if sv.bulk_cutoff_hz > 0.0 and sv.bulk_modes != default_modes:
        raise ValueError(f"solver.bulk_modes = {sv.bulk_modes!r} with solver.bulk_cutoff_hz = "
                         f"{sv.bulk_cutoff_hz!r}: the cut-off decides which modes are kept (the "
                         "count would be ignored); allowed: one of the two")
    g = scene.geometry
    if g.rock_sides == "absorbing":
        raise ValueError("geometry.rock_sides = 'absorbing' with solver.bulk = 'reduced': not "
                         "supported (the rock's interior has no support: no constraint modes); "
                         "allowed: rock_sides 'fixed' | 'roller' | 'free', or solver.bulk = "
                         "'full'")
    if scene.screening.enabled:
        raise ValueError("screening.enabled = true with solver.bulk = 'reduced': not supported "
                         "(the element stresses are not recovered every step); allowed: "
                         "screening.enabled = false, or solver.bulk = 'full'")
    r = scene.reservoir
    if r.model == "acoustic" and not r.compressible:
        raise ValueError("reservoir.compressible = false with solver.bulk = 'reduced': not "
                         "supported; allowed: reservoir.compressible = true, reservoir.model = "
                         "'westergaard' | 'none', or solver.bulk = 'full'")
    fmax = resolved_frequency(scene)
    if sv.bulk_cutoff_hz > fmax:
        raise ValueError(f"solver.bulk_cutoff_hz = {sv.bulk_cutoff_hz!r}: above what the mesh "
                         f"resolves ({ELEMENTS_PER_WAVELENGTH:g} elements of mesh.h_coarse = "
                         f"{scene.mesh.h_coarse:g} m a shear wavelength); allowed: (0, "
                         f"{fmax:.4g}] Hz, or 0 (solver.bulk_modes decides)")
