"""Size-scale laws of the interface parameters and their adaptive update (paper §2 and §5).

Paggi, Ferro & Braga (2013) make the cohesive and frictional parameters functions of the size
``b`` of the interface already failed, and update them at every step of the simulation. This
module provides

* :class:`PowerLaw` ``y = y_ref (b/b_ref)^k`` and the paper's laws: tensile strength
  (k = -0.14, Carpinteri & Ferro 1994), fracture energy (k = +0.38, Carpinteri & Chiaia 1995),
  interface peak stresses (as concrete), dissipated energy density in compression (Ferro 2006;
  exponent required, no default);
* :class:`FrictionScaling`: friction coefficient decreasing from 0.6 (laboratory joints,
  0.1 m) to a floor of 0.3 (Bandis et al. 1981; Carpinteri & Paggi 2005/2008), a power law
  through the two anchors, constant (the floor) beyond the second one;
* :func:`fit_power_law`: log-log least squares with R^2 and a t-interval on the exponent;
* :class:`SizeScaling`: the object the FE driver asks once per step, ``params_for(b)``, for the
  ``(CohesiveParams, FrictionParams)`` at size ``max(b_ref, b)``;
* :func:`characteristic_times` (paper Eq. 11) and :func:`characteristic_length`;
* :func:`mode_one_update_energy`: the energy effect of updating the parameters of a softening
  point (diagnostic used by the tests and by ``verification/scaling_plots.py``).

The choices (b_ref, the friction form, the compression exponent, what happens to a softening
point when the parameters change) are documented in ``docs/scaling.md``.
Pure numpy (+ scipy.special for the t quantile): never imports NGSolve.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .params import CohesiveParams, FrictionParams

__all__ = [
    "TENSILE_STRENGTH_EXPONENT", "FRACTURE_ENERGY_EXPONENT", "INTERFACE_STRENGTH_EXPONENT",
    "B_REF_DEFAULT", "PowerLaw", "FrictionScaling", "PowerLawFit", "fit_power_law",
    "tensile_strength_law", "fracture_energy_law", "compression_energy_law",
    "SizeScaling", "CharacteristicTimes", "characteristic_times", "characteristic_length",
    "mode_one_update_energy",
]

#: Carpinteri & Ferro (1994), paper Fig. 1(a): sigma_u ~ b^-0.14.
TENSILE_STRENGTH_EXPONENT = -0.14
#: Carpinteri & Chiaia (1995), paper Fig. 1(b): G_F ~ b^+0.38.
FRACTURE_ENERGY_EXPONENT = 0.38
#: Interface peak stresses sigma_max, tau_max decrease "in analogy with concrete" (paper §2).
INTERFACE_STRENGTH_EXPONENT = TENSILE_STRENGTH_EXPONENT
#: Size [m] at which the paper's initial values (G = 250 N/m, sigma = tau = 3 MPa, f = 0.3)
#: are taken to hold ("consistent with large specimens"); docs/scaling.md §2.
B_REF_DEFAULT = 1.0


# ---------------------------------------------------------------------------------------------
# validation helpers: ValueError naming the argument, the value and what is allowed
def _real(where: str, name: str, value, *, positive=False, nonneg=False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: {name} = {value!r} is not a real number; allowed: a finite "
                         f"real number{' > 0' if positive else ' >= 0' if nonneg else ''}") \
            from None
    if not math.isfinite(v) or (positive and v <= 0.0) or (nonneg and v < 0.0):
        allowed = "finite and > 0" if positive else "finite and >= 0" if nonneg else "finite"
        raise ValueError(f"{where}: {name} = {value!r} is not allowed; allowed: {allowed}")
    return v


def _positive_array(where: str, name: str, value) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: {name} = {value!r} is not numeric; allowed: finite "
                         "real numbers > 0") from None
    bad = ~np.isfinite(a) | (a <= 0.0)
    if bad.any():
        i = np.flatnonzero(bad.ravel())[0]
        raise ValueError(f"{where}: {name} contains {float(a.ravel()[i])!r} (index {i}); allowed: "
                         "finite real numbers > 0")
    return a


def _out(a: np.ndarray):
    return float(a) if a.ndim == 0 else a


# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PowerLaw:
    """``y(b) = y_ref * (b / b_ref) ** exponent`` for sizes ``b > 0`` [m].

    At ``b == b_ref`` the result is exactly ``y_ref`` (``1.0 ** k == 1.0``).
    Accepts a scalar (returns a float) or an array (returns an array).
    """

    y_ref: float
    b_ref: float
    exponent: float

    def __post_init__(self):
        object.__setattr__(self, "y_ref", _real("PowerLaw", "y_ref", self.y_ref, positive=True))
        object.__setattr__(self, "b_ref", _real("PowerLaw", "b_ref", self.b_ref, positive=True))
        object.__setattr__(self, "exponent", _real("PowerLaw", "exponent", self.exponent))

    def __call__(self, b):
        b = _positive_array("PowerLaw", "b", b)
        return _out(self.y_ref * (b / self.b_ref) ** self.exponent)

    def ratio(self, b_new, b_old):
        """``y(b_new)/y(b_old) = (b_new/b_old)^k``."""
        b_new = _positive_array("PowerLaw.ratio", "b_new", b_new)
        b_old = _positive_array("PowerLaw.ratio", "b_old", b_old)
        return _out((b_new / b_old) ** self.exponent)


def tensile_strength_law(sigma_ref: float, b_ref: float = B_REF_DEFAULT,
                         exponent: float = TENSILE_STRENGTH_EXPONENT) -> PowerLaw:
    """Concrete tensile strength, decreasing: k = -0.14 (Carpinteri & Ferro 1994)."""
    return PowerLaw(sigma_ref, b_ref, exponent)


def fracture_energy_law(G_ref: float, b_ref: float = B_REF_DEFAULT,
                        exponent: float = FRACTURE_ENERGY_EXPONENT) -> PowerLaw:
    """Concrete fracture energy, increasing: k = +0.38 (Carpinteri & Chiaia 1995)."""
    return PowerLaw(G_ref, b_ref, exponent)


def compression_energy_law(S_ref: float, b_ref: float, exponent: float) -> PowerLaw:
    """Energy density dissipated in compression S(b), decreasing (Ferro 2006, paper Fig. 2b).

    The paper shows the decrease but gives no number for the exponent, and the value of
    Ferro (2006) could not be verified here: ``exponent`` is therefore required (no default)
    and must be < 0. Use :func:`fit_power_law` on the measured S of the specimens.
    """
    k = _real("compression_energy_law", "exponent", exponent)
    if k >= 0.0:
        raise ValueError(f"compression_energy_law: exponent = {exponent!r} is not allowed; "
                         "allowed: < 0 (S decreases with size, Ferro 2006)")
    return PowerLaw(S_ref, b_ref, k)


# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FrictionScaling:
    """Friction coefficient decreasing with size, with a floor.

    ``f(b) = f_lab (b/b_lab)^k``  for ``b < b_floor``,  ``f(b) = f_floor`` for ``b >= b_floor``,
    with ``k = ln(f_floor/f_lab) / ln(b_floor/b_lab)`` (the power law through the two anchors,
    continuous at ``b_floor``). Defaults: 0.6 at 0.1 m (laboratory joints, Bandis et al. 1981)
    and the floor 0.3 (paper §5: "worst case for a very large fault") reached at 1 m (= the
    default b_ref, so that f(b_ref) = 0.3 as the paper starts). Beyond b_floor the coefficient
    is constant: size effects on joint friction vanish beyond the natural block size (Barton &
    Bandis 1982) and the paper's 0.3 is already the large-fault value.
    """

    f_lab: float = 0.6
    b_lab: float = 0.1
    f_floor: float = 0.3
    b_floor: float = B_REF_DEFAULT

    def __post_init__(self):
        c = "FrictionScaling"
        for name in ("f_lab", "b_lab", "f_floor", "b_floor"):
            object.__setattr__(self, name, _real(c, name, getattr(self, name), positive=True))
        if not self.b_floor > self.b_lab:
            raise ValueError(f"{c}: b_floor = {self.b_floor!r} is not allowed; allowed: "
                             f"> b_lab = {self.b_lab!r}")
        if not self.f_floor <= self.f_lab:
            raise ValueError(f"{c}: f_floor = {self.f_floor!r} is not allowed; allowed: "
                             f"<= f_lab = {self.f_lab!r} (friction decreases with size)")

    @property
    def exponent(self) -> float:
        """Exponent of the decreasing branch (-0.301 with the defaults)."""
        return math.log(self.f_floor / self.f_lab) / math.log(self.b_floor / self.b_lab)

    def __call__(self, b):
        b = _positive_array("FrictionScaling", "b", b)
        f = np.where(b >= self.b_floor, self.f_floor,
                     self.f_lab * (np.minimum(b, self.b_floor) / self.b_lab) ** self.exponent)
        return _out(f)


# ---------------------------------------------------------------------------------------------
class PowerLawFit(NamedTuple):
    """Result of :func:`fit_power_law`: ``values ~ y_ref (sizes/b_ref)^exponent``.

    ci_low, ci_high : two-sided ``confidence`` t-interval on the exponent (n - 2 degrees of
        freedom); infinite when n = 2 (no residual degree of freedom), a point when the data
        are exact.
    stderr : standard error of the exponent; r2 : coefficient of determination in log-log.
    """

    exponent: float
    y_ref: float
    b_ref: float
    r2: float
    ci_low: float
    ci_high: float
    stderr: float
    n: int
    confidence: float

    @property
    def law(self) -> PowerLaw:
        return PowerLaw(self.y_ref, self.b_ref, self.exponent)


def fit_power_law(sizes, values, *, b_ref: float = 1.0,
                  confidence: float = 0.95) -> PowerLawFit:
    """Least-squares fit of ``log(values) = log(y_ref) + k log(sizes/b_ref)``.

    sizes, values : 1-D sequences of the same length >= 2, finite and > 0; sizes must contain
        at least two distinct values.
    b_ref : size [m] at which ``y_ref`` is reported (> 0).
    confidence : level of the t-interval on the exponent, in (0, 1).
    """
    w = "fit_power_law"
    b_ref = _real(w, "b_ref", b_ref, positive=True)
    c = _real(w, "confidence", confidence)
    if not 0.0 < c < 1.0:
        raise ValueError(f"{w}: confidence = {confidence!r} is not allowed; allowed: in (0, 1)")
    arrs = []
    for name, v in (("sizes", sizes), ("values", values)):
        try:
            a = np.asarray(v, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{w}: {name} = {v!r} is not numeric; allowed: a 1-D sequence of "
                             "finite real numbers > 0") from None
        if a.ndim != 1:
            raise ValueError(f"{w}: {name} has shape {a.shape}; allowed: a 1-D sequence")
        arrs.append(a)
    x, y = arrs
    if x.size != y.size:
        raise ValueError(f"{w}: sizes has length {x.size} but values has length {y.size}; "
                         "allowed: equal lengths")
    if x.size < 2:
        raise ValueError(f"{w}: {x.size} point(s) given; allowed: at least 2 points")
    _positive_array(w, "sizes", x)
    _positive_array(w, "values", y)
    lx = np.log(x / b_ref)
    ly = np.log(y)
    xm, ym = lx.mean(), ly.mean()
    dx, dy = lx - xm, ly - ym
    sxx = float(dx @ dx)
    if sxx <= 1e-300 or np.ptp(x) == 0.0:
        raise ValueError(f"{w}: sizes = {x.tolist()} are all equal; allowed: at least 2 "
                         "distinct sizes")
    k = float(dx @ dy) / sxx
    a0 = ym - k * xm
    res = dy - k * dx
    ss_res = float(res @ res)
    ss_tot = float(dy @ dy)
    r2 = 1.0 if ss_tot == 0.0 else 1.0 - ss_res / ss_tot
    n = int(x.size)
    if n > 2:
        from scipy.special import stdtrit      # Student-t quantile (lighter than scipy.stats)
        se = math.sqrt(ss_res / (n - 2) / sxx)
        half = float(stdtrit(n - 2, 0.5 + c / 2.0)) * se
    else:
        se, half = math.inf, math.inf
    return PowerLawFit(k, math.exp(a0), b_ref, r2, k - half, k + half, se, n, c)


# ---------------------------------------------------------------------------------------------
class SizeScaling:
    """Adaptive interface parameters: the FE driver calls :meth:`params_for` once per step.

    reference : the cohesive parameters at ``b_ref`` (paper §5: sigma_max = tau_max = 3 MPa,
        G = 250 N/m; lambda_max = 0.2 and l_Tc/l_Nc = 1 by default, see :meth:`paper`).
    f_ref : friction coefficient at b_ref (paper: 0.3, the large-fault worst case).
    b_ref : size [m] at which the reference values hold (default 1 m, docs §2).
    strength_exponent : of sigma_max and tau_max (-0.14). energy_exponent : of G_I (+0.38).
    friction : :class:`FrictionScaling`; default: 0.6 at 0.1 m down to the floor f_ref at
        b_ref. Its value at b_ref must be f_ref (checked) and its floor keeps f >= f_ref.
    friction_penalty : "reference" (default) keeps the stick stiffness C_T fixed at the
        reference cohesive tangential stiffness (a numerical parameter, not a size-dependent
        property: no stick-traction jump at an update); None lets it follow the current cohesive
        parameters (FrictionParams default); a float fixes it.

    lambda_max and l_Tc/l_Nc are kept; ``l_Nc = 2 G(b) / sigma(b)`` follows
    (``CohesiveParams.from_fracture_energy``), so l_Nc ~ b^(0.38 + 0.14) = b^0.52.
    """

    def __init__(self, reference: CohesiveParams, f_ref: float = 0.3,
                 b_ref: float = B_REF_DEFAULT,
                 strength_exponent: float = INTERFACE_STRENGTH_EXPONENT,
                 energy_exponent: float = FRACTURE_ENERGY_EXPONENT,
                 friction: FrictionScaling | None = None,
                 friction_penalty: float | str | None = "reference"):
        w = "SizeScaling"
        if not isinstance(reference, CohesiveParams):
            raise ValueError(f"{w}: reference = {reference!r} is not allowed; allowed: a "
                             "CohesiveParams")
        self.reference = reference
        self.b_ref = _real(w, "b_ref", b_ref, positive=True)
        self.f_ref = FrictionParams(f_ref).f
        self.sigma_law = PowerLaw(reference.sigma_max, self.b_ref, strength_exponent)
        self.tau_law = PowerLaw(reference.tau_max, self.b_ref, strength_exponent)
        self.energy_law = PowerLaw(reference.G_I, self.b_ref, energy_exponent)
        if self.sigma_law.exponent > 0.0 or self.energy_law.exponent < 0.0:
            raise ValueError(f"{w}: strength_exponent = {strength_exponent!r}, energy_exponent "
                             f"= {energy_exponent!r}; allowed: strength <= 0, energy >= 0")
        if friction is None:
            friction = FrictionScaling(f_lab=max(0.6, self.f_ref), b_lab=min(0.1, self.b_ref / 2),
                                       f_floor=self.f_ref, b_floor=self.b_ref)
        if not isinstance(friction, FrictionScaling):
            raise ValueError(f"{w}: friction = {friction!r} is not allowed; allowed: a "
                             "FrictionScaling or None")
        if friction(self.b_ref) != self.f_ref or friction.f_floor != self.f_ref:
            raise ValueError(f"{w}: friction gives f(b_ref) = {friction(self.b_ref)!r} with "
                             f"floor {friction.f_floor!r}; allowed: f(b_ref) = f_floor = f_ref = "
                             f"{self.f_ref!r} (b_floor <= b_ref)")
        self.friction = friction
        self.ratio_lTc_lNc = reference.l_Tc / reference.l_Nc
        if friction_penalty == "reference":
            self.friction_penalty = reference.k_tangential
        elif friction_penalty is None:
            self.friction_penalty = None
        else:
            self.friction_penalty = _real(w, "friction_penalty", friction_penalty, positive=True)
        self._ref_params = (reference, FrictionParams(self.f_ref, self.friction_penalty))

    @classmethod
    def paper(cls, lambda_max: float = 0.2, ratio_lTc_lNc: float = 1.0, **kw) -> "SizeScaling":
        """The paper's §5 values: sigma = tau = 3 MPa, G = 250 N/m, f = 0.3 at b_ref."""
        ref = CohesiveParams.from_fracture_energy(3.0e6, 3.0e6, 250.0, lambda_max,
                                                  ratio_lTc_lNc)
        return cls(ref, **kw)

    def size(self, b) -> float:
        """The size used for a failed length ``b`` >= 0 [m]: ``max(b_ref, b)``."""
        b = _real("SizeScaling.params_for", "b", b, nonneg=True)
        return max(self.b_ref, b)

    def cohesive_for(self, b) -> CohesiveParams:
        bb = self.size(b)
        if bb == self.b_ref:
            return self._ref_params[0]
        s = self.sigma_law(bb)
        return CohesiveParams.from_fracture_energy(s, self.tau_law(bb), self.energy_law(bb),
                                                   self.reference.lambda_max,
                                                   self.ratio_lTc_lNc)

    def friction_for(self, b) -> FrictionParams:
        bb = self.size(b)
        if bb == self.b_ref:
            return self._ref_params[1]
        return FrictionParams(self.friction(bb), self.friction_penalty)

    def params_for(self, b) -> tuple[CohesiveParams, FrictionParams]:
        """Cohesive and friction parameters for the failed interface length ``b`` [m] (>= 0;
        0 before any failure). The size used is ``max(b_ref, b)``: at and below b_ref the
        reference objects themselves are returned (exactly the reference values)."""
        return self.cohesive_for(b), self.friction_for(b)

    def update(self, law, b):
        """``law.with_params(*params_for(b))`` (the law keeps its contact and damage parts);
        the state is normalised and carries over unchanged (docs/scaling.md §4)."""
        coh, fri = self.params_for(b)
        return law.with_params(cohesive=coh, friction=fri if law.friction is not None else None)

    def __repr__(self):
        return (f"SizeScaling(b_ref={self.b_ref}, sigma={self.sigma_law}, tau={self.tau_law}, "
                f"G={self.energy_law}, friction={self.friction})")


# ---------------------------------------------------------------------------------------------
class CharacteristicTimes(NamedTuple):
    """t1 = rho c_L l_Nc / (2 sigma_max) (cohesive), t2 = a0 / c_L (structural), c_L [m/s]."""

    t1: float
    t2: float
    c_L: float


def characteristic_times(E, rho, l_Nc, sigma_max, a0) -> CharacteristicTimes:
    """Paper Eq. 11 with ``c_L = sqrt(E/rho)``. Arguments broadcast (arrays allowed), all > 0."""
    w = "characteristic_times"
    E = _positive_array(w, "E", E)
    rho = _positive_array(w, "rho", rho)
    l_Nc = _positive_array(w, "l_Nc", l_Nc)
    sigma_max = _positive_array(w, "sigma_max", sigma_max)
    a0 = _positive_array(w, "a0", a0)
    c = np.sqrt(E / rho)
    return CharacteristicTimes(_out(rho * c * l_Nc / (2.0 * sigma_max)), _out(a0 / c), _out(c))


def characteristic_length(E, G, sigma):
    """Hillerborg's characteristic length ``l_ch = E G / sigma^2`` [m] (arrays allowed)."""
    w = "characteristic_length"
    E = _positive_array(w, "E", E)
    G = _positive_array(w, "G", G)
    sigma = _positive_array(w, "sigma", sigma)
    return _out(E * G / sigma ** 2)


# ---------------------------------------------------------------------------------------------
def mode_one_update_energy(scaling: SizeScaling, b_final: float, n_steps: int = 2000,
                           overshoot: float = 1.05) -> dict:
    """Energy effect of updating the parameters every step (diagnostic, docs §4).

    One material point is opened monotonically in mode I, ``g_k = (k/n) g_end`` with
    ``g_end = overshoot * l_Nc(b_final)``, while the size grows linearly in the step,
    ``b_k = b_ref + (k/n)(b_final - b_ref)``; at each step the law gets ``params_for(b_k)``
    and the committed state is kept. Returned (energies per unit area, J/m^2):

    dissipated : the law's counter (softening dissipation, per step with that step's G);
    work : external work sum over steps of the trapezoid of the traction in the step's law,
        from the traction at g_{k-1} *after* the update to the traction at g_k (exact for the
        piecewise-linear branches up to the kinks);
    released : stored energy lost at the updates, sum of g (F_before - F_after)/2 (the secant
        stored energy is g F/2);
    G_ref, G_final : G at b_ref and at b_final; kappa_end, max_jump_ratio (largest
    |F_after/F_before - expected ratio|), finite (no NaN anywhere).
    """
    from .law import InterfaceLaw

    b_final = _real("mode_one_update_energy", "b_final", b_final, positive=True)
    n = int(n_steps)
    if n < 2:
        raise ValueError(f"mode_one_update_energy: n_steps = {n_steps!r}; allowed: >= 2")
    coh0 = scaling.cohesive_for(scaling.b_ref)
    law = InterfaceLaw(coh0)
    state = law.initial_state(1, 2)
    g_end = overshoot * scaling.cohesive_for(b_final).l_Nc
    gap = np.zeros((1, 2))
    F_prev = 0.0
    g_prev = 0.0
    work = released = 0.0
    max_dev = 0.0
    finite = True
    b_prev = scaling.b_ref
    for k in range(1, n + 1):
        t = k / n
        b = scaling.b_ref + t * (b_final - scaling.b_ref)
        new_law = scaling.update(law, b)
        # traction at the old gap with the new parameters and the committed state
        gap[0, 0] = g_prev
        F_after = new_law.evaluate(gap, state)[0][0, 0] if g_prev > 0.0 else 0.0
        if F_prev > 0.0:
            expect = (scaling.sigma_law.ratio(b, b_prev)
                      * law.cohesive.l_Nc / new_law.cohesive.l_Nc)
            max_dev = max(max_dev, abs(F_after / F_prev - expect))
        released += 0.5 * g_prev * (F_prev - F_after)
        law = new_law
        g = t * g_end
        gap[0, 0] = g
        F, _, state = law.evaluate(gap, state)
        F_now = F[0, 0]
        finite &= bool(np.isfinite(F).all() and np.isfinite(state.kappa).all())
        work += 0.5 * (F_after + F_now) * (g - g_prev)
        F_prev, g_prev, b_prev = F_now, g, b
    return dict(dissipated=float(state.dissipated[0]), work=work, released=released,
                G_ref=coh0.G_I, G_final=scaling.cohesive_for(b_final).G_I,
                kappa_end=float(state.kappa[0]), max_jump_ratio_error=max_dev,
                finite=finite, n_steps=n, b_final=b_final)
