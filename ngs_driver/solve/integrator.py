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

import numpy as np

from .kernels import newmark_update, rhs_alpha, rhs_combine, rhs_fused, rhs_vectors
from .products import FusedPair, pair_products

__all__ = ["Integrator", "INTEGRATORS", "TimeDiscretisation"]

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


class TimeDiscretisation:
    """The integrator applied to the structure's matrices: everything of a step that is not the
    joints' Newton -- the effective matrix, the right-hand side (the predictor's terms of the
    committed state), the update of v and a at a commit, and the committed state's products
    for the energy budget. One place for the family's algebra (``JointSolver`` holds one).

    K, M : scipy CSR (ndof, ndof); C : CSR or None (no damping); lowrank : None or the dense
    low-rank part of the damping, C = C + a0 U W U^T (solve/damping.py, ``product(y)``).
    The committed state ``cs`` passed to the methods has u, v, a, f and t (solve/committed.py);
    its arrays are replaced at a commit, never modified in place, which is what lets the
    products formed for the energy budget be reused by the next right-hand side (``rhs``).
    rayleigh: (a0, a1) when C = a0 M + a1 K (checked bit for bit by ``FusedPair``), or None."""

    def __init__(self, integrator: Integrator, K, M, C, lowrank=None, rayleigh=None):
        self.integrator = integrator
        self.K, self.M, self.C = K, M, C
        self.lowrank = lowrank
        self.alpha_hht = -integrator.alpha_f          # Hilber et al.'s sign convention
        self.alpha_m = integrator.alpha_m
        self.gamma = integrator.gamma
        self.ndof = K.shape[0]
        # M x and C y of the right-hand side in one compiled pass (bitwise scipy's products);
        # K on the same pattern for ``step_products`` (the energy budget's K u, M v)
        self.fused = FusedPair(M, C, K, rayleigh=rayleigh) if C is not None else None
        self._work = None
        self._next = None            # (h, u, v, a, M x, C y[, K u, C v]) of step_products

    def coefficients(self, h):
        return self.integrator.coefficients(h)

    def damping_product(self, y):
        """C y, with the low-rank part of C when there is one."""
        out = self.C @ y
        if self.lowrank is not None:
            out += self.lowrank.product(y)
        return out

    def matrix(self, h, coupled=None):
        """c0 (1 - alpha_m) M + c (K + c1 C) (+ the coupled field's block ``coupled``, a sparse
        matrix or None) for step size h, c = 1 + alpha_hht; None -> static K."""
        if h is None:
            return self.K
        c0, c1 = self.coefficients(h)[:2]
        c = 1.0 + self.alpha_hht
        A = (c0 * (1.0 - self.alpha_m) if self.alpha_m else c0) * self.M + c * self.K
        if self.C is not None:
            A = A + (c * c1) * self.C
        if coupled is not None:
            A = A + coupled
        return A.tocsr()

    def forget_products(self):
        """Drop the products kept by ``step_products`` (the next ``rhs`` forms its own)."""
        self._next = None

    @property
    def products_kept(self) -> bool:
        """True while products formed by ``step_products`` wait for the next ``rhs``."""
        return self._next is not None

    def _buffers(self):
        if self._work is None:
            self._work = np.empty((4, self.ndof))
        return self._work

    def rhs(self, h, cs, f_next, internal_force, fused: bool = True):
        """Effective right-hand side of the step of size h from the committed state ``cs`` to the
        load f_next (without the coupled field's share). internal_force(t) = B^T W t.
        fused=False: the numpy / scipy expressions (the reference the compiled passes equal
        bit for bit, tests/test_run_loop.py)."""
        c0, c1, c2, c3, c4, c5 = self.coefficients(h)
        al = self.alpha_hht
        c = 1.0 + al
        mc = self.fused if fused else None
        u, v, a = cs.u, cs.v, cs.a
        if mc is not None and al == 0.0 and self.alpha_m == 0.0:
            rhs = np.empty(self.ndof)
            f = np.ascontiguousarray(f_next, dtype=np.float64)
            nx = self._next
            if (nx is not None and len(nx) == 6 and nx[0] == h and nx[1] is u
                    and nx[2] is v and nx[3] is a):     # formed by step_products
                rhs_combine(nx[4], nx[5], c, f, rhs)
            else:
                x, y, om, oc = self._buffers()
                if self.lowrank is None:
                    rhs_fused(mc.indptr, mc.indices, mc.Ax, mc.Bx, u, v, a,
                              np.array([c0, c2, c3]), np.array([c1, c4, c5]), c, f, x, y,
                              om, oc, rhs)
                else:                             # C y = C_s y + a0 U W U^T y
                    rhs_vectors(u, v, a, np.array([c0, c2, c3]), np.array([c1, c4, c5]), x, y)
                    pair_products(mc.indptr, mc.indices, mc.Ax, mc.Bx, x, y, om, oc)
                    oc += self.lowrank.product(y)
                    rhs_combine(om, oc, c, f, rhs)
            return rhs
        if mc is not None:          # HHT / generalized alpha: the products in one pass
            nx = self._next
            if (nx is not None and len(nx) == 8 and nx[0] == h and nx[1] is u
                    and nx[2] is v and nx[3] is a):      # formed by step_products
                Mx, Cy, Ku, Cv = nx[4:]
            else:
                Ku, _, Mx, Cy, Cv = self.products_alpha(cs, h)
            af = -al
            f_n = cs.f if cs.f is not None else f_next
            # Mx + c Cy + (c f_next + af f_n) - af (Ku + B^T W t_n + Cv) in one compiled pass
            out = np.empty(self.ndof)
            rhs_alpha(Mx, Cy, Ku, internal_force(cs.t), Cv,
                      np.ascontiguousarray(f_next, dtype=np.float64),
                      np.ascontiguousarray(f_n, dtype=np.float64), c, af, out)
            return out
        am = self.alpha_m
        if am == 0.0:
            rhs = self.M @ (c0 * u + c2 * v + c3 * a)
        else:       # (1 - am) M a_{n+1} + am M a_n with a_{n+1} = c0 du - c2 v - c3 a
            rhs = self.M @ ((1.0 - am) * (c0 * u + c2 * v + c3 * a) - am * a)
        if self.C is not None:
            rhs += c * self.damping_product(c1 * u + c4 * v + c5 * a)
        if al != 0.0:
            f_n = cs.f if cs.f is not None else f_next
            rhs += c * f_next - al * f_n
            r_n = self.K @ u + internal_force(cs.t)
            if self.C is not None:
                r_n += self.damping_product(v)
            rhs += al * r_n
        else:
            rhs += f_next
        return rhs

    def rates(self, h, u, cs):
        """(v, a) at the end of a step of size h that ends at u, from the committed state ``cs``
        (the Newmark relations; the commit of every member of the family)."""
        c0, c1, c2, c3, c4, c5 = self.coefficients(h)
        v_new, a_new = np.empty(self.ndof), np.empty(self.ndof)
        newmark_update(u, cs.u, cs.v, cs.a, c0, c2, c3, h, 1.0 - self.gamma, self.gamma,
                       v_new, a_new)
        return v_new, a_new

    def step_products(self, cs, dt):
        """(K u, M v) of the committed state, bitwise scipy's ``K @ u`` and ``M @ v`` (the
        energy budget's products), or None when there is no damping matrix. The same
        compiled pass (``FusedPair.products5``) forms the right-hand-side products of a next
        step of size dt (M x, C y; with HHT / generalized alpha also K u + C v), which ``rhs`` then
        takes instead of forming them (kept while u, v, a are the same arrays)."""
        mc = self.fused
        if mc is None:
            return None
        if not self.integrator.plain:
            Ku, Mv, Mx, Cy, Cv = self.products_alpha(cs, dt)
            self._next = (dt, cs.u, cs.v, cs.a, Mx, Cy, Ku, Cv)
            return Ku, Mv
        c0, c1, c2, c3, c4, c5 = self.coefficients(dt)
        x, y = self._buffers()[:2]
        rhs_vectors(cs.u, cs.v, cs.a, np.array([c0, c2, c3]), np.array([c1, c4, c5]), x, y)
        Ku, Mv, Mx, Cy, Cv = (np.empty(self.ndof) for _ in range(5))
        # the generalized-alpha pass; Newmark's right-hand side does not use its C v (one sum
        # more per row: 0.23 against 0.22 ms on Koyna; the other four bitwise the same)
        mc.products5(cs.u, cs.v, x, y, Ku, Mv, Mx, Cy, Cv)
        if self.lowrank is not None:
            Cy += self.lowrank.product(y)
        self._next = (dt, cs.u, cs.v, cs.a, Mx, Cy)
        return Ku, Mv

    def products_alpha(self, cs, h):
        """(K u, M v, M x, C y, C v) of the committed state for a step h of HHT / generalized
        alpha in one compiled pass: x = (1 - am)(c0 u + c2 v + c3 a) - am a (the inertia at the
        alpha_m point), y = c1 u + c4 v + c5 a; the low-rank damping part added to C y, C v."""
        mc = self.fused
        c0, c1, c2, c3, c4, c5 = self.coefficients(h)
        am = self.alpha_m
        cm = 1.0 - am
        x, y = self._buffers()[:2]
        rhs_vectors(cs.u, cs.v, cs.a, np.array([cm * c0, cm * c2, cm * c3 - am]),
                    np.array([c1, c4, c5]), x, y)
        Ku, Mv, Mx, Cy, Cv = (np.empty(self.ndof) for _ in range(5))
        mc.products5(cs.u, cs.v, x, y, Ku, Mv, Mx, Cy, Cv)
        if self.lowrank is not None:
            Cy += self.lowrank.product(y)
            Cv += self.lowrank.product(cs.v)
        return Ku, Mv, Mx, Cy, Cv
