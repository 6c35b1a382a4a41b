"""Public API of the interface law: validate, allocate, call the numba kernel."""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from . import _kernels
from .params import CohesiveParams, ContactParams, DamageParams, FrictionParams

__all__ = ["InterfaceState", "InterfaceLaw", "BoundLaw"]

# below this many points the parallel kernel's thread start-up costs more than it saves.
# Measured on 2 cores (full law, random states; serial/parallel time ratio): 0.81 at 256 points,
# 1.64 at 1024, 2.1 at 16384 and beyond
PARALLEL_MIN_POINTS = 512
# the kernels square gaps divided by l_Nc: this bound keeps every square far from overflow
GAP_LIMIT = 1e100
# ``BoundLaw``'s quick accept of a gap: sum g_i^2 <= this implies |g_i| <= 3.2e99 < GAP_LIMIT
# for every i (a NaN or inf makes the sum NaN or inf: not accepted), with a margin of a factor
# 10 in the squares for the rounding of the sum; a gap not accepted gets the full check
_QUICK_SQ = 1e199


@dataclass(frozen=True)
class InterfaceState:
    """Committed history of n material points (struct of arrays, never mutated by the law).

    kappa      (n,)      largest normalised gap reached, lambda_h (>= 1: debonded)
    damage     (n,)      cyclic damage D in [0, 1]
    separation (n,)      resultant separation hypot(<g_N>, |g_T|) of the committed gap [m]
    slip       (n, d-1)  plastic (frictional) slip [m]
    dissipated (n,)      cumulative dissipated energy per unit area [J/m^2]
    """

    kappa: np.ndarray
    damage: np.ndarray
    separation: np.ndarray
    slip: np.ndarray
    dissipated: np.ndarray

    @property
    def n(self) -> int:
        return self.kappa.shape[0]

    @property
    def dim(self) -> int:
        return self.slip.shape[1] + 1

    @property
    def debonded(self) -> np.ndarray:
        return (self.kappa >= 1.0) | (self.damage >= 1.0)

    def copy(self) -> "InterfaceState":
        return InterfaceState(*(getattr(self, f.name).copy() for f in fields(self)))

    def take(self, idx) -> "InterfaceState":
        """The state of a subset of points (fancy index or mask)."""
        return InterfaceState(*(getattr(self, f.name)[idx] for f in fields(self)))

    def put(self, idx, other: "InterfaceState") -> "InterfaceState":
        """A new state equal to this one with the points ``idx`` replaced by ``other``."""
        new = self.copy()
        for f in fields(self):
            getattr(new, f.name)[idx] = getattr(other, f.name)
        return new

    def as_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_dict(cls, d) -> "InterfaceState":
        return cls(*(np.array(d[f.name], dtype=np.float64) for f in fields(cls)))


def _flat(a):
    """The flat C-order view of ``a`` (a C-contiguous copy first if ``a`` is strided)."""
    return (a if a.flags.c_contiguous else np.ascontiguousarray(a)).reshape(-1)


class InterfaceLaw:
    """The material-point interface law of Paggi, Ferro & Braga (2013), §3.

    Cohesive zone (always), and optionally contact, friction (needs contact) and cyclic damage.
    The optional parts are chosen once here; the kernel compiled for this combination does not
    contain the parts that are absent. See docs/law.md for the equations.

    Note on damage: for ``alpha != 1`` the paper's damage increment depends on the step size;
    the form "rate" does not (at a constant opening rate) but needs ``evaluate(..., dt=...)``.
    """

    def __init__(self, cohesive: CohesiveParams, contact: ContactParams | None = None,
                 friction: FrictionParams | None = None, damage: DamageParams | None = None,
                 parallel: bool | None = None):
        if not isinstance(cohesive, CohesiveParams):
            raise ValueError(f"InterfaceLaw.cohesive = {cohesive!r} is not allowed; allowed: "
                             "a CohesiveParams")
        for name, val, typ in (("contact", contact, ContactParams),
                               ("friction", friction, FrictionParams),
                               ("damage", damage, DamageParams)):
            if val is not None and not isinstance(val, typ):
                raise ValueError(f"InterfaceLaw.{name} = {val!r} is not allowed; allowed: "
                                 f"None or a {typ.__name__}")
        if friction is not None and contact is None:
            raise ValueError("InterfaceLaw.friction is set but contact = None; allowed: "
                             "friction only with a ContactParams (friction needs F_N < 0)")
        self.cohesive = cohesive
        self.contact = contact
        self.friction = friction
        self.damage = damage
        self.parallel = parallel
        # parameters go to the kernel as tuples of floats (no reference counting per point)
        c = cohesive
        self._coh = (c.sigma_max, c.tau_max, c.l_Nc, c.l_Tc, c.lambda_max, 1.0 / c.l_Nc,
                     1.0 / c.l_Tc, c.tau_max * c.l_Nc / c.l_Tc ** 2, 1.0 / c.lambda_max,
                     1.0 / (1.0 - c.lambda_max))
        self._con = None if contact is None else tuple(map(float, contact.as_array(cohesive)))
        self._fri = None if friction is None else tuple(map(float, friction.as_array(cohesive)))
        self._dmg = None if damage is None else tuple(map(float, damage.as_array(cohesive)))
        # the kernel specialisation: exponents 0, 1, 2 only -> no pow call, vectorised loop
        self._fast = _kernels.is_fast(self._con, self._dmg)
        # the loop specialisation of this kind of law (exponents, damage form, threshold)
        self._code = _kernels.code(self._con, self._dmg)
        self._parts = (contact is None, friction is None, damage is None)

    @property
    def kernel_params(self) -> tuple:
        """The parameter tuples the kernel takes, (cohesive, contact, friction, damage): the
        derived constants of docs/law.md, None for an absent part (the C ABI packs them)."""
        return self._coh, self._con, self._fri, self._dmg

    def __repr__(self):
        return (f"InterfaceLaw({self.cohesive}, contact={self.contact}, "
                f"friction={self.friction}, damage={self.damage})")

    def with_params(self, cohesive: CohesiveParams | None = None,
                    friction: FrictionParams | None = None) -> "InterfaceLaw":
        """The same law with new cohesive and/or friction parameters (size-scale update)."""
        return InterfaceLaw(cohesive or self.cohesive, self.contact,
                            friction or self.friction, self.damage, self.parallel)

    # ------------------------------------------------------------------------------------
    @staticmethod
    def initial_state(n: int, dim: int = 2) -> InterfaceState:
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
            raise ValueError(f"initial_state n = {n!r} is not allowed; allowed: an integer >= 0")
        if dim not in (2, 3):
            raise ValueError(f"initial_state dim = {dim!r} is not allowed; allowed: 2 or 3")
        z = np.zeros(n)
        return InterfaceState(z, z.copy(), z.copy(), np.zeros((n, dim - 1)), z.copy())

    def _check(self, gap, state: InterfaceState):
        if not isinstance(gap, np.ndarray) or gap.dtype != np.float64 or gap.ndim != 2 \
                or gap.shape[1] not in (2, 3):
            desc = (f"array of dtype {gap.dtype} and shape {gap.shape}"
                    if isinstance(gap, np.ndarray) else type(gap).__name__)
            raise ValueError(f"evaluate gap: {desc} is not allowed; allowed: a float64 array "
                             "of shape (n, 2) or (n, 3)")
        if not isinstance(state, InterfaceState):
            raise ValueError(f"evaluate state = {type(state).__name__} is not allowed; allowed: "
                             "an InterfaceState (law.initial_state)")
        n, dim = gap.shape
        if state.n != n or state.dim != dim:
            raise ValueError(f"evaluate state: {state.n} points in {state.dim}D do not match "
                             f"gap of shape {gap.shape}; allowed: the same n and dim")
        if n and gap.flags.c_contiguous:
            flat = gap.reshape(-1)
            if _kernels.sum_squares(flat) <= _QUICK_SQ:   # every |g| < GAP_LIMIT (_QUICK_SQ)
                return
        self.check_gap(gap)

    @staticmethod
    def check_gap(gap):
        """ValueError (``evaluate``'s message) unless every |gap| <= GAP_LIMIT (no NaN, no
        inf); one pass over |gap|, the first bad point named."""
        big = np.abs(gap).max() if gap.shape[0] else 0.0
        if not big <= GAP_LIMIT:                      # one pass: also catches NaN and inf
            bad = ~(np.abs(gap) <= GAP_LIMIT).all(axis=1)
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(f"evaluate gap[{i}] = {gap[i].tolist()} is not finite or exceeds "
                             f"{GAP_LIMIT:g} m; allowed: finite values with |g| <= {GAP_LIMIT:g} m"
                             " (first bad point shown)")

    @property
    def needs_dt(self) -> bool:
        """True when ``evaluate`` needs the step's time increment ``dt`` (damage form "rate")."""
        return self.damage is not None and self.damage.needs_dt

    def _rdt(self, dt) -> float:
        """dt/t_ref for the kernel (1.0 when the law does not use dt); validates dt."""
        if not self.needs_dt:
            return 1.0                        # ignored (not even checked) by the other forms
        if dt is None:
            raise ValueError("evaluate dt = None is not allowed for DamageParams(form='rate'); "
                             "allowed: the step's time increment dt > 0 [s] "
                             "(evaluate(gap, state, dt=...))")
        try:
            d = float(dt)
        except (TypeError, ValueError):
            raise ValueError(f"evaluate dt = {dt!r} is not a real number; allowed: a finite "
                             "time increment > 0 [s]") from None
        if not (d > 0.0 and math.isfinite(d)):
            raise ValueError(f"evaluate dt = {dt!r} is out of range; allowed: a finite time "
                             "increment > 0 [s]")
        r = d / self.damage.t_ref
        if not (r > 0.0 and math.isfinite(r)):
            raise ValueError(f"evaluate dt = {dt!r} with t_ref = {self.damage.t_ref!r}: dt/t_ref "
                             f"= {r!r} is not representable; allowed: dt/t_ref finite and > 0")
        return r

    def evaluate(self, gap: np.ndarray, state: InterfaceState, out=None, dt=None,
                 check: bool = True):
        """Traction, consistent tangent and end-of-step state for the total gap ``gap``.

        gap   : float64 (n, dim), dim 2 (g_N, g_T) or 3 (g_N, g_T1, g_T2); total gap at the end
                of the step, opening positive.
        state : the committed start-of-step state (not modified).
        out   : optional (traction (n,dim), tangent (n,dim,dim), InterfaceState) buffers,
                overwritten; they must not be ``state``'s arrays.
        dt    : the step's time increment [s] (> 0). Required by the damage form "rate"
                (``DamageParams(form="rate")``, which integrates Eq. 7 as a rate); ignored by
                the other forms (not even checked: a solver may pass its dt always).
        Returns ``traction, tangent, new_state`` with ``tangent[i] = d traction[i] / d gap[i]``.
        """
        rdt = self._rdt(dt)
        if check:
            self._check(gap, state)
        n, dim = gap.shape
        if out is None:
            F = np.empty((n, dim))
            T = np.empty((n, dim, dim))
            new = InterfaceState(np.empty(n), np.empty(n), np.empty(n),
                                 state.slip if self.friction is None else np.empty((n, dim - 1)),
                                 np.empty(n))
        else:
            F, T, new = out
            for name, a in (("traction", F), ("tangent", T), *new.as_dict().items()):
                if not a.flags.c_contiguous:
                    raise ValueError(f"evaluate out: the {name} buffer is not C-contiguous; "
                                     "allowed: C-contiguous float64 arrays (written in place)")
            if self.friction is None:
                new.slip[...] = state.slip
        par = self.parallel if self.parallel is not None else n >= PARALLEL_MIN_POINTS
        kern = _kernels.loop(self._code, dim, par)
        # the kernels index flat C-order views (vectorisation): copy any strided input
        c = _flat
        _kernels.call(kern, self._parts, c(gap), self._coh, self._con, self._fri, self._dmg,
                      rdt, c(state.kappa), c(state.damage), c(state.separation),
                      c(state.slip), c(state.dissipated), F.reshape(-1), T.reshape(-1),
                      new.kappa, new.damage, new.separation, new.slip.reshape(-1),
                      new.dissipated)
        return F, T, new

    def traction(self, gap, state, dt=None):
        """Traction only (convenience)."""
        return self.evaluate(gap, state, dt=dt)[0]

    def bind(self, state: InterfaceState, dt=None) -> "BoundLaw":
        """``evaluate(gap, state, dt=dt)`` for a fixed ``state`` and ``dt`` as a callable of
        the gap alone (a solver's Newton loop: many gaps, one committed state): the state's
        checks and flat views, ``dt``'s validation and the kernel's choice are done once here,
        and each call checks its gap in one pass (``BoundLaw``). The same numbers as
        ``evaluate`` bit for bit, and the same errors."""
        return BoundLaw(self, state, dt)


class BoundLaw:
    """``law.evaluate(gap, state, dt=dt)`` with ``state`` and ``dt`` fixed (``InterfaceLaw.bind``).

    ``bound(gap)`` takes the gap as a float64 array of n * dim values (flat, or (n, dim));
    returns ``traction (n, dim), tangent (n, dim, dim), new_state`` in new arrays, as
    ``evaluate`` with ``out=None``. Per call: the gap's dtype and shape (O(1)) and one sum
    g . g (``_kernels.sum_squares``; a NaN, an inf or a value near ``GAP_LIMIT`` fails the
    quick accept; then ``evaluate``'s own check runs and raises its error, or passes a large
    finite gap)."""

    __slots__ = ("law", "state", "dt", "n", "dim", "rdt", "kern", "key", "sflat", "slip",
                 "ready")

    def __init__(self, law: InterfaceLaw, state: InterfaceState, dt=None):
        if not isinstance(state, InterfaceState):
            raise ValueError(f"bind state = {type(state).__name__} is not allowed; allowed: "
                             "an InterfaceState (law.initial_state)")
        self.law, self.state, self.dt = law, state, dt
        self.n, self.dim = state.n, state.dim
        try:
            self.rdt = law._rdt(dt)
        except ValueError:
            self.rdt = None                   # each call raises evaluate's error
        par = law.parallel if law.parallel is not None else self.n >= PARALLEL_MIN_POINTS
        self.kern = _kernels.loop(law._code, self.dim, par)
        self.key = law._parts
        c = _flat
        self.sflat = (c(state.kappa), c(state.damage), c(state.separation), c(state.slip),
                      c(state.dissipated))
        # no friction: the new state's slip is the committed one (as ``evaluate``)
        self.slip = state.slip if law.friction is None else None
        # the kernel went through _kernels.call (compiled with its options): called directly
        self.ready = _kernels.compiled(self.kern, self.key)

    def __call__(self, gap):
        n, dim = self.n, self.dim
        if self.rdt is None:
            self.law._rdt(self.dt)            # raises evaluate's error
        if not isinstance(gap, np.ndarray) or gap.dtype != np.float64 or gap.size != n * dim \
                or (gap.ndim != 1 and gap.shape != (n, dim)):
            self.refuse(gap)
        g = gap if gap.flags.c_contiguous else np.ascontiguousarray(gap)
        g = g.reshape(-1)
        if not (n == 0 or _kernels.sum_squares(g) <= _QUICK_SQ):
            self.law.check_gap(g.reshape(n, dim))   # raises, or a large finite gap passes
        F = np.empty((n, dim))
        T = np.empty((n, dim, dim))
        slip = self.slip if self.slip is not None else np.empty((n, dim - 1))
        new = InterfaceState(np.empty(n), np.empty(n), np.empty(n), slip, np.empty(n))
        law = self.law
        s = self.sflat
        args = (g, law._coh, law._con, law._fri, law._dmg, self.rdt, s[0], s[1], s[2], s[3],
                s[4], F.reshape(-1), T.reshape(-1), new.kappa, new.damage, new.separation,
                new.slip.reshape(-1), new.dissipated)
        if self.ready:
            self.kern(*args)
        else:
            _kernels.call(self.kern, self.key, *args)
            self.ready = True
        return F, T, new

    def refuse(self, gap):
        """Raise the error of a gap that is not n * dim float64 values, flat or (n, dim):
        ``evaluate``'s where it has one (type, dtype, shape, another n or dim), else the bound
        law's own (a flat gap whose size is not a multiple of dim)."""
        n, dim = self.n, self.dim
        flat = isinstance(gap, np.ndarray) and gap.ndim == 1
        g2 = gap.reshape(-1, dim) if flat and gap.size % dim == 0 else gap
        if not (flat and g2 is gap and gap.dtype == np.float64):
            self.law._check(g2, self.state)    # raises evaluate's error
        raise ValueError(f"bound law: gap of shape {np.shape(gap)} is not allowed; "
                         f"allowed: {n * dim} float64 values, flat or of shape ({n}, {dim})")
