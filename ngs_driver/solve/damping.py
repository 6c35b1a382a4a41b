"""Rayleigh damping whose mass term does not act on the sliding and rocking of the blocks, and
the factor that solves with it.

``damping.model = "rayleigh_deformation"`` (docs/sliding.md): C = a0 D^T M D + a1 K with

    D v = v - sum_j Rt_j c_j(v),     c_j(v) = (J_j^T W_j J_j)^-1 J_j^T W_j (B_j v),

c_j the rigid motion (two translations and a rotation about the centroid of the block above
joint j) that fits, in the least-squares sense weighted by the integration weights W_j, the
gap rates B_j v at the points of joint j (J_j: the gap rate (N, T) of a unit rigid motion at
each point), and Rt_j that rigid motion applied to every dam block above joint j (a block
rides on all the joints below it: its rigid velocity is the sum of theirs). A stack of blocks
that slides or rocks on its joints as rigid bodies has D v = 0: the mass term no longer acts
as a dashpot between them and the ground (Hall 2006, Earthquake Engng Struct. Dyn. 35:525); a
bonded joint has B_j v ~ 0, and the mass term is Rayleigh's a0 M. (The M-orthogonal projection
onto the blocks' rigid motions, M - M R (R^T M R)^-1 R^T M, was tried and rejected: it also
removes the mass damping of a bonded cantilever's first mode, whose mass-weighted mean motion
is a translation and a rotation; measured on Koyna it raised the linear crest peak by 31 %.)

D^T M D = M + U W U^T with U = [M Rt, G^T] (n x 6 per joint, G the stacked c_j operators) and
W = [[0, -I], [-I, Rt^T M Rt]]: C = C_s + a0 U W U^T, C_s = a0 M + a1 K sparse. The effective
matrix of a step, A = A_s + U W' U^T (W' = c c1 a0 W), is solved by the Sherman-Morrison-
Woodbury identity on the sparse factor of A_s:

    A^-1 b = A_s^-1 (b + U Q Z^T b),   Z = A_s^-1 U,   Q = -W' (I + U^T Z W')^-1,

a change of the right-hand side only (A_s symmetric: U^T A_s^-1 b = Z^T b), so the split
forward/backward solves of the condensed method keep their structure: ``LowRankFactor`` adds
F U Q Z^T b to the forward half (F U = L^-1 Pr U, kept).
"""
from __future__ import annotations

import numpy as np

__all__ = ["DeformationDamping", "LowRankFactor"]


class DeformationDamping:
    """The dense rank-6-per-joint part of C: C = C_s + a0 U W U^T (module docstring).

    M (n, n) sparse; R (n, 3 nb) the rigid modes of each dam block (bottom up, each about its
    own centroid, zero off the block); centroids (nb, 2); B (2 npts, n) the joints' gap
    operator, x, y, w the points' coordinates and weights, slices[j] the points of joint j
    (the base first: joint j carries the blocks j, j+1, ...); a0 the mass coefficient."""

    def __init__(self, M, R, centroids, B, x, y, w, slices, a0: float):
        R = np.asarray(R, dtype=np.float64)
        n = M.shape[0]
        nb = centroids.shape[0]
        if R.shape != (n, 3 * nb) or len(slices) < nb:
            raise ValueError(f"rigid modes {R.shape}, {nb} blocks, {len(slices)} joints for "
                             f"{n} DOFs")
        nj = nb
        Rt = np.zeros((n, 3 * nj))
        Gt = np.zeros((n, 3 * nj))
        for j in range(nj):
            xc, yc = centroids[j]
            for b in range(j, nb):          # the blocks above joint j, about block j's centroid
                tx, ty, rot = R[:, 3 * b], R[:, 3 * b + 1], R[:, 3 * b + 2]
                xb, yb = centroids[b]
                Rt[:, 3 * j] += tx
                Rt[:, 3 * j + 1] += ty
                Rt[:, 3 * j + 2] += rot + (yc - yb) * tx + (xb - xc) * ty
            sl = slices[j]
            xp, yp, wp = x[sl], y[sl], w[sl]
            m = xp.size
            J = np.zeros((2 * m, 3))           # gap rate (N, T) of a unit rigid motion
            J[0::2, 1] = 1.0
            J[0::2, 2] = xp - xc
            J[1::2, 0] = 1.0
            J[1::2, 2] = -(yp - yc)
            wd = np.repeat(wp, 2)
            JW = (J * wd[:, None]).T           # (3, 2m)
            Bj = B[2 * sl.start:2 * sl.stop]
            G = np.linalg.solve(JW @ J, np.asarray((Bj.T @ JW.T)).T)    # (3, n)
            Gt[:, 3 * j:3 * j + 3] = G.T
        MRt = np.asarray(M @ Rt)
        k = 3 * nj
        W = np.zeros((2 * k, 2 * k))
        W[:k, k:] = -np.eye(k)
        W[k:, :k] = -np.eye(k)
        W[k:, k:] = Rt.T @ MRt
        self.U = np.ascontiguousarray(np.hstack([MRt, Gt]))
        self.W = 0.5 * (W + W.T)
        self.a0 = float(a0)

    @property
    def rank(self) -> int:
        return self.U.shape[1]

    def product(self, y):
        """a0 U W U^T y (added to C_s y)."""
        return self.U @ (self.a0 * (self.W @ (self.U.T @ y)))

    def work(self, du, vs) -> float:
        """du . a0 U W U^T vs (added to the budget's du . C_s vs)."""
        return self.a0 * float((self.U.T @ du) @ (self.W @ (self.U.T @ vs)))


class LowRankFactor:
    """A^-1 for A = A_s + U W U^T given the (restricted) ``SparseFactor`` F of A_s; offers
    what the condensed solver uses of a factor: forward, backward, backward_at,
    forward_sparse, solve, solve_at (module docstring). dofs: the DOFs F was restricted to."""

    def __init__(self, F, U, W, dofs=None):
        self.F = F
        U = np.ascontiguousarray(U, dtype=np.float64)
        self.shape = F.shape
        self.Z = F.solve(U)                                     # A_s^-1 U
        self.FU = np.column_stack([F.forward(U[:, j]) for j in range(U.shape[1])])
        m = U.shape[1]
        self.Q = -W @ np.linalg.inv(np.eye(m) + (U.T @ self.Z) @ W)
        self._ZI = None if dofs is None else self.Z[np.asarray(dofs, np.int64)]

    def forward(self, b):
        return self.F.forward(b) + self.FU @ (self.Q @ (self.Z.T @ b))

    def backward(self, z):
        return self.F.backward(z)

    def backward_at(self, z):
        return self.F.backward_at(z)

    def forward_sparse(self, bd):
        bd = np.asarray(bd, np.float64)
        return self.F.forward_sparse(bd) + self.FU @ (self.Q @ (self._ZI.T @ bd))

    def solve(self, b):
        b = np.asarray(b, dtype=np.float64)
        return self.F.solve(b) + self.Z @ (self.Q @ (self.Z.T @ b))

    def solve_at(self, bd):
        bd = np.asarray(bd, np.float64)
        return self.F.solve_at(bd) + self._ZI @ (self.Q @ (self._ZI.T @ bd))
