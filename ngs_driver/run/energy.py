"""The energy budget of a run, step by step (docs/run.md §9).

From the static state (t = 0) on, per metre of dam [J/m]:

    W_ext     work of the external loads, trapezoid per step: du . (f_n + f_n+1)/2, with
              f = f_static - M r a_g(t) (gravity, hydrostatic, the ground motion's inertia)
    E_kin     1/2 v.M v
    E_bulk    1/2 u.K u - its static value
    E_damp    viscous dissipation, du . C (v_n + v_n+1)/2 (the damping model's C)
    E_alg     energy removed by the time integrator (HHT, generalized alpha): the work of the
              discrete equations of motion that is neither kinetic, bulk elastic, viscous nor
              done on the joints, W_ext - dE_kin - dE_bulk - E_damp - W_joints, with
              W_joints = sum over the points of w dg . (t_n + t_n+1)/2 (trapezoid)
    E_stored  per joint, the law's recoverable energy (below) - its static value
    E_diss    per joint, the law's own dissipated energy (state "dissipated", friction
              included) - its static value
    E_scaling energy released by the size-scale updates (paper §2, Eq. 11): a new strength
              at a fixed gap changes the stored energy without any work; the jump is booked
              here (stored with the old law minus stored with the new, at the committed gap)

    residual = W_ext - (E_kin + E_bulk + E_damp + E_alg + E_stored + E_diss + E_scaling)
             = W_joints - (E_stored + E_diss + E_scaling)

With compressible acoustic water (``fluid``: the fluid stepper's ``energy_terms``) the water's
terms join the budget: the ground's work on the water W_water (an input) and the
water's kinetic and potential energy, the energy radiated at the far end and absorbed at the
bottom, and (HHT, generalized alpha) E_water_alg, the work the scheme does on the water through
the drift of its once-integrated rows (solve/fluid.py ``_book``); residual = W_ext + W_water -
(... + E_water_kin + E_water_pot + E_water_radiated + E_water_absorbed + E_water_alg).
Westergaard and incompressible water are added masses in M: their kinetic energy is inside
E_kin already; ``E_kin_added_mass`` = 1/2 v.M_a v shows that part.

For average-acceleration Newmark the kinetic, bulk and damping terms obey the identity
W_ext = dE_kin + dE_bulk + E_damp + W_joints exactly per step (the trapezoid pairs with the
scheme: both end-of-step equations hold), so E_alg is zero to the Newton tolerance there (a
check of the bookkeeping, tests/test_energy*); HHT and generalized alpha satisfy a weighted
equation instead, and E_alg >= 0 is their numerical dissipation (Hilber, Hughes & Taylor 1977;
Chung & Hulbert 1993). The joints' term does not close by construction: the stored +
dissipated energy comes from the law, the trapezoid only approximates the work of its
traction along the step, so the residual measures the time-integration error of the joints'
work, O(dt^2) where the traction is smooth in time, and the energy a non-smooth contact or
stick-slip event gains or loses inside a step (tests, verification/energy).

Stored energy of a point: the secant law stores 1/2 t.g (cohesive part, Eqs. 2-3 with secant
unloading; linear contact, whose crack and bond stiffness are equal by default); a point in
frictional contact stores 1/2 t_T^2 / C_T in its stick spring instead of 1/2 t_T g_T. For the
"rough" contact law 1/2 t_N g_N is an approximation of the stored closure energy.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from ..solve.products import FusedPair, pair_products
from .parts import Part

__all__ = ["EnergyBudget", "EnergyGuard", "stored_energy", "ENERGY_KEYS", "GUARD_FRACTION",
           "GUARD_FLOOR", "GUARD_SPLITS"]

# The energy guard (``EnergyGuard``, docs/run.md §9.1): a step that creates more energy than
# GUARD_FRACTION of the work done in it plus GUARD_FLOOR of the run's energy scale is cut.
# 0.5: on koyna_1967 (10 s; docs/run.md §9.1) the largest ratio of created energy to work is 0.13
# (t = 4.912 s: 7.0e3 J/m for 5.4e4 J/m, 0.21 of its limit), 99.9 % of the steps are below
# 0.040; pine_flat (54.38 s) 0.021 (t = 27.9 s), 99.9 % below 0.0052, its largest jump 163 J/m
# (6.88 s) 0.0074 of its limit; the step of the re-pairing bug (koyna_1967, 3.642 s) created
# 7.5e9 J/m, that of pine_flat's water stepped twice by the uplift's fixed point (2.97 s)
# 2.1e3 J/m, 1.2 x its work.
GUARD_FRACTION = 0.5
# the floor keeps quiet steps (work ~ 0) from being cut for round-off and the joints'
# stick-slip: 1e-3 of the scale (static strain energy, or the largest input work so far,
# whichever is larger); neither koyna_1967 nor pine_flat has a step whose jump exceeds 0.5 x
# its work (the floor passes none); the re-pairing bug's 7.5e9 J/m is 700 times koyna_1967's
# scale
GUARD_FLOOR = 1e-3
# a step is retried in 2, 4, ... 2^GUARD_SPLITS uniform sub-steps before the run stops
GUARD_SPLITS = 6

ENERGY_KEYS = ("W_ext", "E_kin", "E_bulk", "E_damp", "E_alg", "E_stored", "E_diss",
               "E_scaling", "residual")
WATER_KEYS = ("W_water", "E_water_kin", "E_water_pot", "E_water_radiated", "E_water_absorbed",
              "E_water_alg")


def stored_energy(law, t, g, state) -> np.ndarray:
    """Recoverable energy per unit area of each point [J/m^2] (see module doc)."""
    deb = np.asarray(state.debonded, bool) if law.friction is not None else None
    return _stored_energy(law, t, g, deb)


def _stored_energy(law, t, g, deb) -> np.ndarray:
    """``stored_energy`` with the points' debonded mask ``deb`` (needed with friction only)."""
    e = 0.5 * t[:, 0] * g[:, 0]
    tang = 0.5 * t[:, 1] * g[:, 1]
    if law.friction is not None:
        ct = law.friction.penalty if law.friction.penalty is not None \
            else law.cohesive.k_tangential
        fr = deb & (t[:, 0] < 0.0)
        tang = np.where(fr, 0.5 * t[:, 1] ** 2 / ct, tang)
    return e + tang


def _symmetric(A) -> bool:
    """A (sparse) equals its transpose to round-off."""
    if A.shape[0] != A.shape[1]:
        return False
    d = abs(A - A.T)
    return d.nnz == 0 or float(d.max()) <= 1e-13 * float(abs(A).max())


def _vec(x, n):
    x = np.ascontiguousarray(x, dtype=np.float64)
    if x.shape != (n,):
        raise ValueError(f"vector of shape {x.shape}, expected ({n},)")
    return x


@njit(cache=True)
def _km_step(indptr, indices, Kx, Mx, u, v, f, u0, v0, f0, Ku0, Mv0, Ku, Mv, du, fs, ms, vs, kd):
    """One step of the budget: Ku, Mv (``solve.products.pair_products``), then
    ``_km_vectors``."""
    pair_products(indptr, indices, Kx, Mx, u, v, Ku, Mv)
    _km_vectors(u, v, f, u0, v0, f0, Ku0, Mv0, Ku, Mv, du, fs, ms, vs, kd)


@njit(cache=True)
def _km_vectors(u, v, f, u0, v0, f0, Ku0, Mv0, Ku, Mv, du, fs, ms, vs, kd):
    """The vectors the step's dot products need, du = u - u0, fs = f0 + f, ms = Mv0 + Mv,
    vs = v0 + v, kd = Ku - Ku0 (numpy's elementwise operations, in one loop), and
    u0, v0, f0 <- u, v, f."""
    for i in range(Ku.size):
        du[i] = u[i] - u0[i]
        fs[i] = f0[i] + f[i]
        ms[i] = Mv0[i] + Mv[i]
        vs[i] = v0[i] + v[i]
        kd[i] = Ku[i] - Ku0[i]
        u0[i] = u[i]
        v0[i] = v[i]
        f0[i] = f[i]


class EnergyBudget(Part):
    """Accumulates the budget; ``start`` at the static state, ``step`` after each step.

    rayleigh = (a0, a1) says that C = a0 M + a1 K + C_extra (C_extra: None or a sparse
    matrix, e.g. the dashpots of absorbing boundaries). For symmetric M and K the damping work
    of a step is then formed from the products the budget takes anyway (no product with C):

        du.C(v0 + v) = a0 du.(M v0 + M v) + a1 (v0 + v).(K u - K u0) + du.C_extra (v0 + v)

    (equal to the direct product to round-off); without it, du.C(v0 + v) directly."""

    def __init__(self, K, M, C, w, joints, rayleigh=None, C_extra=None, fluid=None,
                 added_mass=None, C_lowrank=None):
        self.K, self.M, self.C, self.w = K, M, C, w
        self.C_lowrank = C_lowrank        # C = C + a0 U W U^T (solve/damping.py), or None
        # the water: fluid has energy_terms() (compressible acoustic water); added_mass the
        # Westergaard / incompressible added mass already in M (reported only)
        self.fluid = fluid if hasattr(fluid, "energy_terms") else None
        self.added_mass = added_mass
        self.joints = joints              # run.joints.Joints (names, slices, laws)
        self.rows = []
        self._split = None
        if C is not None and rayleigh is not None and _symmetric(K) and _symmetric(M):
            self._split = (float(rayleigh[0]), float(rayleigh[1]), C_extra)
        self._prods = None                # (M v, K u) of the previous state
        self._km = FusedPair(K, M)          # (K u, M v) in one pass
        n = self._km.n
        self._next = (np.empty(n), np.empty(n))          # buffers of the next (M v, K u)
        self._work = np.empty((5, n))                    # du, fs, ms, vs, kd of a step

    def _levels(self, u, v, t, g, state, Mv=None, Ku=None, scan=None):
        if Mv is None:
            Ku, Mv = self._km.products(_vec(u, self._km.n), _vec(v, self._km.n))
        stored, diss = self._joint_levels(t, g, state, scan)
        return (0.5 * float(v @ Mv), 0.5 * float(u @ Ku), stored, diss)

    def _joint_levels(self, t, g, state, scan=None):
        """Per joint: sum of w x the stored energy (``stored_energy``; from the step's
        ``JointScan`` when the joints can form one) and of w x the law's dissipated energy."""
        if scan is None and hasattr(self.joints, "scan"):
            scan = self.joints.scan(state, g, t)
        dissipated = state.dissipated
        stored, diss = [], []
        if scan is not None:
            for sl in self.joints.slices:
                w = self.w[sl]
                stored.append(float(np.dot(w, scan.stored[sl])))
                diss.append(float(np.dot(w, dissipated[sl])))
            return stored, diss
        laws = self.joints.laws
        deb = (np.asarray(state.debonded, bool)
               if any(law.friction is not None for law in laws) else None)
        for law, sl in zip(laws, self.joints.slices):
            w = self.w[sl]
            stored.append(float(np.dot(w, _stored_energy(law, t[sl], g[sl],
                                                         None if deb is None else deb[sl]))))
            diss.append(float(np.dot(w, dissipated[sl])))
        return stored, diss

    def start(self, u, v, f, t, g, state):
        n = self._km.n
        self._prev = tuple(_vec(x, n).copy() for x in (u, v, f))
        Ku, Mv = self._km.products(_vec(u, n), _vec(v, n))
        self._prods = (Mv, Ku)
        self._ref = self._levels(u, v, t, g, state, *self._prods)
        self.W_ext = 0.0
        self.E_damp = 0.0
        self.E_scaling = 0.0
        self.W_joints = 0.0
        self._tg = self._joint_vectors(t, g)

    def _joint_vectors(self, t, g):
        """(w t, g) flattened (copies): the joints' work of a step is dg . (wt_n + wt_n+1)/2."""
        t = np.ascontiguousarray(t, dtype=np.float64).reshape(-1, 2)
        g = np.ascontiguousarray(g, dtype=np.float64).reshape(-1, 2)
        return (t * self.w[:, None]).ravel(), g.ravel().copy()

    def law_update(self, old_laws, g, state):
        """Book the stored-energy jump of a size-scale update (call after the laws changed,
        before the next step; ``old_laws`` the laws before)."""
        for old, new, sl in zip(old_laws, self.joints.laws, self.joints.slices):
            if old is new:
                continue
            st = state.take(sl)
            gg = np.ascontiguousarray(g[sl])
            # at the committed gap nothing grows: dt (rate-form damage) plays no role
            t_old = old.evaluate(gg, st, dt=1.0)[0]
            t_new = new.evaluate(gg, st, dt=1.0)[0]
            self.E_scaling += float(np.dot(self.w[sl], stored_energy(old, t_old, gg, st)
                                           - stored_energy(new, t_new, gg, st)))

    def step(self, u, v, f, t, g, state, scan=None, products=None) -> dict:
        """Book the step to the committed (u, v, f, t, g, state); scan: the ``JointScan`` of
        (state, g, t) if the caller has it; products: (K u, M v) of this state if the caller
        has them, bitwise those of the budget's K and M (``JointSolver.step_products`` of
        the solver built on the same K and M)."""
        u0, v0, f0 = self._prev                 # updated in place to u, v, f by the kernel
        Mv0, Ku0 = self._prods
        n = self._km.n
        u, v, f = _vec(u, n), _vec(v, n), _vec(f, n)
        du, fs, ms, vs, kd = self._work
        if products is not None:
            Ku, Mv = (_vec(x, n) for x in products)
            _km_vectors(u, v, f, u0, v0, f0, Ku0, Mv0, Ku, Mv, du, fs, ms, vs, kd)
        else:
            Mv, Ku = self._next
            km = self._km
            _km_step(km.indptr, km.indices, km.Ax, km.Bx, u, v, f, u0, v0, f0, Ku0, Mv0, Ku,
                     Mv, du, fs, ms, vs, kd)
        self.W_ext += 0.5 * float(du @ fs)
        if self._split is not None:
            a0, a1, C_extra = self._split
            work = a0 * float(du @ ms) + a1 * float(vs @ kd)
            if C_extra is not None:
                work += float(du @ (C_extra @ vs))
            self.E_damp += 0.5 * work
        elif self.C is not None:
            self.E_damp += 0.5 * float(du @ (self.C @ vs))
        if self.C_lowrank is not None:
            self.E_damp += 0.5 * self.C_lowrank.work(du, vs)
        if products is None:
            self._prods, self._next = (Mv, Ku), (Mv0, Ku0)  # the old products' buffers reused
        else:
            self._prods = (Mv, Ku)
        wt1, g1 = self._joint_vectors(t, g)
        wt0, g0 = self._tg
        self.W_joints += 0.5 * float((g1 - g0) @ (wt0 + wt1))
        self._tg = (wt1, g1)
        kin, bulk, stored, diss = self._levels(u, v, t, g, state, Mv, Ku, scan)
        k0, b0, s0, d0 = self._ref
        e_alg = self.W_ext - (kin - k0) - (bulk - b0) - self.E_damp - self.W_joints
        wt = None
        if self.fluid is not None:              # the water's work and energies close it too
            wt = self.fluid.energy_terms()
            e_alg += wt["W_water"] - (wt["E_water_kin"] + wt["E_water_pot"]
                                      + wt["E_water_radiated"] + wt["E_water_absorbed"]
                                      + wt["E_water_alg"])
        row = {"W_ext": self.W_ext, "E_kin": kin - k0, "E_bulk": bulk - b0,
               "E_damp": self.E_damp, "E_alg": e_alg}
        for name, s, s_0, d, d_0 in zip(self.joints.names, stored, s0, diss, d0):
            row[f"{name}_E_stored"] = s - s_0
            row[f"{name}_E_diss"] = d - d_0
        row["E_stored"] = sum(stored) - sum(s0)
        row["E_diss"] = sum(diss) - sum(d0)
        row["E_scaling"] = self.E_scaling
        row["residual"] = row["W_ext"] - (row["E_kin"] + row["E_bulk"] + row["E_damp"] + e_alg
                                          + row["E_stored"] + row["E_diss"] + self.E_scaling)
        if wt is not None:
            row.update(wt)
            row["residual"] += wt["W_water"] - (wt["E_water_kin"] + wt["E_water_pot"]
                                                + wt["E_water_radiated"]
                                                + wt["E_water_absorbed"]
                                                + wt["E_water_alg"])
        if self.added_mass is not None:
            row["E_kin_added_mass"] = 0.5 * float(v @ (self.added_mass @ v))
        return row

    def rebase_gap(self, g):
        """The joints' gap was re-based without motion (a joint paired anew, run/pairing: a
        point that slid off its face is opened by ``OPEN_GAP``): the next step's joint work
        starts from ``g`` (npts, 2), so that the jump books no work (no traction acts over it)."""
        self._tg = (self._tg[0], np.ascontiguousarray(g, dtype=np.float64).ravel().copy())

    def keys(self) -> list[str]:
        water = (list(WATER_KEYS) if self.fluid is not None else []) + (
            ["E_kin_added_mass"] if self.added_mass is not None else [])
        return list(ENERGY_KEYS[:-1]) + [f"{n}_{k}" for n in self.joints.names
                                         for k in ("E_stored", "E_diss")] + water + ["residual"]

    # a run part (run.parts): the budget's row of the step is formed in the solve (the energy
    # guard checks it there); after the step it goes into the history row
    name = "energy"

    def after_step(self, ctx):
        ctx.row.update(ctx.energy)

    def checkpoint(self) -> dict:
        """What a checkpoint (or a repeat of the step) must keep to continue bitwise."""
        u0, v0, f0 = self._prev
        k0, b0, s0, d0 = self._ref
        return {"prev_u": u0.copy(), "prev_v": v0.copy(), "prev_f": f0.copy(),
                "ref": np.array([k0, b0, *s0, *d0]),
                "acc": np.array([self.W_ext, self.E_damp, self.E_scaling, self.W_joints]),
                "joint_wt": self._tg[0].copy(), "joint_g": self._tg[1].copy()}

    def restore(self, arrs):
        self._prev = tuple(_vec(arrs[f"prev_{x}"], self._km.n).copy() for x in "uvf")
        r = arrs["ref"]
        nj = len(self.joints.names)
        self._ref = (float(r[0]), float(r[1]), [float(x) for x in r[2:2 + nj]],
                     [float(x) for x in r[2 + nj:2 + 2 * nj]])
        acc = [float(x) for x in arrs["acc"]]
        self.W_ext, self.E_damp, self.E_scaling = acc[:3]
        self.W_joints = acc[3]
        self._tg = (np.array(arrs["joint_wt"]), np.array(arrs["joint_g"]))
        u0, v0, _ = self._prev              # the products the run had (bitwise the same)
        Ku, Mv = self._km.products(_vec(u0, self._km.n), _vec(v0, self._km.n))
        self._prods = (Mv, Ku)


class EnergyGuard(Part):
    """No verdict from a step that breaks the energy balance (docs/run.md §9.1).

    From two consecutive rows of the budget (``EnergyBudget.step``), the step's

        jump = max(0, -d (residual + E_alg))          (energy the step created)
        work = |d W_ext| + |d W_water| + |d W_joints| + d E_damp     (work done in the step)

    with W_joints = residual + E_stored + E_diss + E_scaling (the joints' trapezoid work).
    residual + E_alg = W_ext + W_water - (E_kin + E_bulk + E_damp + E_stored + E_diss +
    E_scaling + the water's energies): the input minus every physical energy, independent of
    the trapezoid that splits it between the two (at a rocking impact the residual gains
    2.4e3 J/m and E_alg loses as much: sliding_block rocking at 1.25 x its threshold). It
    decreases when a step makes more energy than its loads put in; the integrator's own
    dissipation (generalized alpha, HHT) only increases it. The water's share of the scheme's
    exchange, E_water_alg (either sign, fixed by the scheme's algebra), is booked apart and
    not in it; a water stepped otherwise (pine_flat's, stepped twice by the uplift's fixed
    point until the solver's saved state held it, docs/run.md §9.1) still shows. A step is
    rejected when

        jump > GUARD_FRACTION * work + GUARD_FLOOR * scale,

    scale = max(static strain energy 1/2 u.f of the static state, the largest |W_ext| +
    |W_water| so far). The run then repeats it from the committed state in 2, 4, ... uniform
    sub-steps (``JointSolver.step(split=k)``) and stops with an error after GUARD_SPLITS
    halvings: such a step is never accepted. The cost: a few scalar differences per step
    (the budget is formed anyway), and a copy of the committed state
    (``run.checkpoint.SolverPart``).
    """

    def __init__(self, e_static: float = 0.0, fraction: float = GUARD_FRACTION,
                 floor: float = GUARD_FLOOR):
        self.fraction, self.floor = float(fraction), float(floor)
        self.e_static = abs(float(e_static))
        self.prev = None                      # the last accepted row's terms
        self.scale = self.e_static
        self.max_jump = 0.0                   # over the accepted steps
        self.max_jump_t = None
        self.max_ratio = 0.0                  # jump / (fraction work + floor scale)
        self.cuts = 0                         # rejected step attempts

    @staticmethod
    def terms(row) -> tuple:
        wj = row["residual"] + row["E_stored"] + row["E_diss"] + row["E_scaling"]
        return (float(row["residual"]), float(row["E_alg"]), float(row["W_ext"]),
                float(row.get("W_water", 0.0)), float(wj), float(row["E_damp"]))

    def start(self, row=None):
        """From the static state (row None: every term zero) or a resumed run's last row."""
        self.prev = (0.0,) * 6 if row is None else self.terms(row)
        self.scale = max(self.e_static, abs(self.prev[2]) + abs(self.prev[3]))

    def measure(self, row) -> tuple[float, float, float]:
        """(jump, work, limit) of the step that ends in ``row``."""
        r0, a0, x0, w0, j0, d0 = self.prev
        r1, a1, x1, w1, j1, d1 = self.terms(row)
        jump = max(0.0, (r0 + a0) - (r1 + a1))
        work = abs(x1 - x0) + abs(w1 - w0) + abs(j1 - j0) + abs(d1 - d0)
        scale = max(self.scale, abs(x1) + abs(w1))
        return jump, work, self.fraction * work + self.floor * scale

    def check(self, row, t) -> tuple[bool, str]:
        """(accepted, why) for the step to time t that ends in ``row``; an accepted step
        becomes the reference of the next."""
        jump, work, limit = self.measure(row)
        if self.fraction > 0.0 and not jump <= limit:      # NaN is rejected too
            self.cuts += 1
            return False, (f"energy jump {jump:.4g} J/m in the step to t = {t:.6g} s exceeds "
                           f"{self.fraction:g} x its work {work:.4g} J/m + {self.floor:g} x the "
                           f"energy scale (limit {limit:.4g} J/m)")
        terms = self.terms(row)
        self.prev = terms
        self.scale = max(self.scale, abs(terms[2]) + abs(terms[3]))
        if jump > self.max_jump:
            self.max_jump, self.max_jump_t = jump, float(t)
        if limit > 0.0:
            self.max_ratio = max(self.max_ratio, jump / limit)
        return True, ""

    # a run part (run.parts): it judges the step inside the solve (``check``)
    name = "guard"

    def checkpoint(self) -> dict:
        """What a checkpoint keeps (JSON): the last accepted step's terms, the energy scale,
        and the maxima so far."""
        return {"e_static": self.e_static, "prev": None if self.prev is None
                else list(self.prev), "scale": self.scale, "cuts": self.cuts,
                "max_jump": self.max_jump, "max_jump_t": self.max_jump_t,
                "max_ratio": self.max_ratio}

    def restore(self, d):
        """A resumed run: ``checkpoint()``'s dict."""
        self.e_static = float(d["e_static"])
        self.prev = None if d["prev"] is None else tuple(float(x) for x in d["prev"])
        self.scale = float(d["scale"])
        self.cuts = int(d["cuts"])
        self.max_jump = float(d["max_jump"])
        self.max_jump_t = d["max_jump_t"]
        self.max_ratio = float(d["max_ratio"])

    def summary(self) -> dict:
        return {"max_step_jump": self.max_jump, "max_step_jump_t": self.max_jump_t,
                "max_step_jump_over_limit": self.max_ratio, "guard_cuts": int(self.cuts),
                "guard": f"a step is cut when the energy it creates, -d(residual + E_alg), > "
                         f"{self.fraction:g} x (|d W_ext| + |d W_water| + |d W_joints| + "
                         f"d E_damp) + {self.floor:g} x max(static strain energy, |W_ext| + "
                         f"|W_water|); docs/run.md §9.1"}
