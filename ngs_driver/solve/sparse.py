"""Sparse direct factorisation for the interface solver: SuperLU (scipy.sparse.linalg.splu) for
the factorisation, and numba triangular solves on its factors (SuperLU's own solve is 2-4x
slower from Python on these matrices; measured in docs/decisions.md §6): supernodal L and D
for SPD matrices (``supernodal``), column-compressed L and U otherwise.

    Pr A Pc = L U     (scipy's convention: Pr[perm_r[i], i] = 1, Pc[i, perm_c[i]] = 1)
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl
from numba import njit

from .supernodal import Supernodal

__all__ = ["SparseFactor"]


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


@njit(cache=True)
def _fwd_mat(Lp, Li, Lx, y):
    """y <- L^-1 y in place (y (n, k)); L CSC, diagonal first in each column."""
    n, k = y.shape
    for j in range(n):
        d = Lx[Lp[j]]
        for r in range(k):
            y[j, r] /= d
        for q in range(Lp[j] + 1, Lp[j + 1]):
            i = Li[q]
            lv = Lx[q]
            for r in range(k):
                y[i, r] -= lv * y[j, r]


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
        j = cols[a]
        d = Lx[Lp[j]]
        for r in range(k):
            y[j, r] /= d
        for q in range(Lp[j] + 1, Lp[j + 1]):
            i = Li[q]
            lv = Lx[q]
            for r in range(k):
                y[i, r] -= lv * y[j, r]


@njit(cache=True)
def _bwd_part(Urp, Urj, Urx, rows, z, w):
    """U^-1 z on the positions ``rows`` only (descending; closed under the row structure of U,
    so every entry they need is among them); U by rows with its diagonal first in each row."""
    k = z.shape[1]
    for a in range(rows.shape[0]):
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
def _bwd_part1(Urp, Urj, Urx, rows, z, w):
    """_bwd_part for one right-hand side (z, w (n,))."""
    for a in range(rows.shape[0]):
        j = rows[a]
        acc = z[j]
        for q in range(Urp[j] + 1, Urp[j + 1]):
            acc -= Urx[q] * w[Urj[q]]
        w[j] = acc / Urx[Urp[j]]


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
    U = D L^T to round-off, so U is not kept (P A P^T = L D L^T), and L is kept in supernodal
    storage (``supernodal.Supernodal``; issue #15, measured in BENCHMARKS.md): the backward
    half takes its dot products down the same blocks the forward half reads.
    If SuperLU pivoted anyway, L is not unit, or U is not D L^T to 1e-10, the general LU is kept.
    symmetric=False: partial pivoting, L and U (column-compressed).
    ``solve(b)`` accepts (n,) or (n, k).  ``fast=False`` uses SuperLU's own solve.
    """

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
        self._sn = None
        self._L = None
        self._U = None
        if fast:
            L = lu.L.tocsc()
            U = lu.U.tocsc()
            L.sort_indices()
            U.sort_indices()
            self._pr = lu.perm_r.astype(np.int64)
            self._pc = lu.perm_c.astype(np.int64)
            # int32 indices (n, nnz < 2^31 here): a solve streams L (and U), a quarter less
            Lc = (L.indptr.astype(np.int32), L.indices.astype(np.int32), L.data)
            if symmetric and np.array_equal(self._pr, self._pc) and _is_dlt(L, U):
                self._sn = Supernodal(*Lc, U.diagonal())
            else:
                self._L = Lc
                self._U = (U.indptr.astype(np.int32), U.indices.astype(np.int32), U.data)
            self._lu = None                  # SuperLU's own copy of the factors is not kept
        else:
            self._lu = lu

    @property
    def ldl(self) -> bool:
        """True when only L (supernodal) and D are kept (P A P^T = L D L^T)."""
        return self._sn is not None

    @property
    def nnz(self) -> int:
        """Stored factor entries (L and U; or L's blocks without its unit diagonal, and D)."""
        if not self.fast:
            return -1
        if self.ldl:
            return self._sn.nnz
        return int(self._L[2].size + self._U[2].size)

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
            _scatter_rows(self._pr, b2, y)
            self._sn.forward(y)
            self._sn.backward(y)
            _gather_rows(self._pc, y, x)
        else:
            _lu_solve(*self._L, *self._U, self._pr, self._pc, b2, x, y)
        return x

    # ---- split and partial solves (condensed interface solver, issue #15) ---------------
    # A^-1 = Pc U^-1 L^-1 Pr.  Right-hand sides supported on a few DOFs ("interface") reach
    # only the closure of their rows under the structure of L; a solution wanted at those DOFs
    # only needs the closure of their positions under the structure of U (the etree ancestors).
    def restrict(self, dofs):
        """Prepare ``forward_sparse``, ``backward_at`` and ``solve_at`` for the original indices
        ``dofs`` (sorted, unique); returns self."""
        if not self.fast:
            raise ValueError("SparseFactor.restrict needs fast=True")
        dofs = np.asarray(dofs, np.int64)
        rin = self._pr[dofs]
        qout = self._pc[dofs]
        if self.ldl:                          # one list of supernodes serves both halves
            sl = self._sn.closure(rin)
            self._part = dict(dofs=dofs, rin=rin, qout=qout, sl=sl)
            return self
        Lp, Li, _ = self._L
        fcols = np.flatnonzero(_closure(Lp, Li, rin))
        Up, Ui, Ux = self._U
        Ur = sp.csc_matrix((Ux, Ui, Up), shape=self.shape).tocsr()
        Ur.sort_indices()
        Ur = (Ur.indptr.astype(np.int32), Ur.indices.astype(np.int32), Ur.data)
        brows = np.flatnonzero(_closure(Ur[0], Ur[1], qout))[::-1].copy()
        self._part = dict(dofs=dofs, rin=rin, fcols=fcols, Ur=Ur, qout=qout, brows=brows)
        return self

    def partial_fraction(self) -> tuple[float, float]:
        """Share of L's and of U's entries that the partial forward / backward solves visit."""
        pt = self._part
        if self.ldl:
            f = self._sn.entries(pt["sl"]) / max(self._sn.entries(self._sn.all), 1)
            return f, f
        Lp = self._L[0]
        Urp = pt["Ur"][0]
        f = float(np.sum(Lp[pt["fcols"] + 1] - Lp[pt["fcols"]])) / self._L[2].size
        b = float(np.sum(Urp[pt["brows"] + 1] - Urp[pt["brows"]])) / pt["Ur"][2].size
        return f, b

    def forward(self, b):
        """z = L^-1 Pr b (the first half of ``solve``; permuted space)."""
        b = np.asarray(b, dtype=np.float64)
        z = np.empty_like(b)
        if self.ldl:
            z[self._pr] = b
            self._sn.forward(z)
        else:
            _fwd1(*self._L, self._pr, b, z)
        return z

    def backward(self, z):
        """x = Pc U^-1 z (the second half of ``solve``); z is not modified."""
        zz = np.array(z, dtype=np.float64)
        if self.ldl:
            self._sn.backward(zz)
            return zz[self._pc]
        x = np.empty_like(zz)
        _bwd1(*self._U, self._pc, zz, x)
        return x

    def backward_at(self, z):
        """(Pc U^-1 z)[dofs] for z (n,) or (n, k), visiting only the closure of the dofs."""
        pt = self._part
        if self.ldl:
            w = np.array(z, dtype=np.float64, order="C")
            self._sn.backward(w, pt["sl"])
            return w[pt["qout"]]
        if z.ndim == 1:
            w = np.empty_like(z)
            _bwd_part1(*pt["Ur"], pt["brows"], z, w)
            return w[pt["qout"]]
        z2 = np.ascontiguousarray(z)
        w = np.empty_like(z2)
        _bwd_part(*pt["Ur"], pt["brows"], z2, w)
        return w[pt["qout"]]

    def forward_sparse(self, bd):
        """L^-1 Pr b for b zero outside ``dofs`` with b[dofs] = bd ((m,) or (m, k))."""
        pt = self._part
        bd = np.asarray(bd, np.float64)
        if self.ldl:
            z = np.zeros((self.shape[0],) + bd.shape[1:])
            z[pt["rin"]] = bd
            self._sn.forward(z, pt["sl"])
            return z
        if bd.ndim == 1:
            z = np.zeros(self.shape[0])
            _fwd_part1(*self._L, pt["fcols"], pt["rin"], bd, z)
            return z
        b2 = np.ascontiguousarray(bd.reshape(pt["dofs"].size, -1))
        z = np.zeros((self.shape[0], b2.shape[1]))
        _fwd_part(*self._L, pt["fcols"], pt["rin"], b2, z)
        return z

    def solve_at(self, bd):
        """(A^-1 b)[dofs] for b zero outside ``dofs`` (b[dofs] = bd, (m,) or (m, k))."""
        return self.backward_at(self.forward_sparse(bd))


def _is_dlt(L, U, rtol=1e-10) -> bool:
    """L unit lower (exactly: the supernodal solve does not divide by its diagonal) and
    U == D L^T to rtol of U's largest entry (same structure)."""
    if L.nnz != U.nnz or not np.all(L.diagonal() == 1.0):
        return False
    d = U.diagonal()
    if not np.all(np.isfinite(d)) or np.any(d == 0.0):
        return False
    DLt = sp.csc_matrix(sp.diags(d) @ L.T.tocsc())
    diff = abs(DLt - U)
    return bool(diff.max() <= rtol * abs(U).max()) if diff.nnz else True
