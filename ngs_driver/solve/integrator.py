"""Time integrators of the Newmark family: the coefficients a step needs.

One form covers the three schemes (Chung & Hulbert 1993, J. Appl. Mech. 60:371, Eqs. 2-4,
with the Newmark relations):

    (1 - alpha_m) M a_{n+1} + alpha_m M a_n
        + (1 - alpha_f) [C v + K u + f_int(u)]_{n+1} + alpha_f [C v + K u + f_int(u)]_n
        = (1 - alpha_f) f_{n+1} + alpha_f f_n,
    u_{n+1} = u_n + h v_n + h^2 [(1/2 - beta) a_n + beta a_{n+1}],
    v_{n+1} = v_n + h [(1 - gamma) a_n + gamma a_{n+1}].

* ``newmark``: alpha_m = alpha_f = 0 and the user's beta, gamma (average acceleration 1/4, 1/2:
  second order, no numerical dissipation).
* ``hht`` (Hilber, Hughes & Taylor 1977, Earthquake Engng Struct. Dyn. 5:283): alpha_m = 0,
  alpha_f = (1 - rho_inf) / (1 + rho_inf) in [0, 1/3] (rho_inf in [1/2, 1]),
  gamma = 1/2 + alpha_f, beta = (1 + alpha_f)^2 / 4.
* ``generalized-alpha`` (Chung & Hulbert 1993, Eqs. 25, 17, 20): alpha_m = (2 rho_inf - 1) /
  (rho_inf + 1), alpha_f = rho_inf / (rho_inf + 1), gamma = 1/2 - alpha_m + alpha_f,
  beta = (1 - alpha_m + alpha_f)^2 / 4: second order, rho_inf the spectral radius at infinite
  frequency (1: no dissipation; 0: the highest frequencies are annihilated in one step),
  least low-frequency dissipation for a given rho_inf.

HHT's alpha is -alpha_f in Hilber et al.'s sign convention (alpha in [-1/3, 0]). The internal
force f_int (the interface law) is averaged between n and n+1, as in HHT: the law is evaluated
at the end-of-step gap only, which keeps its return map and its history at real states.
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Integrator", "INTEGRATORS"]

INTEGRATORS = ("newmark", "hht", "generalized-alpha")


@dataclass(frozen=True)
class Integrator:
    """A member of the family above; build it with ``Integrator.make``."""

    name: str
    beta: float
    gamma: float
    alpha_f: float = 0.0
    alpha_m: float = 0.0
    rho_inf: float | None = None

    @classmethod
    def make(cls, name: str = "newmark", *, rho_inf: float = 1.0, beta: float = 0.25,
             gamma: float = 0.5) -> "Integrator":
        """``name`` in INTEGRATORS; ``rho_inf`` for hht ([0.5, 1]) and generalized-alpha
        ([0, 1]); ``beta``, ``gamma`` for newmark only. Raises ValueError naming the value."""
        if name not in INTEGRATORS:
            raise ValueError(f"time.integrator = {name!r} is not allowed; allowed: "
                             f"{', '.join(map(repr, INTEGRATORS))}")
        if name == "newmark":
            if not (0.0 < beta <= 0.5):
                raise ValueError(f"time.newmark_beta = {beta!r} is out of range; allowed: "
                                 "(0, 0.5]")
            if not (0.5 <= gamma <= 1.0):
                raise ValueError(f"time.newmark_gamma = {gamma!r} is out of range; allowed: "
                                 "[0.5, 1]")
            return cls("newmark", float(beta), float(gamma))
        r = float(rho_inf)
        if name == "hht":
            if not (0.5 <= r <= 1.0):
                raise ValueError(f"time.rho_inf = {rho_inf!r} is out of range for "
                                 "time.integrator = 'hht'; allowed: [0.5, 1] (HHT's alpha in "
                                 "[-1/3, 0]); use 'generalized-alpha' for smaller values")
            af = (1.0 - r) / (1.0 + r)
            return cls("hht", (1.0 + af) ** 2 / 4.0, 0.5 + af, af, 0.0, r)
        if not (0.0 <= r <= 1.0):
            raise ValueError(f"time.rho_inf = {rho_inf!r} is out of range; allowed: [0, 1]")
        am = (2.0 * r - 1.0) / (r + 1.0)
        af = r / (r + 1.0)
        return cls("generalized-alpha", (1.0 - am + af) ** 2 / 4.0, 0.5 - am + af, af, am, r)

    @property
    def plain(self) -> bool:
        """True for the Newmark scheme (equilibrium at the end of the step only)."""
        return self.alpha_f == 0.0 and self.alpha_m == 0.0

    def coefficients(self, h: float) -> tuple:
        """(c0, c1, c2, c3, c4, c5) for the step h: a_{n+1} = c0 (u_{n+1} - u_n) - c2 v_n -
        c3 a_n and v_{n+1} = c1 (u_{n+1} - u_n) - c4 v_n - c5 a_n."""
        b, g = self.beta, self.gamma
        return (1.0 / (b * h * h), g / (b * h), 1.0 / (b * h), 0.5 / b - 1.0, g / b - 1.0,
                h * (0.5 * g / b - 1.0))

    def describe(self) -> dict:
        return {"name": self.name, "beta": self.beta, "gamma": self.gamma,
                "alpha_f": self.alpha_f, "alpha_m": self.alpha_m, "rho_inf": self.rho_inf}
