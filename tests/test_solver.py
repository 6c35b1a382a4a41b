"""Tests of ngs_driver.solve.joint_solver (condensed interface Newton vs full Newton, Newmark, step cutting).

The model is toymodel.block_on_block: a 4 m x 2 m elastic "dam" on an
8 m x 2 m "rock", P1 triangles, matching interface nodes, 2 Gauss points per interface segment.
Low strengths (30 kPa) so a crest load opens, closes, slides and damages the interface.
"""
import inspect

import numpy as np
import pytest

pytest.importorskip("scipy")

from interfacelaw import (CohesiveParams, ContactParams, DamageParams, FrictionParams,
                          InterfaceLaw)
from ngs_driver.solve.coupled import CoupledField
from ngs_driver.solve.fluid import FluidStepper, GroundPressureLoad
from ngs_driver.solve.joint_solver import JointSolver, SolverError
from toymodel import block_on_block


@pytest.fixture(scope="module")
def model():
    return block_on_block(0.5)


def weak_law(**kw):
    coh = CohesiveParams.from_fracture_energy(3e4, 3e4, 3.0, 0.2)
    return InterfaceLaw(coh, ContactParams("linear"), FrictionParams(0.3),
                        DamageParams(g_max=1e-3, alpha=2), **kw)


def strong_elastic_law():
    # stays in the initial elastic branch (lambda << lambda_max), contact intact in compression
    coh = CohesiveParams.from_fracture_energy(3e9, 3e9, 3e6, 0.2)
    return InterfaceLaw(coh, ContactParams("linear"))


def crest_load(m, n, dt=2e-3, amp=1.2e5, freq=10.0):
    return m.gravity + amp * np.sin(2 * np.pi * freq * n * dt) * m.crest_x


def run(m, law, method, nsteps=60, dt=2e-3, C=None, **kw):
    s = JointSolver(m.K, m.M, C, m.B, m.w, law, dt=dt, method=method, **kw)
    s.static(m.gravity)
    U, hist = [], dict(gN_max=0.0, closed_after_debond=False, slip=0.0, D=0.0, cuts=0)
    for n in range(1, nsteps + 1):
        rep = s.step(crest_load(m, n, dt))
        hist["cuts"] += rep.cuts
        U.append(s.u.copy())
        hist["gN_max"] = max(hist["gN_max"], s.g[:, 0].max())
        deb = s.state.debonded
        hist["closed_after_debond"] |= bool(np.any(deb & (s.g[:, 0] < 0) & (s.t[:, 0] < 0)))
        hist["slip"] = max(hist["slip"], np.abs(s.state.slip).max())
        hist["D"] = max(hist["D"], s.state.damage.max())
    return s, np.array(U), hist


def test_condensed_matches_full_newton(model):
    law = weak_law()
    sc, Uc, hc = run(model, law, "condensed", tol_residual=1e-11)
    sf, Uf, hf = run(model, law, "full", tol_residual=1e-11)
    # the history contains opening, closure on a debonded crack, frictional sliding, damage
    assert hc["gN_max"] > 0.5 * law.cohesive.l_Nc          # opened well into softening
    assert hc["closed_after_debond"]
    assert hc["slip"] > 1e-4
    assert hc["D"] > 1e-3
    assert sc.state.debonded.any()
    rel = np.abs(Uc - Uf).max() / np.abs(Uf).max()
    assert rel < 1e-8, rel
    for f in ("kappa", "damage", "slip", "dissipated"):
        a, b = getattr(sc.state, f), getattr(sf.state, f)
        assert np.abs(a - b).max() <= 1e-8 * max(np.abs(b).max(), 1e-30), f
    # the condensed method's Newton: at most 2.5 iterations per step on average over the 60
    # steps (a loading path through softening; a method that lost quadratic convergence
    # near the solution, e.g. a wrong tangent, takes its max_iter on some steps)
    its = sum(r.iterations for r in sc.history[1:])
    assert its <= 2.5 * 60


def test_set_law_size_scale_update(model):
    """A parameter change between steps (k0 changes): condensed keeps its factorised K0 and
    treats the difference as part of phi; it must agree with the full Newton."""
    law = weak_law()
    law2 = law.with_params(cohesive=law.cohesive.replace(sigma_max=3.3e4, l_Nc=2.2e-4))
    out = []
    for method in ("condensed", "full"):
        s = JointSolver(model.K, model.M, None, model.B, model.w, law, dt=2e-3,
                        method=method, tol_residual=1e-11)
        s.static(model.gravity)
        for n in range(1, 31):
            if n == 10:
                s.set_law(law2)
            s.step(crest_load(model, n))
        out.append(s.u)
    assert np.abs(out[0] - out[1]).max() <= 1e-8 * np.abs(out[1]).max()


def plain_newmark(m, Ktot, u0, v0, f_list, dt, beta=0.25, gamma=0.5, C=None):
    import scipy.sparse.linalg as spl
    Cm = C if C is not None else 0 * m.M
    c0, c1, c2 = 1 / (beta * dt ** 2), gamma / (beta * dt), 1 / (beta * dt)
    c3, c4, c5 = 0.5 / beta - 1, gamma / beta - 1, dt * (0.5 * gamma / beta - 1)
    lu = spl.splu((Ktot + c0 * m.M + c1 * Cm).tocsc())
    u, v = u0.copy(), v0.copy()
    a = spl.spsolve(m.M.tocsc(), f_list[0] - Ktot @ u - Cm @ v)
    out = []
    for f in f_list[1:]:
        rhs = f + m.M @ (c0 * u + c2 * v + c3 * a) + Cm @ (c1 * u + c4 * v + c5 * a)
        un = lu.solve(rhs)
        an = c0 * (un - u) - c2 * v - c3 * a
        v = v + dt * ((1 - gamma) * a + gamma * an)
        u, a = un, an
        out.append(u.copy())
    return np.array(out)


@pytest.mark.parametrize("method", ["condensed", "full"])
def test_linear_equals_plain_newmark(model, method):
    m = model
    law = strong_elastic_law()
    k0 = np.array([law.cohesive.k_normal, law.cohesive.k_tangential])
    import scipy.sparse as sp
    Ktot = (m.K + m.B.T @ sp.diags(np.tile(k0, m.npts) * np.repeat(m.w, 2)) @ m.B).tocsr()
    C = 1e-4 * m.K + 2.0 * m.M
    dt = 1e-3
    f_list = [m.gravity + 1e7 * np.sin(2 * np.pi * 30 * n * dt) * m.crest_x for n in range(41)]
    s = JointSolver(m.K, m.M, C, m.B, m.w, law, dt=dt, method=method, tol_residual=1e-12)
    s.static(f_list[0])
    u0 = s.u.copy()
    U = []
    for f in f_list[1:]:
        rep = s.step(f)
        assert rep.cuts == 0
        U.append(s.u.copy())
    if method == "condensed":
        assert s.active.sum() == 0                     # never left the elastic branch
    Ur = plain_newmark(m, Ktot, u0, np.zeros(m.ndof), f_list, dt, C=C)
    assert np.abs(np.array(U) - Ur).max() <= 1e-10 * np.abs(Ur).max()


def test_energy_conserved_undamped_average_acceleration(model):
    m = model
    law = strong_elastic_law()
    s = JointSolver(m.K, m.M, None, m.B, m.w, law, dt=5e-4)
    s.static(1e7 * m.crest_x)                 # pre-stressed, then released
    zero = np.zeros(m.ndof)
    s.initial_acceleration(zero)
    E0 = s.energy()
    Es = []
    for n in range(100):
        s.step(zero)
        Es.append(s.energy())
    assert np.abs(np.array(Es) - E0).max() <= 1e-10 * E0
    assert np.abs(s.v).max() > 0                 # it did vibrate


def test_step_is_cut_and_matches_smaller_dt(model):
    """A large step that cannot converge in max_iter is cut; the result equals a run with the
    smaller dt from the start (load interpolated linearly inside the step)."""
    m = model
    law = weak_law()
    F = m.gravity + 1.6e5 * m.crest_x
    s = JointSolver(m.K, m.M, None, m.B, m.w, law, dt=2e-2, tol_residual=1e-11)
    s.static(m.gravity)
    s.max_iter = 6
    rep = s.step(F)
    assert rep.cuts >= 1 and len(rep.dts) >= 2
    h = min(rep.dts)
    assert all(d == h for d in rep.dts)
    nsub = len(rep.dts)
    r = JointSolver(m.K, m.M, None, m.B, m.w, law, dt=h, tol_residual=1e-11)
    r.static(m.gravity)
    for k in range(1, nsub + 1):
        rr = r.step(m.gravity + (k / nsub) * (F - m.gravity))
        assert rr.cuts == 0
    assert np.abs(s.u - r.u).max() <= 1e-9 * np.abs(r.u).max()
    assert np.abs(s.state.damage - r.state.damage).max() <= 1e-9
    assert s.time == pytest.approx(2e-2)


def test_min_dt_raises_and_keeps_committed_state(model):
    m = model
    law = weak_law()
    s = JointSolver(m.K, m.M, None, m.B, m.w, law, dt=2e-2, min_dt=1e-2)
    s.static(m.gravity)
    s.max_iter = 1
    u0, st0 = s.u.copy(), s.state.copy()
    with pytest.raises(SolverError, match="minimum sub-step"):
        s.step(m.gravity + 1.6e5 * m.crest_x)
    # nothing unconverged was accepted: the committed time is the sum of the converged
    # sub-steps (each below the tolerance) and, with none, the state is the one before
    rep = s.history[-1]
    assert rep.cuts >= 1 and s.time == pytest.approx(sum(rep.dts), abs=1e-15)
    assert all(r <= s.tol_residual for r in rep.residuals)
    if not rep.dts:
        assert np.array_equal(s.u, u0)
        assert np.array_equal(s.state.damage, st0.damage)
    else:
        assert not np.array_equal(s.u, u0)


def test_hht_linear_dissipates(model):
    """HHT-alpha (alpha = -0.1) on the undamped elastic problem loses energy where the
    trapezoidal rule (alpha = 0) keeps it: after 50 steps Newmark's E/E0 = 1 to round-off
    (measured 1 - 5e-14; 1e-10 allowed), HHT's below 0.95 (measured 0.870: its modes with
    omega dt >> 1 keep rho_inf = (1 + alpha)/(1 - alpha) = 0.82 of their amplitude a step)."""
    m = model
    ratio = {}
    for a in (0.0, -0.1):
        s = JointSolver(m.K, m.M, None, m.B, m.w, strong_elastic_law(), dt=5e-4, alpha_hht=a)
        s.static(1e7 * m.crest_x)
        zero = np.zeros(m.ndof)
        s.initial_acceleration(zero)
        E0 = s.energy()
        for n in range(50):
            s.step(zero)
        ratio[a] = s.energy() / E0
    assert abs(ratio[0.0] - 1.0) < 1e-10, ratio
    assert ratio[-0.1] < 0.95, ratio


def test_report_fields(model):
    law = weak_law()
    s = JointSolver(model.K, model.M, None, model.B, model.w, law, dt=2e-3)
    rep = s.static(model.gravity)
    assert rep.iterations >= 1 and rep.cuts == 0
    rep = s.step(crest_load(model, 1))
    assert rep.dts == [2e-3] and len(rep.residuals) == 1
    assert rep.residuals[0] <= s.tol_residual
    assert 0 <= rep.n_active <= model.npts


@pytest.mark.parametrize("paired", [True, False])
def test_relative_dof_jacobian_matches_full(model, paired):
    """The Newton direction goes through the r x r system of the relative interface DOFs:
    on the matching toy interface every dam-side DOF pairs with a rock-side one
    (r = |I| / 2); without the pairing (the non-matching fallback, r = |I|) the answer is the
    same. Both agree with the full Newton to 1e-8 (tolerance 1e-11; measured ~1e-12)."""
    import scipy.sparse as sp
    law = weak_law()
    s = JointSolver(model.K, model.M, None, model.B, model.w, law, dt=2e-3,
                    tol_residual=1e-11)
    J0 = s.joints                                  # solve/interface.py JointOperator
    nI = J0.dofs.size
    assert J0.Dt.shape == (nI, nI // 2)
    assert abs(J0.G @ J0.Dt.T - J0.BI).max() == 0.0           # B_I = G Delta exactly
    s.static(model.gravity)
    if not paired:
        J0.G, J0.Dt = sp.csr_matrix(J0.BI), sp.identity(nI, format="csr")
        J0.GT = J0.G.T.tocsr()
    Uc = []
    for n in range(1, 31):
        s.step(crest_load(model, n))
        Uc.append(s.u.copy())
    sf, Uf, _ = run(model, law, "full", nsteps=30, tol_residual=1e-11)
    assert s.stats["jacobian_solves"] > 30
    assert np.abs(np.array(Uc) - Uf).max() <= 1e-8 * np.abs(Uf).max()


def test_jacobian_reuse_same_history(model):
    """Newton directions by GMRES on an earlier LU of the r x r system (jacobian_reuse) give
    the history of fresh factorisations to 1e-9 of the largest displacement (the directions
    agree to the GMRES tolerance 1e-13 on the true residual; the converged steps to the Newton
    tolerance 1e-11 each, over 30 steps); the reuse path is taken and saves factorisations."""
    law = weak_law()
    runs = {}
    for reuse in (True, False):
        s = JointSolver(model.K, model.M, None, model.B, model.w, law, dt=2e-3,
                        tol_residual=1e-11, jacobian_reuse=reuse, few_max=0)
        s.static(model.gravity)
        U = []
        for n in range(1, 31):
            s.step(crest_load(model, n))
            U.append(s.u.copy())
        runs[reuse] = (np.array(U), dict(s.stats))
    (Ur, st_r), (Uf, st_f) = runs[True], runs[False]
    assert np.abs(Ur - Uf).max() <= 1e-9 * np.abs(Uf).max()
    assert st_f["jacobian_reuses"] == 0 and st_r["jacobian_reuses"] > 0
    assert st_r["jacobian_factorisations"] < st_f["jacobian_factorisations"]


def _grid_laplacian(m, shift=0.0, skew=0.0):
    """5-point Laplacian on an m x m grid (+ shift I; + skew (antisymmetric part))."""
    import scipy.sparse as sp
    T = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(m, m))
    A = sp.kronsum(T, T) + shift * sp.identity(m * m)
    if skew:
        S = sp.diags([skew, -skew], [-1, 1], shape=(m * m, m * m))
        A = A + S
    return sp.csc_matrix(A)


@pytest.mark.parametrize("symmetric_matrix", [True, False])
def test_sparse_factor_ldl_and_lu_paths(symmetric_matrix):
    """SPD matrices keep only L and D (P A P^T = L D L^T); a nonsymmetric one keeps L and U.
    Every solve (whole, split, partial, several right-hand sides) equals a reference solve
    to 1e-12 relative (round-off of a 2500-unknown factorisation, condition ~1e3)."""
    import scipy.sparse.linalg as spl
    from ngs_driver.solve.sparse import SparseFactor
    A = _grid_laplacian(50, shift=0.01, skew=0.0 if symmetric_matrix else 0.3)
    n = A.shape[0]
    F = SparseFactor(A, symmetric=True)
    assert F.ldl is symmetric_matrix
    rng = np.random.default_rng(3)
    b = rng.standard_normal(n)
    B = rng.standard_normal((n, 3))
    x_ref = spl.spsolve(A, b)
    scale = np.abs(x_ref).max()
    assert np.abs(F.solve(b) - x_ref).max() <= 1e-12 * scale
    assert np.abs(F.backward(F.forward(b)) - x_ref).max() <= 1e-12 * scale
    X = F.solve(B)
    assert np.abs(A @ X - B).max() <= 1e-12 * np.abs(B).max() * 1e3
    dofs = np.sort(rng.choice(n, 60, replace=False))
    F.restrict(dofs)
    assert np.abs(F.backward_at(F.forward(b)) - x_ref[dofs]).max() <= 1e-12 * scale
    bd = rng.standard_normal((60, 2))
    full = np.zeros((n, 2))
    full[dofs] = bd
    ref = spl.spsolve(A, full)[dofs]
    assert np.abs(F.solve_at(bd) - ref).max() <= 1e-12 * np.abs(ref).max()
    assert np.abs(F.solve_at(bd[:, 0]) - ref[:, 0]).max() <= 1e-12 * np.abs(ref).max()
    if symmetric_matrix:       # L and D only: about half the entries of L and U
        G = SparseFactor(A, symmetric=False)
        assert not G.ldl and F.nnz < 0.6 * G.nnz


def test_forget_jacobian_makes_a_restart_bitwise(model):
    """A solver restarted from the committed fields and state of step 15 (a fresh solver, as
    after a checkpoint) continues bit for bit like the original one, and factorises and reuses
    its Jacobian at the same iterations, provided the original forgot its reused LUs at that
    step (``forget_jacobian``, called by the run after each checkpoint). Without it the
    original reuses an LU where the restart factorises (the counts differ; the directions then
    agree only to the refinement tolerance, which on this toy does not reach u's last bit)."""
    law = weak_law()

    def make():
        return JointSolver(model.K, model.M, None, model.B, model.w, law, dt=2e-3,
                           tol_residual=1e-11, few_max=0)
    a = make()
    a.static(model.gravity)
    for n in range(1, 16):
        a.step(crest_load(model, n))
    saved = a.checkpoint()               # what the run's checkpoint saves
    assert a.jacobian_kept
    a.forget_jacobian()
    before = dict(a.stats)
    b = make()
    b.restore(saved)                           # as a resumed run does
    for n in range(16, 31):
        a.step(crest_load(model, n))
        b.step(crest_load(model, n))
        assert np.array_equal(a.u, b.u) and np.array_equal(a.state.damage, b.state.damage)
    for key in ("jacobian_factorisations", "jacobian_reuses", "jacobian_solves"):
        assert a.stats[key] - before[key] == b.stats[key], key
    assert b.stats["jacobian_reuses"] > 0


def test_gmres_on_an_earlier_lu_solves_to_the_true_residual():
    """solve/krylov.gmres_lu on H = Hd + P preconditioned by the LU of Hd + P0: the solution's
    true residual is <= 1e-13 |v| (the kernel's own check, re-measured here with numpy); a
    small change of P (rank 6) converges in <= 7 iterations (GMRES: rank + 1); a large
    full-rank change does not converge in 3 iterations (-1, the caller then factorises);
    lu_solve_into solves the factorised system to round-off."""
    import scipy.linalg as sla
    import scipy.sparse as sp
    from ngs_driver.solve.krylov import gmres_lu, lu_solve_into
    rng = np.random.default_rng(4)
    r = 60
    Q = rng.standard_normal((r, r))
    Hd = Q @ Q.T / r + np.eye(r)                      # SPD, as Y^-1
    P = sp.random(r, r, density=0.08, random_state=rng, format="csr")
    P.data = rng.standard_normal(P.nnz)
    P0 = P.data.copy()
    H0 = Hd + P.toarray()
    lu, piv, _ = sla.lapack.dgetrf(H0)
    luT, piv = np.ascontiguousarray(lu.T), piv.astype(np.int32)
    v = rng.standard_normal(r)
    z = np.empty(r)
    lu_solve_into(luT, piv, v, z)
    assert np.linalg.norm(H0 @ z - v) <= 1e-13 * np.linalg.norm(v)
    m = 16
    work = (np.empty((m + 1, r)), np.empty((m, r)), np.empty((m + 1, m)), np.empty(m),
            np.empty(m), np.empty(m + 1), np.empty(r))
    Px = P0.copy()
    Px[:6] *= 1.5                                     # six entries: rank <= 6
    its = gmres_lu(luT, piv, Hd, P.indptr, P.indices, Px, P0, v, 1e-13, m, z, *work)
    H = Hd + sp.csr_matrix((Px, P.indices, P.indptr), shape=(r, r)).toarray()
    assert 1 <= its <= 7
    assert np.linalg.norm(H @ z - v) <= 1e-13 * np.linalg.norm(v)
    Px = P0 + 3.0 * rng.standard_normal(P0.size)     # large, full-rank change
    assert gmres_lu(luT, piv, Hd, P.indptr, P.indices, Px, P0, v, 1e-13, 3, z,
                    *work[:2], np.empty((4, 3)), np.empty(3), np.empty(3), np.empty(4),
                    work[-1]) == -1


# ---------------------------------------------------------------------------------------------
# the integrator family (solve/integrator.py) and the low-rank damping (solve/damping.py)
# ---------------------------------------------------------------------------------------------
def test_integrator_coefficients_are_chung_hulbert():
    """rho_inf -> (alpha_m, alpha_f, beta, gamma) of Chung & Hulbert (1993, Eqs. 25, 17, 20)
    and HHT (Hilber et al. 1977); generalized alpha at rho_inf = 0.5 is HHT's alpha = -1/3."""
    from ngs_driver.solve.integrator import Integrator
    ga = Integrator.make("generalized-alpha", rho_inf=0.7)
    assert (ga.alpha_m, ga.alpha_f) == pytest.approx((0.4 / 1.7, 0.7 / 1.7), rel=1e-15)
    assert ga.gamma == pytest.approx(0.5 - ga.alpha_m + ga.alpha_f, rel=1e-15)
    assert ga.beta == pytest.approx(0.25 * (1 - ga.alpha_m + ga.alpha_f) ** 2, rel=1e-15)
    h5, g5 = Integrator.make("hht", rho_inf=0.5), Integrator.make("generalized-alpha", rho_inf=0.5)
    assert h5.alpha_f == pytest.approx(1 / 3) and g5.alpha_m == 0.0
    assert (h5.beta, h5.gamma, h5.alpha_f) == pytest.approx((g5.beta, g5.gamma, g5.alpha_f))
    for bad in (("hht", 0.4), ("generalized-alpha", 1.1), ("leapfrog", 1.0)):
        with pytest.raises(ValueError, match="time.rho_inf|time.integrator"):
            Integrator.make(bad[0], rho_inf=bad[1])


@pytest.mark.parametrize("rho", [0.0, 0.7])
def test_generalized_alpha_spectral_radius(model, rho):
    """Free vibration of the linear block (elastic interface): the energy left after many
    steps at a large omega dt decays as the scheme's spectral radius predicts, and at rho_inf
    the highest modes lose at least (1 - rho_inf^2) of their energy per step (asymptotically);
    a low mode keeps its energy to 2nd order. Here: the whole-system energy after 40 steps of
    an impulse that excites every mode is below that of Newmark (rho_inf = 1), and never
    grows (the scheme is dissipative)."""
    from ngs_driver.solve.integrator import Integrator
    m = model
    law = strong_elastic_law()
    energies = {}
    for r in (rho, 1.0):
        it = Integrator.make("generalized-alpha", rho_inf=r)
        s = JointSolver(m.K, m.M, None, m.B, m.w, law, dt=2e-3, integrator=it)
        s.static(np.zeros(m.K.shape[0]))
        s.set_initial(u=np.zeros(m.K.shape[0]), v=np.random.default_rng(1).standard_normal(
            m.K.shape[0]) * 1e-3, a=None, f=np.zeros(m.K.shape[0]))
        s.initial_acceleration(np.zeros(m.K.shape[0]))
        e = [s.energy()]
        for _ in range(40):
            s.step(np.zeros(m.K.shape[0]))
            e.append(s.energy())
        energies[r] = np.array(e)
    e = energies[rho]
    assert np.all(np.diff(e) <= 1e-9 * e[0])                 # never gains energy
    assert e[-1] < 0.9 * energies[1.0][-1]                     # dissipates the high modes
    assert abs(energies[1.0][-1] / energies[1.0][0] - 1) < 1e-8   # trapezoid: conserves


def test_alpha_rhs_fused_equals_numpy(model):
    """The right-hand side of a generalized-alpha step from the fused products (one compiled
    pass, solve/products.step_products5) equals the numpy expression to round-off (1e-13 of
    its norm: the same sums in another association)."""
    from ngs_driver.solve.integrator import Integrator
    m = model
    rng = np.random.default_rng(7)
    C = (0.3 * m.M + 1e-3 * m.K).tocsr()
    s = JointSolver(m.K, m.M, C, m.B, m.w, weak_law(), dt=2e-3,
                    integrator=Integrator.make("generalized-alpha", rho_inf=0.6))
    n = m.K.shape[0]
    s.set_initial(u=1e-4 * rng.standard_normal(n), v=rng.standard_normal(n) * 1e-2,
                  a=rng.standard_normal(n), f=rng.standard_normal(n))
    f = rng.standard_normal(n)
    fused = s.right_hand_side(2e-3, f)
    plain = s.right_hand_side(2e-3, f, fused=False)     # the numpy path
    assert np.linalg.norm(fused - plain) <= 1e-13 * np.linalg.norm(plain)


def test_coupled_fields_declare_the_protocol():
    """The water classes give the solver every method of ``CoupledField`` (solve/coupled.py):
    the protocol is what ``JointSolver`` calls, so a renamed or missing method fails here, not
    in a long reservoir run."""
    wanted = {n for n, _ in inspect.getmembers(CoupledField, inspect.isfunction)
              if not n.startswith("_")}
    assert wanted == {"bind", "matrix", "rhs", "commit", "checkpoint", "restore"}
    for cls in (FluidStepper, GroundPressureLoad):
        assert all(callable(getattr(cls, n, None)) for n in wanted), cls


def test_checkpoint_restore_round_trip_bit_for_bit(model):
    """``checkpoint()`` holds copies (a later step does not change them) and ``restore`` of it
    makes a fresh solver take the same next steps bit for bit (a repeated step, a resume)."""
    law = weak_law()
    a = JointSolver(model.K, model.M, None, model.B, model.w, law, dt=2e-3)
    a.static(model.gravity)
    for n in range(1, 6):
        a.step(crest_load(model, n))
    d = a.checkpoint()
    u5 = d["u"].copy()
    a.forget_jacobian()
    a.step(crest_load(model, 6))
    assert np.array_equal(d["u"], u5) and not np.array_equal(a.u, u5)
    b = JointSolver(model.K, model.M, None, model.B, model.w, law, dt=2e-3)
    b.restore(d)
    assert b.time == d["time"]
    b.step(crest_load(model, 6))
    assert np.array_equal(a.u, b.u) and np.array_equal(a.t, b.t)
    assert np.array_equal(a.state.damage, b.state.damage)


def test_checkpoint_without_copies_still_restores_the_step(model):
    """``checkpoint(copy=False)`` (the run's snapshot before a step, for the energy guard's
    repeat) holds the committed arrays themselves; a step replaces them and writes nothing
    into them, so restoring it after a step repeats that step bit for bit."""
    law = weak_law()
    a = JointSolver(model.K, model.M, None, model.B, model.w, law, dt=2e-3)
    a.static(model.gravity)
    for n in range(1, 6):
        a.step(crest_load(model, n))
    d = a.checkpoint(copy=False)
    assert d["u"] is a.u and d["state_damage"] is a.state.damage
    kept = {k: np.array(v, copy=True) for k, v in d.items() if isinstance(v, np.ndarray)}
    a.forget_jacobian()
    a.step(crest_load(model, 6))
    u6, t6, D6 = a.u.copy(), a.t.copy(), a.state.damage.copy()
    assert not np.array_equal(u6, kept["u"])
    for k, v in kept.items():            # the step wrote into none of the committed arrays
        assert np.array_equal(d[k], v), k
    a.restore(d)
    a.forget_jacobian()
    a.step(crest_load(model, 6))
    assert np.array_equal(a.u, u6) and np.array_equal(a.t, t6)
    assert np.array_equal(a.state.damage, D6)
