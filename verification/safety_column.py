"""Check of the Lysmer-Kuhlemeyer absorbing bottom (issue #13; docs/safety.md §8).

A rock column (E = 50 GPa, nu = 0.2, rho = 2800 kg/m^3, the paper's rock) of width 2 m and
depth 100 m, plane strain, P1 triangles of size h, free top, dashpots on the bottom
(``fe.foundation.dashpot_matrix``). One displacement component is kept (u_x: a shear wave;
u_y: a compression wave), the other is fixed, so the column is exactly one-dimensional (the
side tractions of the 1D wave are taken by the fixed component). A Gaussian pulse of standard
deviation s travels down from y0 = -30 m (u(y, 0) = g(y), v(y, 0) = c g'(y)); average
acceleration Newmark. When the pulse has had time to leave through the bottom (but a
reflection could not yet have come back to the top and down again), the energy still in the
column, kinetic + strain, over the initial energy is the reflected fraction.

    python verification/safety_column.py            # the table (h = 1, 0.5 m; s = 5 m)
"""
from __future__ import annotations

import math
import sys

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl

E, NU, RHO = 50e9, 0.2, 2800.0


def column_reflection(wave: str = "S", h: float = 1.0, width: float = 2.0, depth: float = 100.0,
                      sigma: float = 5.0, y0: float = -30.0, courant: float = 0.5,
                      absorbing: bool = True) -> dict:
    """Reflected energy fraction of a pulse at the bottom of a 1D column (module docstring)."""
    import ngsolve as ngs
    from ngsolve.meshes import MakeStructured2DMesh

    from ngs_driver.fe.foundation import dashpot_matrix, wave_speeds
    from ngs_driver.fe.ngs_helpers import to_scipy

    nx, ny = max(1, round(width / h)), round(depth / h)
    mesh = MakeStructured2DMesh(quads=False, nx=nx, ny=ny,
                                mapping=lambda x, y: (width * x, -depth + depth * y))
    fes = ngs.VectorH1(mesh, order=1)
    u, v = fes.TnT()
    lam = E * NU / ((1 + NU) * (1 - 2 * NU))
    mu = E / (2 * (1 + NU))

    def sig(w):
        e = ngs.Sym(ngs.Grad(w))
        return lam * ngs.Trace(e) * ngs.Id(2) + 2 * mu * e

    a = ngs.BilinearForm(fes)
    a += ngs.InnerProduct(sig(u), ngs.Sym(ngs.Grad(v))) * ngs.dx
    m = ngs.BilinearForm(fes)
    m += RHO * u * v * ngs.dx
    a.Assemble()
    m.Assemble()
    nv = fes.ndof // 2                       # VectorH1: the x block, then the y block
    comp = 0 if wave == "S" else 1
    free = np.arange(comp * nv, (comp + 1) * nv)
    K = to_scipy(a.mat)[free][:, free].tocsr()
    M = to_scipy(m.mat)[free][:, free].tocsr()
    C = dashpot_matrix(mesh, fes, free, "bottom", E, NU, RHO) if absorbing else \
        sp.csr_matrix(K.shape)
    cp, cs = wave_speeds(E, NU, RHO)
    c = cs if wave == "S" else cp
    # node coordinates of the kept component's DOFs (order 1: DOF k = vertex k)
    y = np.array([mesh.vertices[k].point[1] for k in range(nv)])
    g = np.exp(-0.5 * ((y - y0) / sigma) ** 2)
    dg = -(y - y0) / sigma ** 2 * g
    u_n = 1e-4 * g
    v_n = 1e-4 * c * dg                      # u(y, t) = g(y + c t): travels down
    dt = courant * h / c
    t_end = (depth + y0 + 6 * sigma) / c     # the pulse has left; a reflection is still inside
    n = int(math.ceil(t_end / dt))
    beta, gamma = 0.25, 0.5
    c0, c1 = 1 / (beta * dt ** 2), gamma / (beta * dt)
    A = (c0 * M + c1 * C + K).tocsc()
    lu = spl.splu(A)
    a_n = spl.spsolve(M.tocsc(), -(K @ u_n) - C @ v_n)

    def energy(uu, vv):
        return 0.5 * vv @ (M @ vv) + 0.5 * uu @ (K @ uu)

    E0 = energy(u_n, v_n)
    for _ in range(n):
        rhs = M @ (c0 * u_n + v_n / (beta * dt) + (0.5 / beta - 1) * a_n) + \
            C @ (c1 * u_n + (gamma / beta - 1) * v_n + dt * (0.5 * gamma / beta - 1) * a_n)
        u_new = lu.solve(rhs)
        a_new = c0 * (u_new - u_n) - v_n / (beta * dt) - (0.5 / beta - 1) * a_n
        v_n = v_n + dt * ((1 - gamma) * a_n + gamma * a_new)
        u_n, a_n = u_new, a_new
    E1 = energy(u_n, v_n)
    return {"wave": wave, "h": h, "dt": dt, "steps": n, "c": c, "E0": E0, "E_end": E1,
            "reflected": E1 / E0, "absorbing": absorbing}


def main(argv=()):
    rows = []
    for wave in ("S", "P"):
        for h in (1.0, 0.5):
            r = column_reflection(wave, h)
            rows.append(r)
        rows.append(column_reflection(wave, 1.0, absorbing=False))
    print("| wave | h [m] | steps | bottom | E_end / E0 |")
    print("|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['wave']} | {r['h']:g} | {r['steps']} | "
              f"{'dashpots' if r['absorbing'] else 'free'} | {r['reflected']:.3e} |")
    return rows


if __name__ == "__main__":
    main(sys.argv[1:])
