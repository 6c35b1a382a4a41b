"""Mode-I double cantilever beam in scikit-fem, the two arms joined by the interface law.

Two elastic arms (plane strain, biquadratic quads) share no node: the only link between them is
the interface law, evaluated at Gauss points of the crack line y = 0 on the bonded part
a0 <= x <= L. The gap there is g = (u_y, u_x)_top - (u_y, u_x)_bottom (normal +y, tangent +x).
The load faces x = 0 move by u_y = +-delta/2 (displacement control); Newton uses the law's
consistent tangent: K + B^T W T B. The state is committed only when a step has converged.

Reference: corrected beam theory + LEFM (Kanninen's root rotation a -> a + 0.64 h and Timoshenko
shear): P_c = sqrt(2 b G_I / C'(a0)), the load at which the crack starts to grow. The cohesive
law is not LEFM: with l_ch = E' G_I / sigma_max^2 = 3.5 h the process zone is about h long and
the peak comes ~9 % below P_c (the same specimen in NGSolve, `python -m ngs_driver run dcb`,
gives -9.0 %); the curve joins the LEFM envelope once the crack runs.

Asserts: the peak load within [-12 %, -6 %] of P_c (prints -9.35 %), and the load at
3 delta_c within 2 % of the LEFM envelope.

Run: python examples/ex02_dcb_skfem.py        (a few seconds)
"""
import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu
from skfem import Basis, ElementQuad2, ElementVector, FacetBasis, MeshQuad, asm
from skfem.models.elasticity import lame_parameters, linear_elasticity

from interfacelaw import CohesiveParams, ContactParams, InterfaceLaw

# the specimen of ngs_driver/scenes/dcb.toml [m, Pa, J/m^2], thickness b = 1 m
L, h, a0, E, nu = 1.0, 0.1, 0.4, 30e9, 0.2
sigma_max, G_I, lambda_max = 3e6, 100.0, 0.01
law = InterfaceLaw(CohesiveParams.from_fracture_energy(sigma_max, sigma_max, G_I, lambda_max),
                   contact=ContactParams("linear"))   # the bonded ligament carries compression

# beam theory per unit thickness: opening/load C(a) = 2 ae^3/(3 E' I) + 2 ae/(k G h) of the two
# arms, ae = a + 0.64 h; LEFM: the crack of length a grows at P(a) = sqrt(2 G_I / C'(a))
Ep, I, G, k = E / (1 - nu**2), h**3 / 12, E / (2 * (1 + nu)), 5 / 6
C = lambda a: 2 * (a + 0.64 * h)**3 / (3 * Ep * I) + 2 * (a + 0.64 * h) / (k * G * h)
dC = lambda a: 2 * (a + 0.64 * h)**2 / (Ep * I) + 2 / (k * G * h)
P_c = np.sqrt(2 * G_I / dC(a0))                          # peak load of LEFM [N/m]
d_c = P_c * C(a0)                                        # its opening [m]

# mesh: the top arm and its mirror image, with duplicated nodes on y = 0 (two bodies)
top = MeshQuad.init_tensor(np.linspace(0, L, 51), np.linspace(0, h, 3))
n = top.p.shape[1]
mesh = MeshQuad(np.hstack([top.p, top.p * [[1], [-1]]]), np.hstack([top.t, top.t[::-1] + n]))
basis = Basis(mesh, ElementVector(ElementQuad2()))
K = asm(linear_elasticity(*lame_parameters(E, nu)), basis).tocsr()   # 3D Lame: plane strain


def trace(y_side):
    """Sparse matrix u -> (u_y, u_x) at the Gauss points of the bonded crack line of one arm,
    rows point-major; with the points' x and weights (the points sorted along x)."""
    facets = mesh.facets_satisfying(lambda x: (abs(x[1]) < 1e-12) & (x[0] > a0),
                                    boundaries_only=True)
    side = np.sign(mesh.p[1, mesh.t[:, mesh.f2t[0, facets]]].sum(axis=0))   # arm above/below
    facets = facets[side == y_side]
    fb = FacetBasis(mesh, basis.elem, facets=facets, intorder=5)
    x = fb.global_coordinates().value[0].ravel()
    rows, cols, vals = [], [], []
    for k in range(fb.Nbfun):
        phi = fb.basis[k][0].value                      # (2, nfacets, nqp)
        dofs = np.repeat(fb.element_dofs[k], phi.shape[2])
        for comp, c in ((1, 0), (0, 1)):                # gap component 0 = y, 1 = x
            rows.append(2 * np.arange(x.size) + c)
            cols.append(dofs)
            vals.append(phi[comp].ravel())
    B = sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(2 * x.size, basis.N)).tocsr()
    order = np.argsort(x)
    perm = np.stack([2 * order, 2 * order + 1], 1).ravel()
    return B[perm], x[order], fb.dx.ravel()[order]


Bt, xt, w = trace(+1)
Bb, xb, _ = trace(-1)
assert np.allclose(xt, xb, atol=1e-12)                 # the two arms' points coincide
B = (Bt - Bb).tocsr()                                   # u -> gap (g_N, g_T) per point

# displacement control: the load faces move by u_y = +-delta/2; u_x = 0 at the neutral axes
face = basis.get_dofs(lambda x: np.isclose(x[0], 0.0))
uy = face.all("u^2")
arm = np.ones(basis.N)                                  # +1 top arm, -1 bottom arm, per DOF
arm[basis.element_dofs[:, top.t.shape[1]:]] = -1.0
sgn = arm[uy]
axis = basis.get_dofs(lambda x: np.isclose(x[0], 0.0) & np.isclose(np.abs(x[1]), h / 2))
fixed = np.concatenate([uy, axis.nodal["u^1"]])
free = np.setdiff1d(np.arange(basis.N), fixed)
top_uy = uy[sgn > 0]


def newton(u, delta, state):
    """Equilibrium at the opening delta from the committed state; None if not converged."""
    u = u.copy()
    u[uy] = 0.5 * delta * sgn
    for it in range(25):
        t, T, trial = law.evaluate((B @ u).reshape(-1, 2), state)
        r = K @ u + B.T @ (w[:, None] * t).ravel()         # internal force (bulk + interface)
        P = r[top_uy].sum()                                  # reaction of the top load face
        if it > 0 and np.linalg.norm(r[free]) < 1e-9 * abs(P):
            return u, trial, P
        A = K + B.T @ sp.block_diag(w[:, None, None] * T, format="csr") @ B
        u[free] -= splu(A[free][:, free].tocsc()).solve(r[free])
    return None


u, state = np.zeros(basis.N), law.initial_state(w.size, 2)
delta, P_hist = 0.0, []
for target in np.concatenate([[0.6 * d_c], np.linspace(0.6, 3.0, 41)[1:] * d_c]):
    step = target - delta
    while delta < target:                                # halve the step until Newton converges
        res = newton(u, min(delta + step, target), state)
        if res is None:
            step *= 0.5
            assert step > 1e-4 * d_c, f"no convergence at delta = {delta:.4e} m"
            continue
        u, state, P = res                                    # commit the converged step
        delta = min(delta + step, target)
        P_hist.append(P)

# once the crack runs, the process zone travels with the tip and P follows the LEFM envelope
# (delta, P) = (P(a) C(a), P(a)): compare at delta = 3 delta_c
a = np.linspace(a0, L, 2001)
P_env = np.interp(3 * d_c, np.sqrt(2 * G_I / dC(a)) * C(a), np.sqrt(2 * G_I / dC(a)))
# 2 %: beam theory neglects O((h/a)^2) terms and the process zone's own compliance; measured
# -0.6 % here (the NGSolve DCB: within 0.3 %)
assert abs(P_hist[-1] / P_env - 1) < 0.02

P_max = max(P_hist)
print(f"peak load P_max = {P_max:.1f} N/m (beam theory P_c = {P_c:.1f} N/m, "
      f"{P_max / P_c - 1:+.2%})")
# window [-12 %, -6 %] around the -9 % of the cohesive process zone (see the docstring): a wrong
# G_I (x2 moves P_c by 41 %), E' or arm height falls outside
assert -0.12 < P_max / P_c - 1 < -0.06
