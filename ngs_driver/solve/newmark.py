"""Implicit Newmark / HHT-alpha time integration with a nonlinear interface, condensed on the
interface (one sparse factorisation per dt, Newton on the interface gaps only), and a
straightforward re-factorising full Newton used as the reference.

Equation (relative formulation, free DOFs, plane strain):

    M u'' + C u' + K u + B^T W t(B u) = f(t),          f = f_static - M r a_g(t)

B (2 npts x ndof, CSR): gap of point p  g_p = (g_N, g_T) = B[2p:2p+2] @ u;  W = diag(w) with w
(npts,) the integration weights; t = law.evaluate(g) the interface traction (interfacelaw).

Condensed method (docs/decisions.md §6).  K0 = diag(k_N, k_T) the law's initial elastic
stiffness (frozen at construction / ``set_law(..., refactor=True)``), phi(g) = t(g) - K0 g the
nonlinear correction (zero at every point still in its initial elastic state).  For the step
size h the effective matrix

    A = c0 M + c (K + c1 C) + c B^T W K0 B            (c = 1 + alpha_hht; static: K + B^T W K0 B)

is constant: factorised once per h (cached).  With u_lin = A^-1 rhs and S = B A^-1 B^T,

    u = u_lin - c A^-1 B^T W phi(g),    g = g_lin - c S W phi(g).

Newton runs on the gaps only: R(g) = g - g_lin + c S_:a W_a phi_a(g_a) = 0 (a: active points,
phi != 0), exact Jacobian I + c S W (T - K0) (T - K0 = 0 at inactive points), solved by iterative
refinement preconditioned with the LU of a reference Jacobian kept across iterations and steps
plus a low-rank (Woodbury) correction over the points whose tangent moved away from it
(``_jac_solve``). The columns S_:p are computed lazily (partial multi-right-hand-side solves
on the interface DOFs, ``SparseFactor.restrict``) when a point first becomes active, cached per
h. A^-1 rhs is split in its triangular halves so that a nonlinear step costs one forward and
one backward sparse solve plus the closure of the interface DOFs (docs/decisions.md §6, #15).
"""
from __future__ import annotations

import math
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spl

from .joint_laws import initial_stiffness, reference_gap
from .sparse import SparseFactor

__all__ = ["NewmarkSolver", "StepReport", "SolverError", "SparseFactor"]


def _getrs(lu, b):
    """LAPACK getrs on a scipy ``lu_factor`` result (without lu_solve's Python overhead)."""
    x, info = sla.lapack.dgetrs(lu[0], lu[1], b)
    if info != 0:
        raise np.linalg.LinAlgError(f"dgetrs info {info}")
    return x


# duration given to rate-dependent laws for the static solve: the dead load and the reservoir
# build up over months to years (impounding); one year [s]
STATIC_DURATION = 3.15e7


class SolverError(RuntimeError):
    """A step could not be converged even with the minimum step size (state is unchanged)."""


@dataclass
class StepReport:
    """What one ``step``/``static`` call did.

    iterations  : Newton iterations summed over the accepted sub-steps (failed attempts excluded)
    iterations_failed : Newton iterations spent in attempts that were rejected (cut)
    cuts        : number of rejected attempts (each halves the sub-step)
    dts         : sizes of the accepted sub-steps (sum = dt); [dt] if no cut
    iters_per_substep : iterations of each accepted sub-step
    residuals   : final relative residual norm of each accepted sub-step
    n_active    : number of points not in their initial elastic state at the end
    wall        : wall time of the call [s]
    """
    iterations: int = 0
    iterations_failed: int = 0
    cuts: int = 0
    dts: list = field(default_factory=list)
    iters_per_substep: list = field(default_factory=list)
    residuals: list = field(default_factory=list)
    n_active: int = 0
    wall: float = 0.0


@dataclass
class _Cache:
    """Per-step-size data of the condensed method."""
    factor: SparseFactor
    S: np.ndarray | None = None          # (2 npts, 2 npts), columns valid where have[p]
    have: np.ndarray | None = None       # (npts,) bool
    jr: list | None = None               # [LU of J_ref, E_ref, {point: Y columns}, c]
    base: bool = True                    # the nominal step's entry (never evicted)


class NewmarkSolver:
    """Newmark-beta / HHT-alpha integrator with an interface law; see module docstring.

    Parameters
    ----------
    K, M, C : scipy sparse (ndof, ndof) stiffness, mass, damping (C may be None = 0)
    B, w    : interface operator (2 npts, ndof) and weights (npts,)
    law     : interfacelaw.InterfaceLaw
    dt      : nominal step size [s]
    beta, gamma : Newmark parameters (default average acceleration 1/4, 1/2)
    alpha_hht : HHT-alpha in [-1/3, 0]; if nonzero and beta/gamma not given they are set to
              beta = (1 - alpha)^2 / 4, gamma = 1/2 - alpha
    tol_residual : relative residual tolerance (condensed: gap residual relative to the gap
              norm; full: force residual relative to the effective load)
    tol_energy : energy criterion |dx . r_k| <= tol_energy |dx_0 . r_0| (both must hold)
    max_iter : Newton iterations per attempt before the step is cut
    min_dt  : smallest sub-step; below it SolverError is raised (default dt / 2**10)
    method  : "condensed" (default) or "full" (re-factorising reference)
    line_search : backtracking on the residual norm
    max_cache : number of step sizes whose factorisation/S columns are kept
    jacobian_tol : a point's tangent enters the low-rank correction of the reference Jacobian
              when it differs from the reference one by more than jacobian_tol max K0
    lowrank_max : more changed points than this refactorise the reference Jacobian
    inner_rtol, inner_max : iterative refinement of the Newton direction (relative residual,
              refinements before refactorising)
    reference_every : reference Jacobians are dropped every so many steps (resume = bitwise
              the uninterrupted run when checkpoints fall on multiples of it; 0: never)
    """

    def __init__(self, K, M, C, B, w, law, *, dt, beta=None, gamma=None, alpha_hht=0.0,
                 tol_residual=1e-8, tol_energy=1e-16, max_iter=25, min_dt=None,
                 method="condensed", line_search=True, max_cache=6, active_tol=1e-12,
                 lowrank_max=64, jacobian_tol=1e-4, inner_rtol=1e-9, inner_max=6,
                 reference_every=10):
        if method not in ("condensed", "full"):
            raise ValueError(f"NewmarkSolver method = {method!r} is not allowed; allowed: "
                             "'condensed', 'full'")
        if not (-1.0 / 3.0 - 1e-12 <= alpha_hht <= 0.0):
            raise ValueError(f"NewmarkSolver alpha_hht = {alpha_hht!r} is not allowed; "
                             "allowed: [-1/3, 0]")
        self.K = sp.csr_matrix(K)
        self.M = sp.csr_matrix(M)
        self.C = None if C is None else sp.csr_matrix(C)
        self.B = sp.csr_matrix(B)
        self.BT = self.B.T.tocsr()
        self.w = np.asarray(w, dtype=np.float64)
        self.ndof = self.K.shape[0]
        self.npts = self.w.shape[0]
        if self.B.shape != (2 * self.npts, self.ndof):
            raise ValueError(f"NewmarkSolver B shape {self.B.shape} does not match "
                             f"(2*npts, ndof) = {(2 * self.npts, self.ndof)}")
        self.alpha_hht = float(alpha_hht)
        self.beta = float(beta if beta is not None else (1.0 - alpha_hht) ** 2 / 4.0)
        self.gamma = float(gamma if gamma is not None else 0.5 - alpha_hht)
        self.dt = float(dt)
        self.tol_residual = float(tol_residual)
        self.tol_energy = float(tol_energy)
        self.max_iter = int(max_iter)
        self.min_dt = float(min_dt) if min_dt is not None else self.dt / 2 ** 10
        self.method = method
        self.line_search = bool(line_search)
        self.max_cache = int(max_cache)
        self.active_tol = float(active_tol)
        self.lowrank_max = int(lowrank_max)
        self.inner_rtol = float(inner_rtol)
        self.inner_max = int(inner_max)
        self.reference_every = int(reference_every)
        self.jacobian_tol = float(jacobian_tol)
        self.stats = dict(jacobian_factorisations=0, lowrank_points=0, refinements=0)
        self.law = law
        self._set_k0(law)
        self._wd = np.repeat(self.w, 2)                     # W on the (2 npts) gap vector
        self._Idofs = np.unique(self.B.indices)               # DOFs the interface touches
        self._BI = self.B[:, self._Idofs].tocsr()            # (2 npts, |I|)
        self._BIT = self._BI.T.tocsr()
        self._cache: OrderedDict = OrderedDict()
        self._static_cache = None
        self._Minv = None
        # committed fields
        self.u = np.zeros(self.ndof)
        self.v = np.zeros(self.ndof)
        self.a = np.zeros(self.ndof)
        self.f = None                                       # load at the current time
        self.time = 0.0
        self.state = law.initial_state(self.npts, 2)
        self.t = np.zeros((self.npts, 2))                   # committed traction
        self.g = np.zeros((self.npts, 2))                   # committed gap
        self._phi = np.zeros(2 * self.npts)                 # committed phi (condensed)
        self._active = np.zeros(self.npts, bool)
        self.history = []                                   # StepReport per call

    # ------------------------------------------------------------------ set-up / parameters
    def _set_k0(self, law):
        self.k0p = initial_stiffness(law, self.npts)         # (npts, 2): k_N, k_T per point
        self.k0 = self.k0p.max(axis=0)
        self._k0v = self.k0p.ravel()
        self._k0blk = np.zeros((self.npts, 2, 2))
        self._k0blk[:, 0, 0] = self.k0p[:, 0]
        self._k0blk[:, 1, 1] = self.k0p[:, 1]
        self._gref = reference_gap(law) * 1e-3 * math.sqrt(self.npts)
        self._BtWK0B = (self.BT @ sp.diags(self._k0v * np.repeat(self.w, 2)) @ self.B).tocsr()

    def set_law(self, law, refactor: bool = False):
        """Replace the interface law between steps (size-scale update).  The factorised K0
        stays that of the original law unless ``refactor``; the difference is part of phi."""
        self.law = law
        if refactor:
            self._set_k0(law)
            self._cache.clear()
            self._static_cache = None

    def _law_dt(self, h):
        """The step's duration for rate-dependent laws (damage form "rate"); the static
        solve (h None) stands for the slow build-up of dead load and reservoir, taken as
        STATIC_DURATION (docs/decisions.md §6)."""
        return STATIC_DURATION if h is None else h

    def set_initial(self, u=None, v=None, a=None, f=None):
        """Set the committed fields (e.g. after a restart); the interface traction and gap are
        recomputed from the committed state without changing it."""
        if u is not None:
            self.u = np.array(u, dtype=float)
        if v is not None:
            self.v = np.array(v, dtype=float)
        if a is not None:
            self.a = np.array(a, dtype=float)
        if f is not None:
            self.f = np.array(f, dtype=float)
        g = (self.B @ self.u).reshape(-1, 2)
        t, _, _ = self.law.evaluate(np.ascontiguousarray(g), self.state, dt=self.dt)
        self.g, self.t = g, t
        self._phi = (t.ravel() - self._k0v * g.ravel())
        self._active = self._phi_mask(self._phi, g.ravel())

    def initial_acceleration(self, f):
        """Solve M a = f - C v - K u - B^T W t for the committed u, v (sets self.a, self.f)."""
        if self._Minv is None:
            self._Minv = SparseFactor(self.M)
        r = f - self.K @ self.u - self._fint(self.t)
        if self.C is not None:
            r -= self.C @ self.v
        self.a = self._Minv.solve(r)
        self._Minv = None                # used once per run: not kept (memory, #15)
        self.f = np.array(f, dtype=float)
        return self.a

    # ------------------------------------------------------------------ helpers
    def _fint(self, t):
        return self.BT @ (self._wd * t.ravel())

    def _coeffs(self, h):
        b, g = self.beta, self.gamma
        return (1.0 / (b * h * h), g / (b * h), 1.0 / (b * h), 0.5 / b - 1.0, g / b - 1.0,
                h * (0.5 * g / b - 1.0))

    def _A_lin(self, h):
        """c0 M + c (K + c1 C) (no interface) for step size h; None -> static K."""
        if h is None:
            return self.K
        c0, c1 = self._coeffs(h)[:2]
        c = 1.0 + self.alpha_hht
        A = c0 * self.M + c * self.K
        if self.C is not None:
            A = A + (c * c1) * self.C
        if getattr(self, "ext", None) is not None:     # compressible water (acoustic_newmark)
            A = A + self.ext.matrix(h)
        return A.tocsr()

    def _entry(self, h):
        if h is None:
            if self._static_cache is None:
                self._static_cache = _Cache(SparseFactor(self.K + self._BtWK0B)
                                            .restrict(self._Idofs))
            return self._static_cache
        key = float(h)
        e = self._cache.get(key)
        if e is None:
            c = 1.0 + self.alpha_hht
            # a cut costs one factorisation + columns once per sub-step size for the whole
            # run; the cache holds every halving level (measured: 18 cuts at 1.5-3.8 s each
            # with 3 slots); the nominal step's entry is never evicted
            e = _Cache(SparseFactor(self._A_lin(h) + c * self._BtWK0B).restrict(self._Idofs),
                       base=abs(h - self.dt) <= 1e-12 * self.dt)
            self._cache[key] = e
            while len(self._cache) > self.max_cache:      # evict the LRU sub-step entry
                old = next((k for k, v in self._cache.items() if not v.base),
                           next(iter(self._cache)))
                self._cache.pop(old)
        else:
            self._cache.move_to_end(key)
        return e

    def _ensure_cols(self, e: _Cache, pts):
        """Compute the columns S[:, 2p:2p+2] = B A^-1 B_p^T for points ``pts`` not cached."""
        if e.S is None:
            e.S = np.zeros((2 * self.npts, 2 * self.npts))
            e.have = np.zeros(self.npts, bool)
        new = pts[~e.have[pts]]
        if new.size == 0:
            return
        dofs = np.empty(2 * new.size, np.int64)
        dofs[0::2] = 2 * new
        dofs[1::2] = 2 * new + 1
        # S[:, dofs] = B_I (A^-1)_II B_I^T[:, dofs]: partial solves (right-hand sides and the
        # wanted entries on the interface DOFs I only; SparseFactor.restrict)
        for k in range(0, dofs.size, 128):                # blocks: bounded work memory
            blk = dofs[k:k + 128]
            e.S[:, blk] = self._BI @ e.factor.solve_at(self._BIT[:, blk].toarray())
        e.have[new] = True

    def _phi_mask(self, phi, g):
        """Points whose correction phi is not round-off of K0 g."""
        p2 = np.abs(phi) > self.active_tol * (self._k0v * np.abs(g)) + 1e-300
        return p2[0::2] | p2[1::2]

    def _rhs(self, h, f_next):
        """Effective right-hand side of the step of size h ending with load f_next."""
        c0, c1, c2, c3, c4, c5 = self._coeffs(h)
        al = self.alpha_hht
        c = 1.0 + al
        rhs = self.M @ (c0 * self.u + c2 * self.v + c3 * self.a)
        if self.C is not None:
            rhs += c * (self.C @ (c1 * self.u + c4 * self.v + c5 * self.a))
        if al != 0.0:
            f_n = self.f if self.f is not None else f_next
            rhs += c * f_next - al * f_n
            r_n = self.K @ self.u + self._fint(self.t)
            if self.C is not None:
                r_n += self.C @ self.v
            rhs += al * r_n
        else:
            rhs += f_next
        if getattr(self, "ext", None) is not None:
            rhs += self.ext.rhs(h)
        return rhs

    # ------------------------------------------------------------------ Newton kernels
    def _converged(self, rnorm, energy, energy0):
        return rnorm <= self.tol_residual and (energy <= self.tol_energy * energy0
                                               or rnorm <= 1e-3 * self.tol_residual)

    def _line_search(self, x, dx, rnorm, trial):
        """Backtracking on the residual norm (halving down to 1/64; Armijo-like decrease).
        ``trial(x) -> (out, rnorm)``. Returns (s, x + s dx, out, rnorm) or None (no finite
        trial point)."""
        s = 1.0
        while True:
            xt = x + s * dx
            try:
                out, rn_t = trial(xt)
            except (ValueError, FloatingPointError):
                out, rn_t = None, np.inf
            if out is not None and (not self.line_search or s < 1.0 / 64
                                    or rn_t <= (1.0 - 1e-4 * s) * rnorm):
                return s, xt, out, rn_t
            if out is None and s < 1.0 / 64:
                return None
            s *= 0.5

    def _status(self, rnorm, energy, energy0, it):
        """Newton control shared by both methods: True converged, False failed (cut the
        step), None iterate on."""
        if not np.isfinite(rnorm) or rnorm > 1e12:
            return False
        if energy0 is not None and self._converged(rnorm, energy, energy0):
            return True
        if energy0 is None and rnorm <= 1e-3 * self.tol_residual:
            return True
        if it >= self.max_iter:
            return False
        return None

    @staticmethod
    def _dof_idx(pts):
        d = np.empty(2 * pts.size, np.int64)
        d[0::2] = 2 * pts
        d[1::2] = 2 * pts + 1
        return d

    def _newton_condensed(self, h, rhs, c):
        """Returns (ok, u, g, t, new_state, phi, active, iterations, rnorm)."""
        law, state = self.law, self.state
        e = self._entry(h)
        # A^-1 rhs split in its two triangular halves: with active points only the interface
        # entries of u_lin are formed now (the closure of I in U), and the one full backward
        # solve comes after Newton, on z - c L^-1 Pr B^T W phi (issue #15)
        z_lin = e.factor.forward(rhs)
        if self._active.any():
            u_lin = None
            g_lin = self._BI @ e.factor.backward_at(z_lin)
        else:
            u_lin = e.factor.backward(z_lin)
            g_lin = self.B @ u_lin
        wd, k0v = self._wd, self._k0v
        n2 = 2 * self.npts
        act = self._active.copy()
        self._ensure_cols(e, np.flatnonzero(act))
        S = e.S
        ad = self._dof_idx(np.flatnonzero(act))

        def Smul(ad, y):
            """S[:, ad] @ y without copying S when most columns are active."""
            if ad.size == n2:
                return S @ y
            if 2 * ad.size >= n2:
                yp = np.zeros(n2)
                yp[ad] = y
                return S @ yp
            return S[:, ad] @ y

        g = g_lin - c * Smul(ad, wd[ad] * self._phi[ad]) if ad.size else g_lin.copy()
        gscale = max(np.linalg.norm(g_lin), self._gref)

        def resid(g, act, ad):
            t, T, new = law.evaluate(g.reshape(-1, 2), state, dt=self._law_dt(h))
            phi = t.ravel() - k0v * g
            newly = ~act & self._phi_mask(phi, g)
            if newly.any():
                act = act | newly
                self._ensure_cols(e, np.flatnonzero(newly))
                ad = self._dof_idx(np.flatnonzero(act))
            R = g - g_lin
            if ad.size:
                R += c * Smul(ad, wd[ad] * phi[ad])
            return t, T, new, phi, R, act, ad

        try:
            t, T, new, phi, R, act, ad = resid(g, act, ad)
        except (ValueError, FloatingPointError):
            return (False,) + (None,) * 6 + (0, np.inf)
        rnorm = np.linalg.norm(R) / max(np.linalg.norm(g), gscale)
        energy0 = None
        energy = np.inf
        it = 0
        while True:
            status = self._status(rnorm, energy, energy0, it)
            if status is False:
                return (False,) + (None,) * 6 + (it, rnorm)
            if status:
                break
            it += 1
            # Newton direction on all gaps: (I + c S W E) dg = -R, E = T - K0 at the active
            # points (0 elsewhere), by the LU of a reference Jacobian kept across iterations and
            # steps plus an exact low-rank (Woodbury) correction over the points whose tangent
            # moved away from the reference one by more than jacobian_tol (docs §6, #15)
            E = T - self._k0blk
            E[~act] = 0.0
            try:
                dg = self._jac_solve(e, S, E, -R, c)
            except (np.linalg.LinAlgError, ValueError):
                return (False,) + (None,) * 6 + (it, rnorm)
            en = abs(np.dot(dg, wd * k0v * R))
            if energy0 is None:
                energy0 = max(en, 1e-300)
            # backtracking line search on the residual norm
            def trial(x):
                o = resid(x, act, ad)
                return o, np.linalg.norm(o[4]) / max(np.linalg.norm(x), gscale)

            ls = self._line_search(g, dg, rnorm, trial)
            if ls is None:
                return (False,) + (None,) * 6 + (it, np.inf)
            s, g, out, rn_t = ls
            t, T, new, phi, R, act, ad = out
            energy = s * en
            rnorm = rn_t
        # recover u = A^-1 (rhs - c B^T W phi_a) = Pc U^-1 (z_lin - c L^-1 Pr B^T W phi_a):
        # the forward part only visits the closure of the interface rows
        phia = np.zeros_like(phi)
        phia[ad] = phi[ad]
        if ad.size:
            u = e.factor.backward(z_lin - c * e.factor.forward_sparse(self._BIT @ (wd * phia)))
        else:
            u = u_lin if u_lin is not None else e.factor.backward(z_lin)
        return True, u, g, t, new, phia, act, it, rnorm

    def _jac_solve(self, e, S, E, b, c):
        """Solve J x = b, J = I + S blockdiag(c w_p E_p) the exact Jacobian (E = T - K0, zero
        at inactive points), by iterative refinement to ``inner_rtol`` preconditioned with P:

        P = J_ref + S_:k blockdiag(c w dE_k) E_k^T,  J_ref = I + S blockdiag(c w E_ref)
        LU-factorised once and kept (per step size), dE = E - E_ref over the m points k where
        it exceeds jacobian_tol max K0 (P is J there: exact), by Woodbury

            P^-1 r = x0 - Y_k C^-1 blockdiag(c w dE_k) x0_k,  x0 = J_ref^-1 r, Y_k = J_ref^-1 S_:k,
            C = I + blockdiag(c w dE_k) Y_k[k, :]     (2m x 2m).

        ||P^-1 (J - P)|| ~ jacobian_tol, so one or two refinements reach inner_rtol; the Newton
        direction is then the exact one to round-off, whatever J_ref is (so the iterates do not
        depend on when J_ref was factorised: a resumed run equals an uninterrupted one). The
        columns Y_k are cached with J_ref; more than ``lowrank_max`` changed points, a singular
        C or a slow refinement refactorise J_ref at the current E."""
        cw = c * self.w
        Dw = E * cw[:, None, None]
        n2 = b.size

        d00, d01, d10, d11 = Dw[:, 0, 0], Dw[:, 0, 1], Dw[:, 1, 0], Dw[:, 1, 1]

        def Jmul(x):
            y = np.empty_like(x)
            x0, x1 = x[0::2], x[1::2]
            y[0::2] = d00 * x0 + d01 * x1
            y[1::2] = d10 * x0 + d11 * x1
            return x + S @ y

        jr = e.jr
        ch = None
        fresh = False
        if jr is not None and jr[3] == c:
            dE = E - jr[1]
            ch = np.flatnonzero(np.abs(dE).reshape(-1, 4).max(axis=1)
                                > self.jacobian_tol * self.k0.max())
            if ch.size > self.lowrank_max:
                jr = None
        else:
            jr = None
        if jr is None:
            J = np.empty_like(S)
            S0 = S[:, 0::2]
            S1 = S[:, 1::2]
            J[:, 0::2] = S0 * Dw[:, 0, 0] + S1 * Dw[:, 1, 0]
            J[:, 1::2] = S0 * Dw[:, 0, 1] + S1 * Dw[:, 1, 1]
            J[np.diag_indices_from(J)] += 1.0
            lu = sla.lu_factor(J, check_finite=False, overwrite_a=True)
            self.stats["jacobian_factorisations"] += 1
            jr = e.jr = [lu, E.copy(), {}, c]
            ch = np.zeros(0, np.int64)
            fresh = True
        lu, _, Ycols, _ = jr
        if ch.size:
            need = [p for p in ch.tolist() if p not in Ycols]
            if need:
                nd = self._dof_idx(np.asarray(need, np.int64))
                Yn = sla.lu_solve(lu, S[:, nd], check_finite=False)
                for q, p in enumerate(need):
                    Ycols[p] = Yn[:, 2 * q:2 * q + 2]
            m = ch.size
            kd = self._dof_idx(ch)
            Yk = np.empty((n2, 2 * m))
            for q, p in enumerate(ch.tolist()):
                Yk[:, 2 * q:2 * q + 2] = Ycols[p]
            dW = dE[ch] * cw[ch][:, None, None]
            C = np.einsum("pij,pjk->pik", dW, Yk[kd, :].reshape(m, 2, 2 * m)).reshape(2 * m,
                                                                                       2 * m)
            C[np.diag_indices_from(C)] += 1.0
            Clu = sla.lu_factor(C, check_finite=False, overwrite_a=True)
            self.stats["lowrank_points"] += m

        def Pinv(r):
            x0 = _getrs(lu, r)
            if ch.size:
                z = _getrs(Clu, np.einsum("pij,pj->pi", dW, x0[kd].reshape(m, 2)).ravel())
                x0 -= Yk @ z
            return x0

        x = Pinv(b)
        if self.inner_max == 0:          # modified Newton on the unchanged points
            if np.all(np.isfinite(x)):
                return x
            if fresh:
                raise np.linalg.LinAlgError("interface Jacobian: non-finite solution")
            e.jr = None
            return self._jac_solve(e, S, E, b, c)
        bn = np.linalg.norm(b)
        prev = np.inf
        for k in range(self.inner_max):
            r = b - Jmul(x)
            rn = np.linalg.norm(r)
            if not np.isfinite(rn):
                break
            # converged, or (P = J: the LU of this very matrix) at its round-off floor
            if rn <= self.inner_rtol * bn or (fresh and rn >= 0.5 * prev):
                self.stats["refinements"] += k
                return x
            prev = rn
            x += Pinv(r)
        if fresh:
            if np.all(np.isfinite(x)):
                return x
            raise np.linalg.LinAlgError("interface Jacobian: non-finite solution")
        e.jr = None                    # slow refinement: refactorise at the current E
        return self._jac_solve(e, S, E, b, c)

    def _newton_full(self, h, rhs, c):
        law, state = self.law, self.state
        A_lin = self._A_lin(h)
        wd = self._wd
        # start from the last converged displacement
        u = self.u.copy()
        fscale = max(np.linalg.norm(rhs), 1e-300)

        def resid(u):
            g = self.B @ u
            t, T, new = law.evaluate(g.reshape(-1, 2), state, dt=self._law_dt(h))
            r = rhs - A_lin @ u - c * (self.BT @ (wd * t.ravel()))
            return g, t, T, new, r

        try:
            g, t, T, new, r = resid(u)
        except (ValueError, FloatingPointError):
            return (False,) + (None,) * 6 + (0, np.inf)
        rnorm = np.linalg.norm(r) / fscale
        energy0 = None
        energy = np.inf
        it = 0
        n = self.npts
        while True:
            status = self._status(rnorm, energy, energy0, it)
            if status is False:
                return (False,) + (None,) * 6 + (it, rnorm)
            if status:
                break
            it += 1
            WT = sp.bsr_matrix((T * self.w[:, None, None], np.arange(n), np.arange(n + 1)),
                               shape=(2 * n, 2 * n))
            J = A_lin + c * (self.BT @ WT.tocsr() @ self.B)
            try:
                du = SparseFactor(J, symmetric=False, fast=False).solve(r)
            except RuntimeError:
                return (False,) + (None,) * 6 + (it, rnorm)
            en = abs(np.dot(du, r))
            if energy0 is None:
                energy0 = max(en, 1e-300)
            def trial(x):
                o = resid(x)
                return o, np.linalg.norm(o[4]) / fscale

            ls = self._line_search(u, du, rnorm, trial)
            if ls is None:
                return (False,) + (None,) * 6 + (it, np.inf)
            s, u, out, rn_t = ls
            g, t, T, new, r = out
            energy = s * en
            rnorm = rn_t
        phi = t.ravel() - self._k0v * g
        act = self._phi_mask(phi, g)
        phi[np.repeat(~act, 2)] = 0.0
        return True, u, g, t, new, phi, act, it, rnorm

    def _attempt(self, h, f_next):
        c = 1.0 if h is None else 1.0 + self.alpha_hht
        rhs = f_next if h is None else self._rhs(h, f_next)
        with np.errstate(all="ignore"):
            if self.method == "condensed":
                return self._newton_condensed(h, rhs, c)
            return self._newton_full(h, rhs, c)

    def _commit(self, h, f_next, res):
        _, u, g, t, new, phi, act, it, rnorm = res
        if h is not None:
            c0, c1, c2, c3, c4, c5 = self._coeffs(h)
            du = u - self.u
            a_new = c0 * du - c2 * self.v - c3 * self.a
            v_new = self.v + h * ((1.0 - self.gamma) * self.a + self.gamma * a_new)
            self.v, self.a = v_new, a_new
            self.time += h
        self.u = u
        self.g = g.reshape(-1, 2).copy()
        self.t = t.copy()
        self.state = new
        self._phi = phi
        self._active = act
        self.f = np.array(f_next, dtype=float)
        if h is not None and getattr(self, "ext", None) is not None:
            self.ext.commit(h)

    # ------------------------------------------------------------------ public steps
    def static(self, f) -> StepReport:
        """Solve K u + B^T W t(B u) = f from the committed state (dead load + reservoir);
        commits u, the interface state; sets v = a = 0 and the current load to f."""
        t0 = time.perf_counter()
        rep = StepReport()
        res = self._attempt(None, f)
        if not res[0]:
            raise SolverError(f"static solve did not converge in {self.max_iter} iterations "
                              f"(relative residual {res[-1]:.3e})")
        self._commit(None, f, res)
        self.v = np.zeros(self.ndof)
        self.a = np.zeros(self.ndof)
        rep.iterations = res[7]
        rep.iters_per_substep = [res[7]]
        rep.residuals = [res[8]]
        rep.n_active = int(self._active.sum())
        rep.wall = time.perf_counter() - t0
        self.history.append(rep)
        return rep

    def step(self, f_next) -> StepReport:
        """Advance by dt to the load ``f_next``; on non-convergence the sub-step is halved and
        retried from the committed state (load interpolated linearly in time), sizes grow back
        after success.  Raises SolverError below ``min_dt`` (committed fields are then those at
        the last accepted sub-step, ``self.time`` tells where)."""
        t0 = time.perf_counter()
        rep = StepReport()
        self._static_cache = None        # the static factorisation is not needed any more
        f_next = np.asarray(f_next, dtype=float)
        f_start = self.f if self.f is not None else f_next
        # the reference Jacobians are dropped at every reference_every-th step, so that the
        # iterates are a function of the committed state there: a run resumed from a
        # checkpoint at such a step repeats the uninterrupted one bit for bit
        if self.reference_every > 0 and round(self.time / self.dt) % self.reference_every == 0:
            for e in self._cache.values():
                e.jr = None
        pos = Fraction(0)
        hf = Fraction(1)
        while pos < 1:
            hf = min(hf, 1 - pos)
            h = self.dt * float(hf)
            end = pos + hf
            fe = f_next if end == 1 else f_start + float(end) * (f_next - f_start)
            res = self._attempt(h, fe)
            if res[0]:
                self._commit(h, fe, res)
                rep.iterations += res[7]
                rep.iters_per_substep.append(res[7])
                rep.residuals.append(res[8])
                rep.dts.append(h)
                pos = end
                if hf < 1 and pos % (2 * hf) == 0:
                    hf *= 2
            else:
                rep.iterations_failed += res[7]
                rep.cuts += 1
                hf /= 2
                if self.dt * float(hf) < self.min_dt * (1 - 1e-12):
                    rep.wall = time.perf_counter() - t0
                    self.history.append(rep)
                    raise SolverError(
                        f"step to t = {self.time + self.dt * float(1 - pos):.6g} s did not "
                        f"converge with the minimum sub-step {self.min_dt:.3g} s "
                        f"({rep.cuts} cuts; last relative residual {res[-1]:.3e}); committed "
                        f"state is at t = {self.time:.6g} s")
        rep.n_active = int(self._active.sum())
        rep.wall = time.perf_counter() - t0
        self.history.append(rep)
        return rep

    # ------------------------------------------------------------------ diagnostics
    def energy(self):
        """Kinetic + elastic (bulk + interface at K0) energy of the committed state; exact
        stored energy only while the interface is elastic."""
        kin = 0.5 * self.v @ (self.M @ self.v)
        el = 0.5 * self.u @ (self.K @ self.u)
        el += 0.5 * np.sum(self.w[:, None] * self.t * self.g)
        return kin + el
