"""One Newton loop for the joint solver, with interchangeable direction providers.

``NewtonControl.solve`` iterates x -> x + s dx with the convergence test (relative residual and
energy), the stall rule and the backtracking line search; the method supplies the residual of an
iterate and the direction. Two methods (docs/solver.md §2): the condensed Newton on the
interface gaps (solve/condensed.py, the default) and the full Newton on all DOFs with a fresh
factorisation per iteration (``FullNewton`` below, the reference). Each attempt of a step
returns an ``Attempt``."""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from .sparse import SparseFactor

__all__ = ["Attempt", "DirectionFailed", "NewtonControl", "FullNewton", "failed"]


class Attempt(NamedTuple):
    """The outcome of one attempt of a (sub-)step: converged or not, and what a commit takes.

    ok          : converged
    u           : (ndof,) displacement (None when not ok)
    g           : (2 npts,) gap of the law
    t           : (npts, 2) traction
    state       : the interface state the law returned (not yet committed)
    phi         : (2 npts,) t - K0 g at the active points, zero elsewhere
    active      : (npts,) active-point mask
    iterations  : Newton iterations spent
    rnorm       : the last relative residual norm"""

    ok: bool
    u: np.ndarray | None
    g: np.ndarray | None
    t: np.ndarray | None
    state: object
    phi: np.ndarray | None
    active: np.ndarray | None
    iterations: int
    rnorm: float


def failed(iterations, rnorm) -> Attempt:
    """An attempt that did not converge (its sub-step is cut)."""
    return Attempt(False, None, None, None, None, None, None, iterations, rnorm)


class DirectionFailed(Exception):
    """The Newton direction could not be formed (a singular or non-finite system)."""


class NewtonControl:
    """Convergence test, stall rule and line search, shared by every Newton method.

    tol_residual : relative residual tolerance; tol_energy : |dx . r_k| <= tol_energy |dx_0 .
    r_0| (both must hold, or the residual 1e-3 below tolerance); max_iter : iterations per
    attempt; line_search : backtracking on the residual norm."""

    def __init__(self, tol_residual, tol_energy, max_iter, line_search):
        self.tol_residual = float(tol_residual)
        self.tol_energy = float(tol_energy)
        self.max_iter = int(max_iter)
        self.line_search = bool(line_search)

    def converged(self, rnorm, energy, energy0):
        return rnorm <= self.tol_residual and (energy <= self.tol_energy * energy0
                                               or rnorm <= 1e-3 * self.tol_residual)

    def search(self, x, dx, rnorm, trial):
        """Backtracking on the residual norm (halving down to 1/64; Armijo-like decrease).
        ``trial(x) -> (out, rnorm)``. Returns (s, x + s dx, out, rnorm) or None (no finite
        trial point)."""
        s = 1.0
        while True:
            xt = x + dx if s == 1.0 else x + s * dx      # 1.0 * dx is dx bit for bit
            try:
                out, rn_t = trial(xt)
            except (ValueError, FloatingPointError):
                out, rn_t = None, np.inf
            if out is not None and (not self.line_search or s < 1.0 / 64
                                    or rn_t <= (1.0 - 1e-4 * s) * rnorm):
                return s, xt, out, rn_t
            if out is None and s < 1.0 / 64:
                return None
            s *= 0.5

    def status(self, rnorm, energy, energy0, it, stall, hist):
        """True converged, False failed (cut the step), None iterate on. stall = m > 0: the
        stall rule (``stalled``) on the residuals ``hist`` of the attempt so far."""
        if not math.isfinite(rnorm) or rnorm > 1e12:
            return False
        if energy0 is not None and self.converged(rnorm, energy, energy0):
            return True
        if energy0 is None and rnorm <= 1e-3 * self.tol_residual:
            return True
        if it >= self.max_iter:
            return False
        if stall:
            hist.append(rnorm)
            if stalled(hist, stall):
                return False
        return None

    def solve(self, x, evaluate, direction, stall=0):
        """Newton from x. evaluate(x, out) -> (out', rnorm): the method's data at x (``out``:
        that of the current iterate, None at the start); direction(x, out) -> (dx, en): the
        Newton direction and its energy |dx . r| (raises DirectionFailed). Returns
        (ok, x, out, iterations, rnorm)."""
        try:
            out, rnorm = evaluate(x, None)
        except (ValueError, FloatingPointError):
            return False, None, None, 0, np.inf
        energy0 = None
        energy = np.inf
        it = 0
        hist = []
        while True:
            status = self.status(rnorm, energy, energy0, it, stall, hist)
            if status is False:
                return False, None, None, it, rnorm
            if status:
                return True, x, out, it, rnorm
            it += 1
            try:
                dx, en = direction(x, out)
            except DirectionFailed:
                return False, None, None, it, rnorm
            if energy0 is None:
                energy0 = max(en, 1e-300)
            cur = out
            ls = self.search(x, dx, rnorm, lambda xt: evaluate(xt, cur))
            if ls is None:
                return False, None, None, it, np.inf
            s, x, out, rnorm = ls
            energy = s * en


def stalled(hist, m) -> bool:
    """The best of the last m residuals is not below half the best before them. The
    attempts that fail on the Koyna scenes cycle between active sets with the residual
    stuck above tolerance (e.g. 10^-3.7 ... 10^-3.9 repeating); none of the attempts that
    converged there (up to 13 iterations) meets the rule with m = 6 (docs/solver.md §4)."""
    k = len(hist)
    if k <= m + 1:
        return False
    return min(hist[k - m:]) > 0.5 * min(hist[:k - m])


class FullNewton:
    """The reference method: Newton on all DOFs, J = A + c B^T W T B factorised afresh at every
    iteration, the residual relative to the effective load."""

    def __init__(self, joints, control: NewtonControl):
        self.joints = joints
        self.control = control

    def attempt(self, A_lin, rhs, c, law, state, law_dt, u0, stall=0) -> Attempt:
        """One attempt from u0 with the effective matrix A_lin (no interface) and load rhs."""
        J0 = self.joints
        wd = J0.wd
        fscale = max(np.linalg.norm(rhs), 1e-300)
        n = J0.npts

        def evaluate(u, _):
            g = J0.gap(u)
            t, T, new = law.evaluate(g.reshape(-1, 2), state, dt=law_dt)
            r = rhs - A_lin @ u - c * (J0.BT @ (wd * t.ravel()))
            return (g, t, T, new, r), np.linalg.norm(r) / fscale

        def direction(u, out):
            T, r = out[2], out[4]
            WT = sp.bsr_matrix((T * J0.w[:, None, None], np.arange(n), np.arange(n + 1)),
                               shape=(2 * n, 2 * n))
            J = A_lin + c * (J0.BT @ WT.tocsr() @ J0.B)
            try:
                du = SparseFactor(J, symmetric=False, fast=False).solve(r)
            except RuntimeError as e:
                raise DirectionFailed(str(e)) from e
            return du, abs(np.dot(du, r))

        ok, u, out, it, rnorm = self.control.solve(u0.copy(), evaluate, direction, stall)
        if not ok:
            return failed(it, rnorm)
        g, t, T, new, r = out
        phi = t.ravel() - J0.k0v * g
        act = J0.phi_mask(phi, g)
        phi[np.repeat(~act, 2)] = 0.0
        return Attempt(True, u, g, t, new, phi, act, it, rnorm)
