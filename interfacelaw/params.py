"""Frozen, validated parameter sets of the interface law (SI units).

Every constructor checks its fields and raises ``ValueError`` naming the field, the value and
the allowed range. See ``docs/law.md`` for the equations each parameter enters.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["CohesiveParams", "ContactParams", "FrictionParams", "DamageParams", "DAMAGE_FORMS"]

# damage forms; the index is the code the kernels receive (docs/law.md §6)
DAMAGE_FORMS = ("paper", "objective", "rate")


def _check(cls: str, name: str, value, *, lo=None, hi=None, lo_open=True, hi_open=True,
           allowed: str | None = None):
    """Raise a ValueError naming ``cls.name``, its value and the allowed range."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{cls}.{name} = {value!r} is not a real number; allowed: "
                         f"{allowed or _range(lo, hi, lo_open, hi_open)}") from None
    bad = not math.isfinite(v)
    if lo is not None:
        bad |= v <= lo if lo_open else v < lo
    if hi is not None:
        bad |= v >= hi if hi_open else v > hi
    if bad:
        raise ValueError(f"{cls}.{name} = {value!r} is out of range; allowed: "
                         f"{allowed or _range(lo, hi, lo_open, hi_open)}")
    return v


def _range(lo, hi, lo_open, hi_open):
    left = "(" if lo_open else "["
    right = ")" if hi_open else "]"
    return f"{left}{'-inf' if lo is None else lo}, {'+inf' if hi is None else hi}{right} (finite)"


@dataclass(frozen=True)
class CohesiveParams:
    """Geubelle–Baylor bilinear mixed-mode cohesive zone (paper Eqs. 1–3).

    sigma_max, tau_max : peak normal / shear strengths [Pa] (> 0). As Eq. 3 is written the peak
        mode-II traction is ``tau_max * l_Nc / l_Tc``.
    l_Nc, l_Tc : critical normal / tangential gaps [m] (> 0).
    lambda_max : normalised gap at peak traction, in (0, 1).
    """

    sigma_max: float
    tau_max: float
    l_Nc: float
    l_Tc: float
    lambda_max: float

    def __post_init__(self):
        c = "CohesiveParams"
        for name in ("sigma_max", "tau_max", "l_Nc", "l_Tc"):
            object.__setattr__(self, name, _check(c, name, getattr(self, name), lo=0.0))
        object.__setattr__(self, "lambda_max",
                           _check(c, "lambda_max", self.lambda_max, lo=0.0, hi=1.0))

    @classmethod
    def from_fracture_energy(cls, sigma_max: float, tau_max: float, G_I: float,
                             lambda_max: float, ratio_lTc_lNc: float = 1.0) -> "CohesiveParams":
        """Build from the mode-I fracture energy ``G_I = sigma_max * l_Nc / 2`` [N/m]."""
        c = "CohesiveParams"
        s = _check(c, "sigma_max", sigma_max, lo=0.0)
        G = _check(c, "G_I", G_I, lo=0.0)
        r = _check(c, "ratio_lTc_lNc", ratio_lTc_lNc, lo=0.0)
        l_Nc = 2.0 * G / s
        return cls(sigma_max=s, tau_max=tau_max, l_Nc=l_Nc, l_Tc=r * l_Nc, lambda_max=lambda_max)

    # derived quantities -------------------------------------------------------------------
    @property
    def G_I(self) -> float:
        """Mode-I work of separation ``sigma_max l_Nc / 2`` [N/m]."""
        return 0.5 * self.sigma_max * self.l_Nc

    @property
    def G_II(self) -> float:
        """Mode-II work of separation implied by Eq. 3: ``tau_max l_Nc / 2`` [N/m]."""
        return 0.5 * self.tau_max * self.l_Nc

    def G_mixed(self, psi):
        """Work of separation of a proportional path at physical angle ``psi`` [rad]
        (``tan psi = g_T/g_N``, psi = 0 mode I, pi/2 mode II); docs/law.md §2."""
        psi = np.asarray(psi, dtype=float)
        phi = np.arctan2(np.sin(psi) / self.l_Tc, np.cos(psi) / self.l_Nc)
        return 0.5 * self.l_Nc * (self.sigma_max * np.cos(phi) ** 2
                                  + self.tau_max * np.sin(phi) ** 2)

    @property
    def k_normal(self) -> float:
        """Initial normal stiffness ``sigma_max / (lambda_max l_Nc)`` [Pa/m]."""
        return self.sigma_max / (self.lambda_max * self.l_Nc)

    @property
    def k_tangential(self) -> float:
        """Initial tangential stiffness ``tau_max l_Nc / (lambda_max l_Tc^2)`` [Pa/m]."""
        return self.tau_max * self.l_Nc / (self.lambda_max * self.l_Tc ** 2)

    @property
    def peak_shear(self) -> float:
        """Peak mode-II traction implied by Eq. 3 [Pa]."""
        return self.tau_max * self.l_Nc / self.l_Tc

    def replace(self, **kw) -> "CohesiveParams":
        d = dict(sigma_max=self.sigma_max, tau_max=self.tau_max, l_Nc=self.l_Nc,
                 l_Tc=self.l_Tc, lambda_max=self.lambda_max)
        d.update(kw)
        return CohesiveParams(**d)

    def as_array(self) -> np.ndarray:
        return np.array([self.sigma_max, self.tau_max, self.l_Nc, self.l_Tc, self.lambda_max])


_CONTACT_KINDS = ("linear", "rough")


@dataclass(frozen=True)
class ContactParams:
    """Unilateral contact by penalty (paper §3.2, Fig. 6); docs/law.md §4.

    kind : "linear" (curve (c): ``p = C_N g_N``) or "rough" (curve (d): power law
        ``p = -C_N g_ref (-g_N/g_ref)^m``, zero stiffness at first contact, stiffening).
    penalty : C_N [Pa/m]; None -> the cohesive initial stiffness K0 = sigma_max/(lambda_max l_Nc).
    exponent : m >= 1 (forced to 1 for "linear"); default 2 for "rough".
    g_ref : [m] closure at which the rough law's secant stiffness is C_N; None -> lambda_max l_Nc.
    intact_stiffness : compressive stiffness of the intact interface [Pa/m]; None -> K0 for
        "rough", C_N for "linear".
    """

    kind: str = "linear"
    penalty: float | None = None
    exponent: float | None = None
    g_ref: float | None = None
    intact_stiffness: float | None = None

    def __post_init__(self):
        c = "ContactParams"
        if self.kind not in _CONTACT_KINDS:
            raise ValueError(f"{c}.kind = {self.kind!r} is not allowed; allowed: "
                             f"{', '.join(map(repr, _CONTACT_KINDS))}")
        for name in ("penalty", "g_ref", "intact_stiffness"):
            v = getattr(self, name)
            if v is not None:
                object.__setattr__(self, name, _check(c, name, v, lo=0.0))
        if self.exponent is None:
            object.__setattr__(self, "exponent", 1.0 if self.kind == "linear" else 2.0)
        else:
            m = _check(c, "exponent", self.exponent, lo=1.0, hi=20.0, lo_open=False,
                       hi_open=False)
            if self.kind == "linear" and m != 1.0:
                raise ValueError(f"{c}.exponent = {self.exponent!r} is not allowed for "
                                 "kind='linear'; allowed: 1 (use kind='rough' for m > 1)")
            object.__setattr__(self, "exponent", m)

    def as_array(self, coh: CohesiveParams) -> np.ndarray:
        """[K_intact, C_N, g_ref, m, c*] with the defaults resolved against ``coh``; c* is the
        normalised closure beyond which the crack stiffness is capped at K_intact.

        Default K_intact: K0 for "rough"; for "linear" the penalty C_N (itself K0 by default),
        so a linear law is one linear spring in compression whatever the damage (a penalty
        stiffer than the intact bond would otherwise create energy as damage grows in
        compression: docs/law.md §4)."""
        k0 = coh.k_normal
        cn = k0 if self.penalty is None else self.penalty
        if self.intact_stiffness is not None:
            kint = self.intact_stiffness
        else:
            kint = k0 if self.kind == "rough" else cn
        m = self.exponent
        if m == 1.0:
            if self.kind == "rough":          # constant stiffness: capped at K_intact if above
                cs = np.inf if cn <= kint else 0.0
            elif cn > kint * (1 + 1e-12):
                raise ValueError(
                    f"ContactParams.penalty = {cn!r} exceeds intact_stiffness = {kint!r}; "
                    "allowed: penalty <= intact stiffness (a crack stiffer than the bond would "
                    "create energy as damage grows in compression; raise intact_stiffness too)")
            else:
                cs = np.inf
        else:  # closure at which the crack stiffness C_N m c^(m-1) reaches K_intact (the cap)
            # beyond the float range (m close to 1, K_intact >> C_N): never reached, inf (the
            # uncapped value of m = 1); Python's float power would raise OverflowError there
            with np.errstate(over="ignore"):
                cs = float(np.power(kint / (cn * m), 1.0 / (m - 1.0)))
        return np.array([
            kint,
            cn,
            coh.lambda_max * coh.l_Nc if self.g_ref is None else self.g_ref,
            m,
            cs,
        ])


@dataclass(frozen=True)
class FrictionParams:
    """Coulomb friction after decohesion (paper Eqs. 4–5); docs/law.md §5.

    f : friction coefficient (>= 0, < 10).
    penalty : tangential stick stiffness C_T [Pa/m]; None -> the cohesive initial tangential
        stiffness tau_max l_Nc / (lambda_max l_Tc^2).
    """

    f: float = 0.3
    penalty: float | None = None

    def __post_init__(self):
        c = "FrictionParams"
        object.__setattr__(self, "f", _check(c, "f", self.f, lo=0.0, hi=10.0, lo_open=False))
        if self.penalty is not None:
            object.__setattr__(self, "penalty", _check(c, "penalty", self.penalty, lo=0.0))

    def as_array(self, coh: CohesiveParams) -> np.ndarray:
        return np.array([self.f, coh.k_tangential if self.penalty is None else self.penalty])


@dataclass(frozen=True)
class DamageParams:
    """Cyclic damage (paper Eqs. 6–8); docs/law.md §6.

    ``ΔD = (Δg/g_max)^alpha <F/σ^t − F_th/σ_max>^beta`` per step, only for Δg > 0.
    For alpha != 1 the accumulated damage depends on the step size (the paper's form, kept).

    alpha : > 0 (paper: 1 or 2).  beta : >= 0 (paper: 0).
    g_max : cumulative separation to failure [m] (> 0); not given by the paper.
    F_th : threshold traction [Pa] (>= 0).
    form : "paper" (default, Eq. 7 as written), "objective" or "rate".
        "objective": the rate form dD = alpha (p/g_max)^(alpha-1) dp/g_max, dp = B dg+,
        integrated exactly per step as p_new = g_max D_old^(1/alpha) + B dg+,
        D_new = (p_new/g_max)^alpha — independent of the step size for beta = 0
        (docs/law.md §6.2). Identical to "paper" for alpha = 1.
        "rate": Eq. 7 read as a rate of the opening rate, dD/dt = (1/t_ref)
        (g+' t_ref/g_max)^alpha B, per step ΔD = (Δg+/g_max)^alpha (Δt/t_ref)^(1-alpha) B —
        needs the step's Δt (``InterfaceLaw.evaluate(..., dt=...)``); independent of the step
        at a constant opening rate, and a fast opening (g+' t_ref > g_max) damages more for
        larger alpha. Identical to "paper" for alpha = 1 (docs/law.md §6.3).
    t_ref : reference time of the "rate" form [s] (> 0; default 1 s); unused by the others.
    """

    g_max: float
    alpha: float = 1.0
    beta: float = 0.0
    F_th: float = 0.0
    form: str = "paper"
    t_ref: float = 1.0

    def __post_init__(self):
        c = "DamageParams"
        if self.form not in DAMAGE_FORMS:
            raise ValueError(f"{c}.form = {self.form!r} is not allowed; allowed: 'paper' (Eq. 7, "
                             "step-size dependent for alpha != 1), 'objective' or 'rate' "
                             "(Eq. 7 as a rate, needs dt)")
        object.__setattr__(self, "t_ref", _check(c, "t_ref", self.t_ref, lo=0.0))
        object.__setattr__(self, "g_max", _check(c, "g_max", self.g_max, lo=0.0))
        object.__setattr__(self, "alpha", _check(c, "alpha", self.alpha, lo=0.0, hi=20.0,
                                                 hi_open=False))
        object.__setattr__(self, "beta", _check(c, "beta", self.beta, lo=0.0, hi=20.0,
                                                lo_open=False, hi_open=False))
        object.__setattr__(self, "F_th", _check(c, "F_th", self.F_th, lo=0.0, lo_open=False))

    @property
    def needs_dt(self) -> bool:
        """True when the damage increment depends on the step's time increment (form "rate")."""
        return self.form == "rate"

    def as_array(self, coh: CohesiveParams) -> np.ndarray:
        """[alpha, beta, g_max, F_th/sigma_max, form code] (0 paper, 1 objective, 2 rate).

        The rate form with alpha = 1 is the paper's form exactly ((Δt/t_ref)^0 = 1), so it is
        given the paper's code: the same arithmetic, bit for bit."""
        code = DAMAGE_FORMS.index(self.form)
        if self.form == "rate" and self.alpha == 1.0:
            code = 0
        return np.array([self.alpha, self.beta, self.g_max, self.F_th / coh.sigma_max,
                         float(code)])
