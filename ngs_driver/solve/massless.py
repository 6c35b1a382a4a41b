"""The start-up acceleration of a model with massless DOFs (the massless rock block,
``geometry.foundation = "massless"``; docs/safety.md), where M is singular and
``JointSolver.initial_acceleration`` (which factorises M) cannot be used."""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .joint_laws import initial_stiffness
from .sparse import SparseFactor

__all__ = ["initial_acceleration", "massless_dofs"]


def massless_dofs(M) -> np.ndarray:
    """Bool mask of the DOFs whose row of M is zero (the massless rock block)."""
    return np.asarray(abs(sp.csr_matrix(M)).sum(axis=1)).ravel() == 0.0


def initial_acceleration(solver, f, massless, a1: float):
    """Solve the start-up acceleration of a model whose M vanishes on ``massless`` DOFs, for
    the committed u and v = 0 (the static state). Massive DOFs: M_mm a_m = r_m,
    r = f - K u - C v - B^T W t. Massless DOFs have no inertia: their equation is
    a1 K_00 v_0 + (K_00 + J_00) u_0 + J_0m u_m = f_0 (J = B^T W K0 B the bonded interface,
    Rayleigh C = a0 M + a1 K has only its a1 K part there) at every t. Differentiated once at
    v = 0: a1 K_00 a_0 = 0, so a_0 = 0 when a1 > 0 (stiffness-proportional damping makes the
    massless part first order); twice with a1 = 0: (K_00 + J_00) a_0 = -J_0m a_m. Sets
    solver.a and solver.f."""
    m = ~np.asarray(massless, bool)
    r = f - solver.K @ solver.u - solver.internal_force(solver.t)
    if solver.C is not None:
        r = r - solver.C @ solver.v
    a = np.zeros(solver.ndof)
    Mmm = solver.M[m][:, m]
    a[m] = SparseFactor(Mmm.tocsc()).solve(r[m])
    z = ~m
    if a1 <= 0.0 and z.any():
        k0 = initial_stiffness(solver.law, solver.npts).ravel() * np.repeat(solver.w, 2)
        Kt = (solver.K + solver.B.T @ sp.diags(k0) @ solver.B).tocsr()
        a[z] = SparseFactor(Kt[z][:, z].tocsc()).solve(-(Kt[z][:, m] @ a[m]))
    solver.a = a
    solver.f = np.array(f, dtype=float)
    return a
