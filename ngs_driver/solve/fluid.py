"""Compressible water in the condensed Newmark solver: the pressure is eliminated exactly inside
every step (docs/reservoir.md §4).

For a step of size h (coefficients c0..c5 of ``NewmarkSolver.coefficients``) the fluid rows of
the coupled u-p system (fe/acoustic.py) read

    A_pp p_{n+1} = b_p - c0 rho Q^T u_{n+1},     A_pp = c0 G + c1 C_f + H,
    b_p = G (c0 p + c2 p' + c3 p'')_n + C_f (c1 p + c4 p' + c5 p'')_n
          + rho Q^T (c0 u + c2 u' + c3 u'')_n - rho (g_x a_gx + g_y a_gy)(t_{n+1}),

so the structure's step equation becomes

    (A_uu + c0 rho Q A_pp^-1 Q^T) u_{n+1} + B^T W t = rhs_u + Q A_pp^-1 b_p.

The added block c0 rho Q A_pp^-1 Q^T is symmetric positive semidefinite and dense on the face
DOFs only: the effective matrix stays symmetric (SuperLU symmetric mode, factorised once per h
as before) although the u-p system is not, and the interface Newton is untouched.  Per step
one extra sparse solve with A_pp (water DOFs, factorised once per h).  After convergence
p_{n+1} = A_pp^-1 b_p - c0 rho X u_face with X = A_pp^-1 Q_f^T cached per h, and p', p'' by
the Newmark formulas.  This is algebraically the Newmark method on the coupled system, so
the average-acceleration scheme conserves the coupled energy (tests/test_reservoir_run.py).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl


class FluidStepper:
    """Hooks ``NewmarkSolver`` calls when ``solver.ext`` is set: ``matrix(h)``, ``rhs(h)``,
    ``commit(h)``.  ground(t) -> (a_gx, a_gy) at time t (linear between record samples, as the
    solver interpolates its loads)."""

    def __init__(self, acoustic, solver, ground, g=None):
        if solver.alpha_hht != 0.0:
            raise ValueError("reservoir: compressible water needs alpha_hht = 0 (Newmark)")
        self.ac = acoustic
        self.solver = solver
        self.ground = ground
        # ground forcing of the fluid rows per unit a_g: (Q^T r + b) in the relative
        # formulation, b alone when u is total (absorbing rock boundaries)
        self.g = (acoustic.g_x, acoustic.g_y) if g is None else g
        W = acoustic.W
        n = W.free.size
        self.p = np.zeros(n)
        self.pd = np.zeros(n)
        self.pdd = None                               # set from the structure at the start
        self.rows = np.unique(acoustic.Q.nonzero()[0])   # face DOFs of the structure
        self.Qf = acoustic.Q[self.rows].tocsr()           # (nf, np)
        self._cache = {}
        self._bp = None
        solver.ext = self

    # -- per step size ------------------------------------------------------------------------
    def _entry(self, h):
        key = float(h)
        e = self._cache.get(key)
        if e is None:
            c0, c1 = self.solver.coefficients(h)[:2]
            W = self.ac.W
            App = (c0 * W.G + c1 * W.Cf + W.H).tocsc()
            fac = spl.splu(App, permc_spec="MMD_AT_PLUS_A")
            X = fac.solve(np.ascontiguousarray(self.Qf.T.toarray()))     # (np, nf)
            blk = c0 * self.ac.rho * (self.Qf @ X)
            blk = 0.5 * (blk + blk.T)
            nu = self.solver.ndof
            I, J = np.meshgrid(self.rows, self.rows, indexing="ij")
            Mblk = sp.csr_matrix((blk.ravel(), (I.ravel(), J.ravel())), shape=(nu, nu))
            e = (fac, X, Mblk)
            self._cache[key] = e
            if len(self._cache) > 8:
                self._cache.pop(next(iter(self._cache)))
        return e

    def matrix(self, h):
        return self._entry(h)[2]

    def _start(self):
        """p = p' = 0 at rest; p'' from G p'' = -rho Q^T u'' - rho g a_g (compressible)."""
        s, ac = self.solver, self.ac
        agx, agy = self.ground(s.time)
        r = -ac.rho * (ac.Q.T @ s.a + self.g[0] * agx + self.g[1] * agy)
        self.pdd = spl.splu(ac.W.G.tocsc()).solve(r) if ac.W.G.nnz else np.zeros_like(r)

    def rhs(self, h):
        s, ac, W = self.solver, self.ac, self.ac.W
        if self.pdd is None:
            self._start()
        c0, c1, c2, c3, c4, c5 = s.coefficients(h)
        agx, agy = self.ground(s.time + h)
        ubar = c0 * s.u + c2 * s.v + c3 * s.a
        bp = (W.G @ (c0 * self.p + c2 * self.pd + c3 * self.pdd)
              + W.Cf @ (c1 * self.p + c4 * self.pd + c5 * self.pdd)
              + ac.rho * (ac.Q.T @ ubar) - ac.rho * (self.g[0] * agx + self.g[1] * agy))
        fac = self._entry(h)[0]
        y = fac.solve(bp)
        self._bp = (float(h), y)
        return ac.Q @ y

    def commit(self, h):
        s = self.solver
        c0, c1, c2, c3, c4, c5 = s.coefficients(h)
        hk, y = self._bp
        assert hk == float(h)
        X = self._entry(h)[1]
        p_new = y - c0 * self.ac.rho * (X @ s.u[self.rows])
        dp = p_new - self.p
        pdd = c0 * dp - c2 * self.pd - c3 * self.pdd
        self.pd = self.pd + h * ((1 - s.gamma) * self.pdd + s.gamma * pdd)
        self.pdd = pdd
        self.p = p_new

    def state(self) -> dict:
        return {"p": self.p, "pd": self.pd, "pdd": self.pdd}


class GroundPressureLoad:
    """Incompressible water when u is total (absorbing rock boundaries: the run zeroes M r a_g):
    the pressure driven by the bottom / a rigid far end, -rho Q H^-1 b a_g(t), as a load in the
    step's right-hand side (the face part is the added mass acting on the total acceleration)."""

    def __init__(self, acoustic, solver, ground):
        self.ground = ground
        self.solver = solver
        W = acoustic.W
        self.vx = -acoustic.rho * (acoustic.Q @ acoustic.solve_H(W.b_x))
        self.vy = -acoustic.rho * (acoustic.Q @ acoustic.solve_H(W.b_y))
        self._zero = sp.csr_matrix((solver.ndof, solver.ndof))
        solver.ext = self

    def matrix(self, h):
        return self._zero

    def rhs(self, h):
        agx, agy = self.ground(self.solver.time + h)
        return self.vx * agx + self.vy * agy

    def commit(self, h):
        pass

    def state(self) -> dict:
        return {}
