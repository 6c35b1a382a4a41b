"""Several joints, one solver: the laws of all joints over the concatenated points.

The condensed Newton solver sees one gap vector (the base's points first, then each lift
joint's); ``JointLaws`` evaluates each joint's own ``InterfaceLaw`` on its slice and gathers
tractions, tangents and states. A scene with the base only passes its ``InterfaceLaw``
directly (no copy, no overhead).
"""
from __future__ import annotations

from dataclasses import fields

import numpy as np

from interfacelaw import InterfaceState

__all__ = ["JointLaws", "initial_stiffness"]


class JointLaws:
    """``laws[i]`` acts on the points ``slices[i]`` (contiguous, in order, covering all)."""

    def __init__(self, laws, slices):
        self.laws = tuple(laws)
        self.slices = tuple(slices)
        if len(self.laws) != len(self.slices) or not self.laws:
            raise ValueError("JointLaws: one law per slice, at least one")
        self.npts = self.slices[-1].stop

    def replace(self, i: int, law) -> "JointLaws":
        laws = list(self.laws)
        laws[i] = law
        return JointLaws(laws, self.slices)

    def initial_state(self, n: int, dim: int = 2) -> InterfaceState:
        if n != self.npts:
            raise ValueError(f"JointLaws.initial_state: n = {n}, the joints have {self.npts} "
                             "points")
        return self.laws[0].initial_state(n, dim)

    def evaluate(self, gap, state, out=None, **kw):
        laws = self.laws
        return self.gather(state, gap.shape, out,
                           lambda i, sl: laws[i].evaluate(np.ascontiguousarray(gap[sl]),
                                                          state.take(sl), **kw))

    def bind(self, state, dt=None):
        """``evaluate(gap, state, dt=dt)`` as a callable of the gap alone (as
        ``InterfaceLaw.bind``): each joint's law bound to its slice of ``state`` once; the same
        numbers as ``evaluate``."""
        bound = tuple(law.bind(state.take(sl), dt) for law, sl in zip(self.laws, self.slices))

        def call(gap):
            gap = gap.reshape(-1, state.dim)
            return self.gather(state, gap.shape, None,
                               lambda i, sl: bound[i](np.ascontiguousarray(gap[sl])))
        return call

    def gather(self, state, shape, out, each):
        """(traction, tangent, new state) over all points from ``each(i, slices[i])`` of every
        joint i (into ``out``'s arrays when given, else new ones shaped as ``state``'s)."""
        n, dim = shape
        if out is None:
            t = np.empty((n, dim))
            T = np.empty((n, dim, dim))
            new = InterfaceState(*(np.empty_like(getattr(state, f.name))
                                   for f in fields(InterfaceState)))
        else:
            t, T, new = out
        for i, sl in enumerate(self.slices):
            ti, Ti, si = each(i, sl)
            t[sl] = ti
            T[sl] = Ti
            for f in fields(InterfaceState):
                getattr(new, f.name)[sl] = getattr(si, f.name)
        return t, T, new


def law_stiffness(law, cracked: bool = False) -> tuple[float, float]:
    """(k_N, k_T) [Pa/m] of a joint under compression: the normal stiffness is the contact's
    intact (compressive) stiffness when the law has contact (a joint under its dam's weight is
    compressed), else the cohesive one; the tangential is the cohesive one, or for a cracked
    joint with friction the stick stiffness of friction."""
    kn = law.cohesive.k_normal
    kt = law.cohesive.k_tangential
    if law.contact is not None:
        kn = float(law.contact.as_array(law.cohesive)[0])
        if cracked and law.friction is not None:
            kt = float(law.friction.as_array(law.cohesive)[1])
    return kn, kt


def initial_stiffness(law, npts: int, debonded=None) -> np.ndarray:
    """(npts, 2) elastic stiffness (k_N, k_T) of the law at every point [Pa/m]
    (``law_stiffness`` of each joint's law; ``debonded``: bool (npts,) of cracked points)."""
    laws = law.laws if isinstance(law, JointLaws) else (law,)
    slices = law.slices if isinstance(law, JointLaws) else (slice(0, npts),)
    k = np.empty((npts, 2))
    for lw, sl in zip(laws, slices):
        k[sl] = law_stiffness(lw)
        if debonded is not None and np.any(debonded[sl]):
            idx = np.flatnonzero(debonded[sl]) + sl.start
            k[idx] = law_stiffness(lw, cracked=True)
    return k


def reference_gap(law) -> float:
    """The smallest elastic opening at peak, lambda_max l_Nc, over the joints' laws [m]."""
    laws = law.laws if isinstance(law, JointLaws) else (law,)
    return min(lw.cohesive.lambda_max * lw.cohesive.l_Nc for lw in laws)
