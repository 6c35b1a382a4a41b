"""A small, self-contained 2D plane-strain test model for the interface solver (no NGSolve).

An elastic block "dam" (width ``Wd`` x height ``Hd``) sits on an elastic block "rock"
(``Wr`` x ``Hr``); the dam's base and the rock's top are two *separate* node lines that coincide
geometrically on ``x in [x0, x0 + Wd]`` (matching nodes), coupled only by the interface law.
Structured meshes of linear triangles (P1, two per square cell, side ``h``), numpy assembly.
The rock's bottom is fixed. Returns scipy CSR matrices on the free DOFs and the interface
operator in the form the solver expects (docs/solver.md §1):

    gap of point p:  g_p = (g_N, g_T) = B[2p:2p+2] @ u     (normal from rock into dam = +y)
    interface force: B.T @ (w[:, None] * t).ravel()

Used by tests/test_solver.py and tests/bench/test_bench_solver.py; it is not the Koyna model.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

__all__ = ["ToyModel", "block_on_block"]


@dataclass
class ToyModel:
    K: sp.csr_matrix           # stiffness, free DOFs
    M: sp.csr_matrix           # consistent mass, free DOFs
    B: sp.csr_matrix           # (2 npts, ndof) gap operator
    w: np.ndarray              # (npts,) integration weights [m^2 per unit thickness]
    xi: np.ndarray             # (npts,) x coordinate of the interface points
    r_x: np.ndarray            # horizontal influence vector (1 on every free x DOF)
    gravity: np.ndarray        # dead-load vector (rho g, downwards) on the free DOFs
    crest_x: np.ndarray        # unit horizontal load spread on the dam's top edge
    crest_dof: int             # free-DOF index of u_x at the dam's top-left corner
    ndof: int
    npts: int


def _grid(nx, ny, h, x0, y0):
    xs = x0 + h * np.arange(nx + 1)
    ys = y0 + h * np.arange(ny + 1)
    X, Y = np.meshgrid(xs, ys, indexing="xy")
    nodes = np.column_stack([X.ravel(), Y.ravel()])
    idx = np.arange((nx + 1) * (ny + 1)).reshape(ny + 1, nx + 1)
    a = idx[:-1, :-1].ravel()
    b = idx[:-1, 1:].ravel()
    c = idx[1:, 1:].ravel()
    d = idx[1:, :-1].ravel()
    tris = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    return nodes, tris, idx


def _assemble(nodes, tris, E, nu, rho):
    """P1 plane-strain stiffness and consistent mass (2 DOFs per node, interleaved)."""
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    D = np.array([[lam + 2 * mu, lam, 0], [lam, lam + 2 * mu, 0], [0, 0, mu]])
    P = nodes[tris]                                   # (ne, 3, 2)
    x, y = P[..., 0], P[..., 1]
    b = np.stack([y[:, 1] - y[:, 2], y[:, 2] - y[:, 0], y[:, 0] - y[:, 1]], axis=1)
    c = np.stack([x[:, 2] - x[:, 1], x[:, 0] - x[:, 2], x[:, 1] - x[:, 0]], axis=1)
    area = 0.5 * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0])
    ne = len(tris)
    Bm = np.zeros((ne, 3, 6))
    Bm[:, 0, 0::2] = b
    Bm[:, 1, 1::2] = c
    Bm[:, 2, 0::2] = c
    Bm[:, 2, 1::2] = b
    Bm /= (2 * area)[:, None, None]
    Ke = np.einsum("eki,kl,elj->eij", Bm, D, Bm) * area[:, None, None]
    m1 = np.array([[2, 1, 1], [1, 2, 1], [1, 1, 2]]) / 12.0
    Me = np.zeros((ne, 6, 6))
    for comp in range(2):
        Me[:, comp::2, comp::2] = rho * area[:, None, None] * m1
    dofs = np.empty((ne, 6), dtype=np.int64)
    dofs[:, 0::2] = 2 * tris
    dofs[:, 1::2] = 2 * tris + 1
    rows = np.repeat(dofs, 6, axis=1).ravel()
    cols = np.tile(dofs, (1, 6)).ravel()
    n = 2 * len(nodes)
    K = sp.csr_matrix((Ke.ravel(), (rows, cols)), shape=(n, n))
    M = sp.csr_matrix((Me.ravel(), (rows, cols)), shape=(n, n))
    return K, M


def block_on_block(h: float = 0.25, *, Wd=4.0, Hd=2.0, Wr=8.0, Hr=2.0, x0=2.0,
                   E_dam=25e9, nu_dam=0.2, rho_dam=2400.0,
                   E_rock=25e9, nu_rock=0.2, rho_rock=2400.0,
                   n_gauss: int = 2, g=9.81) -> ToyModel:
    """Dam block on rock block; ``h`` the element size (Wd, Hd, Wr, Hr, x0 multiples of h)."""
    def cells(L):
        n = int(round(L / h))
        if abs(n * h - L) > 1e-9 * L:
            raise ValueError(f"block_on_block: length {L} is not a multiple of h = {h}")
        return n
    nxd, nyd, nxr, nyr, nx0 = cells(Wd), cells(Hd), cells(Wr), cells(Hr), cells(x0)
    nr, tr, idr = _grid(nxr, nyr, h, 0.0, -Hr)
    nd, td, idd = _grid(nxd, nyd, h, x0, 0.0)
    nodes = np.vstack([nr, nd])
    off = len(nr)
    Kr, Mr = _assemble(nr, tr, E_rock, nu_rock, rho_rock)
    Kd, Md = _assemble(nd, td, E_dam, nu_dam, rho_dam)
    K = sp.block_diag([Kr, Kd], format="csr")
    M = sp.block_diag([Mr, Md], format="csr")
    nn = len(nodes)
    fixed = np.zeros(2 * nn, bool)
    bottom = idr[0, :]
    fixed[2 * bottom] = True
    fixed[2 * bottom + 1] = True
    free = np.flatnonzero(~fixed)
    fmap = -np.ones(2 * nn, np.int64)
    fmap[free] = np.arange(len(free))
    K = K[free][:, free].tocsr()
    M = M[free][:, free].tocsr()
    ndof = len(free)

    # interface: rock top nodes idr[-1, nx0 + k] <-> dam bottom nodes idd[0, k] + off
    rock_top = idr[-1, nx0:nx0 + nxd + 1]
    dam_bot = idd[0, :] + off
    gp, gw = np.polynomial.legendre.leggauss(n_gauss)
    gp = 0.5 * (gp + 1.0)
    gw = 0.5 * gw
    rows, cols, vals, w, xi = [], [], [], [], []
    p = 0
    for s in range(nxd):
        for q in range(n_gauss):
            N = (1.0 - gp[q], gp[q])
            for a, Na in enumerate(N):
                for comp, row in ((1, 0), (0, 1)):            # g_N = jump u_y, g_T = jump u_x
                    for node, sign in ((dam_bot[s + a], 1.0), (rock_top[s + a], -1.0)):
                        rows.append(2 * p + row)
                        cols.append(fmap[2 * node + comp])
                        vals.append(sign * Na)
            w.append(gw[q] * h)
            xi.append(x0 + h * (s + gp[q]))
            p += 1
    B = sp.csr_matrix((vals, (rows, cols)), shape=(2 * p, ndof))
    B.sum_duplicates()

    r_x = np.zeros(ndof)
    r_x[fmap[2 * np.arange(nn)][fmap[2 * np.arange(nn)] >= 0]] = 1.0
    ones_y = np.zeros(2 * nn)
    ones_y[1::2] = 1.0
    Mfull = sp.block_diag([Mr, Md], format="csr")
    gravity = -(g * (Mfull @ ones_y))[free]
    top = idd[-1, :] + off
    crest = np.zeros(2 * nn)
    crest[2 * top] = h
    crest[2 * top[[0, -1]]] = 0.5 * h
    crest_x = crest[free] / Wd
    return ToyModel(K=K, M=M, B=B, w=np.asarray(w), xi=np.asarray(xi), r_x=r_x,
                    gravity=gravity, crest_x=crest_x, crest_dof=int(fmap[2 * top[0]]),
                    ndof=ndof, npts=p)
