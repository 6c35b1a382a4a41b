"""Sparse direct factorisation for the interface solver: SuperLU (scipy.sparse.linalg.splu) for
the factorisation, and numba triangular solves on its L and U factors (SuperLU's own solve is
2-4x slower from Python on these matrices; docs/solver.md §5).

    Pr A Pc = L U     (scipy's convention: Pr[perm_r[i], i] = 1, Pc[i, perm_c[i]] = 1)

A dense symmetric positive definite matrix (the reduced bulk, fe/reduction.py) gets
``DenseFactor`` instead (LAPACK Cholesky, the same methods): ``SparseFactor(A)`` returns one
when A has at least DENSE_MIN_N rows and DENSE_MIN_FILL of its entries stored.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from scipy.linalg.blas import dtrsv
import scipy.sparse as sp
import scipy.sparse.linalg as spl
from numba import njit

__all__ = ["SparseFactor", "DenseFactor"]


@njit(cache=True)
def _lu_solve(Lp, Li, Lx, Up, Ui, Ux, perm_r, perm_c, b, x, y):
    """Solve A x = b for a (n, k) C-contiguous b: y = Pr b; L z = y; U w = z; x = Pc w
    (general LU: U stored by columns, diagonal last)."""
    n, k = b.shape
    _scatter_rows(perm_r, b, y)
    _fwd_mat(Lp, Li, Lx, y)
    for j in range(n - 1, -1, -1):
        d = Ux[Up[j + 1] - 1]
        for r in range(k):
            y[j, r] /= d
        for q in range(Up[j], Up[j + 1] - 1):
            i = Ui[q]
            uv = Ux[q]
            for r in range(k):
                y[i, r] -= uv * y[j, r]
    _gather_rows(perm_c, y, x)


@njit(cache=True)
def _scatter_rows(perm, b, y):
    """y[perm[i]] = b[i] (rows of (n, k) arrays): into the permuted space."""
    for i in range(b.shape[0]):
        pi = perm[i]
        for r in range(b.shape[1]):
            y[pi, r] = b[i, r]


@njit(cache=True)
def _gather_rows(perm, y, x):
    """x[i] = y[perm[i]] (rows of (n, k) arrays): back from the permuted space."""
    for i in range(x.shape[0]):
        pc = perm[i]
        for r in range(x.shape[1]):
            x[i, r] = y[pc, r]


@njit(cache=True, inline="always")
def _eliminate(Lp, Li, Lx, y, j):
    """Column j of the forward substitution L^-1 y (y (n, k), in place): y[j] /= L_jj, then
    y[i] -= L_ij y[j] below the diagonal (L CSC, diagonal first in each column)."""
    k = y.shape[1]
    d = Lx[Lp[j]]
    for r in range(k):
        y[j, r] /= d
    for q in range(Lp[j] + 1, Lp[j + 1]):
        i = Li[q]
        lv = Lx[q]
        for r in range(k):
            y[i, r] -= lv * y[j, r]


@njit(cache=True)
def _fwd_mat(Lp, Li, Lx, y):
    """y <- L^-1 y in place (y (n, k)); L CSC, diagonal first in each column."""
    for j in range(y.shape[0]):
        _eliminate(Lp, Li, Lx, y, j)


@njit(cache=True)
def _ldl_solve(Lp, Li, Lx, Rp, Ri, Rx, D, perm, b, x, y):
    """Solve A x = b, P A P^T = L D L^T (symmetric), b (n, k): y = P b; L z = y;
    L^T w = D^-1 z (dot products down the columns of L, read from the reversed copy
    (Rp, Ri, Rx), see ``_reversed``); x = P^T w."""
    n, k = b.shape
    _scatter_rows(perm, b, y)
    _fwd_mat(Lp, Li, Lx, y)
    for kk in range(n):
        j = n - 1 - kk
        d = D[j]
        for r in range(k):
            y[j, r] /= d
        for q in range(Rp[kk], Rp[kk + 1]):
            i = Ri[q]
            lv = Rx[q]
            for r in range(k):
                y[j, r] -= lv * y[i, r]
    _gather_rows(perm, y, x)


@njit(cache=True)
def _fwd1(Lp, Li, Lx, perm_r, b, y):
    """Forward half of a solve: y = L^-1 Pr b (permuted space)."""
    n = b.shape[0]
    for i in range(n):
        y[perm_r[i]] = b[i]
    for j in range(n):
        yj = y[j] / Lx[Lp[j]]
        y[j] = yj
        for q in range(Lp[j] + 1, Lp[j + 1]):
            y[Li[q]] -= Lx[q] * yj


@njit(cache=True)
def _bwd1(Up, Ui, Ux, perm_c, z, x):
    """Backward half, general LU: x = Pc U^-1 z (z is overwritten)."""
    n = z.shape[0]
    for j in range(n - 1, -1, -1):
        zj = z[j] / Ux[Up[j + 1] - 1]
        z[j] = zj
        for q in range(Up[j], Up[j + 1] - 1):
            z[Ui[q]] -= Ux[q] * zj
    for i in range(n):
        x[i] = z[perm_c[i]]


@njit(cache=True)
def _bwd1_ldl(Rp, Ri, Rx, D, perm, z, x):
    """Backward half, symmetric: x = P^T L^-T D^-1 z, by dot products down the columns of L
    taken last to first from the reversed copy (ascending addresses; z is overwritten)."""
    n = z.shape[0]
    for k in range(n):
        j = n - 1 - k
        acc = z[j] / D[j]
        for q in range(Rp[k], Rp[k + 1]):
            acc -= Rx[q] * z[Ri[q]]
        z[j] = acc
    for i in range(n):
        x[i] = z[perm[i]]


@njit(cache=True)
def _reversed(Lp, Li, Lx):
    """L's columns last to first, off-diagonal entries only: column j = n-1-k is
    Ri/Rx[Rp[k]:Rp[k+1]]. The backward half of a solve visits the columns in that order; read
    from L itself it walks memory downwards, which the hardware prefetcher does not follow
    (2.4-2.6 ms against 1.1 ms for the same arithmetic on the Koyna factor, measured)."""
    n = Lp.shape[0] - 1
    Rp = np.empty(n + 1, np.int32)
    Rp[0] = 0
    for k in range(n):
        j = n - 1 - k
        Rp[k + 1] = Rp[k] + (Lp[j + 1] - Lp[j] - 1)
    Ri = np.empty(Rp[n], np.int32)
    Rx = np.empty(Rp[n])
    for k in range(n):
        j = n - 1 - k
        q0 = Lp[j] + 1
        for t in range(Rp[k + 1] - Rp[k]):
            Ri[Rp[k] + t] = Li[q0 + t]
            Rx[Rp[k] + t] = Lx[q0 + t]
    return Rp, Ri, Rx


@njit(cache=True)
def _fwd_part(Lp, Li, Lx, cols, rows_in, b, y):
    """L^-1 applied to right-hand sides supported on the rows ``rows_in`` (positions in the
    permuted space, b (len(rows_in), k)); only the columns ``cols`` (ascending: the closure of
    rows_in under the structure of L, which holds every nonzero of the result) are visited.
    y (n, k) must be zero outside ``cols`` on entry; on return y[cols] is L^-1 (scattered b)."""
    k = b.shape[1]
    for a in range(rows_in.shape[0]):
        for r in range(k):
            y[rows_in[a], r] += b[a, r]
    for a in range(cols.shape[0]):
        _eliminate(Lp, Li, Lx, y, cols[a])


@njit(cache=True)
def _bwd_part(Urp, Urj, Urx, D, rows, z, w):
    """U^-1 z on the positions ``rows`` only (descending; closed under the row structure of U,
    so every entry they need is among them). U by rows with its diagonal first in each row
    (D None); or, symmetric, U = D L^T: row j of U is D[j] times column j of L, passed as the
    reversed copy of L (``_reversed``) with ``rows`` given as k = n-1-j (ascending)."""
    k = z.shape[1]
    n = z.shape[0]
    for a in range(rows.shape[0]):
        if D is None:
            j = rows[a]
            for r in range(k):
                w[j, r] = z[j, r]
            for q in range(Urp[j] + 1, Urp[j + 1]):
                i = Urj[q]
                uv = Urx[q]
                for r in range(k):
                    w[j, r] -= uv * w[i, r]
            d = Urx[Urp[j]]
            for r in range(k):
                w[j, r] /= d
        else:
            kk = rows[a]
            j = n - 1 - kk
            d = D[j]
            for r in range(k):
                w[j, r] = z[j, r] / d
            for q in range(Urp[kk], Urp[kk + 1]):
                i = Urj[q]
                lv = Urx[q]
                for r in range(k):
                    w[j, r] -= lv * w[i, r]


@njit(cache=True)
def _fwd_part1(Lp, Li, Lx, cols, rows_in, b, y):
    """_fwd_part for one right-hand side (b (m,), y (n,))."""
    for a in range(rows_in.shape[0]):
        y[rows_in[a]] += b[a]
    for a in range(cols.shape[0]):
        j = cols[a]
        yj = y[j] / Lx[Lp[j]]
        y[j] = yj
        for q in range(Lp[j] + 1, Lp[j + 1]):
            y[Li[q]] -= Lx[q] * yj


@njit(cache=True)
def _bwd_part1(Urp, Urj, Urx, D, rows, z, w):
    """_bwd_part for one right-hand side (z, w (n,))."""
    n = z.shape[0]
    for a in range(rows.shape[0]):
        if D is None:
            j = rows[a]
            acc = z[j]
            for q in range(Urp[j] + 1, Urp[j + 1]):
                acc -= Urx[q] * w[Urj[q]]
            w[j] = acc / Urx[Urp[j]]
        else:
            kk = rows[a]
            j = n - 1 - kk
            acc = z[j] / D[j]
            for q in range(Urp[kk], Urp[kk + 1]):
                acc -= Urx[q] * w[Urj[q]]
            w[j] = acc


@njit(cache=True)
def _closure(p, idx, start):
    """Positions reachable from ``start`` through the compressed structure (p, idx) (each
    column/row lists positions after itself), as a boolean mask."""
    n = p.shape[0] - 1
    mark = np.zeros(n, np.bool_)
    stack = np.empty(n, np.int64)
    top = 0
    for s in start:
        if not mark[s]:
            mark[s] = True
            stack[top] = s
            top += 1
    while top > 0:
        top -= 1
        j = stack[top]
        for q in range(p[j], p[j + 1]):
            i = idx[q]
            if i != j and not mark[i]:
                mark[i] = True
                stack[top] = i
                top += 1
    return mark


class SparseFactor:
    """Direct factorisation of a sparse (ndof x ndof) matrix.

    symmetric=True: SuperLU with MMD ordering on A^T + A, symmetric mode, no pivoting (the
    effective matrices of the condensed method are SPD): then perm_r = perm_c = P and
    U = D L^T to round-off, so U is not kept (P A P^T = L D L^T): the backward half takes dot
    products down the columns of L, last column first, read from a reversed copy of L so that
    both halves stream memory upwards (``_reversed``; measured in BENCHMARKS.md).
    If SuperLU pivoted anyway, or U is not D L^T to 1e-10, the general LU is kept.
    symmetric=False: partial pivoting, L and U.
    ``solve(b)`` accepts (n,) or (n, k).  ``fast=False`` uses SuperLU's own solve.
    """

    def __new__(cls, A, symmetric: bool = True, fast: bool = True):
        # a dense matrix (the reduced bulk's, fe/reduction.py) gets the dense factor with the
        # same methods (``DenseFactor``); a finite-element matrix never is one (module doc)
        if cls is SparseFactor and symmetric and fast:
            L = DenseFactor.cholesky(A)
            if L is not None:
                return DenseFactor(L)
        return super().__new__(cls)

    def __init__(self, A, symmetric: bool = True, fast: bool = True):
        A = sp.csc_matrix(A)
        if symmetric:
            lu = spl.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                          options=dict(SymmetricMode=True))
        else:
            lu = spl.splu(A, permc_spec="MMD_AT_PLUS_A")
        self.shape = A.shape
        self.fast = fast
        self._part = None
        self._D = None
        self._U = None
        self._R = None
        if fast:
            L = lu.L.tocsc()
            U = lu.U.tocsc()
            L.sort_indices()
            U.sort_indices()
            # int32 pointers (nnz < 2^31 here); unsigned row indices, 16-bit while n < 2^16:
            # no negative-index wraparound test in the compiled loops (each half ~1.4x faster
            # than int32 on Koyna, measured; docs/solver.md §5) and fewer bytes to stream
            ix = _index_dtype(A.shape[0])
            self._L = (L.indptr.astype(np.int32), L.indices.astype(ix), L.data)
            self._pr = lu.perm_r.astype(np.int64)
            self._pc = lu.perm_c.astype(np.int64)
            if symmetric and np.array_equal(self._pr, self._pc) and _is_dlt(L, U):
                self._D = U.diagonal().copy()
                Rp, Ri, Rx = _reversed(*self._L)
                self._R = (Rp, Ri.astype(ix), Rx)
            else:
                self._U = (U.indptr.astype(np.int32), U.indices.astype(ix), U.data)
            self._lu = None                  # SuperLU's own copy of the factors is not kept
        else:
            self._lu = lu

    @property
    def ldl(self) -> bool:
        """True when only L and D are kept (P A P^T = L D L^T)."""
        return self._D is not None

    @property
    def nnz(self) -> int:
        """Stored factor entries (L and U, or L and D)."""
        if not self.fast:
            return -1
        return int(self._L[2].size + (self._D.size if self.ldl else self._U[2].size))

    def solve(self, b):
        if not self.fast:
            return self._lu.solve(b)
        b = np.asarray(b, dtype=np.float64)
        if b.ndim == 1:
            return self.backward(self.forward(b))
        b2 = np.ascontiguousarray(b.reshape(b.shape[0], -1))
        x = np.empty_like(b2)
        y = np.empty_like(b2)
        if self.ldl:
            _ldl_solve(*self._L, *self._R, self._D, self._pr, b2, x, y)
        else:
            _lu_solve(*self._L, *self._U, self._pr, self._pc, b2, x, y)
        return x

    # ---- split and partial solves (the condensed interface Newton) -----------------------
    # A^-1 = Pc U^-1 L^-1 Pr.  Right-hand sides supported on a few DOFs ("interface") reach
    # only the closure of their rows under the structure of L; a solution wanted at those DOFs
    # only needs the closure of their positions under the structure of U (the etree ancestors).
    def restrict(self, dofs):
        """Prepare ``forward_sparse``, ``backward_at`` and ``solve_at`` for the original indices
        ``dofs`` (sorted, unique); returns self."""
        if not self.fast:
            raise ValueError("SparseFactor.restrict needs fast=True")
        dofs = np.asarray(dofs, np.int64)
        Lp, Li, _ = self._L
        rin = self._pr[dofs]
        fcols = np.flatnonzero(_closure(Lp, Li, rin))
        n = self.shape[0]
        if self.ldl:                          # row j of U = D_j L[:, j]^T: L's own columns
            brows = n - 1 - np.flatnonzero(_closure(Lp, Li, self._pc[dofs]))[::-1]
            Ur = self._R                      # ... read from the reversed copy, k = n-1-j
        else:
            Up, Ui, Ux = self._U
            Ur = sp.csc_matrix((Ux, Ui, Up), shape=self.shape).tocsr()
            Ur.sort_indices()
            Ur = (Ur.indptr.astype(np.int32), Ur.indices.astype(_index_dtype(n)), Ur.data)
            brows = np.flatnonzero(_closure(Ur[0], Ur[1], self._pc[dofs]))[::-1].copy()
        qout = self._pc[dofs]
        self._part = dict(dofs=dofs, rin=rin, fcols=fcols, Ur=Ur, qout=qout, brows=brows)
        return self

    def forward(self, b):
        """z = L^-1 Pr b (the first half of ``solve``; permuted space)."""
        b = np.asarray(b, dtype=np.float64)
        z = np.empty_like(b)
        _fwd1(*self._L, self._pr, b, z)
        return z

    def backward(self, z):
        """x = Pc U^-1 z (the second half of ``solve``); z is not modified."""
        zz = np.array(z, dtype=np.float64)
        x = np.empty_like(zz)
        if self.ldl:
            _bwd1_ldl(*self._R, self._D, self._pc, zz, x)
        else:
            _bwd1(*self._U, self._pc, zz, x)
        return x

    def backward_at(self, z):
        """(Pc U^-1 z)[dofs] for z (n,) or (n, k), visiting only the closure of the dofs."""
        pt = self._part
        if z.ndim == 1:
            w = np.empty_like(z)
            _bwd_part1(*pt["Ur"], self._D, pt["brows"], z, w)
            return w[pt["qout"]]
        z2 = np.ascontiguousarray(z)
        w = np.empty_like(z2)
        _bwd_part(*pt["Ur"], self._D, pt["brows"], z2, w)
        return w[pt["qout"]]

    def forward_sparse(self, bd):
        """L^-1 Pr b for b zero outside ``dofs`` with b[dofs] = bd ((m,) or (m, k))."""
        pt = self._part
        if np.ndim(bd) == 1:
            z = np.zeros(self.shape[0])
            _fwd_part1(*self._L, pt["fcols"], pt["rin"], np.asarray(bd, np.float64), z)
            return z
        b2 = np.ascontiguousarray(np.asarray(bd, np.float64).reshape(pt["dofs"].size, -1))
        z = np.zeros((self.shape[0], b2.shape[1]))
        _fwd_part(*self._L, pt["fcols"], pt["rin"], b2, z)
        return z[:, 0] if np.ndim(bd) == 1 else z

    def solve_at(self, bd):
        """(A^-1 b)[dofs] for b zero outside ``dofs`` (b[dofs] = bd, (m,) or (m, k))."""
        return self.backward_at(self.forward_sparse(bd))


# DenseFactor: at least this many rows and this fraction of the entries stored. A P1-P3
# finite-element row couples to at most ~100 DOFs (the elements around a node), under half
# of 200 rows: no assembled FE matrix of the full bulk takes the dense path
DENSE_MIN_N = 200
DENSE_MIN_FILL = 0.5


class DenseFactor:
    """A symmetric positive definite matrix stored dense-as-sparse (the reduced bulk's effective
    matrices: a few hundred rows, every entry nonzero), factorised A = L L^T by LAPACK, with
    ``SparseFactor``'s methods (the condensed solver's split and partial solves are its full
    triangular solves: every DOF is in every closure of a dense factor)."""

    ldl = False

    def __init__(self, L):
        self.L = np.asarray(L, dtype=np.float64, order="F")
        self.shape = self.L.shape
        self.fast = True
        self.dofs = None

    @staticmethod
    def cholesky(A):
        """The Cholesky factor L of A when A is dense enough (DENSE_MIN_N, DENSE_MIN_FILL) and
        SPD, else None (the sparse factor is used)."""
        n = A.shape[0]
        if n < DENSE_MIN_N or not sp.issparse(A) or A.nnz < DENSE_MIN_FILL * n * n:
            return None
        try:
            return sla.cholesky(A.toarray(), lower=True, check_finite=False)
        except np.linalg.LinAlgError:
            return None

    @property
    def nnz(self) -> int:
        return int(self.shape[0] * (self.shape[0] + 1) // 2)

    def solve(self, b):
        return sla.cho_solve((self.L, True), np.asarray(b, dtype=np.float64),
                             check_finite=False)

    def restrict(self, dofs):
        self.dofs = np.asarray(dofs, np.int64)
        return self

    def forward(self, b):
        b = np.asarray(b, dtype=np.float64)
        if b.ndim == 1:                    # BLAS dtrsv: ~30 % less call overhead per step
            return dtrsv(self.L, b, lower=1)
        return sla.solve_triangular(self.L, b, lower=True, check_finite=False)

    def backward(self, z):
        z = np.asarray(z, dtype=np.float64)
        if z.ndim == 1:
            return dtrsv(self.L, z, lower=1, trans=1)
        return sla.solve_triangular(self.L, z, lower=True, trans="T", check_finite=False)

    def backward_at(self, z):
        return self.backward(z)[self.dofs]

    def forward_sparse(self, bd):
        bd = np.asarray(bd, np.float64)
        b = np.zeros((self.shape[0],) + bd.shape[1:])
        b[self.dofs] = bd
        return self.forward(b)

    def solve_at(self, bd):
        return self.backward_at(self.forward_sparse(bd))


def _index_dtype(n):
    """Unsigned row indices of the stored factors: uint16 up to 65 535 rows, else uint32."""
    return np.uint16 if n <= np.iinfo(np.uint16).max else np.uint32


def _is_dlt(L, U, rtol=1e-10) -> bool:
    """U == D L^T to rtol of U's largest entry (same structure); L unit lower."""
    if L.nnz != U.nnz:
        return False
    d = U.diagonal()
    if not np.all(np.isfinite(d)) or np.any(d == 0.0):
        return False
    DLt = sp.csc_matrix(sp.diags(d) @ L.T.tocsc())
    diff = abs(DLt - U)
    return bool(diff.max() <= rtol * abs(U).max()) if diff.nnz else True
