"""Uplift (pore pressure) on the joints, as the dam-safety standards draw it (no NGSolve).

docs/safety.md. Coordinates along a joint:
s = distance from its upstream end (the heel for the base), L = its length. Heads are metres of
water above the joint: headwater h_h = max(reservoir.level - y, 0), tailwater
h_t = max(uplift.tailwater - y, 0); pressures p = rho_w g h [Pa], compression of the joint's
faces (the pressure pushes the two faces apart: it acts like an opening traction).

Drawings (USACE EM 1110-2-2100 (2005) ch. 3 and EM 1110-2-2200 (1995) fig. 3-2 to 3-5; FERC
Engineering Guidelines ch. 3 (2016) §3.3.2; CADAM3D help "USACE 1995 distribution of uplift"):

* ``linear``: p_h at s = 0, linear to p_t at s = L;
* ``drains`` (drain line at s = x_d, efficiency E, K = 1 - E): p_h at s = 0, linear to
  p_d = p_t + K (p_h - p_t) (L - x_d)/L at x_d, linear to p_t at L (E = 0 gives ``linear``);
* a crack of length a from the upstream end (static cracked-base analysis): p_h on the crack
  (full reservoir head to the tip), then, if a < x_d, linear to
  p_d = p_t + K (p_h - p_t) (L - x_d)/(L - a) at the drains and on to p_t; if the crack reaches
  the drains (a >= x_d) they are taken as ineffective and p falls linearly from p_h at the tip
  to p_t at L (the USACE "crack extending beyond drains" case).
"""
from __future__ import annotations

import numpy as np

__all__ = ["IN_CRACK", "DEFAULT_DRAIN_FRACTION", "drain_line", "heads", "joint_extent", "pressure_profile", "uplift_force_uncracked",
           "validate_safety", "describe_uplift"]

IN_CRACK = ("unchanged", "zero", "full_headwater")


# uplift.drain_x = 0 (not given) with model = "drains": the drain line ASSUMED at 10 % of the
# joint's length from its upstream end (the assumption koyna_engineering.toml states; a review
# gives its own drains' position)
DEFAULT_DRAIN_FRACTION = 0.10


def drain_line(up, L: float) -> float:
    """The drain line [m from the upstream end] of an uplift table on a joint of length L."""
    return float(up.drain_x) if up.drain_x > 0.0 else DEFAULT_DRAIN_FRACTION * float(L)


def heads(scene, elevation: float, up) -> tuple[float, float]:
    """(headwater, tailwater) heads [m] above a joint at ``elevation`` (m above the base)."""
    H = float(scene.reservoir.level)
    return max(H - elevation, 0.0), max(float(up.tailwater) - elevation, 0.0)


def joint_extent(scene, name: str) -> tuple[float, float, float]:
    """(elevation, x upstream, x downstream) of a joint of the scene."""
    sec = scene.section
    if name == "base":
        return 0.0, 0.0, float(sec.base_width)
    j = next(j for j in scene.joints if j.name == name)
    xu, xd = sec.width_at(j.elevation)
    return float(j.elevation), float(xu), float(xd)


def pressure_profile(s, L: float, p_head: float, p_tail: float, up, crack: float = 0.0):
    """Uplift pressure [Pa] at the distances ``s`` from the upstream end of a joint of length
    ``L`` (module docstring), with a crack of length ``crack`` drawn at full headwater."""
    s = np.asarray(s, dtype=float)
    if up.model == "none" or p_head <= 0.0 and p_tail <= 0.0:
        return np.zeros_like(s)
    a = float(min(max(crack, 0.0), L))
    p = np.full_like(s, p_head)
    beyond = s > a
    if a >= L:
        return p
    xd = drain_line(up, L)
    if up.model == "drains" and a < xd < L:
        K = 1.0 - float(up.drain_efficiency)
        pd = p_tail + K * (p_head - p_tail) * (L - xd) / (L - a)
        m1 = beyond & (s <= xd)
        p[m1] = p_head + (pd - p_head) * (s[m1] - a) / (xd - a)
        m2 = s > xd
        p[m2] = pd + (p_tail - pd) * (s[m2] - xd) / (L - xd)
        return p
    p[beyond] = p_head + (p_tail - p_head) * (s[beyond] - a) / (L - a)
    return p


def uplift_force_uncracked(L: float, p_head: float, p_tail: float, up) -> float:
    """The resultant [N/m] of the uncracked drawing (trapezoids; for describe and checks)."""
    if up.model == "none":
        return 0.0
    if up.model == "drains" and 0.0 < drain_line(up, L) < L:
        xd = drain_line(up, L)
        pd = p_tail + (1.0 - up.drain_efficiency) * (p_head - p_tail) * (L - xd) / L
        return 0.5 * (p_head + pd) * xd + 0.5 * (pd + p_tail) * (L - xd)
    return 0.5 * (p_head + p_tail) * L


def _key(i, name, key):
    return f"uplift.{key}" if i == 0 else f"joints[{i - 1}].uplift.{key}"


def validate_safety(scene) -> None:
    """Uplift and foundation inputs against the section and the water levels (``--dry-run``);
    raises ValueError naming the key, the value and what is allowed."""
    g = scene.geometry
    if g.rock_sides == "absorbing" and g.foundation not in ("rock", "massed"):
        raise ValueError(f"geometry.rock_sides = 'absorbing' with geometry.foundation = "
                         f"{g.foundation!r}: a {'rigid' if g.foundation == 'rigid' else 'massless'}"
                         " foundation carries no waves to absorb; allowed: geometry.foundation "
                         "= 'massed' (or 'rock'), or rock_sides 'fixed' | 'roller' | 'free'")
    H = float(scene.reservoir.level)
    for i, (name, up) in enumerate(scene.uplift_tables()):
        if up.tailwater > H + 1e-12:
            raise ValueError(f"{_key(i, name, 'tailwater')} = {up.tailwater!r}: above the "
                             f"headwater reservoir.level = {H:g} m; allowed: [0, {H:g}] m")
        if up.model != "drains":
            continue
        _, xu, xd = joint_extent(scene, name)
        L = xd - xu
        if not (0.0 < drain_line(up, L) < L):
            raise ValueError(f"{_key(i, name, 'drain_x')} = {up.drain_x!r}: the drain line is "
                             f"outside the {'base' if name == 'base' else 'joint ' + repr(name)}"
                             f"; allowed: (0, {L:g}) m from its upstream end")


def describe_uplift(scene) -> dict:
    """Per joint: heads and the uncracked uplift resultant (the dry-run answer)."""
    out = {}
    rho_g = scene.loads.water_density * scene.loads.gravity
    for name, up in scene.uplift_tables():
        if up.model == "none":
            continue
        y, xu, xd = joint_extent(scene, name)
        hh, ht = heads(scene, y, up)
        out[name] = {"model": up.model, "in_crack": up.in_crack, "head": hh, "tail": ht,
                     "uplift_force_uncracked": uplift_force_uncracked(xd - xu, rho_g * hh,
                                                                      rho_g * ht, up)}
    return out
