"""The condensed Newton on the interface gaps, with its per-step-size factorisations and the
reuse of the interface Jacobian's LU (docs/solver.md §2).

K0 = diag(k_N, k_T) the law's initial elastic stiffness (frozen in the factorised matrix),
phi(g) = t(g) - K0 g the nonlinear correction (zero at every point still in its initial elastic
state). For the step size h the effective matrix

    A = c0 (1 - alpha_m) M + c (K + c1 C) + c B^T W K0 B     (c = 1 + alpha_hht = 1 - alpha_f;
                                                              static: K + B^T W K0 B)

(solve/integrator.py ``TimeDiscretisation.matrix``, plus a coupled field's block)

is constant: factorised once per h (cached). With u_lin = A^-1 rhs and S = B A^-1 B^T,

    u = u_lin - c A^-1 B^T W phi(g),    g = g_lin - c S W phi(g).

Newton runs on the gaps only: R(g) = g - g_lin + c S_:a W_a phi_a(g_a) = 0 (a: active points,
phi != 0), exact Jacobian I + c S W (T - K0) (T - K0 = 0 at inactive points). S is never formed:
B_I = G Delta (Delta: the relative displacements of the paired dam/rock interface DOFs, r of
them: 224 on the default Koyna mesh whatever the number of interface points; G sparse), so
S = G Y G^T with Y = Delta (A^-1)_II Delta^T (r x r, from r partial solves once per h) and the
Newton direction comes from the r x r system Y^-1 + G^T Dw G by the push-through identity
(``CondensedNewton.jacobian_solve``), solved by GMRES on an earlier LU or factorised. A^-1 rhs
is split in its triangular halves so that a nonlinear step costs one forward and one backward
sparse solve plus the closure of the interface DOFs (``SparseFactor.restrict``;
docs/solver.md §2.4).
"""
from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from .interface import JointOperator, dof_index
from .kernels import jac_setup, mv, ptp_pairs
from .gap_kernels import active_blocks, gap_phi, gap_residual, push_back, scatter_add
from .krylov import gmres_lu, lu_solve_into
from .newton import Attempt, DirectionFailed, NewtonControl, failed

__all__ = ["CondensedNewton", "StepEntry"]

# Newton directions with an earlier LU of the r x r interface system (``jacobian_solve``):
# GMRES right-preconditioned by it (solve/krylov.py) to this true relative residual (a direct
# LU solve of the 224 x 224 Koyna system leaves ~1e-15), at most GMRES_MAX iterations, after
# which the system is factorised afresh; after a solve that needed more than GMRES_REFRESH
# iterations the LU is dropped so that the next solve factorises (a factorisation costs
# ~15 iterations on Koyna). Chosen on 4 057 captured solves of the 0.2x Koyna run's first
# 3 s (docs/solver.md §2.3, CHANGELOG.md): per solve ~230 us against ~700 us by refinement on the LU
# of K = I + P Y (the second round), factorisations 408 against 2 008.
GMRES_TOL = 1e-13
GMRES_MAX = 16
GMRES_REFRESH = 8


def norm2(x) -> float:
    """np.linalg.norm(x) of a real array, bit for bit (its own arithmetic: sqrt of the dot
    product of the K-order ravel), without its checks and dispatch."""
    x = x.ravel(order="K")
    return math.sqrt(x.dot(x))


@dataclass
class StepEntry:
    """Per-step-size data of the condensed method."""
    factor: object                       # SparseFactor (restricted) or LowRankFactor
    Y: np.ndarray | None = None          # (r, r) Delta (A^-1)_II Delta^T, S = G Y G^T
    Yinv: np.ndarray | None = None       # Y^-1 (symmetric): the Newton system is Y^-1 + P
    Z: dict = field(default_factory=dict)  # point -> (ndof, 2) A^-1 B_p^T (few active points)
    jac_lu: tuple | None = None          # (LU^T, pivots, P values) of the last Y^-1 + P factorised
    jac_buf: np.ndarray | None = None    # (r, r) where that LU^T is formed (jacobian_solve)
    base: bool = True                    # the nominal step's entry (never evicted)


class CondensedNewton:
    """The condensed method. ``factorise(h)`` -> the factor of the effective matrix of step
    size h (None: static), restricted to the interface DOFs (the solver's, which knows the
    integrator, the damping and the coupled field).

    few_max : up to this many active points u_lin is formed whole and u recovered from cached
              columns A^-1 B_p^T (one solve per step, as a linear step); more: split solve
    jacobian_reuse : solve the r x r Newton system by GMRES preconditioned with the LU of the
              last one factorised (same step size) when that converges in a few iterations;
              else factorise (the direction is the same to round-off: relative residual 1e-13)
    max_cache : number of step sizes whose factorisation/S columns are kept
    stats : counts of Jacobian factorisations, solves, reuses and GMRES iterations."""

    def __init__(self, joints: JointOperator, control: NewtonControl, factorise, *, dt,
                 few_max=16, jacobian_reuse=True, max_cache=6):
        self.joints = joints
        self.control = control
        self.factorise = factorise
        self.dt = float(dt)
        self.few_max = int(few_max)
        self.jacobian_reuse = bool(jacobian_reuse)
        self.max_cache = int(max_cache)
        self.stats = dict(jacobian_factorisations=0, jacobian_solves=0, jacobian_reuses=0,
                          gmres_iterations=0)
        self.steps: OrderedDict = OrderedDict()     # step size -> StepEntry
        self.static_entry = None
        self._ptp = self._ptp_of = self._ptp_map = None   # G^T Dw G pattern (ptp_pattern)
        self._ptp_flatT = None
        self._gmres_wk = None
        self._solve_wk = None

    # ------------------------------------------------------------------ per step size
    def clear(self):
        """Drop every factorisation (the effective matrix changed)."""
        self.steps.clear()
        self.static_entry = None

    def entry(self, h) -> StepEntry:
        if h is None:
            if self.static_entry is None:
                self.static_entry = StepEntry(self.factorise(None))
            return self.static_entry
        key = float(h)
        e = self.steps.get(key)
        if e is None:
            # a cut costs one factorisation + columns once per sub-step size for the whole
            # run; the cache holds every halving level (measured: 18 cuts at 1.5-3.8 s each
            # with 3 slots); the nominal step's entry is never evicted
            e = StepEntry(self.factorise(h), base=abs(h - self.dt) <= 1e-12 * self.dt)
            self.steps[key] = e
            while len(self.steps) > self.max_cache:      # evict the LRU sub-step entry
                old = next((k for k, v in self.steps.items() if not v.base),
                           next(iter(self.steps)))
                self.steps.pop(old)
        else:
            self.steps.move_to_end(key)
        return e

    def ensure_Y(self, e: StepEntry):
        """Y = Delta (A^-1)_II Delta^T (r x r), once per step size: partial solves with
        right-hand sides and wanted entries on the interface DOFs only (SparseFactor.restrict),
        r of them (one per relative interface DOF), in blocks (bounded work memory)."""
        if e.Y is not None:
            return
        Dt = self.joints.Dt
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

    def forget_jacobian(self):
        """Drop the LUs kept for ``jacobian_reuse``."""
        for e in self.steps.values():
            e.jac_lu = None
        if self.static_entry is not None:
            self.static_entry.jac_lu = None

    @property
    def jacobian_kept(self) -> bool:
        """True when some step size keeps the LU of an interface Jacobian (``jacobian_reuse``)."""
        return any(e.jac_lu is not None for e in self.steps.values())

    # ------------------------------------------------------------------ one attempt
    def attempt(self, h, rhs, c, law, state, law_dt, phi0, active0, g0, stall=0) -> Attempt:
        """One attempt of the step of size h (None: static) with the right-hand side rhs, from
        the committed phi0, active0 (active-point mask) and gap g0 ((npts, 2))."""
        J0 = self.joints
        e = self.entry(h)
        # A^-1 rhs split in its two triangular halves: with active points only the interface
        # entries of u_lin are formed now (the closure of I in U), and the one full backward
        # solve comes after Newton, on z - c L^-1 Pr B^T W phi
        # With no or few (<= few_max) active points the whole u_lin is formed (one solve) and
        # u is recovered from cached columns A^-1 B_p^T of the active points (e.Z).
        z_lin = e.factor.forward(rhs)
        if int(active0.sum()) > self.few_max:
            u_lin = None
            g_lin = mv(J0.BI, e.factor.backward_at(z_lin))
            if J0.g_offset is not None:
                g_lin += J0.g_offset
        else:
            u_lin = e.factor.backward(z_lin)
            g_lin = J0.gap(u_lin)
        wd, k0v = J0.wd, J0.k0v
        wdk0 = wd * k0v                  # the direction's energy weight (wd * k0v * R)
        n2 = 2 * J0.npts
        act = active0.copy()
        ad = dof_index(np.flatnonzero(act))
        if ad.size:
            self.ensure_Y(e)

        def Smul(ad, y):
            """S[:, ad] @ y = G Y G^T (y scattered on ad): never forms S (2 npts x 2 npts)."""
            if ad.size == n2:                 # every point active (ad = 0 .. n2-1): no scatter
                yp = y
            else:
                yp = np.zeros(n2)
                yp[ad] = y
            return mv(J0.G, e.Y @ mv(J0.GT, yp))  # r^2 + nnz(G), not 2 npts r

        def wphi(ad, phi):
            """(W phi)[ad] (the whole vector when every point is active)."""
            return wd * phi if ad.size == n2 else wd[ad] * phi[ad]

        g = g_lin - c * Smul(ad, wphi(ad, phi0)) if ad.size else g_lin.copy()
        # the residual's scale is fixed for the attempt (the linear predictor, the committed
        # gap, the law's elastic opening): relative to the iterate's own norm a runaway slip
        # of a sliding joint would make any residual look small
        gscale = max(norm2(g_lin), norm2(g0), J0.gref)

        G, GT = J0.G, J0.GT
        r = GT.shape[0]
        # the law bound to the committed state and law_dt once for the attempt (its checks of
        # state and dt, the kernel's choice): each call checks only its gap (InterfaceLaw.bind)
        lawcall = law.bind(state, law_dt)
        y = np.empty(r)
        wphi_buf = np.empty(n2)
        newly = np.empty(J0.npts, np.bool_)

        def evaluate(g, cur):
            # phi, the newly active points, W phi on the active points and G^T W phi in one
            # compiled pass (``gap_phi``), Y (.) by BLAS, then R = g - g_lin + c G (.)
            # (``gap_residual``): the numbers of ``Smul`` and ``wphi`` in the same order
            act, ad = (cur[5], cur[6]) if cur is not None else (act0, ad0)
            t, T, new = lawcall(g)           # law.evaluate(g.reshape(-1, 2), state, dt=law_dt)
            phi = np.empty(n2)
            nnew, anyact = gap_phi(t.ravel(), g, k0v, wd, J0.active_tol, act, GT.indptr,
                                   GT.indices, GT.data, phi, newly, wphi_buf, y)
            if nnew:
                act = act | newly
                self.ensure_Y(e)
                ad = dof_index(np.flatnonzero(act))
            if anyact:
                R = np.empty(n2)
                gap_residual(g, g_lin, c, G.indptr, G.indices, G.data, e.Y @ y, R)
            else:
                R = g - g_lin
            return (t, T, new, phi, R, act, ad), norm2(R) / gscale

        def direction(g, cur):
            # exact Newton direction on all gaps: (I + c S W E) dg = -R, E = T - K0 at the
            # active points (0 elsewhere), through the r x r system of the relative interface
            # DOFs (``jacobian_solve``)
            T, R, act, ad = cur[1], cur[4], cur[5], cur[6]
            E = np.empty_like(T)
            active_blocks(T, J0.k0blk, act, E)          # T - K0 at active points, 0 elsewhere
            try:
                dg = self.jacobian_solve(e, E, -R, c, ad)
            except (np.linalg.LinAlgError, ValueError) as err:
                raise DirectionFailed(str(err)) from err
            return dg, abs(np.dot(dg, wdk0 * R))

        act0, ad0 = act, ad
        ok, g, out, it, rnorm = self.control.solve(g, evaluate, direction, stall)
        if not ok:
            return failed(it, rnorm)
        t, T, new, phi, R, act, ad = out
        # recover u = A^-1 (rhs - c B^T W phi_a) = Pc U^-1 (z_lin - c L^-1 Pr B^T W phi_a):
        # the forward part only visits the closure of the interface rows
        if ad.size == n2:                         # every point active: phi itself
            phia = phi.copy()
        else:
            phia = np.zeros_like(phi)
            phia[ad] = phi[ad]
        pa = ad[0::2] // 2
        if not ad.size:
            u = u_lin if u_lin is not None else e.factor.backward(z_lin)
        elif u_lin is not None and pa.size <= self.few_max:
            new_p = [p for p in pa.tolist() if p not in e.Z]
            if new_p:
                nd = dof_index(np.asarray(new_p, np.int64))
                Zn = e.factor.solve(J0.BT[:, nd].toarray())
                for q, p in enumerate(new_p):
                    e.Z[p] = Zn[:, 2 * q:2 * q + 2]
            Za = np.hstack([e.Z[p] for p in pa.tolist()])
            u = u_lin - c * (Za @ (wd[ad] * phi[ad]))
        elif u_lin is not None:
            u = u_lin - c * e.factor.backward(e.factor.forward_sparse(mv(J0.BIT, wd * phia)))
        else:
            u = e.factor.backward(z_lin - c * e.factor.forward_sparse(mv(J0.BIT, wd * phia)))
        return Attempt(True, u, g, t, new, phia, act, it, rnorm)

    # ------------------------------------------------------------------ the Newton direction
    def jacobian_solve(self, e, E, b, c, ad):
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
        ``GMRES_TOL`` (round-off of a direct solve) in at most ``GMRES_MAX`` iterations;
        otherwise H is factorised afresh (solve/krylov.py).
        Few active points (4 m < r, the 2 m gap DOFs ``ad``): the same identity on their
        columns, J^-1 b = b - S_:a (I + Dw_a S_aa)^-1 Dw_a b_a with S_:a = G Y G_a^T (2m x 2m
        system, formed and factorised at every call). Above r / 4 the r x r system with its
        reused LU is cheaper (111 Koyna points, 2 m = 222, r = 224: 7.2 -> 4.0 ms per step,
        measured; it was used up to 2 m < r)."""
        J0 = self.joints
        self.stats["jacobian_solves"] += 1
        if 2 * ad.size < e.Y.shape[0]:
            Sa = J0.G @ (e.Y @ J0.GT[:, ad].toarray())       # (2 npts, 2m)
            m = ad.size // 2
            pa = ad[0::2] // 2
            Dw = E[pa] * (c * J0.w[pa])[:, None, None]          # (m, 2, 2)
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
        # a map built once); v = G^T Dw b: one compiled call (``jac_setup``)
        P = self.ptp_pattern()
        GT, G = J0.GT, J0.G
        r = GT.shape[0]
        v, z, tmp = self.solve_work(r, 2 * J0.npts)
        jac_setup(E, c * J0.w, b, *self._ptp_map, G.data, GT.indptr, GT.indices,
                  GT.data, P.data, tmp, v)
        ok = False
        if self.jacobian_reuse and e.jac_lu is not None:
            luT, piv, p0 = e.jac_lu
            wk = self.gmres_work(r)
            its = gmres_lu(luT, piv, e.Yinv, P.indptr, P.indices, P.data, p0, v, GMRES_TOL,
                           GMRES_MAX, z, *wk)
            if its >= 0:
                ok = True
                self.stats["jacobian_reuses"] += 1
                self.stats["gmres_iterations"] += its
                if its > GMRES_REFRESH:                   # the next solve factorises
                    e.jac_lu = None
        if not ok:
            # H = Y^-1 + P is formed in Fortran order in the entry's own buffer and factorised
            # there: Y^-1 is symmetric (bitwise), so a C-order copy of it read as its transpose
            # is Y^-1 again, and P's values go to their transposed positions. getrf then works
            # in place and its LU read in C order is the LU^T the kernels take: no copy, no
            # transposition (a C-order H went through f2py's transposing copy to Fortran
            # order: r = 336 alone, 1.4 against 0.6 ms a factorisation; in a run the gain is
            # within the host's noise, BENCHMARKS.md) and the same numbers bit for bit
            buf = e.jac_buf
            if buf is None or buf.shape != e.Yinv.shape:
                buf = e.jac_buf = np.empty_like(e.Yinv)
            e.jac_lu = None                               # buf holds the kept LU: dropped
            np.copyto(buf, e.Yinv)
            scatter_add(buf.ravel(), self._ptp_flatT, P.data)
            lu, piv, info = sla.lapack.dgetrf(buf.T, overwrite_a=True)
            if info != 0:
                raise np.linalg.LinAlgError(f"interface Jacobian singular (dgetrf info {info})")
            self.stats["jacobian_factorisations"] += 1
            luT = lu.T                          # buf itself (getrf returns Fortran order)
            e.jac_lu = (luT, piv.astype(np.int32), P.data.copy())
            lu_solve_into(luT, e.jac_lu[1], v, z)
        x = np.empty_like(b)
        if not push_back(b, G.indptr, G.indices, G.data, z, x):     # x = b - G z
            raise np.linalg.LinAlgError("interface Jacobian: non-finite solution")
        return x

    def solve_work(self, r, n2):
        """Work vectors of ``jacobian_solve`` (v, z of size r; G^T's operand of size n2),
        allocated once: each is consumed within the call."""
        wk = self._solve_wk
        if wk is None or wk[0].shape[0] != r or wk[2].shape[0] != n2:
            wk = self._solve_wk = (np.empty(r), np.empty(r), np.empty(n2))
        return wk

    def gmres_work(self, r):
        """GMRES work arrays for an r x r system and GMRES_MAX iterations (allocated once,
        again when either changes; the kernel only writes)."""
        wk = self._gmres_wk
        if wk is None or wk[-1].shape[0] != r or wk[3].shape[0] != GMRES_MAX:
            m = GMRES_MAX
            wk = (np.empty((m + 1, r)), np.empty((m, r)), np.empty((m + 1, m)), np.empty(m),
                  np.empty(m), np.empty(m + 1), np.empty(r))
            self._gmres_wk = wk
        return wk

    def ptp_pattern(self):
        """The (r x r) CSR pattern of G^T Dw G for block-diagonal Dw, and the map that scatters
        G_pa Dw_p,ab G_pb into its values (built once per G)."""
        if self._ptp is None or self._ptp_of is not self.joints.G:
            G = self.joints.G
            r = G.shape[1]
            PT, A, Bk, Q1, Q2 = ptp_pairs(G.indptr.astype(np.int64), self.joints.npts)
            rows, cols = G.indices[Q1], G.indices[Q2]
            P = sp.csr_matrix((np.ones(rows.size), (rows, cols)), shape=(r, r))
            P.sum_duplicates()
            P.sort_indices()
            prow = np.repeat(np.arange(r), np.diff(P.indptr))
            pos = np.searchsorted(prow.astype(np.int64) * r + P.indices,
                                  rows.astype(np.int64) * r + cols)
            self._ptp, self._ptp_of = P, G
            # unsigned (no negative-index test in ``jac_setup``'s loops)
            self._ptp_map = tuple(x.astype(np.uint32) for x in (PT, A, Bk, Q1, Q2, pos))
            # positions of P's values in H^T (C order) = H (Fortran order)
            self._ptp_flatT = P.indices.astype(np.int64) * r + prow
        return self._ptp
