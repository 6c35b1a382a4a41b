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
        n, dim = gap.shape
        if out is None:
            t = np.empty((n, dim))
            T = np.empty((n, dim, dim))
            new = InterfaceState(*(np.empty_like(getattr(state, f.name))
                                   for f in fields(InterfaceState)))
        else:
            t, T, new = out
        for law, sl in zip(self.laws, self.slices):
            ti, Ti, si = law.evaluate(np.ascontiguousarray(gap[sl]), state.take(sl), **kw)
            t[sl] = ti
            T[sl] = Ti
            for f in fields(InterfaceState):
                getattr(new, f.name)[sl] = getattr(si, f.name)
        return t, T, new


def initial_stiffness(law, npts: int) -> np.ndarray:
    """(npts, 2) initial elastic stiffness (k_N, k_T) of the law at every point [Pa/m]."""
    if isinstance(law, JointLaws):
        k = np.empty((npts, 2))
        for lw, sl in zip(law.laws, law.slices):
            k[sl] = (lw.cohesive.k_normal, lw.cohesive.k_tangential)
        return k
    return np.tile([law.cohesive.k_normal, law.cohesive.k_tangential], (npts, 1))


def reference_gap(law) -> float:
    """The smallest elastic opening at peak, lambda_max l_Nc, over the joints' laws [m]."""
    laws = law.laws if isinstance(law, JointLaws) else (law,)
    return min(lw.cohesive.lambda_max * lw.cohesive.l_Nc for lw in laws)
