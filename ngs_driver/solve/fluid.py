"""Compressible water in the joint solver: the pressure is eliminated exactly inside every step
(docs/reservoir.md §4). Both classes here are coupled fields (solve/coupled.py
``CoupledField``), given to ``JointSolver(..., coupled=...)``.

For a step of size h (coefficients c0..c5 of ``JointSolver.coefficients``) the fluid rows of
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

from .kernels import fluid_bp, fluid_commit, fluid_drift, fluid_face, mv
from .products import FusedPair
from .sparse import SparseFactor


def _unsigned(A):
    """(indptr, indices, data) of the CSR matrix A with unsigned indices (uint32 row pointers,
    uint16 columns while they fit): numba tests a signed index for Python's negative
    wraparound in the row loops, an unsigned one not; the sums and their order are the same
    (bitwise), ``fluid_bp`` and ``fluid_drift`` ~1.8x faster on Koyna's water (0.018 against
    0.010 ms each, measured)."""
    small = A.shape[1] <= np.iinfo(np.uint16).max
    wide = A.nnz > np.iinfo(np.uint32).max
    return (A.indptr.astype(np.uint64 if wide else np.uint32),
            A.indices.astype(np.uint16 if small else np.uint32), A.data)


def _canonical_csr(A):
    """A as a CSR matrix with sorted, summed indices: ``mv`` on it sums each row in the order
    of scipy's ``A @ x`` (CSR rows in stored order; a CSC matrix's columns ascending), so the
    products are bitwise scipy's without its per-call dispatch (~15 us a call; the water's
    products are a few microseconds of work)."""
    A = sp.csr_matrix(A, dtype=np.float64, copy=True)
    A.sum_duplicates()
    A.sort_indices()
    return A


class FluidStepper:
    """The compressible water as a coupled field (solve/coupled.py): ``matrix(h)``, ``rhs(h)``,
    ``commit(h)``, ``checkpoint()``, ``restore(d)``; the solver binds itself at construction.
    ground(t) -> (a_gx, a_gy) at time t (linear between record samples, as the solver
    interpolates its loads)."""

    def __init__(self, acoustic, ground, g=None):
        self.ac = acoustic
        self.solver = None                            # the solver that binds this field
        self._ground = ground
        self._ag = {}          # time -> ground(time): a step asks for the same times 5 times
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
        # the per-step products in compiled form (``_canonical_csr``): G, C_f, H, Q and Q^T
        # restricted to the face rows (Q^T u reads u at ``rows`` only)
        self._G, self._Cf, self._H = (_canonical_csr(X) for X in (W.G, W.Cf, W.H))
        self._Qf = _canonical_csr(self.Qf)
        self._QfT = _canonical_csr(self.Qf.T)
        # their (indptr, indices, data) for the compiled step (solve/kernels.py ``fluid_*``),
        # the indices unsigned (``_unsigned``)
        self._Gt, self._Cft, self._Ht, self._QfTt, self._Qft = (
            _unsigned(A) for A in (self._G, self._Cf, self._H, self._QfT, self._Qf))
        # H pi and G p of the energy terms in one compiled pass (bitwise the two products)
        self._HG = FusedPair(self._H, self._G)
        self._sd = None        # (h, time, p, pd, pdd, a, value) of the last ``_scheme_drift``
        self._cache = {}
        self._bp = None
        # the water's energy (see energy_terms): pi = int p dt, V = int a_g dt (trapezoid per
        # committed (sub)step, as the scheme), the radiated / absorbed energy and the ground's
        # work on the water, accumulated from the start of the dynamics
        self.pi = np.zeros(n)
        self._V = np.zeros(2)
        self._acc = np.zeros(3)                     # E_radiated, E_absorbed, W_water
        self._c0 = None                             # constant of the integrated fluid rows
        # the integrator's share (HHT, generalized alpha): the drift R of the once-integrated
        # rows from c at the last commit (None: to be formed from the state) and its work
        self._R = None
        self._corr0 = 0.0
        self._alg = 0.0
        Cf_far = getattr(W, "Cf_far", None)
        self._Cfar = Cf_far if Cf_far is not None else sp.csr_matrix(W.Cf.shape)
        self._Cfar = _canonical_csr(self._Cfar)
        # C_far pm and C_f pm of ``_book`` in one compiled pass (bitwise the two products)
        self._CC = FusedPair(self._Cfar, self._Cf)

    def bind(self, solver):
        """Called once by the solver's constructor (solve/coupled.py)."""
        self.solver = solver

    def ground(self, t):
        """(a_gx, a_gy) at time t, remembered for the last few times (the step's start and end
        are asked for by ``rhs``, ``_scheme_drift`` and ``_book``; each ask interpolates the
        record twice)."""
        ag = self._ag.get(t)
        if ag is None:
            ag = self._ground(t)
            if len(self._ag) >= 8:
                self._ag.pop(next(iter(self._ag)))
            self._ag[t] = ag
        return ag

    # -- per step size ------------------------------------------------------------------------
    def _entry(self, h):
        key = float(h)
        e = self._cache.get(key)
        if e is None:
            c0, c1 = self.solver.coefficients(h)[:2]
            cf, cm = self._weights()
            W = self.ac.W
            if cf == 1.0 and cm == 1.0:
                App = (c0 * W.G + c1 * W.Cf + W.H).tocsc()
            else:
                App = ((cm * c0) * W.G + cf * (c1 * W.Cf + W.H)).tocsc()
            # App is symmetric positive definite (water mass, radiation damping, Laplacian):
            # the numba LDL^T solves of solve/sparse.py, 0.034 ms against SuperLU's own solve
            # 0.052 ms per step on the Koyna reservoir (1 009 pressure DOFs, medians of 200)
            fac = SparseFactor(App)
            X = fac.solve(np.ascontiguousarray(self.Qf.T.toarray()))     # (np, nf)
            blk = c0 * self.ac.rho * (self.Qf @ X)
            if cf != 1.0 or cm != 1.0:
                blk = (cf * cm) * blk
            blk = 0.5 * (blk + blk.T)
            nu = self.solver.ndof
            I, J = np.meshgrid(self.rows, self.rows, indexing="ij")
            Mblk = sp.csr_matrix((blk.ravel(), (I.ravel(), J.ravel())), shape=(nu, nu))
            e = (fac, X, Mblk)
            self._cache[key] = e
            if len(self._cache) > 8:
                self._cache.pop(next(iter(self._cache)))
        return e

    def _weights(self):
        """(1 - alpha_f, 1 - alpha_m) of the solver's integrator (1, 1: Newmark)."""
        it = self.solver.integrator
        return 1.0 - it.alpha_f, 1.0 - it.alpha_m

    def matrix(self, h):
        return self._entry(h)[2]

    def _start(self):
        """p = p' = 0 at rest; p'' from G p'' = -rho Q^T u'' - rho g a_g (compressible)."""
        s, ac = self.solver, self.ac
        agx, agy = self.ground(s.time)
        r = -ac.rho * (ac.Q.T @ s.a + self.g[0] * agx + self.g[1] * agy)
        self.pdd = spl.splu(ac.W.G.tocsc()).solve(r) if ac.W.G.nnz else np.zeros_like(r)
        self._c0 = ac.W.G @ self.pd + ac.W.Cf @ self.p + ac.rho * (ac.Q.T @ s.v)

    def rhs(self, h):
        s, ac = self.solver, self.ac
        if self.pdd is None:
            self._start()
        if self._R is None:
            self._R = self._drift()
        self._corr0 = self._scheme_drift(h)
        c0, c1, c2, c3, c4, c5 = s.coefficients(h)
        agx, agy = self.ground(s.time + h)
        cf, cm = self._weights()
        fac = self._entry(h)[0]
        r = self.rows                      # Q^T reads the face rows only
        alpha = not (cf == 1.0 and cm == 1.0)
        am, af = 1.0 - cm, 1.0 - cf
        if alpha:
            # HHT / generalized alpha (solve/integrator.py): the fluid rows weighted as the
            # structure's, (1 - am) [G p'' + rho Q^T u'']_{n+1} + am [...]_n + (1 - af) [C_f
            # p' + H p]_{n+1} + af [...]_n = -rho g [(1 - af) a_g(t_{n+1}) + af a_g(t_n)]
            agx0, agy0 = self.ground(s.time)
            X, Y = cf * agx + af * agx0, cf * agy + af * agy0
        else:                              # Newmark: the fluid rows at t_{n+1}
            X, Y = agx, agy
        # b_p = G (c0 p + c2 p' + c3 p'') + C_f (c1 p + c4 p' + c5 p'') + rho Q^T (c0 u + c2 u'
        # + c3 u'') - rho g a_g (Newmark; the weighted form for alpha) in one compiled call,
        # bitwise the numpy expressions (solve/kernels.py ``fluid_bp``)
        wA, wB, bp = np.empty(self.p.size), np.empty(self.p.size), np.empty(self.p.size)
        fluid_bp(self._Gt, self._Cft, self._Ht, self._QfTt, self.p, self.pd, self.pdd,
                 s.u[r], s.v[r], s.a[r], self.g[0], self.g[1], np.array([c0, c2, c3]),
                 np.array([c1, c4, c5]), np.array([c0, c2, c3]), cm, am, cf, af, ac.rho, X, Y,
                 alpha, wA, wB, np.empty(r.size), bp)
        y = fac.solve(bp)
        self._bp = (float(h), y)
        # the structure sees Q p_{n+1} (alpha: (1 - af) Q p_{n+1} + af Q p_n), zero off the
        # face rows exactly
        out = np.zeros(s.ndof)
        fluid_face(self._Qft, y, self.p, cf, af, alpha, r, out)
        return out

    def commit(self, h):
        s = self.solver
        c0, c1, c2, c3, c4, c5 = s.coefficients(h)
        hk, y = self._bp
        assert hk == float(h)
        X = self._entry(h)[1]
        cm = self._weights()[1]
        cc = c0 if cm == 1.0 else cm * c0
        xu = X @ s.u[self.rows]
        # p, p', p'', pi and the step's mean pressure in one compiled pass (bitwise numpy's
        # p_new = y - cc rho X u_f, the Newmark relations, pm = (p + p_new)/2, dpi = h pm)
        n = self.p.size
        p_new, pm, dpi, pd, pdd, pi = (np.empty(n) for _ in range(6))
        fluid_commit(y, xu, cc * self.ac.rho, self.p, self.pd, self.pdd, self.pi, c0, c2, c3,
                     h, 1 - s.gamma, s.gamma, p_new, pm, dpi, pd, pdd, pi)
        self._book(h, pm, dpi, pi)
        self.pd = pd
        self.pdd = pdd
        self.p = p_new
        # the integrator's work in the water (``_book``): R moves as the scheme's algebra says
        R = self._R + (self._scheme_drift(h) - self._corr0)
        self._alg -= float(self._dpi @ (0.5 * (self._R + R))) / self.ac.rho
        self._R = R

    def _scheme_drift(self, h):
        """The drift's part that the scheme's algebra fixes at the committed state, for steps
        of size h: h [d_m E'' + d_f Phi] + h^2 (beta - gamma/2) C_f p'', E'' = G p'' + rho
        Q^T u'', Phi = C_f p' + H p + rho g a_g (the rows' terms), d_m = gamma - 1 + alpha_m,
        d_f = alpha_f - 1/2 (both alpha_f - 1/2 for HHT and generalized alpha). Summing the
        weighted rows and the Newmark relations over steps of one size h leaves R minus this
        term constant (checked per step to the Newton tolerance). With Newmark the rows hold
        at every step end, E'' + Phi = 0 there, and the term vanishes (beta = gamma / 2 for
        average acceleration). A change of h shifts R by the difference of this term at
        that state."""
        it, s, ac = self.solver.integrator, self.solver, self.ac
        sd = self._sd            # the commit's value, asked again by the next step's ``rhs``
        if (sd is not None and sd[0] == h and sd[1] == s.time and sd[2] is self.p
                and sd[3] is self.pd and sd[4] is self.pdd and sd[5] is s.a):
            return sd[6]         # (the arrays are replaced at a commit, never changed in place)
        dm, df, db = it.gamma - 1.0 + it.alpha_m, it.alpha_f - 0.5, it.beta - 0.5 * it.gamma
        agx, agy = self.ground(s.time)
        # h (dm e2 + df phi) + h^2 db C_f p'', e2 = G p'' + rho Q^T a, phi = C_f p' + H p +
        # rho g a_g: one compiled call, bitwise the numpy expressions
        out = np.empty(self.p.size)
        fluid_drift(self._Gt, self._Cft, self._Ht, self._QfTt, self.p, self.pd, self.pdd,
                    s.a[self.rows], self.g[0], self.g[1], ac.rho, agx, agy, h, dm, df,
                    h * h * db, out)
        self._sd = (h, s.time, self.p, self.pd, self.pdd, s.a, out)
        return out

    def _drift(self) -> np.ndarray:
        """R = G p' + C_f p + H pi + rho Q^T u' + rho g V - c at the committed state: zero
        (to round-off) for average-acceleration Newmark, the drift of the scheme otherwise."""
        ac, W = self.ac, self.ac.W
        if self._c0 is None:
            self._c0 = np.zeros_like(self.p)
        return (W.G @ self.pd + W.Cf @ self.p + W.H @ self.pi + ac.rho * (ac.Q.T @ self.solver.v)
                + ac.rho * (self.g[0] * self._V[0] + self.g[1] * self._V[1]) - self._c0)

    # -- energy -------------------------------------------------------------------------------
    def _book(self, h, pm, dpi, pi):
        """Accumulate the step's water energy terms (before p, p', p'' move on): pm = (p0 +
        p1)/2 the step's mean pressure, dpi = h pm, pi = pi + dpi (``fluid_commit``).

        The fluid rows, summed over the steps with the trapezoid (exact for the Newmark
        relations), integrate once in time to  G p' + C_f p + H pi + rho Q^T u' + rho g V = c
        at every step end, pi = int p dt, V = int a_g dt, c from the start state. Paired with
        the structure's work of the pressure, dpi = h (p0 + p1)/2 and Q^T du = h Q^T (u'0 +
        u'1)/2 give exactly, per step,

            du . Q (p0 + p1)/2 = -Delta[(p.G p + pi.H pi) / 2 rho] - h pm.C_f pm / rho
                                 - dpi . g (V0 + V1)/2 + dpi . c / rho,   pm = (p0 + p1)/2,

        so the structure's budget closes with the water's potential energy p.G p / 2 rho
        (compression, p^2 / 2 rho c^2), kinetic energy pi.H pi / 2 rho (|grad pi|^2 / 2 rho =
        rho |v|^2 / 2), the energy leaving through the far end and absorbed by the bottom
        (h pm.C_f pm / rho) and the work of the ground on the water (the last two terms).

        HHT and generalized alpha satisfy the fluid rows at their weighted point only: the
        once-integrated rows then hold up to a drift R (``_drift``; coarse Koyna, 1 s at
        0.01 s: |R| up to 9e-4 against |H pi| 2.2, zero to 1e-10 with Newmark), and the
        identity gains the term dpi.(R_0 + R_1)/2 rho -- work the scheme, not the ground nor
        the dam, does on the water. It is booked as E_water_alg = -sum dpi.(R_0 + R_1)/2 rho
        (the water's share of the integrator's exchange; docs/run.md §9.1)."""
        s = self.solver
        if self._c0 is None:                  # a resumed run without the start state
            self._c0 = np.zeros_like(pm)
        agx0, agy0 = self.ground(s.time - h)
        agx1, agy1 = self.ground(s.time)
        V0 = self._V.copy()
        self._V += 0.5 * h * np.array([agx0 + agx1, agy0 + agy1])
        Vm = 0.5 * (V0 + self._V)
        rho = self.ac.rho
        Cfar_pm, Cf_pm = self._CC.products(pm, pm)
        far = h * float(pm @ Cfar_pm) / rho
        allc = h * float(pm @ Cf_pm) / rho
        self._acc += (far, allc - far,
                      -float(dpi @ (self.g[0] * Vm[0] + self.g[1] * Vm[1]))
                      + float(dpi @ self._c0) / rho)
        self.pi = pi
        self._dpi = dpi

    def energy_terms(self) -> dict:
        """The water's terms of the run's energy budget [J/m], from the start of the dynamics:
        kinetic pi.H pi / 2 rho, potential (compression) p.G p / 2 rho, radiated at the far
        end, absorbed at the bottom (alpha < 1), and the work of the ground on the water
        (an input, like W_ext). See ``_book``."""
        rho = self.ac.rho
        Hpi, Gp = self._HG.products(self.pi, self.p)
        return {"W_water": float(self._acc[2]),
                "E_water_kin": 0.5 * float(self.pi @ Hpi) / rho,
                "E_water_pot": 0.5 * float(self.p @ Gp) / rho,
                "E_water_radiated": float(self._acc[0]),
                "E_water_absorbed": float(self._acc[1]),
                "E_water_alg": float(self._alg)}

    def checkpoint(self) -> dict:
        """Copies of the water's state: p, p', p'' (None: at rest, before the first step), the
        integrated pressure pi and the energy accumulators."""
        return {"p": self.p.copy(), "pd": self.pd.copy(),
                "pdd": None if self.pdd is None else self.pdd.copy(), "pi": self.pi.copy(),
                "energy": np.concatenate([self._V, self._acc,
                                          self._c0 if self._c0 is not None
                                          else np.zeros_like(self.p)]),
                "energy_alg": np.array([self._alg]),
                "energy_drift": (np.array(self._R, dtype=float) if self._R is not None
                                 else np.zeros(0))}

    @property
    def drift(self):
        """The drift R of the once-integrated fluid rows as followed step by step (None until
        the first step forms it; ``recomputed_drift`` forms it from the state)."""
        return self._R

    def recomputed_drift(self) -> np.ndarray:
        """R formed afresh from the committed state (``_drift``): equal to ``drift`` to the
        Newton tolerance (tests/test_water_alpha_energy.py)."""
        return self._drift()

    def restore(self, d):
        """The state ``checkpoint()`` returned, energy accumulators included."""
        self.p, self.pd = (np.array(d[k], dtype=float) for k in ("p", "pd"))
        self.pdd = None if d["pdd"] is None else np.array(d["pdd"], dtype=float)  # None: at rest
        if "energy" in d:
            e = np.asarray(d["energy"], dtype=float)
            self.pi = np.array(d["pi"], dtype=float)
            self._V, self._acc, self._c0 = e[:2].copy(), e[2:5].copy(), e[5:].copy()
        if "energy_alg" in d:
            self._alg = float(np.asarray(d["energy_alg"]).ravel()[0])
        R = np.asarray(d.get("energy_drift", np.zeros(0)), dtype=float)
        # the drift as followed (a resumed run goes on bitwise); an older checkpoint's: formed
        # from the restored state (``rhs``)
        self._R = R.copy() if R.size == self.p.size else None


class GroundPressureLoad:
    """Incompressible water when u is total (absorbing rock boundaries: the run zeroes M r a_g):
    the pressure driven by the bottom / a rigid far end, -rho Q H^-1 b a_g(t), as a load in the
    step's right-hand side (the face part is the added mass acting on the total acceleration)."""

    def __init__(self, acoustic, ground):
        self.ground = ground
        self.solver = None                            # the solver that binds this field
        W = acoustic.W
        self.vx = -acoustic.rho * (acoustic.Q @ acoustic.solve_H(W.b_x))
        self.vy = -acoustic.rho * (acoustic.Q @ acoustic.solve_H(W.b_y))
        self._zero = None

    def bind(self, solver):
        """Called once by the solver's constructor (solve/coupled.py)."""
        self.solver = solver
        self._zero = sp.csr_matrix((solver.ndof, solver.ndof))

    def matrix(self, h):
        return self._zero

    def rhs(self, h):
        s = self.solver
        agx, agy = self.ground(s.time + h)
        af = s.integrator.alpha_f
        if af == 0.0:
            return self.vx * agx + self.vy * agy
        agx0, agy0 = self.ground(s.time)       # the load at the alpha_f point (HHT)
        return (self.vx * ((1.0 - af) * agx + af * agx0)
                + self.vy * ((1.0 - af) * agy + af * agy0))

    def commit(self, h):
        pass

    def checkpoint(self) -> dict:
        """No state of its own (the load follows the record)."""
        return {}

    def restore(self, d):
        pass
