"""Foundation models (docs/safety.md): Lysmer-Kuhlemeyer viscous boundaries. (The massless
rock block's DOFs, the zero rows of M, are a matrix fact the solver finds itself:
``solve.massless.massless_dofs``.)

* ``dashpot_matrix(...)``: C_LK = integral over boundaries of rho (c_P n n^T + c_S t t^T) u . v,
  the Lysmer & Kuhlemeyer (1969) viscous boundary, to be added to the damping matrix.
"""
from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from .ngs_helpers import to_scipy, vec

__all__ = ["wave_speeds", "dashpot_matrix", "AbsorbingRock"]


def _lame(E: float, nu: float, plane: str = "strain") -> tuple[float, float]:
    """(lambda, mu) of the 2D idealisation: plane strain, or plane stress (lambda* = E nu /
    (1 - nu^2))."""
    lam = E * nu / (1 - nu ** 2) if plane == "stress" else E * nu / ((1 + nu) * (1 - 2 * nu))
    return lam, E / (2 * (1 + nu))


def wave_speeds(E: float, nu: float, rho: float, plane: str = "strain") -> tuple[float, float]:
    """(c_P, c_S): c_P = sqrt((lambda + 2 mu)/rho), c_S = sqrt(mu/rho), with the 2D model's own
    lambda (plane strain: the bulk P wave; plane stress: the plate wave sqrt(E / (rho (1 -
    nu^2)))), so that the dashpots match the model's impedance."""
    lam, mu = _lame(E, nu, plane)
    return math.sqrt((lam + 2 * mu) / rho), math.sqrt(mu / rho)


def dashpot_matrix(mesh, fes, free, boundaries: str, E: float, nu: float, rho: float,
                   field: int | None = None, plane: str = "strain") -> sp.csr_matrix:
    """Lysmer-Kuhlemeyer dashpots on ``boundaries`` ("a|b|c"): the boundary traction
    -rho c_P (v.n) n - rho c_S (v.t) t, i.e. the matrix integral of rho (c_P n n^T +
    c_S (I - n n^T)) u . v (independent of the normal's sign). ``field``: the component of a
    product space that carries the region (None: a single space). Restricted to ``free``."""
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs


    cp, cs = wave_speeds(E, nu, rho, plane)
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
    earthquake entered as free-field forces (docs/safety.md).

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
        # deferred: NGSolve is optional: the package imports without it
        import ngsolve as ngs


        mesh, fes, free = model.mesh, model.fes, model.free
        k = len(model.regions) - 1                     # the rock field (last)
        self.E, self.nu, self.rho = rock.E, rock.nu, rock.rho
        # the model's own 2D idealisation of the rock (fe.model.Material.plane)
        self.plane = getattr(model.materials.get("rock"), "plane", "strain")
        self.cp, self.cs = wave_speeds(rock.E, rock.nu, rock.rho, self.plane)
        lam, mu = _lame(rock.E, rock.nu, self.plane)
        self.kxx = lam / (lam + 2 * mu)                  # sigma_xx / sigma_yy (P)
        self.C = dashpot_matrix(mesh, fes, free, "rock_bottom|rock_left|rock_right", rock.E,
                                rock.nu, rock.rho, field=k, plane=self.plane)
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
