"""Static solves of a run: the pre-earthquake state (dead load, water, tailwater, the uplift of
its own crack) and, for a rock without supports (absorbing boundaries), the same model on
support springs whose reactions then stay as constant loads (docs/safety.md)."""
from __future__ import annotations

import numpy as np

from ..solve.joint_solver import JointSolver

__all__ = ["spring_supported", "solve_pre_earthquake"]


def spring_supported(main, K_support):
    """A solver for static solves of ``main``'s model on the support springs K_support (the
    dashpots of absorbing boundaries have no stiffness); it shares main's interface state."""
    s = JointSolver(main.K + K_support, main.M, None, main.B, main.w, main.law, dt=main.dt,
                    tol_residual=main.tol_residual, max_iter=main.max_iter)
    s.state = main.state
    return s


def solve_pre_earthquake(solver, f_base, uplift, absorbing=None):
    """The static state before the shaking, committed in ``solver``; freezes the
    pre-earthquake uplift. Returns (report, f_static, f_reaction): f_static = f_base + f_U +
    f_reaction, f_reaction the support reactions (absorbing rock) or zeros."""
    f_reaction = np.zeros(solver.ndof)
    if absorbing is None:
        rep, p, f = uplift.solve_static(solver, f_base)
    else:
        springs = spring_supported(solver, absorbing.K_support)
        rep, p, f = uplift.solve_static(springs, f_base)
        f_reaction = -(absorbing.K_support @ springs.u)
        f = f + f_reaction
        solver.state = springs.state
        solver.set_initial(u=springs.u, v=np.zeros(solver.ndof), a=np.zeros(solver.ndof), f=f)
    uplift.freeze(p)
    return rep, f, f_reaction
