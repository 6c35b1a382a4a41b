"""The damping models (docs/sliding.md §4, solve/damping.py, run/damping.py): the mass term of
``rayleigh_deformation`` acts on deformation, not on a block's rigid sliding or rocking, and
its Woodbury factor solves the dense-plus-sparse matrix exactly."""
import numpy as np
import pytest
import scipy.sparse as sp

pytest.importorskip("ngsolve")

from ngs_driver.fe.blocks import block_rigid_modes  # noqa: E402
from ngs_driver.fe.model import build_from_scene  # noqa: E402
from ngs_driver.scene import load_scene  # noqa: E402
from ngs_driver.solve.damping import DeformationDamping, LowRankFactor  # noqa: E402
from ngs_driver.solve.sparse import SparseFactor  # noqa: E402


@pytest.fixture(scope="module")
def neck_model():
    """The coarse Koyna on a rigid base with a neck joint: two dam blocks, two joints."""
    sc = load_scene("small", ["geometry.foundation=rigid", "reservoir.model=none",
                              "joints=[{name='neck', elevation=66.5}]"])
    return build_from_scene(sc)


def _damping(m, a0=1.7):
    R, cents = block_rigid_modes(m)
    it = m.interface
    return DeformationDamping(m.M, R, cents, it.B, it.x, it.y, it.w,
                              [it.parts[n] for n in m.joints], a0), R


def test_rigid_motions_are_not_damped_deformation_is(neck_model):
    """C_mass = a0 (M + U W U^T) = a0 D^T M D: (i) the whole dam sliding as one rigid body on
    its base, and the top block sliding or rocking on the neck, give C_mass v = 0 (to 1e-12 of
    a0 M v); (ii) a velocity with no gap rate at either joint (zero on the joints' faces: a
    deformation) dissipates Rayleigh's power, v.C_mass v = a0 v.M v; (iii) for any velocity the
    mass damping exerts no net force on the blocks above a joint (Rt^T C_mass v = 0: it is not
    a dashpot to the ground; Rayleigh's a0 M v is)."""
    m = neck_model
    low, R = _damping(m)
    n = m.nfree
    mass = lambda v: low.a0 * (m.M @ v) + low.product(v)       # noqa: E731
    whole = R[:, 0] + R[:, 3]                                   # both blocks translate in x
    for v in (whole, R[:, 3], R[:, 4], R[:, 5]):               # ... and the top block alone
        v = np.asarray(v)
        ref = np.linalg.norm(low.a0 * (m.M @ v))
        assert np.linalg.norm(mass(v)) <= 1e-12 * ref
    Idofs = np.unique(m.interface.B.indices)
    v = np.random.default_rng(0).standard_normal(n)
    v[Idofs] = 0.0                                               # no gap rate anywhere
    p_ray = low.a0 * float(v @ (m.M @ v))
    assert float(v @ mass(v)) == pytest.approx(p_ray, rel=1e-12)
    w = np.random.default_rng(2).standard_normal(n)
    # the resultant on the rigid motions of the blocks above each joint (U's first half is
    # M Rt, so Rt = M^-1 U[:, :k], M SPD)
    k = low.U.shape[1] // 2
    MRt = low.U[:, :k]
    f = mass(w)
    import scipy.sparse.linalg as spl
    Rt = np.column_stack([spl.spsolve(m.M.tocsc(), MRt[:, j]) for j in range(k)])
    assert np.linalg.norm(Rt.T @ f) <= 1e-9 * np.linalg.norm(Rt.T @ (low.a0 * (m.M @ w)))


def test_woodbury_factor_solves_the_dense_plus_sparse_matrix(neck_model):
    """LowRankFactor: forward/backward, solve, solve_at and forward_sparse of A = A_s + U W U^T
    equal a dense solve of A (1e-10 relative: cond(A) ~ 1e6 here)."""
    m = neck_model
    low, _ = _damping(m)
    c = 123.0
    A_s = (4e3 * m.M + m.K + sp.identity(m.nfree) * 1e6).tocsr()
    Wp = c * low.a0 * low.W
    A = A_s.toarray() + low.U @ Wp @ low.U.T
    dofs = np.unique(m.interface.B.indices)
    F = LowRankFactor(SparseFactor(A_s).restrict(dofs), low.U, Wp, dofs)
    b = np.random.default_rng(1).standard_normal(m.nfree)
    x = np.linalg.solve(A, b)
    for got in (F.backward(F.forward(b)), F.solve(b)):
        assert np.linalg.norm(got - x) <= 1e-10 * np.linalg.norm(x)
    bd = np.zeros(m.nfree)
    bd[dofs] = b[dofs]
    xd = np.linalg.solve(A, bd)
    assert np.linalg.norm(F.backward(F.forward_sparse(b[dofs])) - xd) <= 1e-10 * np.linalg.norm(xd)
    assert np.linalg.norm(F.solve_at(b[dofs]) - xd[dofs]) <= 1e-10 * np.linalg.norm(xd[dofs])
