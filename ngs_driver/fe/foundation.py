"""Foundation models (issue #13; docs/safety.md §7-9): the massless rock's initial acceleration
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


class AbsorbingRock:
    """A massed rock block with Lysmer-Kuhlemeyer dashpots on its sides and bottom and the
    earthquake entered as free-field forces (docs/safety.md §9).

    The given record is the **outcrop** motion (the free surface of the rock, y = 0). For
    vertically incident waves in the homogeneous rock (S for x, P for y) the free field is
    u_ff(y, t) = (u_o(t + y/c) + u_o(t - y/c)) / 2 (y <= 0; the incident wave is half the
    outcrop motion, the surface doubles it). On each absorbing boundary the force
    integral of (sigma_ff . n + D v_ff) . phi ds (D = rho (c_P n n + c_S t t)) is applied, so
    that the dashpots absorb only the waves scattered by the dam; at the bottom it reduces to
    rho c v_o(t + d/c) = 2 rho c v_incident. The displacements of such a run are total (no
    -M r a_g): the static state is solved on springs (``support``) whose reactions are then
    applied as constant forces."""

    def __init__(self, model, rock, gm, t0: float = 0.0):
        import ngsolve as ngs

        from .ngs_helpers import to_scipy, vec

        mesh, fes, free = model.mesh, model.fes, model.free
        k = len(model.regions) - 1                     # the rock field (last)
        self.E, self.nu, self.rho = rock.E, rock.nu, rock.rho
        self.cp, self.cs = wave_speeds(rock.E, rock.nu, rock.rho)
        lam = rock.E * rock.nu / ((1 + rock.nu) * (1 - 2 * rock.nu))
        self.kxx = lam / (lam + 2 * rock.E / (2 * (1 + rock.nu)))    # sigma_xx / sigma_yy (P)
        self.C = dashpot_matrix(mesh, fes, free, "rock_bottom|rock_left|rock_right", rock.E,
                                rock.nu, rock.rho, field=k)
        u, v = fes.TnT()
        u, v = u[k], v[k]
        self.mass = {}
        for b in ("rock_bottom", "rock_left", "rock_right"):
            for c in (0, 1):
                m = ngs.BilinearForm(fes)
                m += u[c] * v[c] * ngs.ds(b)
                m.Assemble()
                self.mass[b, c] = to_scipy(m.mat)[free][:, free].tocsr()
        gf = ngs.GridFunction(fes)
        gf.components[k].Set(ngs.CF((ngs.y, ngs.y)))
        self.ydof = vec(gf)[free]
        v_o, _ = gm.integrate()                          # outcrop velocity, (n, 2)
        self._t, self._v = np.asarray(gm.t), v_o
        self.t0 = float(t0)
        # support springs for the static state: stiff against the rock's own stiffness
        kb = 1e3 * rock.E / max(float(np.ptp(self.ydof)), 1.0)
        self.K_support = kb * sum(self.mass.values())

    def v_out(self, t, comp):
        return np.interp(self.t0 + t, self._t, self._v[:, comp], left=0.0,
                         right=float(self._v[-1, comp]))

    def force(self, t: float) -> np.ndarray:
        """Free-field forces on the absorbing boundaries at analysis time t."""
        y = np.minimum(self.ydof, 0.0)
        f = np.zeros(self.ydof.size)
        for comp, c in ((0, self.cs), (1, self.cp)):
            up = self.v_out(t - y / c, comp)             # v_o(t + |y|/c)
            dn = self.v_out(t + y / c, comp)             # v_o(t - |y|/c)
            vff = 0.5 * (up + dn)
            s = 0.5 * self.rho * c * (dn - up)           # sigma_xy (S) or sigma_yy (P) at y
            if comp == 0:       # S: v_ff = (v, 0); sigma_xy = s, sigma_xx = sigma_yy = 0
                f += self.mass["rock_bottom", 0] @ (-s + self.rho * self.cs * vff)
                f += self.mass["rock_left", 1] @ (-s)
                f += self.mass["rock_right", 1] @ s
                f += (self.mass["rock_left", 0] + self.mass["rock_right", 0]) @ (
                    self.rho * self.cp * vff)
            else:               # P: v_ff = (0, v); sigma_yy = s, sigma_xx = kxx s
                f += self.mass["rock_bottom", 1] @ (-s + self.rho * self.cp * vff)
                f += self.mass["rock_left", 0] @ (-self.kxx * s)
                f += self.mass["rock_right", 0] @ (self.kxx * s)
                f += (self.mass["rock_left", 1] + self.mass["rock_right", 1]) @ (
                    self.rho * self.cs * vff)
        return f
