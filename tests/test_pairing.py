"""Finite sliding: the lower face below each point of a sliding joint (fe/pairing.py,
run/pairing.py), checked on fields the interpolation must reproduce exactly."""
import numpy as np
import pytest
import scipy.sparse as sp

pytest.importorskip("ngsolve")

from ngs_driver.fe.model import build_from_scene  # noqa: E402
from ngs_driver.fe.pairing import lower_faces  # noqa: E402
from ngs_driver.run.pairing import splice_rows  # noqa: E402
from ngs_driver.scene import load_scene  # noqa: E402


@pytest.fixture(scope="module")
def small_model():
    return build_from_scene(load_scene("small", ["reservoir.model=none"]))


def _field(model, region, cf):
    import ngsolve as ngs
    gf = ngs.GridFunction(model.fes)
    gf.components[list(model.regions).index(region)].Set(cf)
    return np.array(gf.vec.FV().NumPy(), copy=True)[model.free]


def test_lower_face_of_the_base_is_the_rock_top(small_model):
    m = small_model
    faces = lower_faces(m)
    upper, face = faces["base"]
    assert upper == "dam"
    # the rock's top from the upstream end of the block to its downstream end, no gap
    assert face.x0[0] == pytest.approx(-70.0) and face.x1[-1] == pytest.approx(140.0)
    assert np.allclose(face.x1[:-1], face.x0[1:])
    assert face.y0 == 0.0


@pytest.mark.parametrize("shift", [0.0, 0.37, 3.21, -1.5])
def test_shifted_rows_interpolate_a_linear_rock_field_exactly(small_model, shift):
    """rows(x + s) applied to a rock displacement linear in x returns -u_rock(x + s) at every
    point: the interpolation on the face below is exact for linear fields (P1)."""
    import ngsolve as ngs
    m = small_model
    _, face = lower_faces(m)["base"]
    u = _field(m, "rock", ngs.CF((1e-3 * ngs.x + 2e-3, -4e-4 * ngs.x + 1e-3)))
    sl = m.interface.parts["base"]
    x = m.interface.x[sl]
    n = sl.stop - sl.start
    R, off = face.rows(x + shift, 0, n, (2 * n, m.nfree))
    assert not off.any()
    g = (R @ u).reshape(-1, 2)
    xs = x + shift
    assert np.allclose(g[:, 1], -(1e-3 * xs + 2e-3), rtol=0, atol=1e-15)
    assert np.allclose(g[:, 0], -(-4e-4 * xs + 1e-3), rtol=0, atol=1e-15)


def test_unshifted_pairing_is_the_matching_operator(small_model):
    """With no slip the new rows are the original operator's rock part (to round-off)."""
    from ngs_driver.fe.pairing import upper_columns
    m = small_model
    _, face = lower_faces(m)["base"]
    sl = m.interface.parts["base"]
    n = sl.stop - sl.start
    B = m.interface.B[2 * sl.start:2 * sl.stop]
    low = B.multiply(~upper_columns(m, "dam")[None, :]).toarray()
    R, _ = face.rows(m.interface.x[sl], 0, n, (2 * n, m.nfree))
    assert np.max(np.abs(R.toarray() - low)) <= 1e-12


def test_block_sliding_on_a_stiff_rock_is_paired_anew_and_slides_as_on_rigid_ground(tmp_path):
    """The sliding_block (0.14 m of slip) on a rock block 1000x stiffer than concrete, its
    interface elements 0.5 m (pairing tolerance 0.1 of them: 5 cm, so 0.14 m of slip passes
    it at least twice): the run pairs the base anew as it slides, and the permanent slip is the rigid foundation's (measured 2e-4
    relative; tolerance 2e-3: the rock's compliance under the moving load is ~1e-4 of the
    block's slip)."""
    from ngs_driver.apps.dam import run
    sets = ["mesh.h_interface=0.5", "mesh.h_heel=0.5", "solver.pairing_tolerance=0.1"]
    rigid = run(load_scene("sliding_block", sets + ["geometry.foundation=rigid"]),
                tmp_path / "rigid", progress=False, plots=False)
    rock = run(load_scene("sliding_block", sets + ["geometry.foundation=rock",
                                                   "materials.rock.E=1e13"]),
               tmp_path / "rock", progress=False, plots=False)
    assert rigid["finite_sliding"]["repairings"] == 0
    assert rock["finite_sliding"]["repairings"] >= 2
    s0 = rigid["joints"]["base"]["slip_residual"]
    s1 = rock["joints"]["base"]["slip_residual"]
    assert abs(s0) > 0.1 and abs(s1 / s0 - 1) < 2e-3, (s0, s1)


def test_splice_rows_gives_the_lil_assignment_without_its_dense_copy():
    """``run.pairing.splice_rows`` against the LIL slice assignment it replaced (values and
    canonical CSR layout equal to the last bit: the gap products B u must not change)."""
    rng = np.random.default_rng(3)
    B = sp.random(40, 300, density=0.05, random_state=rng, format="csr")
    rows = sp.random(10, 300, density=0.05, random_state=rng, format="csr")
    rows.data[0] = 0.0                  # an explicit zero stored in the new rows: dropped
    assert rows.nnz == np.count_nonzero(rows.data) + 1
    ref = B.tolil(copy=True)
    ref[12:22] = rows.tolil()
    ref = ref.tocsr()
    ref.eliminate_zeros()
    got = splice_rows(B, 12, 22, rows)
    for a in ("indptr", "indices", "data"):
        assert np.array_equal(getattr(got, a), getattr(ref, a)), a
    u = rng.standard_normal(300)
    assert np.array_equal(got @ u, ref @ u)
