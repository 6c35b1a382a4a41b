"""Compiled kernels of the joint solver: the right-hand side's vectors and products, the
Newmark update of v and a, the active-point mask, CSR products without scipy's dispatch, the
data of the condensed interface Newton system (docs/solver.md §2) and the water's step
(solve/fluid.py; docs/solver.md §6.1). Each kernel does numpy's
operations in numpy's order, so its results are bitwise those of the numpy expressions it
replaces (tests/test_solver.py, tests/test_run_loop.py)."""
from __future__ import annotations

import numpy as np
from numba import njit

from .products import pair_products

__all__ = ["rhs_fused", "rhs_vectors", "rhs_combine", "newmark_update", "phi_mask_kernel",
           "csr_mv", "mv", "ptp_pairs", "jac_setup", "rhs_alpha", "fluid_bp", "fluid_face",
           "fluid_drift", "fluid_commit"]


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


@njit(cache=True, inline="always")
def _row(indptr, indices, data, x, i):
    """(A x)[i] for A in CSR, summed as ``csr_mv`` (and scipy) do."""
    acc = 0.0
    for q in range(indptr[i], indptr[i + 1]):
        acc += data[q] * x[indices[q]]
    return acc


@njit(cache=True)
def fluid_bp(G, Cf, H, QfT, p, pd, pdd, ur, vr, ar, g0, g1, cA, cB, cu, cm, am, cf, af, rho,
             X, Y, alpha, wA, wB, ub, bp):
    """The water's step right-hand side b_p (solve/fluid.py ``FluidStepper.rhs``) in one call,
    bitwise its numpy expressions: G, Cf, H, QfT are (indptr, indices, data) of canonical CSR
    matrices (QfT: Q^T on the face rows; ur, vr, ar the structure's u, v, a there);
    cA = (c0, c2, c3), cB = (c1, c4, c5), cu = (c0, c2, c3); X, Y the ground terms. alpha
    False (Newmark): wA = c0 p + c2 p' + c3 p'', wB = c1 p + c4 p' + c5 p'', ub = c0 u + c2 v
    + c3 a, b_p = G wA + C_f wB + rho Q^T ub - rho (g0 X + g1 Y). alpha True (HHT /
    generalized alpha): wA, ub weighted cm (.) - am p'' (a), wB weighted cf (.) - af p', and
    - af H p after C_f wB."""
    for i in range(p.size):
        a = c_lin3(cA[0], p[i], cA[1], pd[i], cA[2], pdd[i])
        b = c_lin3(cB[0], p[i], cB[1], pd[i], cB[2], pdd[i])
        if alpha:
            a = cm * a - am * pdd[i]
            b = cf * b - af * pd[i]
        wA[i] = a
        wB[i] = b
    for k in range(ur.size):
        a = c_lin3(cu[0], ur[k], cu[1], vr[k], cu[2], ar[k])
        if alpha:
            a = cm * a - am * ar[k]
        ub[k] = a
    for i in range(p.size):
        s = _row(G[0], G[1], G[2], wA, i) + _row(Cf[0], Cf[1], Cf[2], wB, i)
        if alpha:
            s = s - af * _row(H[0], H[1], H[2], p, i)
        s = s + rho * _row(QfT[0], QfT[1], QfT[2], ub, i)
        bp[i] = s - rho * (g0[i] * X + g1[i] * Y)


@njit(cache=True, inline="always")
def c_lin3(a, x, b, y, c, z):
    """a x + b y + c z in numpy's order ((a x + b y) + c z)."""
    return (a * x + b * y) + c * z


@njit(cache=True)
def fluid_face(Qf, y, p, cf, af, alpha, rows, out):
    """out[rows] = Q_f y (Newmark) or cf Q_f y + af Q_f p (HHT / generalized alpha); the
    other entries of out are left as they are (zeros)."""
    for k in range(rows.size):
        v = _row(Qf[0], Qf[1], Qf[2], y, k)
        if alpha:
            v = cf * v + af * _row(Qf[0], Qf[1], Qf[2], p, k)
        out[rows[k]] = v


@njit(cache=True)
def fluid_drift(G, Cf, H, QfT, p, pd, pdd, ar, g0, g1, rho, agx, agy, h, dm, df, hhdb, out):
    """The scheme's drift term of the water (``FluidStepper._scheme_drift``) in one call:
    h (dm e2 + df phi) + hhdb C_f p'', e2 = G p'' + rho Q^T a, phi = C_f p' + H p + rho (g0
    agx + g1 agy), bitwise its numpy expressions."""
    for i in range(p.size):
        e2 = _row(G[0], G[1], G[2], pdd, i) + rho * _row(QfT[0], QfT[1], QfT[2], ar, i)
        phi = ((_row(Cf[0], Cf[1], Cf[2], pd, i) + _row(H[0], H[1], H[2], p, i))
               + rho * (g0[i] * agx + g1[i] * agy))
        out[i] = h * (dm * e2 + df * phi) + hhdb * _row(Cf[0], Cf[1], Cf[2], pdd, i)


@njit(cache=True)
def fluid_commit(y, xu, ccr, p, pd, pdd, pi, c0, c2, c3, h, g1m, g, p_new, pm, dpi, pd_new,
                 pdd_new, pi_new):
    """The water's commit (``FluidStepper.commit`` and ``_book``) elementwise, bitwise its
    numpy expressions: p_new = y - ccr xu, pm = (p + p_new) / 2, dpi = h pm, pi_new = pi +
    dpi, p''_new = c0 (p_new - p) - c2 p' - c3 p'', p'_new = p' + h ((1 - gamma) p'' + gamma
    p''_new) (g1m = 1 - gamma, g = gamma)."""
    for i in range(p.size):
        pn = y[i] - ccr * xu[i]
        p_new[i] = pn
        m = 0.5 * (p[i] + pn)
        pm[i] = m
        d = h * m
        dpi[i] = d
        pi_new[i] = pi[i] + d
        a = (c0 * (pn - p[i]) - c2 * pd[i]) - c3 * pdd[i]
        pdd_new[i] = a
        pd_new[i] = pd[i] + h * (g1m * pdd[i] + g * a)


@njit(cache=True)
def rhs_alpha(Mx, Cy, Ku, fi, Cv, f, fn, c, af, out):
    """The HHT / generalized-alpha right-hand side from its products in one pass, bitwise
    numpy's ``Mx + c Cy + (c f + af fn) - af r_n``, r_n = Ku + fi + Cv (fi = B^T W t_n)
    (``integrator.TimeDiscretisation.rhs``)."""
    for i in range(out.size):
        r = (Ku[i] + fi[i]) + Cv[i]
        out[i] = ((Mx[i] + c * Cy[i]) + (c * f[i] + af * fn[i])) - af * r
