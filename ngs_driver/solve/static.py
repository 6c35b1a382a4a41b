"""The static solve of the joint solver: the load applied by continuation (halved on failure,
grown back), and at a limit load the relaxation by damped dynamics until a static attempt from
the moving state converges (docs/solver.md §7)."""
from __future__ import annotations

import time
from fractions import Fraction

import numpy as np

from .massless import initial_acceleration, massless_dofs
from .stepping import SolverError, StepReport

__all__ = ["StaticSolve", "STATIC_DURATION"]

# duration given to rate-dependent laws for the static solve: the dead load and the reservoir
# build up over months to years (impounding); one year [s]
STATIC_DURATION = 3.15e7


class StaticSolve:
    """``JointSolver.static``. relax_max: at most this many dynamic steps of size dt per
    relaxation, a static attempt from the moving state every relax_check steps; a relaxation in
    which some point of a joint slides more than relax_slip_max has no equilibrium to find
    (friction alone cannot hold the static loads: the dam slides off); it stops there (0.05 m:
    the post-earthquake check's bound of small-displacement statics). relax_runaway: (slip,
    time) of the last relaxation stopped so, else None."""

    relax_max = 5000
    relax_check = 25
    relax_slip_max = 0.05

    def __init__(self):
        self.relax_runaway = None

    def solve(self, solver, f, relax: bool = True) -> StepReport:
        """Solve K u + B^T W t(B u) = f from the committed state (dead load + reservoir);
        commits u, the interface state; sets v = a = 0 and the current load to f.
        relax=False: no damped dynamics at a limit load (``relax``): the solve fails there."""
        t0 = time.perf_counter()
        rep = StepReport()
        cs = solver.committed
        f = np.asarray(f, dtype=float)
        # the load in one increment; if that does not converge, by continuation: the load
        # path from the committed load f0 to f in increments, halved on failure and grown back
        # (the friction of a cracked joint is path dependent: the path is the proportional
        # application of the static loads)
        f0 = cs.f if cs.f is not None else np.zeros_like(f)
        pos, hf = Fraction(0), Fraction(1)
        last = None
        while pos < 1:
            hf = min(hf, 1 - pos)
            end = pos + hf
            fe = f if end == 1 else f0 + float(end) * (f - f0)
            res = solver.attempt(None, fe)
            last = res
            if res.ok:
                solver.commit(None, fe, res)
                rep.accepted(res)
                pos = end
                if hf < 1 and pos % (2 * hf) == 0:
                    hf *= 2
            else:
                rep.rejected(res)
                hf /= 2
                if hf < Fraction(1, 2 ** 10):
                    # no equilibrium next to the committed one, even 1/1024 of the load on:
                    # a limit load (a crack tip at its peak traction whose advance needs less
                    # load: the Jacobian's determinant changes sign across the peak kink). The
                    # crack runs at constant load: followed by damped dynamics at the load fe
                    # until the static solve from the moving state converges (``relax``)
                    nrel = self.relax(solver, fe) if relax else None
                    if relax and nrel is None and self.relax_runaway is not None:
                        slid, tr = self.relax_runaway
                        raise SolverError(
                            f"no static equilibrium: at {float(end):.4g} of the static load a "
                            f"joint slid {slid:.3g} m in {tr:.3g} s of damped motion at the held "
                            "load (friction and the bonded part left cannot hold the static "
                            "loads; the dam slides before the earthquake)")
                    if nrel is None:
                        raise SolverError(
                            f"static solve did not converge in {solver.max_iter} iterations, "
                            f"even with the load in 1/1024 increments (relative residual "
                            f"{last.rnorm:.3e})"
                            + (f", nor after {self.relax_max} steps of damped dynamics at the "
                               f"load {float(end):.6g} of the increment" if relax else "")
                            + " (no equilibrium found: can the joints hold the static loads?)")
                    rep.relax_steps.append(nrel)
                    pos = end
        cs.v = np.zeros(solver.ndof)
        cs.a = np.zeros(solver.ndof)
        return rep.finish(solver, cs, t0)

    def relax(self, solver, f):
        """Damped dynamics (the solver's own M, C, integrator and dt; no ground motion, no
        coupled field: ``JointSolver.uncoupled``) from the committed static state (at rest)
        under the constant load f, until a static attempt at f from the current state
        converges; that equilibrium is committed (v = a = 0, time and caches as before).
        Returns the number of dynamic steps, or None (nothing committed, the state before the
        call restored) when no static attempt converged within ``relax_max`` steps or a step
        failed."""
        cs = solver.committed
        saved = cs.snapshot()
        nhist = len(solver.history)
        done = None
        self.relax_runaway = None
        g0 = np.asarray(cs.g, float).reshape(-1, 2)[:, 1].copy()
        with solver.uncoupled():          # the dynamic factorisations here lack the water
            try:
                cs.v = np.zeros(solver.ndof)
                self.start(solver, f)
                for k in range(1, self.relax_max + 1):
                    solver.step(f)
                    if k % self.relax_check == 0:
                        slid = float(np.abs(np.asarray(cs.g).reshape(-1, 2)[:, 1] - g0).max())
                        if slid > self.relax_slip_max:
                            self.relax_runaway = (slid, k * solver.dt)
                            break
                        res = solver.attempt(None, f)
                        if res.ok:
                            solver.commit(None, f, res)
                            done = k
                            break
            except SolverError:
                done = None
            finally:
                if done is None:
                    cs.revert(saved)
                cs.revert(saved, ("time", "slip_sign"))
                cs.v = np.zeros(solver.ndof)
                cs.a = np.zeros(solver.ndof)
                del solver.history[nhist:]
        return done

    @staticmethod
    def start(solver, f):
        """The start-up acceleration of a relaxation: M^-1 of the residual, or, when M vanishes
        on some DOFs (a massless rock block: M is singular), ``solve.massless`` on them; the
        damping's stiffness part acts there iff C has a diagonal on them (Rayleigh a1 > 0)."""
        massless = massless_dofs(solver.M)
        if not massless.any():
            solver.initial_acceleration(f)
            return
        stiff = solver.C is not None and bool(np.any(solver.C.diagonal()[massless] != 0.0))
        initial_acceleration(solver, f, massless, 1.0 if stiff else 0.0)
