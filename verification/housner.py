"""The rigid rocking block (Housner 1963, Bull. Seismol. Soc. Am. 53(2):403-417), exact
equation of motion between impacts (Makris & Konstantinidis 2003, Earthquake Engng Struct.
Dyn. 32:265-289, eq. 1), integrated with scipy's ``solve_ivp``: the reference of
verification/rocking.py and tests/test_rocking.py, independent of the FE code.

A rigid rectangular block of half-width b and half-height h (R = sqrt(b^2 + h^2), slenderness
alpha = atan(b/h), I_o = 4/3 m R^2 about a bottom corner) stands on a rigid base with enough
friction not to slide. The ground accelerates horizontally with a_g(t) (+x). The rotation
theta (counter-clockwise positive: about the left corner for theta > 0) obeys

    I_o theta'' = -sgn(theta) m g R sin(alpha - |theta|) + m a_g R cos(alpha - |theta|)

(the inertial force -m a_g at the centre of mass, R cos(alpha - |theta|) above the pivot).
At rest it uplifts when |a_g| passes g tan(alpha) (theta takes the sign of a_g). Impacts
(theta back to 0) are not modelled: the coefficient of restitution is a property of the
contact law, so the reference stops at the first impact; toppling is |theta| reaching alpha
(the centre of mass over the pivot: past it nothing restores the block).

``inset``: the pivot lies this far inside the block's corner, on its base (b - inset from the
centre line; I_o = m ((b^2 + h^2)/3 + R^2) about it): an FE joint whose contact acts at Gauss
points pivots on the outermost one, 0.113 of the outer segment's length inside the corner
(3 points per segment). inset = 0: Housner's block.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

__all__ = ["rocking_response", "free_rocking_quarter"]


def _block(b, h, inset, g):
    """(R, alpha, p^2 = m g R / I_o) of the block pivoting ``inset`` inside its corner."""
    be = b - inset
    R = math.hypot(be, h)
    return R, math.atan2(be, h), g * R / ((b * b + h * h) / 3.0 + R * R)


def rocking_response(b, h, accel, t_end, *, g=9.81, inset=0.0, rtol=1e-10, atol=1e-12,
                     max_step=1e-3):
    """The block's response to the ground acceleration ``accel(t)`` from rest at t = 0 up to
    the first impact, toppling or ``t_end``. Returns a dict: ``t_uplift`` (None: never),
    ``t``/``theta`` (the history from uplift), ``theta_max`` (signed, largest |theta|),
    ``t_max``, ``t_impact`` (theta back to 0, None if not before t_end or toppling),
    ``t_topple`` (|theta| = alpha, None if not), ``alpha``."""
    R, alpha, p2 = _block(b, h, inset, g)     # p2 = m g R / I_o
    thr = g * math.tan(alpha)
    # uplift: the first time |a_g| passes g tan(alpha), on a fine grid then refined
    ts = np.arange(0.0, t_end, 1e-4)
    a = np.array([accel(t) for t in ts])
    up = np.flatnonzero(np.abs(a) > thr)
    out = {"alpha": alpha, "t_uplift": None, "t": np.zeros(0), "theta": np.zeros(0),
           "theta_max": 0.0, "t_max": None, "t_impact": None, "t_topple": None}
    if not up.size:
        return out
    j = int(up[0])
    lo, hi = ts[max(j - 1, 0)], ts[j]
    for _ in range(60):                       # bisection on |a_g| = g tan(alpha)
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if abs(accel(mid)) <= thr else (lo, mid)
    t0 = hi
    side = 1.0 if accel(t0) > 0 else -1.0     # the sign theta takes

    def rhs(t, y):
        th = abs(y[0])
        return [y[1], p2 * (-side * math.sin(alpha - th) + accel(t) / g * math.cos(alpha - th))]

    def impact(t, y):
        return y[0] if t > t0 + 1e-9 else side
    impact.terminal, impact.direction = True, -side

    def topple(t, y):
        return abs(y[0]) - alpha
    topple.terminal, topple.direction = True, 1.0

    sol = solve_ivp(rhs, (t0, t_end), [side * 1e-12, 0.0], events=(impact, topple),
                    rtol=rtol, atol=atol, max_step=max_step, dense_output=True)
    out.update(t_uplift=t0, t=sol.t, theta=sol.y[0])
    k = int(np.argmax(np.abs(sol.y[0])))
    # the extremum where theta' = 0, from the dense output
    tt = np.linspace(sol.t[max(k - 1, 0)], sol.t[min(k + 1, sol.t.size - 1)], 2001)
    th = sol.sol(tt)[0]
    kk = int(np.argmax(np.abs(th)))
    out.update(theta_max=float(th[kk]), t_max=float(tt[kk]))
    if sol.t_events[0].size:
        out["t_impact"] = float(sol.t_events[0][0])
    if sol.t_events[1].size:
        out["t_topple"] = float(sol.t_events[1][0])
    return out


def free_rocking_quarter(b, h, theta0, *, g=9.81, inset=0.0):
    """Time from release at rest at theta0 (0 < theta0 < alpha) to the impact (theta = 0) of
    the free block: exact (Housner 1963 eq. for the nonlinear pendulum's inverted part)."""
    R, alpha, p2 = _block(b, h, inset, g)

    def rhs(t, y):
        return [y[1], -p2 * math.sin(alpha - y[0])]

    def impact(t, y):
        return y[0]
    impact.terminal, impact.direction = True, -1.0
    sol = solve_ivp(rhs, (0.0, 100.0), [theta0, 0.0], events=impact, rtol=1e-11, atol=1e-13)
    return float(sol.t_events[0][0])
