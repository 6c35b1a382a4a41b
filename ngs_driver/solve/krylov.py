"""The r x r interface Newton system of the condensed solver (solve/condensed.py
``CondensedNewton.jacobian_solve``):

    H z = v,     H = Y^-1 + P     (Y^-1 dense symmetric, P sparse CSR; r = 224 on Koyna)

solved by GMRES right-preconditioned with the LU of an earlier H (an earlier iteration or step
of the same step size), to a true relative residual ``tol``; when that does not happen within
``mmax`` iterations the caller factorises H afresh. Why GMRES and not iterative refinement on
the earlier LU (tried before GMRES; CHANGELOG.md): with the paper's law every point's tangent
moves at every step, so the earlier LU is a good preconditioner but not a contraction fast
enough for refinement, which then gave up and factorised in most solves of the strong
motion; GMRES converges in a few iterations on the same preconditioned operator
(docs/solver.md §2.3, measured in CHANGELOG.md).

Kernels only (numba, no checks, no allocation): the caller owns the work arrays.
``lu`` is LAPACK getrf's output of an (r, r) matrix, passed as its transpose ``luT`` (C order)
with the 0-based pivots of scipy's wrapper.
"""
from __future__ import annotations

import math

from numba import njit

__all__ = ["lu_solve_into", "gmres_lu", "h_residual"]


@njit(cache=True)
def lu_solve_into(luT, piv, b, x):
    """x = H^-1 b from getrf's P H = L U (luT[j, i] = lu[i, j]; column-oriented, so every inner
    loop runs over contiguous memory and vectorises)."""
    n = b.shape[0]
    for i in range(n):
        x[i] = b[i]
    for i in range(n):
        p = piv[i]
        if p != i:
            t = x[i]
            x[i] = x[p]
            x[p] = t
    for j in range(n):                      # L y = P b, L unit lower (column j below j)
        yj = x[j]
        col = luT[j, j + 1:]                # views from 0: numba vectorises loops that start
        xs = x[j + 1:]                      # at 0, not range(j + 1, n) (measured 5 vs 30 us)
        for i in range(col.shape[0]):
            xs[i] -= col[i] * yj
    for j in range(n - 1, -1, -1):          # U x = y (column j above j)
        col = luT[j]
        xj = x[j] / col[j]
        x[j] = xj
        for i in range(j):
            x[i] -= col[i] * xj


@njit(cache=True)
def _h_mul(Hd, Pp, Pi, Px, x, out):
    """out = (Hd + P) x, Hd symmetric (its rows are its columns: axpy form, vectorised)."""
    n = x.shape[0]
    for i in range(n):
        out[i] = 0.0
    for j in range(n):
        xj = x[j]
        row = Hd[j]
        for i in range(n):
            out[i] += row[i] * xj
    for i in range(n):
        acc = 0.0
        for q in range(Pp[i], Pp[i + 1]):
            acc += Px[q] * x[Pi[q]]
        out[i] += acc


@njit(cache=True)
def h_residual(Hd, Pp, Pi, Px, x, v, work):
    """|v - (Hd + P) x| (work (r,) is overwritten)."""
    _h_mul(Hd, Pp, Pi, Px, x, work)
    s = 0.0
    for i in range(v.shape[0]):
        d = v[i] - work[i]
        s += d * d
    return math.sqrt(s)


@njit(cache=True)
def gmres_lu(luT, piv, Hd, Pp, Pi, Px, Px0, v, tol, mmax, x, V, Z, Hh, cs, sn, gv, w):
    """GMRES on H z = v, H = Hd + P, right-preconditioned by the LU (luT, piv) of
    H0 = Hd + P0 (P0 with the values Px0 on P's pattern), from z = 0. The preconditioned
    operator is applied as H H0^-1 y = y + (P - P0) H0^-1 y: one LU solve and a sparse product
    per iteration, the dense Hd is only used for the final true residual. Arnoldi with
    modified Gram-Schmidt applied twice. On success x holds z with the true residual
    |v - H z| <= tol |v| and the number of iterations is returned; -1 if the estimated
    residual did not reach tol in ``mmax`` iterations, -2 if it did but the true residual
    did not (x is then meaningless). Work: V (mmax+1, r), Z (mmax, r), Hh (mmax+1, mmax),
    cs, sn (mmax,), gv (mmax+1,), w (r,)."""
    n = v.shape[0]
    beta = 0.0
    for i in range(n):
        beta += v[i] * v[i]
    beta = math.sqrt(beta)
    if beta == 0.0:
        for i in range(n):
            x[i] = 0.0
        return 0
    for i in range(n):
        V[0, i] = v[i] / beta
    for k in range(mmax + 1):
        gv[k] = 0.0
    gv[0] = beta
    for j in range(mmax):
        lu_solve_into(luT, piv, V[j], Z[j])
        zj = Z[j]
        for i in range(n):
            acc = V[j, i]
            for q in range(Pp[i], Pp[i + 1]):
                acc += (Px[q] - Px0[q]) * zj[Pi[q]]
            w[i] = acc
        for k in range(j + 2):
            Hh[k, j] = 0.0
        for _ in range(2):                    # modified Gram-Schmidt, twice
            for k in range(j + 1):
                d = 0.0
                for i in range(n):
                    d += V[k, i] * w[i]
                Hh[k, j] += d
                for i in range(n):
                    w[i] -= d * V[k, i]
        hn = 0.0
        for i in range(n):
            hn += w[i] * w[i]
        hn = math.sqrt(hn)
        Hh[j + 1, j] = hn
        for k in range(j):                    # earlier rotations on the new column
            t = cs[k] * Hh[k, j] + sn[k] * Hh[k + 1, j]
            Hh[k + 1, j] = -sn[k] * Hh[k, j] + cs[k] * Hh[k + 1, j]
            Hh[k, j] = t
        den = math.hypot(Hh[j, j], Hh[j + 1, j])
        if den == 0.0:
            return -1
        cs[j] = Hh[j, j] / den
        sn[j] = Hh[j + 1, j] / den
        Hh[j, j] = den
        Hh[j + 1, j] = 0.0
        gv[j + 1] = -sn[j] * gv[j]
        gv[j] = cs[j] * gv[j]
        if abs(gv[j + 1]) <= tol * beta or hn == 0.0:
            m = j + 1
            for k in range(m - 1, -1, -1):    # y = R^-1 g (kept in gv)
                s = gv[k]
                for q in range(k + 1, m):
                    s -= Hh[k, q] * gv[q]
                gv[k] = s / Hh[k, k]
            for i in range(n):
                x[i] = 0.0
            for k in range(m):
                yk = gv[k]
                for i in range(n):
                    x[i] += yk * Z[k, i]
            if h_residual(Hd, Pp, Pi, Px, x, v, w) <= tol * beta:
                return m
            return -2
        for i in range(n):
            V[j + 1, i] = w[i] / hn
    return -1
