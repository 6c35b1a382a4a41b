"""The compiled pieces of the condensed Newton's iteration (solve/gap_kernels.py) and the
interface Jacobian's LU kept for reuse (solve/condensed.py ``CondensedNewton.jacobian_solve``;
docs/solver.md §2.3).

The kernels replace numpy expressions one for one, so they are checked bit for bit against
those expressions; the direction is checked against a dense solve of the exact Jacobian
I + S Dw (independent of the push-through identity), and the reuse policy by counting
factorisations on a scripted sequence of tangents."""
import numpy as np
import pytest
import scipy.sparse as sp

from interfacelaw import CohesiveParams, ContactParams, DamageParams, FrictionParams, InterfaceLaw
from ngs_driver.solve import condensed
from ngs_driver.solve.gap_kernels import (active_blocks, gap_phi, gap_residual, push_back,
                                          scatter_add)
from ngs_driver.solve.joint_solver import JointSolver
from ngs_driver.solve.kernels import mv
from toymodel import block_on_block


def _csr(rng, m, n, density):
    A = sp.random(m, n, density=density, random_state=rng, format="csr")
    A.data = rng.standard_normal(A.nnz)
    A.sort_indices()
    return A


def test_gap_kernels_are_the_numpy_expressions_bit_for_bit():
    """gap_phi, gap_residual, active_blocks, scatter_add, push_back against the numpy code
    they replaced in ``CondensedNewton.attempt`` (exact equality: same operations, same
    order; the sparse products as ``csr_mv``)."""
    rng = np.random.default_rng(7)
    npts, r = 40, 30
    n2 = 2 * npts
    G = _csr(rng, n2, r, 0.1)
    GT = G.T.tocsr()
    GT.sort_indices()
    k0v = rng.uniform(1e9, 5e9, n2)
    wd = np.repeat(rng.uniform(0.1, 1.0, npts), 2)
    g = rng.standard_normal(n2) * 1e-4
    t = k0v * g                                       # elastic: phi is round-off ...
    t[:20] += rng.standard_normal(20) * 1e3           # ... except at points 0..9
    t[40:42] *= 1.0 + 1e-14                           # point 20: round-off only (not active)
    act = np.zeros(npts, bool)
    act[[3, 30, 31]] = True                           # committed active set
    g_lin = rng.standard_normal(n2) * 1e-4
    c = 1.3
    tol = 1e-12
    phi, newly, wphi, y = np.empty(n2), np.empty(npts, bool), np.empty(n2), np.empty(r)
    nnew, anyact = gap_phi(t, g, k0v, wd, tol, act, GT.indptr, GT.indices, GT.data, phi,
                           newly, wphi, y)
    # the numpy code it replaced
    phi_np = t - k0v * g
    m = np.abs(phi_np) > tol * (k0v * np.abs(g)) + 1e-300
    mask = m[0::2] | m[1::2]
    newly_np = ~act & mask
    act2 = act | newly_np
    ad = np.flatnonzero(np.repeat(act2, 2))
    yp = np.zeros(n2)
    yp[ad] = wd[ad] * phi_np[ad]
    assert np.array_equal(phi, phi_np)
    assert np.array_equal(newly, newly_np) and nnew == 9 and anyact   # 0..9 less point 3
    assert not newly[20]
    assert np.array_equal(wphi, yp)
    assert np.array_equal(y, mv(GT, yp))
    Y = rng.standard_normal((r, r))
    R = np.empty(n2)
    gap_residual(g, g_lin, c, G.indptr, G.indices, G.data, Y @ y, R)
    R_np = g - g_lin
    R_np += c * mv(G, Y @ mv(GT, yp))
    assert np.array_equal(R, R_np)
    # E = T - K0 at active points, 0 elsewhere
    T = rng.standard_normal((npts, 2, 2))
    k0blk = np.zeros((npts, 2, 2))
    k0blk[:, 0, 0], k0blk[:, 1, 1] = k0v[0::2], k0v[1::2]
    E = np.empty_like(T)
    active_blocks(T, k0blk, act2, E)
    E_np = T - k0blk
    E_np[~act2] = 0.0
    assert np.array_equal(E, E_np)
    # H's scatter and the push back with its finiteness flag
    flat = rng.standard_normal(r * r)
    pos = rng.choice(r * r, 50, replace=False)
    vals = rng.standard_normal(50)
    ref = flat.copy()
    ref[pos] += vals
    scatter_add(flat, pos, vals)
    assert np.array_equal(flat, ref)
    z, b, x = rng.standard_normal(r), rng.standard_normal(n2), np.empty(n2)
    assert push_back(b, G.indptr, G.indices, G.data, z, x)
    assert np.array_equal(x, b - mv(G, z))
    z[0] = np.nan
    assert not push_back(b, G.indptr, G.indices, G.data, z, x)


def _newton_system():
    """A JointSolver on the toy dam after its static solve, with the nominal step's entry
    (Y, Y^-1) of its CondensedNewton ready; random tangents E on every point."""
    m = block_on_block(0.5)
    coh = CohesiveParams.from_fracture_energy(3e4, 3e4, 3.0, 0.2)
    law = InterfaceLaw(coh, ContactParams("linear"), FrictionParams(0.3),
                       DamageParams(g_max=1e-3, alpha=2))
    s = JointSolver(m.K, m.M, None, m.B, m.w, law, dt=2e-3)
    s.static(m.gravity)
    nw = s.newton
    e = nw.entry(s.dt)
    nw.ensure_Y(e)
    return s, nw, e


def _dense_direction(nw, e, E, b, c):
    """x = (I + S Dw)^-1 b with S = G Y G^T formed densely (no push-through identity)."""
    J0 = nw.joints
    S = J0.G @ (e.Y @ J0.GT.toarray())
    Dw = E * (c * J0.w)[:, None, None]
    n2 = 2 * J0.npts
    DW = np.zeros((n2, n2))
    for p in range(J0.npts):
        DW[2 * p:2 * p + 2, 2 * p:2 * p + 2] = Dw[p]
    return np.linalg.solve(np.eye(n2) + S @ DW, b)


def test_kept_lu_direction_equals_fresh_factorisation():
    """The direction from a fresh factorisation of H = Y^-1 + P (formed in Fortran order in
    the entry's buffer) equals the dense solve of I + S Dw; with the tangent changed a little
    the kept LU serves as GMRES preconditioner (a reuse, no factorisation) and the direction
    equals a fresh factorisation's to 1e-13 relative (GMRES_TOL: the true residual of the
    r x r system; the dense comparison to 1e-9, the conditioning of I + S Dw)."""
    s, nw, e = _newton_system()
    J0 = nw.joints
    rng = np.random.default_rng(3)
    npts = J0.npts
    ad = np.arange(2 * npts)
    c = 1.0
    k0 = J0.k0blk
    E1 = -0.5 * k0 + 0.1 * k0[:, :1, :1] * rng.standard_normal((npts, 2, 2))
    b = rng.standard_normal(2 * npts)
    nw.forget_jacobian()
    st0 = dict(nw.stats)
    x1 = nw.jacobian_solve(e, E1.copy(), b, c, ad)
    assert nw.stats["jacobian_factorisations"] == st0["jacobian_factorisations"] + 1
    xd = _dense_direction(nw, e, E1, b, c)
    assert np.linalg.norm(x1 - xd) <= 1e-9 * np.linalg.norm(xd)
    E2 = E1.copy()
    E2[:5] *= 1.02                                    # five points' tangents move
    x2 = nw.jacobian_solve(e, E2.copy(), b, c, ad)    # GMRES on E1's LU
    assert nw.stats["jacobian_factorisations"] == st0["jacobian_factorisations"] + 1
    assert nw.stats["jacobian_reuses"] == st0["jacobian_reuses"] + 1
    nw.forget_jacobian()
    x2f = nw.jacobian_solve(e, E2.copy(), b, c, ad)   # fresh factorisation of E2's H
    assert nw.stats["jacobian_factorisations"] == st0["jacobian_factorisations"] + 2
    assert np.linalg.norm(x2 - x2f) <= 1e-13 * np.linalg.norm(x2f)


def test_reuse_policy_counts_factorisations(monkeypatch):
    """The policy on a scripted sequence of tangents: the first solve factorises; the same
    tangent again and a small change reuse the LU (GMRES); a solve that needed more than
    GMRES_REFRESH iterations drops the LU, so the next one factorises; a change GMRES cannot
    absorb in GMRES_MAX iterations factorises at once."""
    s, nw, e = _newton_system()
    J0 = nw.joints
    rng = np.random.default_rng(5)
    npts = J0.npts
    ad = np.arange(2 * npts)
    k0 = J0.k0blk
    E0 = -0.5 * k0 + 0.1 * k0[:, :1, :1] * rng.standard_normal((npts, 2, 2))
    b = rng.standard_normal(2 * npts)
    nw.forget_jacobian()
    seq = []

    def solve(E):
        f0 = nw.stats["jacobian_factorisations"]
        nw.jacobian_solve(e, E.copy(), b, 1.0, ad)
        seq.append(nw.stats["jacobian_factorisations"] - f0)

    solve(E0)                                         # nothing kept: factorise
    solve(E0)                                         # the same H: 0 or 1 GMRES iteration
    E1 = E0.copy()
    E1[:3] *= 1.01
    solve(E1)                                         # rank <= 12 change: reuse
    assert seq == [1, 0, 0]
    monkeypatch.setattr(condensed, "GMRES_REFRESH", 0)
    E2 = E0.copy()
    E2[3:6] *= 1.01
    solve(E2)                                         # reuse, needs > 0 its: LU dropped
    solve(E2)                                         # so this one factorises
    assert seq[3:] == [0, 1]
    monkeypatch.setattr(condensed, "GMRES_REFRESH", 8)
    monkeypatch.setattr(condensed, "GMRES_MAX", 2)
    E3 = E0 * rng.uniform(0.2, 1.8, (npts, 1, 1))     # every point changes a lot
    solve(E3)                                         # GMRES gives up in 2: factorise
    assert seq[5:] == [1]
    assert sum(seq) == 3
