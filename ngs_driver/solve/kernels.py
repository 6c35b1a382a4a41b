"""Compiled kernels of the joint solver: the right-hand side's vectors and products, the
Newmark update of v and a, the active-point mask, CSR products without scipy's dispatch, and the
data of the condensed interface Newton system (docs/solver.md §2). Each kernel does numpy's
operations in numpy's order, so its results are bitwise those of the numpy expressions it
replaces (tests/test_solver.py, tests/test_run_loop.py)."""
from __future__ import annotations

import numpy as np
from numba import njit

from .products import pair_products

__all__ = ["rhs_fused", "rhs_vectors", "rhs_combine", "newmark_update", "phi_mask_kernel",
           "csr_mv", "mv", "ptp_pairs", "jac_setup"]


@njit(cache=True)
def rhs_fused(indptr, indices, Mx, Cx, u, v, a, cm, cc, c, f, x, y, om, oc, rhs):
    """rhs = M (cm0 u + cm1 v + cm2 a) + c C (cc0 u + cc1 v + cc2 a) + f, bitwise numpy's
    right-hand side (``integrator.TimeDiscretisation.rhs(fused=False)``) (the same operations in the same order; the two products on one
    pattern, ``products.pair_products``)."""
    rhs_vectors(u, v, a, cm, cc, x, y)
    pair_products(indptr, indices, Mx, Cx, x, y, om, oc)
    rhs_combine(om, oc, c, f, rhs)


@njit(cache=True)
def rhs_vectors(u, v, a, cm, cc, x, y):
    """x = cm0 u + cm1 v + cm2 a, y = cc0 u + cc1 v + cc2 a (numpy's order)."""
    for i in range(u.size):
        x[i] = cm[0] * u[i] + cm[1] * v[i] + cm[2] * a[i]
        y[i] = cc[0] * u[i] + cc[1] * v[i] + cc[2] * a[i]


@njit(cache=True)
def rhs_combine(om, oc, c, f, rhs):
    """rhs = (M x + c C y) + f (numpy's order)."""
    for i in range(rhs.size):
        rhs[i] = (om[i] + c * oc[i]) + f[i]


@njit(cache=True)
def newmark_update(u, u0, v0, a0, c0, c2, c3, h, g1, g2, v_new, a_new):
    """a_new = c0 (u - u0) - c2 v0 - c3 a0, v_new = v0 + h (g1 a0 + g2 a_new) in one pass,
    bitwise numpy's expressions (the same operations in the same order)."""
    for i in range(u.size):
        an = (c0 * (u[i] - u0[i]) - c2 * v0[i]) - c3 * a0[i]
        a_new[i] = an
        v_new[i] = v0[i] + h * (g1 * a0[i] + g2 * an)


@njit(cache=True)
def phi_mask_kernel(phi, g, k0v, tol, out):
    """out[p] = |phi| > tol (k0 |g|) + 1e-300 at either gap component of point p (the same
    expression, hence the same booleans, as numpy's)."""
    for p in range(out.size):
        a = abs(phi[2 * p]) > tol * (k0v[2 * p] * abs(g[2 * p])) + 1e-300
        b = abs(phi[2 * p + 1]) > tol * (k0v[2 * p + 1] * abs(g[2 * p + 1])) + 1e-300
        out[p] = a or b


@njit(cache=True)
def csr_mv(indptr, indices, data, x, out):
    """out = A x for A in CSR (indptr, indices, data)."""
    for i in range(out.shape[0]):
        acc = 0.0
        for q in range(indptr[i], indptr[i + 1]):
            acc += data[q] * x[indices[q]]
        out[i] = acc


def mv(A, x):
    """A @ x for a scipy CSR matrix and a 1-D float vector, without scipy's per-call dispatch
    (~15 us; the interface products of a Newton iteration are a few microseconds of work)."""
    out = np.empty(A.shape[0])
    csr_mv(A.indptr, A.indices, A.data, x, out)
    return out


@njit(cache=True)
def ptp_pairs(Gp, npts):
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
def jac_setup(E, cw, b, PT, A, B, Q1, Q2, pos, Gx, GTp, GTi, GTx, Pout, tmp, v):
    """The data of one interface Newton system in one call: with Dw = E * cw[:, None, None]
    (the (npts, 2, 2) blocks c w_p (T_p - K0), formed on the fly), Pout = the values of
    G^T Dw G on its pattern (``ptp_pairs`` and positions ``pos``), tmp = Dw b (blockwise),
    v = G^T tmp (CSR rows summed in order, as ``csr_mv``)."""
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
