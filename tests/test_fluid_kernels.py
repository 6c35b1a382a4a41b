"""The water's compiled step (solve/kernels.py ``fluid_*``) gives bit for bit the numpy / scipy
expressions it replaced in solve/fluid.py (the run's history must not move: the regression pins
of tests/test_koyna_run.py hold to round-off only because of it). Random sparse matrices of the
water's shapes; equality is exact (``np.array_equal``): the kernels do numpy's operations in
numpy's order and sum each CSR row in scipy's order."""
import numpy as np
import pytest
import scipy.sparse as sp

from ngs_driver.solve.kernels import fluid_bp, fluid_commit, fluid_drift, fluid_face

N, NF, NU = 120, 9, 300          # water DOFs, face rows of the structure, structure DOFs


def _mats(rng):
    def rand(m, n, d):
        A = sp.random(m, n, density=d, random_state=rng, format="csr")
        A.sum_duplicates()
        A.sort_indices()
        return A
    G, Cf, H = rand(N, N, 0.05), rand(N, N, 0.01), rand(N, N, 0.05)
    rows = np.sort(rng.choice(NU, NF, replace=False))
    Qf = rand(NF, N, 0.2)
    Q = sp.lil_matrix((NU, N))
    Q[rows] = Qf
    Q = Q.tocsr()
    return G, Cf, H, Q, rows


def _t(A):
    return (A.indptr, A.indices, A.data)


@pytest.mark.parametrize("alpha", [False, True])
def test_rhs_is_the_numpy_expression(alpha):
    rng = np.random.default_rng(3)
    G, Cf, H, Q, rows = _mats(rng)
    Qf = Q[rows].tocsr()
    QfT = Qf.T.tocsr()
    QfT.sort_indices()
    p, pd, pdd = (rng.standard_normal(N) for _ in range(3))
    u, v, a = (rng.standard_normal(NU) for _ in range(3))
    g0, g1 = rng.standard_normal(N), rng.standard_normal(N)
    c0, c1, c2, c3, c4, c5 = rng.uniform(0.1, 1e6, 6)
    rho, agx, agy, agx0, agy0 = 1000.0, 0.3, -0.2, 0.1, 0.05
    cm, cf = (0.7, 0.6) if alpha else (1.0, 1.0)
    am, af = 1.0 - cm, 1.0 - cf
    # the expressions of FluidStepper.rhs before it was compiled (df7b066)
    if alpha:
        ubar = cm * (c0 * u + c2 * v + c3 * a) - am * a
        X, Y = cf * agx + af * agx0, cf * agy + af * agy0
        want = (G @ (cm * (c0 * p + c2 * pd + c3 * pdd) - am * pdd)
                + Cf @ (cf * (c1 * p + c4 * pd + c5 * pdd) - af * pd)
                - af * (H @ p) + rho * (Q.T @ ubar) - rho * (g0 * X + g1 * Y))
    else:
        ubar = c0 * u + c2 * v + c3 * a
        X, Y = agx, agy
        want = (G @ (c0 * p + c2 * pd + c3 * pdd) + Cf @ (c1 * p + c4 * pd + c5 * pdd)
                + rho * (Q.T @ ubar) - rho * (g0 * agx + g1 * agy))
    bp = np.empty(N)
    fluid_bp(_t(G), _t(Cf), _t(H), _t(QfT), p, pd, pdd, u[rows], v[rows], a[rows], g0, g1,
             np.array([c0, c2, c3]), np.array([c1, c4, c5]), np.array([c0, c2, c3]), cm, am,
             cf, af, rho, X, Y, alpha, np.empty(N), np.empty(N), np.empty(NF), bp)
    assert np.array_equal(bp, want)
    out = np.zeros(NU)
    fluid_face(_t(Qf), bp, p, cf, af, alpha, rows, out)
    want_out = cf * (Q @ bp) + af * (Q @ p) if alpha else Q @ bp
    assert np.array_equal(out, want_out)


def test_drift_and_commit_are_the_numpy_expressions():
    rng = np.random.default_rng(4)
    G, Cf, H, Q, rows = _mats(rng)
    QfT = Q[rows].tocsr().T.tocsr()
    QfT.sort_indices()
    p, pd, pdd, pi, y = (rng.standard_normal(N) for _ in range(5))
    a = rng.standard_normal(NU)
    g0, g1 = rng.standard_normal(N), rng.standard_normal(N)
    h, dm, df, db, rho, agx, agy = 2e-3, -0.3, -0.1, 0.02, 1000.0, 0.3, -0.2
    want = (h * (dm * (G @ pdd + rho * (Q.T @ a)) + df * (Cf @ pd + H @ p
                                                         + rho * (g0 * agx + g1 * agy)))
            + (h * h * db) * (Cf @ pdd))
    out = np.empty(N)
    fluid_drift(_t(G), _t(Cf), _t(H), _t(QfT), p, pd, pdd, a[rows], g0, g1, rho, agx, agy, h,
                dm, df, h * h * db, out)
    assert np.array_equal(out, want)
    # commit: p_new = y - cc rho X u_f, the Newmark relations, the step's mean pressure
    xu, cc, c0, c2, c3, gamma = rng.standard_normal(N), 3.1e5, 1e6, 2e3, 0.4, 0.6
    p_new = y - cc * rho * xu
    pm = 0.5 * (p + p_new)
    dpi = h * pm
    dp = p_new - p
    pdd_new = c0 * dp - c2 * pd - c3 * pdd
    pd_new = pd + h * ((1 - gamma) * pdd + gamma * pdd_new)
    got = [np.empty(N) for _ in range(6)]
    fluid_commit(y, xu, cc * rho, p, pd, pdd, pi, c0, c2, c3, h, 1 - gamma, gamma, *got)
    for g, w in zip(got, (p_new, pm, dpi, pd_new, pdd_new, pi + dpi)):
        assert np.array_equal(g, w)
