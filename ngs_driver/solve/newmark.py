"""Implicit Newmark / HHT-alpha time integration with a nonlinear interface, condensed on the
interface (one sparse factorisation per dt, Newton on the interface gaps only), and a
straightforward re-factorising full Newton used as the reference.

Equation (relative formulation, free DOFs, plane strain):

    M u'' + C u' + K u + B^T W t(B u) = f(t),          f = f_static - M r a_g(t)

B (2 npts x ndof, CSR): gap of point p  g_p = (g_N, g_T) = B[2p:2p+2] @ u;  W = diag(w) with w
(npts,) the integration weights; t = law.evaluate(g) the interface traction (interfacelaw).

Condensed method (docs/solver.md §2).  K0 = diag(k_N, k_T) the law's initial elastic
stiffness (frozen at construction / ``set_law(..., refactor=True)``), phi(g) = t(g) - K0 g the
nonlinear correction (zero at every point still in its initial elastic state).  For the step
size h the effective matrix

    A = c0 M + c (K + c1 C) + c B^T W K0 B            (c = 1 + alpha_hht; static: K + B^T W K0 B)

is constant: factorised once per h (cached).  With u_lin = A^-1 rhs and S = B A^-1 B^T,

    u = u_lin - c A^-1 B^T W phi(g),    g = g_lin - c S W phi(g).

Newton runs on the gaps only: R(g) = g - g_lin + c S_:a W_a phi_a(g_a) = 0 (a: active points,
phi != 0), exact Jacobian I + c S W (T - K0) (T - K0 = 0 at inactive points). S is never formed:
B_I = G Delta (Delta: the relative displacements of the paired dam/rock interface DOFs, r of
them: 224 on the default Koyna mesh whatever the number of interface points; G sparse), so
S = G Y G^T with Y = Delta (A^-1)_II Delta^T (r x r, from r partial solves once per h) and the
Newton direction comes from the r x r system Y^-1 + G^T Dw G by the push-through identity
(``_jac_solve``), solved by GMRES on an earlier LU or factorised. A^-1 rhs
is split in its triangular halves so that a nonlinear step costs one forward and one backward
sparse solve plus the closure of the interface DOFs (``SparseFactor.restrict``;
docs/solver.md §2.4, issue #15).
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
from numba import njit

from .damping import LowRankFactor
from .integrator import Integrator
from .joint_laws import initial_stiffness, reference_gap
from .krylov import gmres_lu, lu_solve_into
from .products import FusedPair, pair_products, step_products5
from .sparse import SparseFactor

__all__ = ["NewmarkSolver", "StepReport", "SolverError", "SparseFactor"]


# Newton directions with an earlier LU of the r x r interface system (``_jac_solve``):
# GMRES right-preconditioned by it (solve/krylov.py) to this true relative residual (a direct
# LU solve of the 224 x 224 Koyna system leaves ~1e-15), at most _GMRES_MAX iterations, after
# which the system is factorised afresh; after a solve that needed more than _GMRES_REFRESH
# iterations the LU is dropped so that the next solve factorises (a factorisation costs
# ~15 iterations on Koyna). Chosen on 4 057 captured solves of the 0.2x Koyna run's first
# 3 s (docs/solver.md §2.3, CHANGELOG.md): per solve ~230 us against ~700 us by refinement on the LU
# of K = I + P Y (the second round), factorisations 408 against 2 008.
_GMRES_TOL = 1e-13
_GMRES_MAX = 16
_GMRES_REFRESH = 8


@njit(cache=True)
def _rhs_fused(indptr, indices, Mx, Cx, u, v, a, cm, cc, c, f, x, y, om, oc, rhs):
    """rhs = M (cm0 u + cm1 v + cm2 a) + c C (cc0 u + cc1 v + cc2 a) + f, bitwise numpy's
    ``NewmarkSolver._rhs`` (the same operations in the same order; the two products on one
    pattern, ``products.pair_products``)."""
    _rhs_vectors(u, v, a, cm, cc, x, y)
    pair_products(indptr, indices, Mx, Cx, x, y, om, oc)
    _rhs_combine(om, oc, c, f, rhs)


@njit(cache=True)
def _rhs_vectors(u, v, a, cm, cc, x, y):
    """x = cm0 u + cm1 v + cm2 a, y = cc0 u + cc1 v + cc2 a (numpy's order)."""
    for i in range(u.size):
        x[i] = cm[0] * u[i] + cm[1] * v[i] + cm[2] * a[i]
        y[i] = cc[0] * u[i] + cc[1] * v[i] + cc[2] * a[i]


@njit(cache=True)
def _rhs_combine(om, oc, c, f, rhs):
    """rhs = (M x + c C y) + f (numpy's order)."""
    for i in range(rhs.size):
        rhs[i] = (om[i] + c * oc[i]) + f[i]


@njit(cache=True)
def _newmark_update(u, u0, v0, a0, c0, c2, c3, h, g1, g2, v_new, a_new):
    """a_new = c0 (u - u0) - c2 v0 - c3 a0, v_new = v0 + h (g1 a0 + g2 a_new) in one pass,
    bitwise numpy's expressions (the same operations in the same order)."""
    for i in range(u.size):
        an = (c0 * (u[i] - u0[i]) - c2 * v0[i]) - c3 * a0[i]
        a_new[i] = an
        v_new[i] = v0[i] + h * (g1 * a0[i] + g2 * an)


@njit(cache=True)
def _phi_mask_kernel(phi, g, k0v, tol, out):
    """out[p] = |phi| > tol (k0 |g|) + 1e-300 at either gap component of point p (the same
    expression, hence the same booleans, as numpy's)."""
    for p in range(out.size):
        a = abs(phi[2 * p]) > tol * (k0v[2 * p] * abs(g[2 * p])) + 1e-300
        b = abs(phi[2 * p + 1]) > tol * (k0v[2 * p + 1] * abs(g[2 * p + 1])) + 1e-300
        out[p] = a or b


@njit(cache=True)
def _csr_mv(indptr, indices, data, x, out):
    """out = A x for A in CSR (indptr, indices, data)."""
    for i in range(out.shape[0]):
        acc = 0.0
        for q in range(indptr[i], indptr[i + 1]):
            acc += data[q] * x[indices[q]]
        out[i] = acc


def _mv(A, x):
    """A @ x for a scipy CSR matrix and a 1-D float vector, without scipy's per-call dispatch
    (~15 us; the interface products of a Newton iteration are a few microseconds of work)."""
    out = np.empty(A.shape[0])
    _csr_mv(A.indptr, A.indices, A.data, x, out)
    return out


@njit(cache=True)
def _ptp_pairs(Gp, npts):
    """Every (point, a, b, q1, q2) with q1 in row 2 point + a and q2 in row 2 point + b of G
    (CSR row pointer Gp): the terms of G^T Dw G for block-diagonal Dw."""
    cnt = 0
    for pt in range(npts):
        for a in range(2):
            for b in range(2):
                cnt += (Gp[2 * pt + a + 1] - Gp[2 * pt + a]) * (Gp[2 * pt + b + 1] - Gp[2 * pt + b])
    PT = np.empty(cnt, np.int64)
    A = np.empty(cnt, np.int64)
    B = np.empty(cnt, np.int64)
    Q1 = np.empty(cnt, np.int64)
    Q2 = np.empty(cnt, np.int64)
    k = 0
    for pt in range(npts):
        for a in range(2):
            for b in range(2):
                for q1 in range(Gp[2 * pt + a], Gp[2 * pt + a + 1]):
                    for q2 in range(Gp[2 * pt + b], Gp[2 * pt + b + 1]):
                        PT[k] = pt
                        A[k] = a
                        B[k] = b
                        Q1[k] = q1
                        Q2[k] = q2
                        k += 1
    return PT, A, B, Q1, Q2


@njit(cache=True)
def _jac_setup(E, cw, b, PT, A, B, Q1, Q2, pos, Gx, GTp, GTi, GTx, Pout, tmp, v):
    """The data of one interface Newton system in one call: with Dw = E * cw[:, None, None]
    (the (npts, 2, 2) blocks c w_p (T_p - K0), formed on the fly), Pout = the values of
    G^T Dw G on its pattern (``_ptp_pairs`` and positions ``pos``), tmp = Dw b (blockwise),
    v = G^T tmp (CSR rows summed in order, as ``_csr_mv``)."""
    for k in range(Pout.shape[0]):
        Pout[k] = 0.0
    for k in range(PT.shape[0]):
        p = PT[k]
        Pout[pos[k]] += Gx[Q1[k]] * (E[p, A[k], B[k]] * cw[p]) * Gx[Q2[k]]
    for p in range(E.shape[0]):
        b0 = b[2 * p]
        b1 = b[2 * p + 1]
        tmp[2 * p] = (E[p, 0, 0] * cw[p]) * b0 + (E[p, 0, 1] * cw[p]) * b1
        tmp[2 * p + 1] = (E[p, 1, 0] * cw[p]) * b0 + (E[p, 1, 1] * cw[p]) * b1
    for i in range(v.shape[0]):
        acc = 0.0
        for q in range(GTp[i], GTp[i + 1]):
            acc += GTx[q] * tmp[GTi[q]]
        v[i] = acc


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
    event_cuts  : converged attempts redone with half the sub-step because a sliding joint
                  stopped or reversed inside them (friction events, ``NewmarkSolver.step``)
    relax_steps : static only: dynamic steps of the relaxations at a limit load
                  (``NewmarkSolver._relax``), one entry per relaxation
    n_active    : number of points not in their initial elastic state at the end
    wall        : wall time of the call [s]
    """
    iterations: int = 0
    iterations_failed: int = 0
    cuts: int = 0
    dts: list = field(default_factory=list)
    iters_per_substep: list = field(default_factory=list)
    residuals: list = field(default_factory=list)
    event_cuts: int = 0
    relax_steps: list = field(default_factory=list)
    n_active: int = 0
    wall: float = 0.0

    def accepted(self, res, h=None):
        """Book a converged attempt ``res`` (the Newton result tuple) of sub-step h."""
        self.iterations += res[7]
        self.iters_per_substep.append(res[7])
        self.residuals.append(res[8])
        if h is not None:
            self.dts.append(h)

    def rejected(self, res):
        """Book an attempt that did not converge (its sub-step is cut)."""
        self.iterations_failed += res[7]
        self.cuts += 1


def _relative_dofs(BI):
    """B_I = G Delta with Delta the relative displacements of the interface DOFs.

    A matching interface has every DOF of a dam-side node paired with one of the coincident
    rock-side node whose column of B is exactly its negative (g = B (u_dam - u_rock)): then
    Delta = E_dam^T - E_rock^T (r = |I| / 2 rows) and G = B_I[:, dam], exactly (no round-off).
    Otherwise (non-matching interfaces) Delta = identity, G = B_I.  Returns (G csr, Delta^T csr).
    """
    C = sp.csc_matrix(BI)
    C.sort_indices()
    m = C.shape[1]
    groups = {}
    for j in range(m):
        sl = slice(C.indptr[j], C.indptr[j + 1])
        groups.setdefault(C.indices[sl].tobytes(), []).append(j)
    pos, neg = [], []
    for js in groups.values():
        if len(js) != 2:
            break
        a, b = js
        va = C.data[C.indptr[a]:C.indptr[a + 1]]
        vb = C.data[C.indptr[b]:C.indptr[b + 1]]
        if va.size == 0 or not np.array_equal(va, -vb):
            break
        pos.append(a)
        neg.append(b)
    else:
        if 2 * len(pos) == m:
            r = len(pos)
            Dt = sp.csr_matrix((np.r_[np.ones(r), -np.ones(r)], (np.r_[pos, neg],
                                np.r_[np.arange(r), np.arange(r)])), shape=(m, r))
            return C[:, pos].tocsr(), Dt
    return sp.csr_matrix(BI), sp.identity(m, format="csr")


@dataclass
class _Cache:
    """Per-step-size data of the condensed method."""
    factor: SparseFactor
    Y: np.ndarray | None = None          # (r, r) Delta (A^-1)_II Delta^T, S = G Y G^T
    Yinv: np.ndarray | None = None       # Y^-1 (symmetric): the Newton system is Y^-1 + P
    Z: dict = field(default_factory=dict)  # point -> (ndof, 2) A^-1 B_p^T (few active points)
    jac_lu: tuple | None = None          # (LU^T, pivots, P values) of the last Y^-1 + P factorised
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
    stall_iterations : m > 0: a dynamic attempt is also cut when the best residual of its last
              m iterations is not below half the best before them (Newton cycling between
              active sets; ``stalled``); 0: only ``max_iter`` cuts
    min_dt  : smallest sub-step; below it SolverError is raised (default dt / 2**10)
    method  : "condensed" (default) or "full" (re-factorising reference)
    line_search : backtracking on the residual norm
    max_cache : number of step sizes whose factorisation/S columns are kept
    few_max : up to this many active points u_lin is formed whole and u recovered from cached
              columns A^-1 B_p^T (one solve per step, as a linear step); more: split solve
    jacobian_reuse : solve the r x r Newton system by GMRES preconditioned with the LU of the
              last one factorised (same step size) when that converges in a few iterations;
              else factorise (the direction is the same to round-off: relative residual 1e-13)
    """

    def __init__(self, K, M, C, B, w, law, *, dt, beta=None, gamma=None, alpha_hht=0.0,
                 integrator=None, tol_residual=1e-8, tol_energy=1e-16, max_iter=25,
                 stall_iterations=0, min_dt=None, method="condensed", line_search=True, max_cache=6,
                 active_tol=1e-12, few_max=16, jacobian_reuse=True, C_lowrank=None,
                 event_levels=3):
        if method not in ("condensed", "full"):
            raise ValueError(f"NewmarkSolver method = {method!r} is not allowed; allowed: "
                             "'condensed', 'full'")
        if not (-1.0 / 3.0 - 1e-12 <= alpha_hht <= 0.0):
            raise ValueError(f"NewmarkSolver alpha_hht = {alpha_hht!r} is not allowed; "
                             "allowed: [-1/3, 0]")
        if integrator is None:          # Newmark (beta, gamma) or HHT by its alpha
            integrator = Integrator(
                "newmark" if alpha_hht == 0.0 else "hht",
                float(beta if beta is not None else (1.0 - alpha_hht) ** 2 / 4.0),
                float(gamma if gamma is not None else 0.5 - alpha_hht), -float(alpha_hht))
        elif beta is not None or gamma is not None or alpha_hht != 0.0:
            raise ValueError("NewmarkSolver: give either integrator or beta/gamma/alpha_hht")
        self.integrator = integrator
        # friction events (a sliding joint that stops or reverses) are localised in time by
        # halving the sub-step up to event_levels times (``step``); 0: off
        self.event_levels = int(event_levels)
        self._slip_sign = None                 # sign of each point's last plastic slip step
        # the dense low-rank part of the damping matrix, C = C + a0 U W U^T (solve/damping.py)
        self.C_lowrank = C_lowrank
        self._P = C_lowrank                  # None or a DeformationDamping
        if self._P is not None and (C is None or method != "condensed"):
            raise ValueError("NewmarkSolver: C_lowrank needs a sparse damping matrix C and the "
                             "condensed method")
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
        self.alpha_hht = -integrator.alpha_f          # Hilber et al.'s sign convention
        self.alpha_m = integrator.alpha_m
        self.beta = integrator.beta
        self.gamma = integrator.gamma
        self.dt = float(dt)
        self.tol_residual = float(tol_residual)
        self.tol_energy = float(tol_energy)
        self.max_iter = int(max_iter)
        self.stall_iterations = int(stall_iterations)
        self._stall = 0                      # the rule's m for the attempt under way
        self._rhist = []                     # its residuals so far
        self.min_dt = float(min_dt) if min_dt is not None else self.dt / 2 ** 10
        self.method = method
        self.line_search = bool(line_search)
        self.max_cache = int(max_cache)
        self.few_max = int(few_max)
        self.active_tol = float(active_tol)
        self.jacobian_reuse = bool(jacobian_reuse)
        self.stats = dict(jacobian_factorisations=0, jacobian_solves=0, jacobian_reuses=0,
                          gmres_iterations=0)
        # callables fn(solver, h, iterations) run after every commit (h None: a static one):
        # studies observe the accepted sub-steps without touching the solver (unzip study)
        self.commit_observers = []
        self.law = law
        self._set_k0(law)
        self._wd = np.repeat(self.w, 2)                     # W on the (2 npts) gap vector
        # the gap is g = B u + g_offset: g_offset is zero until a sliding joint is re-paired
        # (``set_operator``), which keeps g continuous across the new pairing
        self.g_offset = None
        self._f_off = None
        self._set_interface_dofs()
        self._ptp = self._ptp_of = self._ptp_map = None   # G^T Dw G pattern (_ptp_pattern)
        self._ptp_flat = None
        self._gmres_wk = None
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
        # M x and C y of the right-hand side in one compiled pass (bitwise scipy's products);
        # K on the same pattern for ``step_products5`` (the energy budget's K u, M v)
        self._mc = FusedPair(self.M, self.C, self.K) if self.C is not None else None
        self._rhs_work = None
        self._rhs_next = None            # (h, u, v, a, M x, C y[, K u, C v]) of step_products

    # ------------------------------------------------------------------ set-up / parameters
    def _set_interface_dofs(self):
        """The interface DOFs I of B and the relative-DOF structure B_I = G Delta."""
        self._Idofs = np.unique(self.B.indices)               # DOFs the interface touches
        self._BI = self.B[:, self._Idofs].tocsr()            # (2 npts, |I|)
        self._BIT = self._BI.T.tocsr()
        # B_I = G Delta: Delta^T (|I| x r), G (2 npts x r) sparse; S = G (Delta X Delta^T) G^T
        self._G, self._Dt = _relative_dofs(self._BI)
        self._GT = self._G.T.tocsr()

    def set_operator(self, B, g_offset=None):
        """Replace the gap operator between steps (a sliding joint paired anew with the face
        below it: finite sliding, run/sliding): g = B u + g_offset. The offset that keeps the
        committed gap is formed here when ``g_offset`` is None: g_offset = g_n - B u_n. The
        effective matrices are factorised anew (they hold B^T W K0 B)."""
        B = sp.csr_matrix(B)
        if B.shape != self.B.shape:
            raise ValueError(f"set_operator: B of shape {B.shape}, expected {self.B.shape}")
        if g_offset is None:
            g_offset = self.g.ravel() - B @ self.u
        self.B = B
        self.BT = B.T.tocsr()
        self.g_offset = np.asarray(g_offset, dtype=np.float64).copy()
        self._set_interface_dofs()
        self._BtWK0B = (self.BT @ sp.diags(self._k0v * np.repeat(self.w, 2)) @ self.B).tocsr()
        self._set_offset_force()
        self._cache.clear()
        self._static_cache = None

    def set_offset(self, g_offset):
        """Replace the gap's offset with B kept (no refactorisation): g = B u + g_offset. The
        finite-rotation kinematics (run/rotation) add the exact rigid rotation's part of the
        gap that B u linearises, once per step."""
        self.g_offset = np.asarray(g_offset, dtype=np.float64).copy()
        self._set_offset_force()

    def _set_offset_force(self):
        """f_off = B^T W K0 g_offset: the part of the interface's elastic force K0 g that the
        factorised matrix (which holds B^T W K0 B, acting on B u only) does not produce once the
        gap has an offset. The condensed equations subtract c f_off from the right-hand side
        (``_attempt``): A u = rhs - c B^T W (phi + K0 g_offset), phi = t - K0 g. Without it a
        re-paired joint carried a spurious traction K0 g_offset at every point: ~1e6 Pa for
        the 1e-5 m offsets of a continuous re-pairing, and 9e10 Pa at a point that slid off
        its face (its offset opens it by 1 m): the energy of koyna_1967's 3.642 s jump
        (docs/solver.md §2.7)."""
        if self.g_offset is None:
            self._f_off = None
            return
        self._f_off = self.BT @ (self._wd * self._k0v * self.g_offset)

    def _gap(self, u):
        """g = B u (+ g_offset) as a flat (2 npts) vector."""
        g = self.B @ u
        if self.g_offset is not None:
            g += self.g_offset
        return g

    def _set_k0(self, law, debonded=None):
        # (npts, 2): k_N, k_T per point (a cracked point: the contact and stick stiffness)
        self.k0p = initial_stiffness(law, self.npts, debonded)
        self.k0 = self.k0p.max(axis=0)
        self._k0v = self.k0p.ravel()
        self._k0blk = np.zeros((self.npts, 2, 2))
        self._k0blk[:, 0, 0] = self.k0p[:, 0]
        self._k0blk[:, 1, 1] = self.k0p[:, 1]
        self._gref = reference_gap(law) * 1e-3 * math.sqrt(self.npts)
        self._BtWK0B = (self.BT @ sp.diags(self._k0v * np.repeat(self.w, 2)) @ self.B).tocsr()
        if getattr(self, "g_offset", None) is not None:
            self._set_offset_force()

    def set_state(self, state):
        """Set the committed interface state before the first solve (e.g. joints that start
        cracked) and take the elastic stiffness K0 of the factorised matrix from it: the
        contact and stick stiffness at cracked points, so that a compressed, sticking cracked
        joint is linear in the condensed Newton (no active points)."""
        self.state = state
        self._set_k0(self.law, np.asarray(state.debonded, bool))
        self._cache.clear()
        self._static_cache = None

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
        STATIC_DURATION (docs/solver.md §7)."""
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
        g = self._gap(self.u).reshape(-1, 2)
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
            r -= self._Cmul(self.v)
        self.a = self._Minv.solve(r)
        self._Minv = None                # used once per run: not kept (memory, #15)
        self.f = np.array(f, dtype=float)
        return self.a

    # ------------------------------------------------------------------ helpers
    def _fint(self, t):
        return self.BT @ (self._wd * t.ravel())

    def _coeffs(self, h):
        return self.integrator.coefficients(h)

    def _Cmul(self, y):
        """C y, with the low-rank part of C when there is one."""
        out = self.C @ y
        if self._P is not None:
            out += self._P.product(y)
        return out

    def _A_lin(self, h):
        """c0 M + c (K + c1 C) (no interface) for step size h; None -> static K."""
        if h is None:
            return self.K
        c0, c1 = self._coeffs(h)[:2]
        c = 1.0 + self.alpha_hht
        A = (c0 * (1.0 - self.alpha_m) if self.alpha_m else c0) * self.M + c * self.K
        if self.C is not None:
            A = A + (c * c1) * self.C
        if getattr(self, "ext", None) is not None:     # compressible water (solve/fluid.py)
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
            F = SparseFactor(self._A_lin(h) + c * self._BtWK0B).restrict(self._Idofs)
            if self._P is not None:          # A = A_s + c c1 a0 U W U^T (Woodbury)
                c1 = self._coeffs(h)[1]
                lo = self._P
                F = LowRankFactor(F, lo.U, (c * c1 * lo.a0) * lo.W, self._Idofs)
            e = _Cache(F, base=abs(h - self.dt) <= 1e-12 * self.dt)
            self._cache[key] = e
            while len(self._cache) > self.max_cache:      # evict the LRU sub-step entry
                old = next((k for k, v in self._cache.items() if not v.base),
                           next(iter(self._cache)))
                self._cache.pop(old)
        else:
            self._cache.move_to_end(key)
        return e

    def _ensure_Y(self, e: _Cache):
        """Y = Delta (A^-1)_II Delta^T (r x r), once per step size: partial solves with
        right-hand sides and wanted entries on the interface DOFs only (SparseFactor.restrict),
        r of them (one per relative interface DOF), in blocks (bounded work memory)."""
        if e.Y is not None:
            return
        Dt = self._Dt
        r = Dt.shape[1]
        XD = np.empty((Dt.shape[0], r))
        for k in range(0, r, 128):
            XD[:, k:k + 128] = e.factor.solve_at(Dt[:, k:k + 128].toarray())
        Y = np.asarray(Dt.T @ XD)
        e.Y = 0.5 * (Y + Y.T)                             # symmetric to round-off
        try:                                              # SPD (A is): Cholesky
            Yi = sla.cho_solve(sla.cho_factor(e.Y), np.eye(r))
        except np.linalg.LinAlgError:
            Yi = np.linalg.inv(e.Y)
        e.Yinv = np.ascontiguousarray(0.5 * (Yi + Yi.T))

    def _phi_mask(self, phi, g):
        """Points whose correction phi is not round-off of K0 g."""
        out = np.empty(self.npts, np.bool_)
        _phi_mask_kernel(phi, g, self._k0v, self.active_tol, out)
        return out

    def _rhs(self, h, f_next):
        """Effective right-hand side of the step of size h ending with load f_next."""
        c0, c1, c2, c3, c4, c5 = self._coeffs(h)
        al = self.alpha_hht
        c = 1.0 + al
        if self._mc is not None and al == 0.0 and self.alpha_m == 0.0:
            mc = self._mc
            rhs = np.empty(self.ndof)
            f = np.ascontiguousarray(f_next, dtype=np.float64)
            nx = self._rhs_next
            if (nx is not None and len(nx) == 6 and nx[0] == h and nx[1] is self.u
                    and nx[2] is self.v and nx[3] is self.a):     # formed by step_products
                _rhs_combine(nx[4], nx[5], c, f, rhs)
            else:
                if self._rhs_work is None:
                    self._rhs_work = np.empty((4, self.ndof))
                x, y, om, oc = self._rhs_work
                if self._P is None:
                    _rhs_fused(mc.indptr, mc.indices, mc.Ax, mc.Bx, self.u, self.v, self.a,
                               np.array([c0, c2, c3]), np.array([c1, c4, c5]), c, f, x, y,
                               om, oc, rhs)
                else:                             # C y = C_s y + a0 U W U^T y
                    _rhs_vectors(self.u, self.v, self.a, np.array([c0, c2, c3]),
                                 np.array([c1, c4, c5]), x, y)
                    pair_products(mc.indptr, mc.indices, mc.Ax, mc.Bx, x, y, om, oc)
                    oc += self._P.product(y)
                    _rhs_combine(om, oc, c, f, rhs)
            if getattr(self, "ext", None) is not None:
                rhs += self.ext.rhs(h)
            return rhs
        if self._mc is not None:          # HHT / generalized alpha: the products in one pass
            nx = self._rhs_next
            if (nx is not None and len(nx) == 8 and nx[0] == h and nx[1] is self.u
                    and nx[2] is self.v and nx[3] is self.a):      # formed by step_products
                Mx, Cy, Ku, Cv = nx[4:]
            else:
                Ku, _, Mx, Cy, Cv = self._products_alpha(h)
            af = -al
            f_n = self.f if self.f is not None else f_next
            r_n = Ku + self._fint(self.t) + Cv
            rhs = Mx + c * Cy + (c * f_next + af * f_n) - af * r_n
            if getattr(self, "ext", None) is not None:
                rhs += self.ext.rhs(h)
            return rhs
        am = self.alpha_m
        if am == 0.0:
            rhs = self.M @ (c0 * self.u + c2 * self.v + c3 * self.a)
        else:       # (1 - am) M a_{n+1} + am M a_n with a_{n+1} = c0 du - c2 v - c3 a
            rhs = self.M @ ((1.0 - am) * (c0 * self.u + c2 * self.v + c3 * self.a)
                            - am * self.a)
        if self.C is not None:
            rhs += c * self._Cmul(c1 * self.u + c4 * self.v + c5 * self.a)
        if al != 0.0:
            f_n = self.f if self.f is not None else f_next
            rhs += c * f_next - al * f_n
            r_n = self.K @ self.u + self._fint(self.t)
            if self.C is not None:
                r_n += self._Cmul(self.v)
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
        if self._stall:
            if it == 0:
                self._rhist = []
            self._rhist.append(rnorm)
            if self.stalled(self._rhist, self._stall):
                return False
        return None

    @staticmethod
    def stalled(hist, m) -> bool:
        """The best of the last m residuals is not below half the best before them. The
        attempts that fail on the Koyna scenes cycle between active sets with the residual
        stuck above tolerance (e.g. 10^-3.7 ... 10^-3.9 repeating); none of the attempts that
        converged there (up to 13 iterations) meets the rule with m = 6 (docs/solver.md §4)."""
        k = len(hist)
        if k <= m + 1:
            return False
        return min(hist[k - m:]) > 0.5 * min(hist[:k - m])

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
        # With no or few (<= few_max) active points the whole u_lin is formed (one solve) and
        # u is recovered from cached columns A^-1 B_p^T of the active points (e.Z).
        z_lin = e.factor.forward(rhs)
        if int(self._active.sum()) > self.few_max:
            u_lin = None
            g_lin = _mv(self._BI, e.factor.backward_at(z_lin))
            if self.g_offset is not None:
                g_lin += self.g_offset
        else:
            u_lin = e.factor.backward(z_lin)
            g_lin = self._gap(u_lin)
        wd, k0v = self._wd, self._k0v
        n2 = 2 * self.npts
        act = self._active.copy()
        ad = self._dof_idx(np.flatnonzero(act))
        if ad.size:
            self._ensure_Y(e)
        G = self._G

        def Smul(ad, y):
            """S[:, ad] @ y = G Y G^T (y scattered on ad): never forms S (2 npts x 2 npts)."""
            if ad.size == n2:                 # every point active (ad = 0 .. n2-1): no scatter
                yp = y
            else:
                yp = np.zeros(n2)
                yp[ad] = y
            return _mv(self._G, e.Y @ _mv(self._GT, yp))  # r^2 + nnz(G), not 2 npts r

        def wphi(ad, phi):
            """(W phi)[ad] (the whole vector when every point is active)."""
            return wd * phi if ad.size == n2 else wd[ad] * phi[ad]

        g = g_lin - c * Smul(ad, wphi(ad, self._phi)) if ad.size else g_lin.copy()
        # the residual's scale is fixed for the attempt (the linear predictor, the committed
        # gap, the law's elastic opening): relative to the iterate's own norm a runaway slip
        # of a sliding joint would make any residual look small
        gscale = max(np.linalg.norm(g_lin), np.linalg.norm(self.g), self._gref)

        def resid(g, act, ad):
            t, T, new = law.evaluate(g.reshape(-1, 2), state, dt=self._law_dt(h))
            phi = t.ravel() - k0v * g
            newly = ~act & self._phi_mask(phi, g)
            if newly.any():
                act = act | newly
                self._ensure_Y(e)
                ad = self._dof_idx(np.flatnonzero(act))
            R = g - g_lin
            if ad.size:
                R += c * Smul(ad, wphi(ad, phi))
            return t, T, new, phi, R, act, ad

        try:
            t, T, new, phi, R, act, ad = resid(g, act, ad)
        except (ValueError, FloatingPointError):
            return (False,) + (None,) * 6 + (0, np.inf)
        rnorm = np.linalg.norm(R) / gscale
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
            # exact Newton direction on all gaps: (I + c S W E) dg = -R, E = T - K0 at the
            # active points (0 elsewhere), through the r x r system of the relative interface
            # DOFs (``_jac_solve``)
            E = T - self._k0blk
            E[~act] = 0.0
            try:
                dg = self._jac_solve(e, E, -R, c, ad)
            except (np.linalg.LinAlgError, ValueError):
                return (False,) + (None,) * 6 + (it, rnorm)
            en = abs(np.dot(dg, wd * k0v * R))
            if energy0 is None:
                energy0 = max(en, 1e-300)
            # backtracking line search on the residual norm
            def trial(x):
                o = resid(x, act, ad)
                return o, np.linalg.norm(o[4]) / gscale

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
        pa = ad[0::2] // 2
        if not ad.size:
            u = u_lin if u_lin is not None else e.factor.backward(z_lin)
        elif u_lin is not None and pa.size <= self.few_max:
            new_p = [p for p in pa.tolist() if p not in e.Z]
            if new_p:
                nd = self._dof_idx(np.asarray(new_p, np.int64))
                Zn = e.factor.solve(self.BT[:, nd].toarray())
                for q, p in enumerate(new_p):
                    e.Z[p] = Zn[:, 2 * q:2 * q + 2]
            Za = np.hstack([e.Z[p] for p in pa.tolist()])
            u = u_lin - c * (Za @ (wd[ad] * phi[ad]))
        elif u_lin is not None:
            u = u_lin - c * e.factor.backward(e.factor.forward_sparse(_mv(self._BIT, wd * phia)))
        else:
            u = e.factor.backward(z_lin - c * e.factor.forward_sparse(_mv(self._BIT, wd * phia)))
        return True, u, g, t, new, phia, act, it, rnorm

    def _jac_solve(self, e, E, b, c, ad):
        """Solve J x = b, J = I + S Dw the exact Jacobian of the gap residual (Dw = blockdiag
        c w_p E_p, E = T - K0, zero at inactive points), with S = G Y G^T of rank r (the
        relative displacements of the interface nodes, r = 224 on the default Koyna mesh,
        whatever the number of interface points):

            J^-1 b = b - G Y K^-1 G^T Dw b = b - G H^-1 G^T Dw b,
            K = I_r + P Y,   H = K Y^-1 = Y^-1 + P,   P = G^T Dw G   (r x r)

        (push-through identity, exact). P is sparse and H is Y^-1 (kept per step size) plus P:
        nothing of size (2 npts)^2, and no r x r product. H^-1 v: with ``jacobian_reuse``
        GMRES preconditioned by the LU of the last H factorised for this step size (an
        earlier iteration or step) is tried first, to the true relative residual
        ``_GMRES_TOL`` (round-off of a direct solve) in at most ``_GMRES_MAX`` iterations;
        otherwise H is factorised afresh (solve/krylov.py).
        Few active points (4 m < r, the 2 m gap DOFs ``ad``): the same identity on their
        columns, J^-1 b = b - S_:a (I + Dw_a S_aa)^-1 Dw_a b_a with S_:a = G Y G_a^T (2m x 2m
        system, formed and factorised at every call). Above r / 4 the r x r system with its
        reused LU is cheaper (111 Koyna points, 2 m = 222, r = 224: 7.2 -> 4.0 ms per step,
        measured; it was used up to 2 m < r)."""
        self.stats["jacobian_solves"] += 1
        if 2 * ad.size < e.Y.shape[0]:
            Sa = self._G @ (e.Y @ self._GT[:, ad].toarray())       # (2 npts, 2m)
            m = ad.size // 2
            pa = ad[0::2] // 2
            Dw = E[pa] * (c * self.w[pa])[:, None, None]          # (m, 2, 2)
            C = np.einsum("pij,pjk->pik", Dw, Sa[ad].reshape(m, 2, ad.size)).reshape(
                ad.size, ad.size)
            C[np.diag_indices_from(C)] += 1.0
            z = np.linalg.solve(C, np.einsum("pij,pj->pi", Dw, b[ad].reshape(m, 2)).ravel())
            self.stats["jacobian_factorisations"] += 1
            x = b - Sa @ z
            if not np.all(np.isfinite(x)):
                raise np.linalg.LinAlgError("interface Jacobian: non-finite solution")
            return x
        # Dw = E c w (npts, 2, 2); P = G^T Dw G sparse (r x r, banded; its values scattered by
        # a map built once); v = G^T Dw b: one compiled call (``_jac_setup``)
        P = self._ptp_pattern()
        GT = self._GT
        r = GT.shape[0]
        v = np.empty(r)
        _jac_setup(E, c * self.w, b, *self._ptp_map, self._G.data, GT.indptr, GT.indices,
                   GT.data, P.data, np.empty(2 * self.npts), v)
        z = np.empty(r)
        ok = False
        if self.jacobian_reuse and e.jac_lu is not None:
            luT, piv, p0 = e.jac_lu
            wk = self._gmres_work(r)
            its = gmres_lu(luT, piv, e.Yinv, P.indptr, P.indices, P.data, p0, v, _GMRES_TOL,
                           _GMRES_MAX, z, *wk)
            if its >= 0:
                ok = True
                self.stats["jacobian_reuses"] += 1
                self.stats["gmres_iterations"] += its
                if its > _GMRES_REFRESH:                   # the next solve factorises
                    e.jac_lu = None
        if not ok:
            H = e.Yinv.copy()
            H.ravel()[self._ptp_flat] += P.data
            lu, piv, info = sla.lapack.dgetrf(H, overwrite_a=True)
            if info != 0:
                raise np.linalg.LinAlgError(f"interface Jacobian singular (dgetrf info {info})")
            self.stats["jacobian_factorisations"] += 1
            e.jac_lu = (np.ascontiguousarray(lu.T), piv.astype(np.int32), P.data.copy())
            lu_solve_into(e.jac_lu[0], e.jac_lu[1], v, z)
        x = b - _mv(self._G, z)
        if not np.all(np.isfinite(x)):
            raise np.linalg.LinAlgError("interface Jacobian: non-finite solution")
        return x

    def _gmres_work(self, r):
        """GMRES work arrays for an r x r system (allocated once; the kernel only writes)."""
        wk = self._gmres_wk
        if wk is None or wk[-1].shape[0] != r:
            m = _GMRES_MAX
            wk = (np.empty((m + 1, r)), np.empty((m, r)), np.empty((m + 1, m)), np.empty(m),
                  np.empty(m), np.empty(m + 1), np.empty(r))
            self._gmres_wk = wk
        return wk

    def _ptp_pattern(self):
        """The (r x r) CSR pattern of G^T Dw G for block-diagonal Dw, and the map that scatters
        G_pa Dw_p,ab G_pb into its values (built once)."""
        if self._ptp is None or self._ptp_of is not self._G:
            G = self._G
            r = G.shape[1]
            PT, A, Bk, Q1, Q2 = _ptp_pairs(G.indptr.astype(np.int64), self.npts)
            rows, cols = G.indices[Q1], G.indices[Q2]
            P = sp.csr_matrix((np.ones(rows.size), (rows, cols)), shape=(r, r))
            P.sum_duplicates()
            P.sort_indices()
            prow = np.repeat(np.arange(r), np.diff(P.indptr))
            pos = np.searchsorted(prow.astype(np.int64) * r + P.indices,
                                  rows.astype(np.int64) * r + cols)
            self._ptp, self._ptp_of = P, G
            # unsigned (no negative-index test in ``_jac_setup``'s loops)
            self._ptp_map = tuple(x.astype(np.uint32) for x in (PT, A, Bk, Q1, Q2, pos))
            self._ptp_flat = prow.astype(np.int64) * r + P.indices   # positions in r x r
        return self._ptp

    def _newton_full(self, h, rhs, c):
        law, state = self.law, self.state
        A_lin = self._A_lin(h)
        wd = self._wd
        # start from the last converged displacement
        u = self.u.copy()
        fscale = max(np.linalg.norm(rhs), 1e-300)

        def resid(u):
            g = self._gap(u)
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
        self._stall = 0 if h is None else self.stall_iterations    # not in static solves
        rhs = f_next if h is None else self._rhs(h, f_next)
        with np.errstate(all="ignore"):
            if self.method == "condensed":
                if self._f_off is not None:        # the gap's offset (``_set_offset_force``)
                    rhs = rhs - c * self._f_off
                return self._newton_condensed(h, rhs, c)
            return self._newton_full(h, rhs, c)

    def _commit(self, h, f_next, res):
        _, u, g, t, new, phi, act, it, rnorm = res
        if h is not None:
            c0, c1, c2, c3, c4, c5 = self._coeffs(h)
            v_new, a_new = np.empty(self.ndof), np.empty(self.ndof)
            _newmark_update(u, self.u, self.v, self.a, c0, c2, c3, h, 1.0 - self.gamma,
                            self.gamma, v_new, a_new)
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
        for fn in self.commit_observers:
            fn(self, h, it)

    # ------------------------------------------------------------------ public steps
    def static(self, f, relax: bool = True) -> StepReport:
        """Solve K u + B^T W t(B u) = f from the committed state (dead load + reservoir);
        commits u, the interface state; sets v = a = 0 and the current load to f.
        relax=False: no damped dynamics at a limit load (``_relax``): the solve fails there."""
        t0 = time.perf_counter()
        rep = StepReport()
        f = np.asarray(f, dtype=float)
        # the load in one increment; if that does not converge, by continuation: the load
        # path from the committed load f0 to f in increments, halved on failure and grown back
        # (the friction of a cracked joint is path dependent: the path is the proportional
        # application of the static loads)
        f0 = self.f if self.f is not None else np.zeros_like(f)
        pos, hf = Fraction(0), Fraction(1)
        last = None
        while pos < 1:
            hf = min(hf, 1 - pos)
            end = pos + hf
            fe = f if end == 1 else f0 + float(end) * (f - f0)
            res = self._attempt(None, fe)
            last = res
            if res[0]:
                self._commit(None, fe, res)
                rep.accepted(res)
                pos = end
                if hf < 1 and pos % (2 * hf) == 0:
                    hf *= 2
            else:
                rep.rejected(res)
                hf /= 2
                if hf < Fraction(1, 2 ** 10):
                    # no equilibrium next to the committed one, even 1/1024 of the load on:
                    # a limit load (a crack tip at its peak traction whose advance needs less
                    # load: the Jacobian's determinant changes sign across the peak kink). The
                    # crack runs at constant load: followed by damped dynamics at the load fe
                    # until the static solve from the moving state converges (``_relax``)
                    nrel = self._relax(fe) if relax else None
                    if relax and nrel is None and self.relax_runaway is not None:
                        slid, tr = self.relax_runaway
                        raise SolverError(
                            f"no static equilibrium: at {float(end):.4g} of the static load a "
                            f"joint slid {slid:.3g} m in {tr:.3g} s of damped motion at the held "
                            "load (friction and the bonded part left cannot hold the static "
                            "loads; the dam slides before the earthquake)")
                    if nrel is None:
                        raise SolverError(
                            f"static solve did not converge in {self.max_iter} iterations, "
                            f"even with the load in 1/1024 increments (relative residual "
                            f"{last[-1]:.3e})"
                            + (f", nor after {self.relax_max} steps of damped dynamics at the "
                               f"load {float(end):.6g} of the increment" if relax else "")
                            + " (no equilibrium found: can the joints hold the static loads?)")
                    rep.relax_steps.append(nrel)
                    pos = end
        self.v = np.zeros(self.ndof)
        self.a = np.zeros(self.ndof)
        rep.n_active = int(self._active.sum())
        rep.wall = time.perf_counter() - t0
        self.history.append(rep)
        return rep

    # static limit loads (``_relax``): at most this many dynamic steps of size dt per
    # relaxation, a static attempt from the moving state every relax_check steps
    relax_max = 5000
    relax_check = 25
    # a relaxation in which some point of a joint slides more than this has no equilibrium to
    # find (friction alone cannot hold the static loads: the dam slides off); it stops there
    # (0.05 m: the post-earthquake check's bound of small-displacement statics)
    relax_slip_max = 0.05

    def _relax(self, f):
        """Damped dynamics (the solver's own M, C, integrator and dt; no ground motion, no
        water stepper: ``ext`` is off) from the committed static state (at rest) under the
        constant load f, until a static attempt at f from the current state converges; that
        equilibrium is committed (v = a = 0, time and caches as before). Returns the number of
        dynamic steps, or None (nothing committed, the state before the call restored) when
        no static attempt converged within ``relax_max`` steps or a step failed."""
        saved = dict(u=self.u, v=self.v, a=self.a, f=self.f, time=self.time,
                     state=self.state, t=self.t, g=self.g, phi=self._phi, act=self._active,
                     slip_sign=self._slip_sign, cache=self._cache, scache=self._static_cache,
                     ext=getattr(self, "ext", None), nhist=len(self.history))
        self.ext = None
        self._cache = OrderedDict()          # the dynamic factorisations here lack the water
        self._rhs_next = None
        done = None
        self.relax_runaway = None
        g0 = np.asarray(self.g, float).reshape(-1, 2)[:, 1].copy()
        try:
            self.v = np.zeros(self.ndof)
            self._relax_start(f)
            for k in range(1, self.relax_max + 1):
                self.step(f)
                if k % self.relax_check == 0:
                    slid = float(np.abs(np.asarray(self.g).reshape(-1, 2)[:, 1] - g0).max())
                    if slid > self.relax_slip_max:
                        self.relax_runaway = (slid, k * self.dt)
                        break
                    res = self._attempt(None, f)
                    if res[0]:
                        self._commit(None, f, res)
                        done = k
                        break
        except SolverError:
            done = None
        finally:
            if done is None:
                self.u, self.v, self.a, self.f = (saved[k] for k in ("u", "v", "a", "f"))
                self.state, self.t, self.g = saved["state"], saved["t"], saved["g"]
                self._phi, self._active = saved["phi"], saved["act"]
            self.v = np.zeros(self.ndof)
            self.a = np.zeros(self.ndof)
            self.time = saved["time"]
            self._slip_sign = saved["slip_sign"]
            self._cache = saved["cache"]
            self._static_cache = saved["scache"]
            self.ext = saved["ext"]
            self._rhs_next = None
            del self.history[saved["nhist"]:]
        return done

    def _relax_start(self, f):
        """The start-up acceleration of a relaxation: M^-1 of the residual, or, when M vanishes
        on some DOFs (a massless rock block: M is singular), ``solve.massless`` on them; the
        damping's stiffness part acts there iff C has a diagonal on them (Rayleigh a1 > 0)."""
        from .massless import initial_acceleration, massless_dofs
        massless = massless_dofs(self.M)
        if not massless.any():
            self.initial_acceleration(f)
            return
        stiff = self.C is not None and bool(np.any(self.C.diagonal()[massless] != 0.0))
        initial_acceleration(self, f, massless, 1.0 if stiff else 0.0)

    def step(self, f_next, split: int = 0) -> StepReport:
        """Advance by dt to the load ``f_next``; on non-convergence the sub-step is halved and
        retried from the committed state (load interpolated linearly in time), sizes grow back
        after success.  Raises SolverError below ``min_dt`` (committed fields are then those at
        the last accepted sub-step, ``self.time`` tells where). split = k > 0: the step is
        taken in sub-steps of at most dt / 2^k (the retry of a step that the run's energy
        guard rejected, ``run.energy.EnergyGuard``); SolverError if dt / 2^k < ``min_dt``."""
        t0 = time.perf_counter()
        rep = StepReport()
        self._static_cache = None        # the static factorisation is not needed any more
        f_next = np.asarray(f_next, dtype=float)
        f_start = self.f if self.f is not None else f_next
        pos = Fraction(0)
        hmax = Fraction(1, 2 ** int(split))
        if self.dt * float(hmax) < self.min_dt * (1 - 1e-12):
            raise SolverError(f"step to t = {self.time + self.dt:.6g} s: a sub-step dt / "
                              f"2^{split} = {self.dt * float(hmax):.3g} s is below the minimum "
                              f"sub-step {self.min_dt:.3g} s; committed state is at "
                              f"t = {self.time:.6g} s")
        hf = hmax
        while pos < 1:
            hf = min(hf, 1 - pos)
            h = self.dt * float(hf)
            end = pos + hf
            fe = f_next if end == 1 else f_start + float(end) * (f_next - f_start)
            res = self._attempt(h, fe)
            if res[0] and self._friction_event(res[4], hf):
                rep.event_cuts += 1                 # redo the event with half the sub-step
                hf /= 2
                continue
            if res[0]:
                signs = self._slip_signs(res[4])
                self._commit(h, fe, res)
                self._slip_sign = signs
                rep.accepted(res, h)
                pos = end
                if hf < hmax and pos % (2 * hf) == 0:
                    hf *= 2
            else:
                rep.rejected(res)
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

    def _slip_signs(self, new):
        """Sign (-1, 0, 1) of each point's plastic slip increment from the committed state to
        ``new`` (0: stick, or no friction)."""
        d = new.slip[:, 0] - self.state.slip[:, 0]
        return np.sign(d).astype(np.int8)

    def _friction_event(self, new, hf) -> bool:
        """True when, in the attempt that ends in ``new``, most of the points that were sliding
        (weighted by w) stopped or reversed, and the sub-step can still be halved (at most
        ``event_levels`` times). Newmark-family schemes put a stick that starts inside a step at
        the step's end: the velocity the scheme then derives from the displacement is not the
        stopped block's (the trapezoidal rule reflects it, v_n+1 = 2 du/h - v_n ~ -v_n), an error
        ~ the block's deceleration times the step; halving localises the event to dt / 2^k
        (verification/sliding.py, docs/sliding.md)."""
        if (self.event_levels <= 0 or self._slip_sign is None
                or hf <= Fraction(1, 2 ** self.event_levels)):
            return False
        prev = self._slip_sign
        sliding = prev != 0
        if not sliding.any():
            return False
        now = self._slip_signs(new)
        changed = sliding & (now != prev)
        w = self.w
        return float(w[changed].sum()) > 0.5 * float(w[sliding].sum())

    def forget_jacobian(self):
        """Drop the LUs kept for ``jacobian_reuse`` (the only numbers carried from step to step
        besides the committed state). A run calls it after writing a checkpoint, so that a run
        resumed from that checkpoint (a fresh solver) and the uninterrupted run take the same
        Newton directions bit for bit."""
        for e in self._cache.values():
            e.jac_lu = None
        if self._static_cache is not None:
            self._static_cache.jac_lu = None

    def release_steps(self):
        """Drop the factorisations of the time-step sizes (the time loop is over): each is
        ~25 MB on the paper scene and a run with cuts holds up to ``max_cache`` of them; the
        static one (post-earthquake solve) is kept. A later ``step`` factorises anew."""
        self._cache.clear()

    # ------------------------------------------------------------------ diagnostics
    def step_products(self):
        """(K u, M v) of the committed state, bitwise scipy's ``K @ u`` and ``M @ v`` (the
        energy budget's products), or None when the solver has no damping matrix. The same
        compiled pass (``step_products5``) forms the right-hand-side products of a next step of
        size dt (M x, C y; with HHT / generalized alpha also K u + C v), which ``_rhs`` then
        takes instead of forming them (kept while u, v, a are the same arrays: the committed
        fields are replaced, never modified in place)."""
        if self._mc is None:
            return None
        if not self.integrator.plain:
            Ku, Mv, Mx, Cy, Cv = self._products_alpha(self.dt)
            self._rhs_next = (self.dt, self.u, self.v, self.a, Mx, Cy, Ku, Cv)
            return Ku, Mv
        mc = self._mc
        c0, c1, c2, c3, c4, c5 = self._coeffs(self.dt)
        if self._rhs_work is None:
            self._rhs_work = np.empty((4, self.ndof))
        x, y = self._rhs_work[0], self._rhs_work[1]
        _rhs_vectors(self.u, self.v, self.a, np.array([c0, c2, c3]), np.array([c1, c4, c5]),
                     x, y)
        Ku, Mv, Mx, Cy, Cv = (np.empty(self.ndof) for _ in range(5))
        # the generalized-alpha pass; Newmark's right-hand side does not use its C v (one sum
        # more per row: 0.23 against 0.22 ms on Koyna; the other four bitwise the same)
        step_products5(mc.indptr, mc.indices, mc.Ax, mc.Bx, mc.Cx, self.u, self.v, x, y, Ku,
                       Mv, Mx, Cy, Cv)
        if self._P is not None:
            Cy += self._P.product(y)
        self._rhs_next = (self.dt, self.u, self.v, self.a, Mx, Cy)
        return Ku, Mv

    def _products_alpha(self, h):
        """(K u, M v, M x, C y, C v) of the committed state for a step h of HHT / generalized
        alpha in one compiled pass: x = (1 - am)(c0 u + c2 v + c3 a) - am a (the inertia at the
        alpha_m point), y = c1 u + c4 v + c5 a; the low-rank damping part added to C y, C v."""
        mc = self._mc
        c0, c1, c2, c3, c4, c5 = self._coeffs(h)
        am = self.alpha_m
        cm = 1.0 - am
        if self._rhs_work is None:
            self._rhs_work = np.empty((4, self.ndof))
        x, y = self._rhs_work[0], self._rhs_work[1]
        _rhs_vectors(self.u, self.v, self.a, np.array([cm * c0, cm * c2, cm * c3 - am]),
                     np.array([c1, c4, c5]), x, y)
        Ku, Mv, Mx, Cy, Cv = (np.empty(self.ndof) for _ in range(5))
        step_products5(mc.indptr, mc.indices, mc.Ax, mc.Bx, mc.Cx, self.u, self.v, x, y, Ku,
                       Mv, Mx, Cy, Cv)
        if self._P is not None:
            Cy += self._P.product(y)
            Cv += self._P.product(self.v)
        return Ku, Mv, Mx, Cy, Cv

    def energy(self):
        """Kinetic + elastic (bulk + interface at K0) energy of the committed state; exact
        stored energy only while the interface is elastic."""
        kin = 0.5 * self.v @ (self.M @ self.v)
        el = 0.5 * self.u @ (self.K @ self.u)
        el += 0.5 * np.sum(self.w[:, None] * self.t * self.g)
        return kin + el

    # ------------------------------------------------------------------ public hooks
    # What other modules may use of the solver besides its committed fields (u, v, a, f, time,
    # state, t, g), step/static and ``ext``: the step's coefficients, the interface force, and
    # the committed internals that a bitwise restart (checkpoint) or a repeated step (the uplift
    # of the crack state a step ends in) must carry.
    def coefficients(self, h):
        """Newmark coefficients (c0, c1, c2, c3, c4, c5) of a step of size h:
        c0 = 1/(beta h^2), c1 = gamma/(beta h), c2 = 1/(beta h), c3 = 1/(2 beta) - 1,
        c4 = gamma/beta - 1, c5 = h (gamma/(2 beta) - 1)."""
        return self._coeffs(h)

    def operator_gap(self):
        """(npts, 2) gap B u + g_offset of the committed u under the current operator: after a
        re-pairing (``set_operator``) it differs from the committed gap ``g`` (the law's) where
        a point slid off its face and was opened (run/sliding)."""
        return self._gap(self.u).reshape(-1, 2)

    def internal_force(self, t):
        """B^T W t: the free-DOF force of the interface tractions t (npts, 2)."""
        return self._fint(t)

    def checkpoint_state(self) -> dict:
        """Copies of the committed internals a bitwise restart needs besides u, v, a, f, time
        and the interface state: traction t, gap g, the nonlinear correction phi and the
        active-point mask."""
        d = {"t": self.t.copy(), "g": self.g.copy(), "phi": self._phi.copy(),
             "active": self._active.copy()}
        if self._slip_sign is not None:
            d["slip_sign"] = self._slip_sign.copy()
        if self.g_offset is not None:      # a joint paired anew (finite sliding)
            d["g_offset"] = self.g_offset.copy()
        return d

    def restore_state(self, d):
        """Set the committed internals from ``checkpoint_state()`` (copies are taken)."""
        self.t = np.array(d["t"])
        self.g = np.array(d["g"])
        self._phi = np.array(d["phi"])
        self._active = np.array(d["active"])
        if "slip_sign" in d:
            self._slip_sign = np.array(d["slip_sign"], dtype=np.int8)
