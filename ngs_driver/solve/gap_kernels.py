"""Compiled pieces of one iteration of the condensed Newton on the interface gaps
(solve/condensed.py ``CondensedNewton.attempt``; docs/solver.md §2.3).

An iteration evaluated the residual in about a dozen numpy calls (phi = t - K0 g, the active
mask, W phi scattered on the active points, G^T (.), G (.), g - g_lin + c (.)) and formed the
direction's blocks E = T - K0 (zero at inactive points) in three more: each of them a few
microseconds of work and as much of dispatch. Here they are two calls around the dense
product with Y (kept in numpy: BLAS, as before); the direction's x = b - G z with its
finiteness test and the scatter of P into H are one call each. Every number is the same expression in the
same order as the numpy code it replaces (sparse rows summed in stored order, as ``csr_mv``),
so the iterates are bit for bit those of that code (``tests/test_gap_kernels.py``).

Kernels only (numba, no checks): the caller owns the output arrays.
"""
from __future__ import annotations

import math

from numba import njit

__all__ = ["gap_phi", "gap_residual", "active_blocks", "scatter_add", "push_back"]


@njit(cache=True)
def gap_phi(t, g, k0v, wd, tol, act, GTp, GTi, GTx, phi, newly, wphi, y):
    """phi = t - k0v g (t flat (2 npts,)); newly[p] = not act[p] and p's phi is not round-off
    of K0 g (``JointOperator.phi_mask``: |phi| > tol (k0 |g|) + 1e-300 at either component);
    wphi = W phi at the points active after that (act or newly), 0 elsewhere; y = G^T wphi.
    Returns the number of newly active points and whether some point is active."""
    npts = act.shape[0]
    nnew = 0
    anyact = False
    for p in range(npts):
        i = 2 * p
        f0 = t[i] - k0v[i] * g[i]
        f1 = t[i + 1] - k0v[i + 1] * g[i + 1]
        phi[i] = f0
        phi[i + 1] = f1
        a = act[p]
        nw = False
        if not a:
            m0 = abs(f0) > tol * (k0v[i] * abs(g[i])) + 1e-300
            m1 = abs(f1) > tol * (k0v[i + 1] * abs(g[i + 1])) + 1e-300
            nw = m0 or m1
        newly[p] = nw
        if nw:
            nnew += 1
        if a or nw:
            anyact = True
            wphi[i] = wd[i] * f0
            wphi[i + 1] = wd[i + 1] * f1
        else:
            wphi[i] = 0.0
            wphi[i + 1] = 0.0
    if anyact:
        for r in range(y.shape[0]):
            acc = 0.0
            for q in range(GTp[r], GTp[r + 1]):
                acc += GTx[q] * wphi[GTi[q]]
            y[r] = acc
    return nnew, anyact


@njit(cache=True)
def gap_residual(g, g_lin, c, Gp, Gi, Gx, x, R):
    """R = (g - g_lin) + c (G x) (G in CSR, rows summed in stored order). Its norm is left to
    numpy (BLAS's order of summation, as before)."""
    for i in range(R.shape[0]):
        acc = 0.0
        for q in range(Gp[i], Gp[i + 1]):
            acc += Gx[q] * x[Gi[q]]
        R[i] = (g[i] - g_lin[i]) + c * acc


@njit(cache=True)
def active_blocks(T, k0blk, act, E):
    """E = T - K0 at the active points, 0 elsewhere ((npts, 2, 2) blocks)."""
    for p in range(act.shape[0]):
        if act[p]:
            for a in range(2):
                for b in range(2):
                    E[p, a, b] = T[p, a, b] - k0blk[p, a, b]
        else:
            for a in range(2):
                for b in range(2):
                    E[p, a, b] = 0.0


@njit(cache=True)
def scatter_add(flat, pos, vals):
    """flat[pos[k]] += vals[k] (distinct positions: numpy's ``flat[pos] += vals``)."""
    for k in range(pos.shape[0]):
        flat[pos[k]] += vals[k]


@njit(cache=True)
def push_back(b, Gp, Gi, Gx, z, x):
    """x = b - G z (G in CSR, rows summed in stored order, as ``csr_mv``); returns whether
    every entry of x is finite."""
    fin = True
    for i in range(x.shape[0]):
        acc = 0.0
        for q in range(Gp[i], Gp[i + 1]):
            acc += Gx[q] * z[Gi[q]]
        xi = b[i] - acc
        x[i] = xi
        if not math.isfinite(xi):
            fin = False
    return fin
