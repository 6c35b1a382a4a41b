"""The joints of a run: each joint's law, its size-scale state and its measures.

Points of all joints are concatenated (the base first, then the lift joints bottom up, each
sorted from its upstream end); ``slices[i]`` are joint i's points. A law is updated from its
own joint's failed length only (paper §2, §5: the size b is the debonded length of *that*
interface).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ..setup import build_law, build_scaling
from ..solve.joint_laws import JointLaws
from .pairing import OPEN_GAP
from .parts import Part

# a point whose normal gap exceeds this has slid off the face below it (run/pairing opens such
# a point by OPEN_GAP = 1 m; a real opening of half a metre is far outside the model anyway)
OFF_FACE_GAP = 0.5 * OPEN_GAP

__all__ = ["Joints", "SizeScale", "JointScan", "crack_measures", "debonded_measures", "JOINT_KEYS"]

# per-joint history columns, prefixed "<joint>_" in timeseries.csv
JOINT_KEYS = ("crack_length", "crack_length_upstream", "n_debonded", "max_D", "D_upstream",
              "opening_upstream", "slip_mean", "size_b", "sigma_max", "slip", "rotation")


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


@njit(cache=True)
def _pairwise_sum(a, i0, n):
    """numpy's sum of a[i0:i0 + n] (``add.reduce`` of a contiguous float64 array: the
    pairwise sum of numpy/_core/src/umath/loops_utils.h, 8 accumulators in blocks of <= 128,
    started from the identity 0.0), the same bits (tests/test_run_loop.py)."""
    if n < 8:
        res = 0.0
        for i in range(i0, i0 + n):
            res += a[i]
        return res
    if n <= 128:
        r0, r1, r2, r3 = a[i0], a[i0 + 1], a[i0 + 2], a[i0 + 3]
        r4, r5, r6, r7 = a[i0 + 4], a[i0 + 5], a[i0 + 6], a[i0 + 7]
        m = n - n % 8
        i = 8
        while i < m:
            j = i0 + i
            r0 += a[j]
            r1 += a[j + 1]
            r2 += a[j + 2]
            r3 += a[j + 3]
            r4 += a[j + 4]
            r5 += a[j + 5]
            r6 += a[j + 6]
            r7 += a[j + 7]
            i += 8
        res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
        while i < n:
            res += a[i0 + i]
            i += 1
        return res
    n2 = n // 2
    n2 -= n2 % 8
    return _pairwise_sum(a, i0, n2) + _pairwise_sum(a, i0 + n2, n - n2)


def np_sum(a) -> float:
    """``float(np.sum(a))`` of a 1-D float64 array by ``_pairwise_sum`` (tests)."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    return 0.0 + _pairwise_sum(a, 0, a.size)


@njit(cache=True, error_model="numpy")       # x / 0 -> inf / nan as numpy, no exception
def _scan(starts, stops, par, w, kappa, damage, t, g, wd, wb, cpb, stored, ints, flts):
    """The per-point work of a step's joint measures, all joints in one call (``JointScan``).

    Joint i has points starts[i]:stops[i] and law parameters par[i] = (tau_max,
    l_Nc / l_Tc, lambda_max, friction 0/1, C_T). Debonded: kappa >= 1 or D >= 1 (the
    state's ``debonded``). Per joint: ints[i] = (n debonded, n bonded), flts[i] = (sum of w
    over debonded points, contiguous debonded length from the upstream end, max D, sum of
    w over bonded points) with numpy's sums; wb, cpb (from starts[i] on) the bonded points'
    w and cohesive shear strength (1 - D) tau_max (l_Nc/l_Tc) clip((1 - kappa)/(1 -
    lambda_max), 0, 1); stored the recoverable energy per point (energy.stored_energy). The
    operations are numpy's of the functions they replace, in the same order (same bits)."""
    for i in range(starts.size):
        s0, s1 = starts[i], stops[i]
        tau, ratio, lam1, fric, ct = par[i, 0], par[i, 1], 1.0 - par[i, 2], par[i, 3], par[i, 4]
        nd = 0
        nb = 0
        heel = s1 - s0                       # contiguous debonded points from the upstream end
        dmax = damage[s0]
        for p in range(s0, s1):
            d = damage[p]
            if dmax == dmax and not d <= dmax:      # np.max: NaN propagates
                dmax = d
            deb = kappa[p] >= 1.0 or d >= 1.0
            e = 0.5 * t[p, 0] * g[p, 0]
            tang = 0.5 * t[p, 1] * g[p, 1]
            if deb:
                wd[s0 + nd] = w[p]
                nd += 1
                if fric != 0.0 and t[p, 0] < 0.0:
                    tang = 0.5 * (t[p, 1] * t[p, 1]) / ct
            else:
                if heel == s1 - s0:
                    heel = p - s0
                x = (1.0 - kappa[p]) / lam1
                if not x != x:                       # np.clip(x, 0, 1), NaN kept
                    x = min(max(x, 0.0), 1.0)
                wb[s0 + nb] = w[p]
                cpb[s0 + nb] = (1.0 - d) * tau * ratio * x
                nb += 1
            stored[p] = e + tang
        ints[i, 0] = nd
        ints[i, 1] = nb
        flts[i, 0] = 0.0 + _pairwise_sum(wd, s0, nd)
        flts[i, 1] = 0.0 + _pairwise_sum(w, s0, heel) if heel > 0 else 0.0
        flts[i, 2] = dmax
        flts[i, 3] = 0.0 + _pairwise_sum(wb, s0, nb)


class JointScan:
    """What a step's measures need from the committed state, computed once for every joint
    in one compiled pass (``_scan``) instead of ~40 small numpy operations spread over the
    joints', safety's and energy's measures. Fields per joint i (``slices[i]``):
    n_debonded, crack_length, crack_length_upstream, max_D, bonded_length, bonded(i) -> (w,
    c_p) of its bonded points; ``stored`` the recoverable energy of every point."""

    def __init__(self, joints, state, gap, traction):
        n = joints.w.size
        st, g, t = state, _c2(gap), _c2(traction)
        self.slices = joints.slices
        self.wb, self.cpb, self.stored = np.empty(n), np.empty(n), np.empty(n)
        self.ints = np.empty((len(joints.slices), 2), dtype=np.int64)
        self.flts = np.empty((len(joints.slices), 4))
        _scan(joints._starts, joints._stops, joints.law_params(), joints._wc,
              _c1(st.kappa), _c1(st.damage), t, g, np.empty(n), self.wb, self.cpb,
              self.stored, self.ints, self.flts)

    def bonded(self, i):
        s0 = self.slices[i].start
        nb = int(self.ints[i, 1])
        return self.wb[s0:s0 + nb], self.cpb[s0:s0 + nb]


def _c1(a):
    return np.ascontiguousarray(a, dtype=np.float64)


def _c2(a):
    a = np.ascontiguousarray(a, dtype=np.float64)
    return a.reshape(-1, 2)


class Joints(Part):
    """The joints of a run (the base first, then the lift joints bottom up): names, point
    slices of the joint operator ``iface``, each joint's reference law, its size scaling and
    its current (size-scaled) law, and the per-step measures; a run part (``run.parts``):
    after each step its measures are the step's ``measures`` and history columns."""

    name = "joints"

    def __init__(self, joints, iface):
        """joints: the scene's ``setup.JointInput``s (``setup.resolve(scene).joints``)."""
        self.names = [j.name for j in joints]
        self.tables = [j.law for j in joints]
        self._cracked = [j.cracked for j in joints]
        self.slices = [iface.parts[n] for n in self.names]
        self.x, self.y, self.w = iface.x, iface.y, iface.w
        self.reference = [build_law(t) for t in self.tables]
        self.scalings = [build_scaling(t, law) for t, law in zip(self.tables, self.reference)]
        self.laws = [scal.update(law, 0.0) if scal is not None else law
                     for scal, law in zip(self.scalings, self.reference)]
        self.sizes = [0.0] * len(self.names)
        # the failed length each law was last updated for: the update is a function of it
        # alone, so an unchanged length leaves the law and the size as they are (skipped)
        self._b = [None] * len(self.names)
        self._wsum = [float(self.w[sl].sum()) for sl in self.slices]
        self._wc = np.ascontiguousarray(self.w, dtype=np.float64)
        self._starts = np.array([sl.start for sl in self.slices], dtype=np.int64)
        self._stops = np.array([sl.stop for sl in self.slices], dtype=np.int64)
        if any(sl.step not in (None, 1) or sl.stop <= sl.start for sl in self.slices):
            raise ValueError("joints: every joint must be a non-empty contiguous slice")
        self._keys = [tuple(f"{n}_{k}" for k in JOINT_KEYS) for n in self.names]
        # the rotation of the block above a joint relative to the face below: the weighted
        # least-squares slope of the opening g_N(x) along the joint (counter-clockwise
        # positive: a rigid rotation theta about any point opens the joint by theta (x - x0))
        self._rot = []
        for sl in self.slices:
            x, w = self.x[sl], self.w[sl]
            xc = x - np.dot(w, x) / w.sum()
            self._rot.append(w * xc / np.dot(w, xc * xc))
        self._ref = np.zeros((len(self.names), 2))       # (slip, rotation) of the static state

    def kinematics(self, gap) -> np.ndarray:
        """(joints, 2): mean slip (w-weighted mean g_T) [m] and rotation of the block above
        (counter-clockwise positive) [rad] of every joint, absolute (not relative to the
        static state)."""
        out = np.empty((len(self.names), 2))
        for i, sl in enumerate(self.slices):
            out[i] = self._slip_rotation(i, sl, gap[sl])
        return out

    def _slip_rotation(self, i, sl, g) -> tuple[float, float]:
        """(mean slip, rotation) of joint i from its gaps g. Points that slid off the face
        below (run/pairing opens them by OPEN_GAP) are left out: their gap is not the body's
        motion (one such point at the end of koyna_1967's neck read as 1.6e-3 rad)."""
        off = g[:, 0] > OFF_FACE_GAP
        if off.any() and not off.all():
            w = np.where(off, 0.0, self.w[sl])
            x = self.x[sl]
            xc = x - np.dot(w, x) / w.sum()
            return (float(np.dot(w, g[:, 1]) / w.sum()),
                    float(np.dot(w * xc, g[:, 0]) / np.dot(w, xc * xc)))
        return (float(np.dot(self.w[sl], g[:, 1]) / self._wsum[i]),
                float(np.dot(self._rot[i], g[:, 0])))

    @property
    def static_motion(self) -> np.ndarray:
        """(joints, 2) static slip and rotation (``set_reference``)."""
        return self._ref.copy()

    @static_motion.setter
    def static_motion(self, value):
        self._ref = np.array(value, dtype=np.float64).reshape(len(self.names), 2)

    def set_reference(self, gap):
        """The static state's slip and rotation: the history's "<joint>_slip" and
        "<joint>_rotation" are measured from them (what the earthquake did)."""
        self._ref = self.kinematics(gap)

    def __len__(self):
        return len(self.names)

    def cracked_points(self) -> np.ndarray:
        """Bool mask of the points of the joints that start cracked (``cracked = true``)."""
        mask = np.zeros(self.w.size, bool)
        for cracked, sl in zip(self._cracked, self.slices):
            if cracked:
                mask[sl] = True
        return mask

    def solver_law(self):
        """The law the solver evaluates: the base's own law when it is the only joint."""
        return self.laws[0] if len(self.laws) == 1 else JointLaws(self.laws, self.slices)

    def update(self, state, scan=None) -> bool:
        """Size-scale update at the start of a step from each joint's failed length; True if
        any law changed (the solver must then be given ``solver_law()``). scan: the
        ``JointScan`` of ``state`` if the caller has it (its crack lengths are the same
        sums)."""
        changed = False
        deb = None
        for i, (scal, sl) in enumerate(zip(self.scalings, self.slices)):
            if scal is None:
                self.sizes[i] = 0.0
                continue
            if scan is not None:
                b = float(scan.flts[i, 0])
            else:
                if deb is None:
                    deb = np.asarray(state.debonded, bool)
                b = float(np.sum(self.w[sl][deb[sl]]))     # crack_measures(...)[0]
            if b == self._b[i]:
                continue
            new = scal.update(self.laws[i], b)
            if new.cohesive != self.laws[i].cohesive or new.friction != self.laws[i].friction:
                self.laws[i] = new
                changed = True
            self.sizes[i] = scal.size(b)
            self._b[i] = b
        return changed

    def law_params(self) -> np.ndarray:
        """(joints, 5): tau_max, l_Nc / l_Tc, lambda_max, friction (0/1) and the tangential
        stick stiffness C_T of each joint's current law (``_scan``)."""
        par = np.empty((len(self.laws), 5))
        for i, law in enumerate(self.laws):
            c, fr = law.cohesive, law.friction
            ct = 1.0 if fr is None else (fr.penalty if fr.penalty is not None
                                         else c.k_tangential)
            par[i] = (c.tau_max, c.l_Nc / c.l_Tc, c.lambda_max, 0.0 if fr is None else 1.0, ct)
        return par

    def scan(self, state, gap, traction) -> JointScan:
        return JointScan(self, state, gap, traction)

    def measures(self, state, gap, scan=None, traction=None) -> dict:
        """{"<joint>_<key>": value} for every joint and JOINT_KEYS. scan: the step's
        ``JointScan`` (else formed here; its traction-dependent parts unused: ``traction``
        defaults to zeros)."""
        if scan is None:
            scan = self.scan(state, gap, np.zeros_like(gap) if traction is None else traction)
        out = {}
        damage = state.damage
        ints, flts = scan.ints.tolist(), scan.flts.tolist()
        for i, (sl, law, b, wsum, keys) in enumerate(zip(self.slices, self.laws, self.sizes,
                                                        self._wsum, self._keys)):
            g = gap[sl]
            tot, up, dmax, _ = flts[i]
            slip, rot = self._slip_rotation(i, sl, g)
            vals = (tot, up, ints[i][0], dmax, float(damage[sl.start]), float(g[0, 0]),
                    slip, b, law.cohesive.sigma_max, slip - self._ref[i, 0],
                    rot - self._ref[i, 1])
            out.update(zip(keys, vals))
        return out

    def history_keys(self) -> list[str]:
        return [f"{n}_{k}" for n in self.names for k in JOINT_KEYS]

    def after_step(self, ctx):
        ctx.measures = self.measures(ctx.state, ctx.solver.g, ctx.scan)
        ctx.row.update(ctx.measures)

    def checkpoint(self) -> dict:
        return {"static_motion": self.static_motion}

    def restore(self, d):
        self.static_motion = d["static_motion"]

    def params(self) -> list[dict]:
        return [{"sigma_max": lw.cohesive.sigma_max, "tau_max": lw.cohesive.tau_max,
                 "l_Nc": lw.cohesive.l_Nc, "l_Tc": lw.cohesive.l_Tc,
                 "friction": None if lw.friction is None else lw.friction.f}
                for lw in self.laws]


class SizeScale(Part):
    """The size-scale update of every joint's law from its failed length (paper §2), a run
    part (``run.parts``): after each step, the laws of the next; the solver gets the new law
    and the energy budget books the energy the change of law releases. Its checkpoint is
    empty: the laws follow from the committed interface state (``restore``)."""

    name = "size_scale"

    def __init__(self, joints, solver, energy):
        self.joints, self.solver, self.energy = joints, solver, energy

    def update(self, state, book_energy: bool = True, scan=None):
        old = list(self.joints.laws)
        if self.joints.update(state, scan):
            self.solver.set_law(self.joints.solver_law())
            if book_energy:
                self.energy.law_update(old, self.solver.g, state)

    def after_step(self, ctx):
        self.update(ctx.state, scan=ctx.scan)

    def restore(self, d):
        """The laws of the restored solver's state (its energy was booked before)."""
        self.update(self.solver.state, book_energy=False)
