"""The joint solver: the structure's semi-discrete equations with nonlinear joints, advanced in
time by an implicit integrator of the Newmark family (Newmark, HHT, generalized alpha), with the
Newton on the joints' gaps (docs/solver.md, docs/architecture.md).

Equation (relative formulation, free DOFs; plane strain or plane stress, as the model's K):

    M u'' + C u' + K u + B^T W t(B u + g_0) = f(t),          f = f_static - M r a_g(t)

B (2 npts x ndof, CSR): gap of point p  g_p = (g_N, g_T) = B[2p:2p+2] @ u + g_0[2p:2p+2] (g_0
the gap offset: zero until a sliding joint is paired anew or a finite rotation corrects it,
``set_operator`` / ``set_offset``);  W = diag(w) with w (npts,) the integration weights;
t = law.evaluate(g) the interface traction (interfacelaw).

The concepts live in their own modules; this class wires them and keeps the public methods:

* solve/integrator.py   the integrator family and its algebra on M, C, K (``TimeDiscretisation``)
* solve/interface.py    the joints' operator B, w, K0 and the relative interface DOFs
* solve/newton.py       one Newton loop (``NewtonControl``), the ``Attempt`` result, full Newton
* solve/condensed.py    the condensed Newton on the gaps, factorisations per step size, the
                        interface Jacobian and its LU reuse
* solve/stepping.py     sub-steps, cuts, friction events (``StepController``), ``StepReport``
* solve/static.py       the static continuation and the relaxation at a limit load
* solve/committed.py    the committed state (``snapshot`` / ``revert``)
* solve/coupled.py      the declared interface of a coupled field (the water)
* solve/kernels.py      the compiled kernels
"""
from __future__ import annotations

import contextlib
from collections import OrderedDict
from operator import attrgetter

import numpy as np
import scipy.sparse as sp

from .committed import Committed
from .condensed import CondensedNewton
from .damping import LowRankFactor
from .integrator import Integrator, TimeDiscretisation
from .interface import JointOperator
from .newton import Attempt, FullNewton, NewtonControl, stalled
from .sparse import SparseFactor
from .static import STATIC_DURATION, StaticSolve
from .stepping import SolverError, StepController, StepReport

__all__ = ["JointSolver", "StepReport", "SolverError", "Attempt", "STATIC_DURATION"]


def _same(x):
    return x


def _committed_field(name, doc):
    """A committed field read and set through the solver (the getter in C: read every step)."""
    def set_(self, value):
        setattr(self.committed, name, value)
    return property(attrgetter(f"committed.{name}"), set_, doc=doc)


def _delegated(part, name, kind):
    """A parameter that lives in the solver's part ``part`` (read and set through the solver)."""
    def get(self):
        return getattr(getattr(self, part), name)

    def set_(self, value):
        setattr(getattr(self, part), name, kind(value))
    return property(get, set_, doc=f"``{part}.{name}``")


class JointSolver:
    """The structure with its nonlinear joints, stepped by a Newmark-family integrator with a
    Newton on the joints (condensed on the interface gaps by default); see module docstring.

    Parameters
    ----------
    K, M, C : scipy sparse (ndof, ndof) stiffness, mass, damping (C may be None = 0)
    B, w    : interface operator (2 npts, ndof) and weights (npts,)
    law     : interfacelaw.InterfaceLaw
    dt      : nominal step size [s]
    integrator : solve.integrator.Integrator (Newmark, HHT or generalized alpha); or
    beta, gamma : Newmark parameters (default average acceleration 1/4, 1/2)
    alpha_hht : HHT-alpha in [-1/3, 0]; if nonzero and beta/gamma not given they are set to
              beta = (1 - alpha)^2 / 4, gamma = 1/2 - alpha
    tol_residual : relative residual tolerance (condensed: gap residual relative to the gap
              norm; full: force residual relative to the effective load)
    tol_energy : energy criterion |dx . r_k| <= tol_energy |dx_0 . r_0| (both must hold)
    max_iter : Newton iterations per attempt before the step is cut
    stall_iterations : m > 0: a dynamic attempt is also cut when the best residual of its last
              m iterations is not below half the best before them (Newton cycling between
              active sets; ``stalled``); 0: only ``max_iter`` cuts
    min_dt  : smallest sub-step; below it SolverError is raised (default dt / 2**10)
    method  : "condensed" (default) or "full" (re-factorising reference)
    line_search : backtracking on the residual norm
    max_cache, few_max, jacobian_reuse : of the condensed method (solve/condensed.py)
    C_lowrank : None or the dense low-rank part of the damping (solve/damping.py)
    event_levels : friction events are localised by halving the sub-step up to this many
              times (solve/stepping.py); 0: off
    coupled : None or a field coupled inside every step (solve/coupled.py ``CoupledField``:
              the compressible water of solve/fluid.py)
    """

    stalled = staticmethod(stalled)

    def __init__(self, K, M, C, B, w, law, *, dt, beta=None, gamma=None, alpha_hht=0.0,
                 integrator=None, tol_residual=1e-8, tol_energy=1e-16, max_iter=25,
                 stall_iterations=0, min_dt=None, method="condensed", line_search=True, max_cache=6,
                 active_tol=1e-12, few_max=16, jacobian_reuse=True, C_lowrank=None,
                 event_levels=3, coupled=None, rayleigh=None):
        if method not in ("condensed", "full"):
            raise ValueError(f"JointSolver method = {method!r} is not allowed; allowed: "
                             "'condensed', 'full'")
        if not (-1.0 / 3.0 - 1e-12 <= alpha_hht <= 0.0):
            raise ValueError(f"JointSolver alpha_hht = {alpha_hht!r} is not allowed; "
                             "allowed: [-1/3, 0]")
        if integrator is None:          # Newmark (beta, gamma) or HHT by its alpha
            integrator = Integrator(
                "newmark" if alpha_hht == 0.0 else "hht",
                float(beta if beta is not None else (1.0 - alpha_hht) ** 2 / 4.0),
                float(gamma if gamma is not None else 0.5 - alpha_hht), -float(alpha_hht))
        elif beta is not None or gamma is not None or alpha_hht != 0.0:
            raise ValueError("JointSolver: give either integrator or beta/gamma/alpha_hht")
        self.integrator = integrator
        self.C_lowrank = C_lowrank           # None or a DeformationDamping
        if C_lowrank is not None and (C is None or method != "condensed"):
            raise ValueError("JointSolver: C_lowrank needs a sparse damping matrix C and the "
                             "condensed method")
        self.K = sp.csr_matrix(K)
        self.M = sp.csr_matrix(M)
        self.C = None if C is None else sp.csr_matrix(C)
        self.ndof = self.K.shape[0]
        self.joints = JointOperator(B, w, law, active_tol)
        self.npts = self.joints.npts
        if self.joints.B.shape != (2 * self.npts, self.ndof):
            raise ValueError(f"JointSolver B shape {self.joints.B.shape} does not match "
                             f"(2*npts, ndof) = {(2 * self.npts, self.ndof)}")
        self.alpha_hht = -integrator.alpha_f          # Hilber et al.'s sign convention
        self.alpha_m = integrator.alpha_m
        self.beta = integrator.beta
        self.gamma = integrator.gamma
        self.dt = float(dt)
        self.stall_iterations = int(stall_iterations)
        self.min_dt = float(min_dt) if min_dt is not None else self.dt / 2 ** 10
        self.method = method
        self.active_tol = float(active_tol)
        self.discretisation = TimeDiscretisation(integrator, self.K, self.M, self.C, C_lowrank,
                                                 rayleigh=rayleigh)
        self.control = NewtonControl(tol_residual, tol_energy, max_iter, line_search)
        self.newton = CondensedNewton(self.joints, self.control, self.factorise, dt=self.dt,
                                      few_max=few_max, jacobian_reuse=jacobian_reuse,
                                      max_cache=max_cache)
        self.full = FullNewton(self.joints, self.control)
        self.controller = StepController(event_levels)
        self.statics = StaticSolve()
        # callables fn(solver, h, iterations) run after every commit (h None: a static one):
        # studies observe the accepted sub-steps without touching the solver
        # (verification/debonding_step_refinement.py)
        self.commit_observers = []
        self.law = law
        self._Minv = None
        self.committed = Committed(
            u=np.zeros(self.ndof), v=np.zeros(self.ndof), a=np.zeros(self.ndof), f=None,
            time=0.0, state=law.initial_state(self.npts, 2), t=np.zeros((self.npts, 2)),
            g=np.zeros((self.npts, 2)), phi=np.zeros(2 * self.npts),
            active=np.zeros(self.npts, bool))
        self.history = []                                   # StepReport per call
        self.coupled = coupled
        if coupled is not None:
            coupled.bind(self)

    # ------------------------------------------------------------------ committed fields
    u = _committed_field("u", "committed displacement (ndof,)")
    v = _committed_field("v", "committed velocity (ndof,)")
    a = _committed_field("a", "committed acceleration (ndof,)")
    f = _committed_field("f", "load at the committed time (ndof,) or None")
    time = _committed_field("time", "committed time [s]")
    state = _committed_field("state", "committed interface state (interfacelaw)")
    t = _committed_field("t", "committed traction (npts, 2)")
    g = _committed_field("g", "committed gap of the law (npts, 2)")

    @property
    def active(self) -> np.ndarray:
        """(npts,) the committed active-point mask: points not in their initial elastic state
        (their correction t - K0 g is not round-off), which the condensed Newton iterates on."""
        return self.committed.active

    @property
    def phi(self) -> np.ndarray:
        """(2 npts,) the committed nonlinear correction t - K0 g at the active points."""
        return self.committed.phi

    # the joints' operator, read by run/ and the studies
    B = property(attrgetter("joints.B"))

    BT = property(attrgetter("joints.BT"))

    w = property(attrgetter("joints.w"))

    @property
    def k0(self):
        """(2,) the largest K0 = (k_N, k_T) of the factorised matrix over the points."""
        return self.joints.k0

    @property
    def k0p(self):
        """(npts, 2) K0 per point."""
        return self.joints.k0p

    @property
    def g_offset(self):
        """The gap's offset of a re-paired joint (``set_operator``), or None."""
        return self.joints.g_offset

    # the Newton's parameters (solve/newton.py, solve/condensed.py), settable between steps
    tol_residual = _delegated("control", "tol_residual", float)
    tol_energy = _delegated("control", "tol_energy", float)
    max_iter = _delegated("control", "max_iter", int)
    line_search = _delegated("control", "line_search", bool)
    few_max = _delegated("newton", "few_max", int)
    jacobian_reuse = _delegated("newton", "jacobian_reuse", bool)
    max_cache = _delegated("newton", "max_cache", int)

    @property
    def stats(self) -> dict:
        """Counts of the interface Jacobian's factorisations, solves, reuses and GMRES
        iterations (condensed method)."""
        return self.newton.stats

    @property
    def jacobian_kept(self) -> bool:
        """True when an LU of the interface Jacobian is kept for reuse (``forget_jacobian``)."""
        return self.newton.jacobian_kept

    # static limit loads (solve/static.py)
    relax_max = _delegated("statics", "relax_max", int)
    relax_check = _delegated("statics", "relax_check", int)
    relax_slip_max = _delegated("statics", "relax_slip_max", float)
    relax_runaway = property(lambda s: s.statics.relax_runaway)
    # friction events (solve/stepping.py)
    event_levels = _delegated("controller", "event_levels", int)

    # ------------------------------------------------------------------ set-up / parameters
    def set_operator(self, B, g_offset=None):
        """Replace the gap operator between steps (a sliding joint paired anew with the face
        below it: finite sliding, run/pairing): g = B u + g_offset. The offset that keeps the
        committed gap is formed here when ``g_offset`` is None: g_offset = g_n - B u_n. The
        effective matrices are factorised anew (they hold B^T W K0 B)."""
        B = sp.csr_matrix(B)
        if B.shape != self.joints.B.shape:
            raise ValueError(f"set_operator: B of shape {B.shape}, expected {self.joints.B.shape}")
        if g_offset is None:
            g_offset = self.g.ravel() - B @ self.u
        self.joints.set_operator(B, g_offset)
        self.newton.clear()

    def set_offset(self, g_offset):
        """Replace the gap's offset with B kept (no refactorisation): g = B u + g_offset. The
        finite-rotation kinematics (run/rotation) add the exact rigid rotation's part of the
        gap that B u linearises, once per step."""
        self.joints.set_offset(g_offset)

    def set_state(self, state):
        """Set the committed interface state before the first solve (e.g. joints that start
        cracked) and take the elastic stiffness K0 of the factorised matrix from it: the
        contact and stick stiffness at cracked points, so that a compressed, sticking cracked
        joint is linear in the condensed Newton (no active points)."""
        self.state = state
        self.joints.set_k0(self.law, np.asarray(state.debonded, bool))
        self.newton.clear()

    def set_law(self, law, refactor: bool = False):
        """Replace the interface law between steps (size-scale update).  The factorised K0
        stays that of the original law unless ``refactor``; the difference is part of phi."""
        self.law = law
        if refactor:
            self.joints.set_k0(law)
            self.newton.clear()

    def set_initial(self, u=None, v=None, a=None, f=None):
        """Set the committed fields (e.g. after a restart); the interface traction and gap are
        recomputed from the committed state without changing it."""
        cs = self.committed
        if u is not None:
            cs.u = np.array(u, dtype=float)
        if v is not None:
            cs.v = np.array(v, dtype=float)
        if a is not None:
            cs.a = np.array(a, dtype=float)
        if f is not None:
            cs.f = np.array(f, dtype=float)
        g = self.joints.gap(cs.u).reshape(-1, 2)
        t, _, _ = self.law.evaluate(np.ascontiguousarray(g), cs.state, dt=self.dt)
        cs.g, cs.t = g, t
        cs.phi = (t.ravel() - self.joints.k0v * g.ravel())
        cs.active = self.joints.phi_mask(cs.phi, g.ravel())

    def initial_acceleration(self, f):
        """Solve M a = f - C v - K u - B^T W t for the committed u, v (sets self.a, self.f)."""
        if self._Minv is None:
            self._Minv = SparseFactor(self.M)
        r = f - self.K @ self.u - self.internal_force(self.t)
        if self.C is not None:
            r -= self.discretisation.damping_product(self.v)
        self.a = self._Minv.solve(r)
        self._Minv = None                # used once per run: not kept (memory)
        self.f = np.array(f, dtype=float)
        return self.a

    # ------------------------------------------------------------------ the step's algebra
    def coefficients(self, h):
        """Newmark coefficients (c0, c1, c2, c3, c4, c5) of a step of size h:
        c0 = 1/(beta h^2), c1 = gamma/(beta h), c2 = 1/(beta h), c3 = 1/(2 beta) - 1,
        c4 = gamma/beta - 1, c5 = h (gamma/(2 beta) - 1)."""
        return self.discretisation.coefficients(h)

    def effective_matrix(self, h):
        """c0 M + c (K + c1 C) (+ the coupled field's block) for step size h, without the
        interface; None -> static K."""
        if h is None:
            return self.K
        return self.discretisation.matrix(
            h, None if self.coupled is None else self.coupled.matrix(h))

    def factorise(self, h):
        """The factor of the condensed method's effective matrix for step size h (None: the
        static K + B^T W K0 B), restricted to the interface DOFs; with the low-rank damping
        part by the Woodbury identity (solve/damping.py)."""
        J0 = self.joints
        if h is None:
            return SparseFactor(self.K + J0.BtWK0B).restrict(J0.dofs)
        c = 1.0 + self.alpha_hht
        F = SparseFactor(self.effective_matrix(h) + c * J0.BtWK0B).restrict(J0.dofs)
        if self.C_lowrank is not None:          # A = A_s + c c1 a0 U W U^T (Woodbury)
            c1 = self.coefficients(h)[1]
            lo = self.C_lowrank
            F = LowRankFactor(F, lo.U, (c * c1 * lo.a0) * lo.W, J0.dofs)
        return F

    def right_hand_side(self, h, f_next, fused: bool = True):
        """Effective right-hand side of the step of size h ending with load f_next (the
        coupled field's share included). fused=False: the numpy / scipy expressions, which the
        compiled passes equal bit for bit (tests/test_run_loop.py)."""
        rhs = self.discretisation.rhs(h, self.committed, f_next, self.internal_force, fused)
        if self.coupled is not None:
            rhs += self.coupled.rhs(h)
        return rhs

    def forget_products(self):
        """Drop the products ``step_products`` kept for the next right-hand side."""
        self.discretisation.forget_products()

    @property
    def products_kept(self) -> bool:
        """True while ``step_products``' products wait for the next right-hand side."""
        return self.discretisation.products_kept

    def law_dt(self, h):
        """The step's duration for rate-dependent laws (damage form "rate"); the static
        solve (h None) stands for the slow build-up of dead load and reservoir, taken as
        STATIC_DURATION (docs/solver.md §7)."""
        return STATIC_DURATION if h is None else h

    # ------------------------------------------------------------------ attempt and commit
    def attempt(self, h, f_next) -> Attempt:
        """One Newton attempt of the step of size h (None: static) to the load f_next from the
        committed state; nothing is committed."""
        cs = self.committed
        c = 1.0 if h is None else 1.0 + self.alpha_hht
        stall = 0 if h is None else self.stall_iterations    # not in static solves
        rhs = f_next if h is None else self.right_hand_side(h, f_next)
        with np.errstate(all="ignore"):
            if self.method == "condensed":
                if self.joints.f_off is not None:  # the gap's offset (``set_offset_force``)
                    rhs = rhs - c * self.joints.f_off
                return self.newton.attempt(h, rhs, c, self.law, cs.state, self.law_dt(h),
                                           cs.phi, cs.active, cs.g, stall)
            return self.full.attempt(self.effective_matrix(h), rhs, c, self.law, cs.state,
                                     self.law_dt(h), cs.u, stall)

    def commit(self, h, f_next, res: Attempt):
        """Make the converged attempt ``res`` of a step of size h (None: static) the committed
        state; the coupled field commits too, then the observers run."""
        cs = self.committed
        if h is not None:
            cs.v, cs.a = self.discretisation.rates(h, res.u, cs)
            cs.time += h
        cs.u = res.u
        cs.g = res.g.reshape(-1, 2).copy()
        cs.t = res.t.copy()
        cs.state = res.state
        cs.phi = res.phi
        cs.active = res.active
        cs.f = np.array(f_next, dtype=float)
        if h is not None and self.coupled is not None:
            self.coupled.commit(h)
        for fn in self.commit_observers:
            fn(self, h, res.iterations)

    # ------------------------------------------------------------------ public steps
    def static(self, f, relax: bool = True) -> StepReport:
        """Solve K u + B^T W t(B u) = f from the committed state (dead load + reservoir);
        commits u, the interface state; sets v = a = 0 and the current load to f.
        relax=False: no damped dynamics at a limit load (solve/static.py): the solve fails
        there."""
        return self.statics.solve(self, f, relax)

    def step(self, f_next, split: int = 0) -> StepReport:
        """Advance by dt to the load ``f_next``; on non-convergence the sub-step is halved and
        retried from the committed state (load interpolated linearly in time), sizes grow back
        after success.  Raises SolverError below ``min_dt`` (committed fields are then those at
        the last accepted sub-step, ``self.time`` tells where). split = k > 0: the step is
        taken in sub-steps of at most dt / 2^k (the retry of a step that the run's energy
        guard rejected, ``run.energy.EnergyGuard``); SolverError if dt / 2^k < ``min_dt``."""
        return self.controller.step(self, f_next, split)

    @contextlib.contextmanager
    def uncoupled(self):
        """Within: no coupled field, and dynamic factorisations of their own (they lack the
        field's block); the field, the factorisations and the static one are restored at the
        exit (the relaxation at a static limit load, solve/static.py)."""
        saved = (self.coupled, self.newton.steps, self.newton.static_entry)
        self.coupled = None
        self.newton.steps = OrderedDict()
        self.forget_products()
        try:
            yield self
        finally:
            self.coupled, self.newton.steps, self.newton.static_entry = saved
            self.forget_products()

    def drop_static(self):
        """Drop the static factorisation (the time steps do not need it)."""
        self.newton.static_entry = None

    def forget_jacobian(self):
        """Drop the LUs kept for ``jacobian_reuse`` (the only numbers carried from step to step
        besides the committed state). A run calls it after writing a checkpoint, so that a run
        resumed from that checkpoint (a fresh solver) and the uninterrupted run take the same
        Newton directions bit for bit."""
        self.newton.forget_jacobian()

    def release_steps(self):
        """Drop the factorisations of the time-step sizes (the time loop is over): each is
        ~25 MB on the paper scene and a run with cuts holds up to ``max_cache`` of them; the
        static one (post-earthquake solve) is kept. A later ``step`` factorises anew."""
        self.newton.steps.clear()

    # ------------------------------------------------------------------ diagnostics
    def step_products(self):
        """(K u, M v) of the committed state, bitwise scipy's ``K @ u`` and ``M @ v`` (the
        energy budget's products), or None when the solver has no damping matrix; the same
        pass forms the next step's right-hand-side products (``TimeDiscretisation``)."""
        return self.discretisation.step_products(self.committed, self.dt)

    def energy(self):
        """Kinetic + elastic (bulk + interface at K0) energy of the committed state; exact
        stored energy only while the interface is elastic."""
        kin = 0.5 * self.v @ (self.M @ self.v)
        el = 0.5 * self.u @ (self.K @ self.u)
        el += 0.5 * np.sum(self.w[:, None] * self.t * self.g)
        return kin + el

    def operator_gap(self):
        """(npts, 2) gap B u + g_offset of the committed u under the current operator: after a
        re-pairing (``set_operator``) it differs from the committed gap ``g`` (the law's) where
        a point slid off its face and was opened (run/pairing)."""
        return self.joints.gap(self.u).reshape(-1, 2)

    def internal_force(self, t):
        """B^T W t: the free-DOF force of the interface tractions t (npts, 2)."""
        return self.joints.internal_force(t)

    # ------------------------------------------------------------------ checkpoint / restore
    def checkpoint(self, coupled: bool = True, copy: bool = True) -> dict:
        """Copies of everything the solver has committed, as plain arrays and floats: u, v, a,
        f (absent before the first load), time, the interface state (``state_<name>``), the
        law's traction t and gap g, the correction phi, the active mask, the slip signs of the
        friction events (when set), the gap offset of a re-paired joint (when set; restored by
        the run's pairing through ``set_operator``, not by ``restore``) and the coupled field's
        state (``coupled_<name>``; coupled=False: without it, for a run whose reservoir part
        saves the water itself). ``restore`` puts the solver back bit for bit.
        copy=False: the solver's own committed arrays, not copies (the run's snapshot before a
        step, restored at once if the step is rejected: a commit replaces the committed arrays
        and never writes into them, and ``restore`` copies)."""
        cs = self.committed
        cp = np.copy if copy else _same
        d = {"u": cp(cs.u), "v": cp(cs.v), "a": cp(cs.a), "time": float(cs.time),
             "t": cp(cs.t), "g": cp(cs.g), "phi": cp(cs.phi), "active": cp(cs.active)}
        if cs.f is not None:
            d["f"] = cp(cs.f)
        if cs.slip_sign is not None:
            d["slip_sign"] = cp(cs.slip_sign)
        if self.joints.g_offset is not None:      # a joint paired anew (finite sliding)
            d["g_offset"] = cp(self.joints.g_offset)
        d.update({f"state_{k}": np.array(v, copy=copy)
                  for k, v in cs.state.as_dict().items()})
        if coupled and self.coupled is not None:
            d.update({f"coupled_{k}": None if v is None else np.array(v, copy=True)
                      for k, v in self.coupled.checkpoint().items()})
        return d

    def restore(self, d: dict) -> None:
        """Set the committed state from ``checkpoint()``'s dict (copies are taken). Keys that
        are absent keep their value: the interface state (``state_*``), the time, the slip
        signs and the coupled field's state (``coupled_*``)."""
        cs = self.committed
        cs.u, cs.v, cs.a = (np.array(d[k], dtype=float) for k in ("u", "v", "a"))
        cs.f = None if d.get("f") is None else np.array(d["f"], dtype=float)
        if "time" in d:
            cs.time = float(d["time"])
        cs.t = np.array(d["t"])
        cs.g = np.array(d["g"])
        cs.phi = np.array(d["phi"])
        cs.active = np.array(d["active"])
        if "slip_sign" in d:
            cs.slip_sign = np.array(d["slip_sign"], dtype=np.int8)
        st = {k[6:]: v for k, v in d.items() if k.startswith("state_")}
        if st:
            cs.state = type(cs.state).from_dict(st)          # copies
        co = {k[8:]: v for k, v in d.items() if k.startswith("coupled_")}
        if co and self.coupled is not None:
            self.coupled.restore(co)
