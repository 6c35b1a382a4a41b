"""The rigid block on a Coulomb plane (Newmark 1965, Geotechnique 15(2):139-160): the permanent
slip a ground motion gives a rigid block that cannot rock, the reference of the sliding checks
(verification/sliding.py, tests/test_sliding.py). Independent of the FE code.

The block (mass m per metre) rests on the ground with friction coefficient f; a constant
horizontal push P (e.g. the hydrostatic water load) acts downstream (+x). The ground moves
with horizontal acceleration a_x(t) and vertical a_y(t), both linear between the record's
samples (as the FE run interpolates them). Relative to the ground the block's slip s obeys,
per unit mass,

    stick:    s'' = 0             while |d(t)| <= mu(t)
    slide:    s'' = d(t) - sign(s') mu(t),    d = -a_x + P/m,   mu = f max(g + a_y, 0)

and a sliding block sticks when its relative velocity reaches zero. Between two samples d and
mu are linear in t, so the velocity is a quadratic and every event (the start of sliding when
|d| reaches mu, the stop when s' reaches 0) is the root of a polynomial of degree <= 2: the
integration below is exact up to round-off (no time step).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["rigid_block_slip"]


def _roots_in(a, b, c, lo, hi):
    """Real roots of a t^2 + b t + c in (lo, hi], sorted."""
    out = []
    if abs(a) < 1e-300:
        if abs(b) > 1e-300:
            out = [-c / b]
    else:
        disc = b * b - 4 * a * c
        if disc >= 0.0:
            q = -0.5 * (b + math.copysign(math.sqrt(disc), b))
            out = [q / a] + ([c / q] if q != 0.0 else [])
    return sorted(t for t in out if lo < t <= hi)


def rigid_block_slip(t, ax, f, *, ay=None, g=9.81, push_over_weight=0.0):
    """Slip history s(t_k) [m] (downstream +x) of the rigid block at the sample times ``t``
    of the ground acceleration ``ax`` [m/s^2] (``ay`` vertical, default 0), friction
    coefficient ``f`` and push P = push_over_weight m g."""
    t = np.asarray(t, dtype=float)
    ax = np.asarray(ax, dtype=float)
    ay = np.zeros_like(ax) if ay is None else np.asarray(ay, dtype=float)
    P = push_over_weight * g
    s = np.zeros(t.size)
    pos, vel = 0.0, 0.0
    for k in range(t.size - 1):
        h = t[k + 1] - t[k]
        d0, d1 = -ax[k] + P, -ax[k + 1] + P
        m0, m1 = f * max(g + ay[k], 0.0), f * max(g + ay[k + 1], 0.0)
        tau = 0.0                                  # time into the interval
        while tau < h:
            # linear in the local time: d(tau) = d0 + dd tau, mu(tau) = m0 + dm tau
            dd, dm = (d1 - d0) / h, (m1 - m0) / h
            dt_, mt_ = d0 + dd * tau, m0 + dm * tau
            if vel == 0.0:                          # stuck: when does |d| exceed mu?
                tol = 1e-14 * max(1.0, mt_)
                sgn = 1.0 if dt_ > 0 else -1.0
                # sliding starts where |d| is past mu, or at mu (within round-off) and rising:
                # the crossing found below lands there, and the block must start at once
                # (re-testing |d| > mu + tol there missed it, and the block stuck to the end
                # of the interval: sliding began up to one sample late)
                if abs(dt_) > mt_ + tol or (abs(dt_) >= mt_ - tol and sgn * dd - dm > 0.0):
                    pass
                else:
                    # first tau' in (tau, h] where d = mu or d = -mu (and beyond it |d| > mu)
                    cand = []
                    for sg in (1.0, -1.0):
                        # sg d - mu = 0: (sg dd - dm) x + (sg dt_ - mt_) = 0, x = tau' - tau
                        a1 = sg * dd - dm
                        if a1 > 0.0:
                            x = -(sg * dt_ - mt_) / a1
                            if 0.0 <= x < h - tau:
                                cand.append((x, sg))
                    if not cand:
                        tau = h
                        break
                    x, sgn = min(cand)
                    tau += x
                    if x == 0.0:
                        tau += 1e-15 * h             # step past the touching point
                    continue
                vel = sgn * 1e-300                    # sliding (sign kept)
            sgn = 1.0 if vel > 0 else -1.0
            a0 = (d0 + dd * tau) - sgn * (m0 + dm * tau)
            a1 = dd - sgn * dm
            if abs(vel) <= 1e-300 and sgn * a0 < 0.0:
                a0 = 0.0                              # just started at the threshold: round-off
            # v(x) = vel + a0 x + a1 x^2 / 2 on x in (0, h - tau]: stops at its first zero
            r = _roots_in(0.5 * a1, a0, vel, 1e-300, h - tau)
            x = r[0] if r else h - tau
            pos += vel * x + a0 * x * x / 2 + a1 * x ** 3 / 6
            vel = 0.0 if r else vel + a0 * x + a1 * x * x / 2
            if vel != 0.0 and (vel > 0) != (sgn > 0):   # rounding past zero
                vel = 0.0
            tau += x
        s[k + 1] = pos
    return s
