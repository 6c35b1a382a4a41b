"""The step controller of the joint solver: a time step in sub-steps, halved and retried on a
failed Newton attempt, grown back after success, and redone with half the sub-step at a
friction event (a sliding joint that stops or reverses inside it); with the report of what a
``step``/``static`` call did."""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

__all__ = ["StepReport", "SolverError", "StepController", "slip_signs"]


class SolverError(RuntimeError):
    """A step could not be converged even with the minimum step size (state is unchanged)."""


@dataclass
class StepReport:
    """What one ``step``/``static`` call did.

    iterations  : Newton iterations summed over the accepted sub-steps (failed attempts excluded)
    iterations_failed : Newton iterations spent in attempts that were rejected (cut)
    cuts        : number of rejected attempts (each halves the sub-step)
    dts         : sizes of the accepted sub-steps (sum = dt); [dt] if no cut
    iters_per_substep : iterations of each accepted sub-step
    residuals   : final relative residual norm of each accepted sub-step
    event_cuts  : converged attempts redone with half the sub-step because a sliding joint
                  stopped or reversed inside them (friction events, ``StepController``)
    relax_steps : static only: dynamic steps of the relaxations at a limit load
                  (solve/static.py ``relax``), one entry per relaxation
    n_active    : number of points not in their initial elastic state at the end
    wall        : wall time of the call [s]
    """
    iterations: int = 0
    iterations_failed: int = 0
    cuts: int = 0
    dts: list = field(default_factory=list)
    iters_per_substep: list = field(default_factory=list)
    residuals: list = field(default_factory=list)
    event_cuts: int = 0
    relax_steps: list = field(default_factory=list)
    n_active: int = 0
    wall: float = 0.0

    def accepted(self, res, h=None):
        """Book a converged attempt ``res`` (newton.Attempt) of sub-step h."""
        self.iterations += res.iterations
        self.iters_per_substep.append(res.iterations)
        self.residuals.append(res.rnorm)
        if h is not None:
            self.dts.append(h)

    def finish(self, solver, cs, t0):
        """The end of a ``step``/``static`` call: the active points of the committed state
        ``cs``, the wall time since t0, the report appended to the solver's history; returns
        the report."""
        self.n_active = int(cs.active.sum())
        self.wall = time.perf_counter() - t0
        solver.history.append(self)
        return self

    def rejected(self, res):
        """Book an attempt that did not converge (its sub-step is cut)."""
        self.iterations_failed += res.iterations
        self.cuts += 1


def slip_signs(new, committed_state):
    """Sign (-1, 0, 1) of each point's plastic slip increment from the committed interface
    state to ``new`` (0: stick, or no friction)."""
    d = new.slip[:, 0] - committed_state.slip[:, 0]
    return np.sign(d).astype(np.int8)


class StepController:
    """Sub-steps of one time step (``step``). event_levels: friction events are localised in
    time by halving the sub-step up to this many times (0: off)."""

    def __init__(self, event_levels=3):
        self.event_levels = int(event_levels)
        self._signs = None                # (state, its slip_signs) of the last friction_event

    def commit(self, solver, h, fe, res, rep):
        """Commit the converged attempt ``res`` of sub-step h and book it."""
        cs = solver.committed
        kept = self._signs
        self._signs = None
        signs = kept[1] if kept is not None and kept[0] is res.state else \
            slip_signs(res.state, cs.state)
        solver.commit(h, fe, res)
        cs.slip_sign = signs
        rep.accepted(res, h)

    def friction_event(self, solver, new, hf) -> bool:
        """True when, in the attempt that ends in ``new``, most of the points that were sliding
        (weighted by w) stopped or reversed, and the sub-step can still be halved (at most
        ``event_levels`` times). Newmark-family schemes put a stick that starts inside a step at
        the step's end: the velocity the scheme then derives from the displacement is not the
        stopped block's (the trapezoidal rule reflects it, v_n+1 = 2 du/h - v_n ~ -v_n), an error
        ~ the block's deceleration times the step; halving localises the event to dt / 2^k
        (verification/sliding.py, docs/sliding.md)."""
        prev = solver.committed.slip_sign
        # 0.5**k is 2^-k exactly: the comparison with a Fraction hf is exact
        if (self.event_levels <= 0 or prev is None
                or hf <= 0.5 ** self.event_levels):
            return False
        sliding = prev != 0
        if not sliding.any():
            return False
        now = slip_signs(new, solver.committed.state)
        self._signs = (new, now)          # the commit of ``new`` takes them (``step``)
        changed = sliding & (now != prev)
        w = solver.w
        return float(w[changed].sum()) > 0.5 * float(w[sliding].sum())

    def step(self, solver, f_next, split: int = 0):
        """``JointSolver.step``: advance by dt to the load ``f_next`` (see there)."""
        t0 = time.perf_counter()
        rep = StepReport()
        solver.drop_static()             # the static factorisation is not needed any more
        cs = solver.committed
        dt, min_dt = solver.dt, solver.min_dt
        f_next = np.asarray(f_next, dtype=float)
        f_start = cs.f if cs.f is not None else f_next
        hmax_f = 0.5 ** int(split)                  # float(Fraction(1, 2^split)) exactly
        if dt * hmax_f < min_dt * (1 - 1e-12):
            raise SolverError(f"step to t = {cs.time + dt:.6g} s: a sub-step dt / "
                              f"2^{split} = {dt * hmax_f:.3g} s is below the minimum "
                              f"sub-step {min_dt:.3g} s; committed state is at "
                              f"t = {cs.time:.6g} s")
        first = None
        if split == 0:
            # the whole step in one attempt (the common case) without Fraction arithmetic:
            # h = dt * float(1) = dt, the load f_next (end == 1), the event test at hf = 1
            self._signs = None
            first = solver.attempt(dt, f_next)
            if first.ok and not self.friction_event(solver, first.state, 1):
                self.commit(solver, dt, f_next, first, rep)
                return rep.finish(solver, cs, t0)
        pos = Fraction(0)
        hmax = Fraction(1, 2 ** int(split))
        hf = hmax
        while pos < 1:
            hf = min(hf, 1 - pos)
            h = dt * float(hf)
            end = pos + hf
            fe = f_next if end == 1 else f_start + float(end) * (f_next - f_start)
            if first is not None:                   # the first attempt, made above
                res, first = first, None
            else:
                self._signs = None
                res = solver.attempt(h, fe)
            if res.ok and self.friction_event(solver, res.state, hf):
                rep.event_cuts += 1                 # redo the event with half the sub-step
                hf /= 2
                continue
            if res.ok:
                self.commit(solver, h, fe, res, rep)
                pos = end
                if hf < hmax and pos % (2 * hf) == 0:
                    hf *= 2
            else:
                rep.rejected(res)
                hf /= 2
                if dt * float(hf) < min_dt * (1 - 1e-12):
                    rep.wall = time.perf_counter() - t0
                    solver.history.append(rep)
                    raise SolverError(
                        f"step to t = {cs.time + dt * float(1 - pos):.6g} s did not "
                        f"converge with the minimum sub-step {min_dt:.3g} s "
                        f"({rep.cuts} cuts; last relative residual {res.rnorm:.3e}); committed "
                        f"state is at t = {cs.time:.6g} s")
        return rep.finish(solver, cs, t0)
