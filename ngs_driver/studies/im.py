"""Intensity measures of a record as it enters the analysis, and scaling to a target.

* ``pga``: max |a_x| of the horizontal input [g] (the whole record, not only the analysed window).
* ``sa``:  Sa(T1, 5 %) [g], the 5 %-damped pseudo-spectral acceleration of the horizontal input
  at the dam's first natural period T1 (modal analysis with the interface bonded,
  ``fe.modal.modal_analysis``), computed by ``setup.ground_motion.response_spectrum``.

The IM is evaluated on the record exactly as the run sees it: ``load_ground_motion(scene)``
with ``ground_motion.scale = 1`` (after reading, vertical choice and resampling to the scene's
dt). Both IMs are linear in the scale factor, so the factor that brings a record to a target is
``target / IM(unscaled)``; the IDA sets ``ground_motion.scale`` to it.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ..fe.modal import modal_analysis
from ..fe.model import build_from_scene
from ..setup import k0_from_scene, load_ground_motion
from ..setup.ground_motion import G, response_spectrum

IMS = ("pga", "sa")
ZETA = 0.05
IM_LABEL = {"pga": "PGA [g]", "sa": "Sa(T1, 5 %) [g]"}


def pga_g(gm) -> float:
    return float(np.max(np.abs(gm.ax))) / G


def sa_g(gm, T: float, zeta: float = ZETA) -> float:
    if not (T > 0):
        raise ValueError(f"Sa(T): period T = {T!r} s is not allowed; T must be > 0")
    return float(response_spectrum(gm.ax, gm.dt, np.array([float(T)]), zeta)[0]) / G


def intensity(gm, im: str, T1: float | None = None) -> float:
    if im == "pga":
        return pga_g(gm)
    if im == "sa":
        if T1 is None:
            raise ValueError("--im sa needs the first period T1 of the dam")
        return sa_g(gm, T1)
    raise ValueError(f"--im {im!r}: not allowed; choose one of {list(IMS)}")


def unit_scene(scene):
    """The scene with ground_motion.scale = 1 (the record as stored)."""
    return dataclasses.replace(scene, ground_motion=dataclasses.replace(scene.ground_motion,
                                                                        scale=1.0))


def scale_factor(scene, im: str, target: float, T1: float | None = None) -> tuple[float, float]:
    """(factor, IM of the unscaled record) such that the record times factor has IM = target."""
    if not (target > 0):
        raise ValueError(f"target {im} = {target!r} g: not allowed; must be > 0")
    gm = load_ground_motion(unit_scene(scene))
    im0 = intensity(gm, im, T1)
    if not (im0 > 0):
        raise ValueError(f"{scene.ground_motion.record}: {im} of the unscaled record is "
                         f"{im0!r}; it cannot be scaled to a target")
    return target / im0, im0


def first_period(scene) -> dict:
    """T1 [s] of the scene's dam (bonded interface), with the frequencies; builds the model."""
    model = build_from_scene(scene)
    k0n, k0t = k0_from_scene(scene)
    res = modal_analysis(model, 6, k0n, k0t)
    f1 = float(res.frequencies_hz[0])
    return {"T1": 1.0 / f1, "f1_hz": f1,
            "frequencies_hz": [float(f) for f in res.frequencies_hz]}
