"""Sparse direct factorisation for the interface solver: SuperLU (scipy.sparse.linalg.splu) for
the factorisation, and numba triangular solves on its L and U factors (SuperLU's own solve is
2-4x slower from Python on these matrices; measured in docs/decisions.md §6).

    Pr A Pc = L U     (scipy's convention: Pr[perm_r[i], i] = 1, Pc[i, perm_c[i]] = 1)
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl
from numba import njit

__all__ = ["SparseFactor"]


@njit(cache=True)
def _lu_solve(Lp, Li, Lx, Up, Ui, Ux, perm_r, perm_c, b, x, y):
    """Solve A x = b for a (n, k) C-contiguous b: y = Pr b; L z = y; U w = z; x = Pc w."""
    n, k = b.shape
    for i in range(n):
        pi = perm_r[i]
        for r in range(k):
            y[pi, r] = b[i, r]
    # L: CSC, unit diagonal stored first in each column (sorted indices)
    for j in range(n):
        d = Lx[Lp[j]]
        for r in range(k):
            y[j, r] /= d
        for q in range(Lp[j] + 1, Lp[j + 1]):
            i = Li[q]
            lv = Lx[q]
            for r in range(k):
                y[i, r] -= lv * y[j, r]
    # U: CSC, diagonal stored last in each column (sorted indices)
    for j in range(n - 1, -1, -1):
        d = Ux[Up[j + 1] - 1]
        for r in range(k):
            y[j, r] /= d
        for q in range(Up[j], Up[j + 1] - 1):
            i = Ui[q]
            uv = Ux[q]
            for r in range(k):
                y[i, r] -= uv * y[j, r]
    for i in range(n):
        pc = perm_c[i]
        for r in range(k):
            x[i, r] = y[pc, r]


@njit(cache=True)
def _lu_solve1(Lp, Li, Lx, Up, Ui, Ux, perm_r, perm_c, b, x, y):
    """Single right-hand side version of _lu_solve."""
    n = b.shape[0]
    for i in range(n):
        y[perm_r[i]] = b[i]
    for j in range(n):
        yj = y[j] / Lx[Lp[j]]
        y[j] = yj
        for q in range(Lp[j] + 1, Lp[j + 1]):
            y[Li[q]] -= Lx[q] * yj
    for j in range(n - 1, -1, -1):
        yj = y[j] / Ux[Up[j + 1] - 1]
        y[j] = yj
        for q in range(Up[j], Up[j + 1] - 1):
            y[Ui[q]] -= Ux[q] * yj
    for i in range(n):
        x[i] = y[perm_c[i]]


class SparseFactor:
    """Direct factorisation of a sparse (ndof x ndof) matrix.

    symmetric=True: SuperLU with MMD ordering on A^T + A, symmetric mode, no pivoting
    (the effective matrices of the condensed method are SPD); otherwise partial pivoting.
    ``solve(b)`` accepts (n,) or (n, k).  ``fast=False`` uses SuperLU's own solve.
    """

    def __init__(self, A, symmetric: bool = True, fast: bool = True):
        A = sp.csc_matrix(A)
        if symmetric:
            lu = spl.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                          options=dict(SymmetricMode=True))
        else:
            lu = spl.splu(A, permc_spec="MMD_AT_PLUS_A")
        self._lu = lu
        self.shape = A.shape
        self.fast = fast
        if fast:
            L = lu.L.tocsc()
            U = lu.U.tocsc()
            L.sort_indices()
            U.sort_indices()
            self._L = (L.indptr.astype(np.int64), L.indices.astype(np.int64), L.data)
            self._U = (U.indptr.astype(np.int64), U.indices.astype(np.int64), U.data)
            self._pr = lu.perm_r.astype(np.int64)
            self._pc = lu.perm_c.astype(np.int64)

    def solve(self, b):
        if not self.fast:
            return self._lu.solve(b)
        b = np.asarray(b, dtype=np.float64)
        if b.ndim == 1:
            x = np.empty_like(b)
            _lu_solve1(*self._L, *self._U, self._pr, self._pc, b, x, np.empty_like(b))
            return x
        vec = False
        b2 = np.ascontiguousarray(b.reshape(b.shape[0], -1))
        x = np.empty_like(b2)
        y = np.empty_like(b2)
        _lu_solve(*self._L, *self._U, self._pr, self._pc, b2, x, y)
        return x[:, 0] if vec else x
