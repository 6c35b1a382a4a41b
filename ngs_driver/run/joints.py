"""The joints of a run: each joint's law, its size-scale state and its measures.

Points of all joints are concatenated (the base first, then the lift joints bottom up, each
sorted from its upstream end); ``slices[i]`` are joint i's points. A law is updated from its
own joint's failed length only (paper §2, §5: the size b is the debonded length of *that*
interface).
"""
from __future__ import annotations

import numpy as np

from ..setup import build_law, build_scaling
from ..solve.joint_laws import JointLaws

__all__ = ["JointSet", "crack_measures", "debonded_measures", "JOINT_KEYS"]

# per-joint history columns, prefixed "<joint>_" in timeseries.csv
JOINT_KEYS = ("crack_length", "crack_length_upstream", "n_debonded", "max_D", "D_upstream",
              "opening_upstream", "slip_mean", "size_b", "sigma_max")


def crack_measures(state, w) -> tuple[float, float, int]:
    """(sum of w over debonded points, contiguous debonded length from the upstream end,
    n debonded) of one joint. Points are sorted from the upstream end."""
    return debonded_measures(np.asarray(state.debonded, bool), w)


def debonded_measures(deb, w) -> tuple[float, float, int]:
    """``crack_measures`` from the debonded mask ``deb`` of the joint's points (a slice of
    the mask of all joints, computed once instead of a state copy per joint)."""
    total = float(np.sum(w[deb]))
    if deb.size and deb[0]:
        k = int(np.argmin(deb)) if not deb.all() else deb.size
        heel = float(np.sum(w[:k]))
    else:
        heel = 0.0
    return total, heel, int(deb.sum())


class JointSet:
    def __init__(self, scene, iface):
        tables = scene.joint_tables()
        self.names = [n for n, _ in tables]
        self.tables = [t for _, t in tables]
        self.slices = [iface.parts[n] for n in self.names]
        self.x, self.y, self.w = iface.x, iface.y, iface.w
        self.reference = [build_law(t) for t in self.tables]
        self.scalings = [build_scaling(t, law) for t, law in zip(self.tables, self.reference)]
        self.laws = [sc.update(law, 0.0) if sc is not None else law
                     for sc, law in zip(self.scalings, self.reference)]
        self.sizes = [0.0] * len(self.names)
        # the failed length each law was last updated for: the update is a function of it
        # alone, so an unchanged length leaves the law and the size as they are (skipped)
        self._b = [None] * len(self.names)
        self._wsum = [float(self.w[sl].sum()) for sl in self.slices]

    def __len__(self):
        return len(self.names)

    def solver_law(self):
        """The law the solver evaluates: the base's own law when it is the only joint."""
        return self.laws[0] if len(self.laws) == 1 else JointLaws(self.laws, self.slices)

    def update(self, state) -> bool:
        """Size-scale update at the start of a step from each joint's failed length; True if
        any law changed (the solver must then be given ``solver_law()``)."""
        changed = False
        deb = None
        for i, (sc, sl) in enumerate(zip(self.scalings, self.slices)):
            if sc is None:
                self.sizes[i] = 0.0
                continue
            if deb is None:
                deb = np.asarray(state.debonded, bool)
            b = float(np.sum(self.w[sl][deb[sl]]))     # crack_measures(...)[0]
            if b == self._b[i]:
                continue
            new = sc.update(self.laws[i], b)
            if new.cohesive != self.laws[i].cohesive or new.friction != self.laws[i].friction:
                self.laws[i] = new
                changed = True
            self.sizes[i] = sc.size(b)
            self._b[i] = b
        return changed

    def measures(self, state, gap) -> dict:
        """{"<joint>_<key>": value} for every joint and JOINT_KEYS."""
        out = {}
        deb = np.asarray(state.debonded, bool)
        damage = state.damage
        for name, sl, law, b, wsum in zip(self.names, self.slices, self.laws, self.sizes,
                                          self._wsum):
            w = self.w[sl]
            total, upstream, ndeb = debonded_measures(deb[sl], w)
            d = damage[sl]
            g = gap[sl]
            out[f"{name}_crack_length"] = total
            out[f"{name}_crack_length_upstream"] = upstream
            out[f"{name}_n_debonded"] = ndeb
            out[f"{name}_max_D"] = float(d.max())
            out[f"{name}_D_upstream"] = float(d[0])
            out[f"{name}_opening_upstream"] = float(g[0, 0])
            out[f"{name}_slip_mean"] = float(np.dot(w, g[:, 1]) / wsum)
            out[f"{name}_size_b"] = b
            out[f"{name}_sigma_max"] = law.cohesive.sigma_max
        return out

    def history_keys(self) -> list[str]:
        return [f"{n}_{k}" for n in self.names for k in JOINT_KEYS]

    def params(self) -> list[dict]:
        return [{"sigma_max": lw.cohesive.sigma_max, "tau_max": lw.cohesive.tau_max,
                 "l_Nc": lw.cohesive.l_Nc, "l_Tc": lw.cohesive.l_Tc,
                 "friction": None if lw.friction is None else lw.friction.f}
                for lw in self.laws]
