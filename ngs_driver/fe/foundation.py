"""Foundation models (issue #13; docs/decisions.md §9): the massless rock's initial acceleration
and Lysmer-Kuhlemeyer viscous boundaries.

* ``massless_dofs(M)``: free DOFs without mass (zero rows of M: the massless rock block).
* ``initial_acceleration(solver, f, massless, a1)``: the start-up acceleration when M is
  singular on the massless DOFs (``NewmarkSolver.initial_acceleration`` factorises M).
* ``dashpot_matrix(...)``: C_LK = integral over boundaries of rho (c_P n n^T + c_S t t^T) u . v,
  the Lysmer & Kuhlemeyer (1969) viscous boundary, to be added to the damping matrix.
"""
from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

__all__ = ["massless_dofs", "initial_acceleration", "wave_speeds", "dashpot_matrix"]


def massless_dofs(M) -> np.ndarray:
    """Bool mask of the DOFs whose row of M is zero."""
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
    from ..solve.sparse import SparseFactor

    m = ~np.asarray(massless, bool)
    r = f - solver.K @ solver.u - solver._fint(solver.t)
    if solver.C is not None:
        r = r - solver.C @ solver.v
    a = np.zeros(solver.ndof)
    Mmm = solver.M[m][:, m]
    a[m] = SparseFactor(Mmm.tocsc()).solve(r[m])
    z = ~m
    if a1 <= 0.0 and z.any():
        from ..solve.joint_laws import initial_stiffness
        k0 = initial_stiffness(solver.law, solver.npts).ravel() * np.repeat(solver.w, 2)
        Kt = (solver.K + solver.B.T @ sp.diags(k0) @ solver.B).tocsr()
        a[z] = SparseFactor(Kt[z][:, z].tocsc()).solve(-(Kt[z][:, m] @ a[m]))
    solver.a = a
    solver.f = np.array(f, dtype=float)
    return a


def wave_speeds(E: float, nu: float, rho: float) -> tuple[float, float]:
    """(c_P, c_S) of plane strain: c_P = sqrt((lambda + 2 mu)/rho), c_S = sqrt(mu/rho)."""
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    return math.sqrt((lam + 2 * mu) / rho), math.sqrt(mu / rho)


def dashpot_matrix(mesh, fes, free, boundaries: str, E: float, nu: float, rho: float,
                   field: int | None = None) -> sp.csr_matrix:
    """Lysmer-Kuhlemeyer dashpots on ``boundaries`` ("a|b|c"): the boundary traction
    -rho c_P (v.n) n - rho c_S (v.t) t, i.e. the matrix integral of rho (c_P n n^T +
    c_S (I - n n^T)) u . v (independent of the normal's sign). ``field``: the component of a
    product space that carries the region (None: a single space). Restricted to ``free``."""
    import ngsolve as ngs

    from .ngs_helpers import to_scipy

    cp, cs = wave_speeds(E, nu, rho)
    u, v = fes.TnT()
    if field is not None:
        u, v = u[field], v[field]
    n = ngs.specialcf.normal(2)
    nn = ngs.OuterProduct(n, n)
    D = rho * (cp * nn + cs * (ngs.Id(2) - nn))
    c = ngs.BilinearForm(fes)
    c += ngs.InnerProduct(D * u, v) * ngs.ds(boundaries)
    c.Assemble()
    C = to_scipy(c.mat)[free][:, free].tocsr()
    return ((C + C.T) * 0.5).tocsr()
