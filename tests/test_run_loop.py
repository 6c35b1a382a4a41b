"""The per-step bookkeeping of a run (issue #15): the energy budget's damping work formed from
the products it takes anyway, the skipped size-scale update, the history buffer. No NGSolve."""
from types import SimpleNamespace

import numpy as np
import scipy.sparse as sp

from interfacelaw import CohesiveParams, ContactParams, InterfaceLaw
from ngs_driver.run.energy import EnergyBudget, FusedKM
from ngs_driver.run.joints import JointSet, crack_measures
from ngs_driver.run.record import History
from ngs_driver.scene import load_scene


def _spd(n, rng, density=0.05):
    A = sp.random(n, n, density=density, random_state=rng)
    return (A @ A.T + n * sp.identity(n)).tocsr()


def _budgets(rng, n=60, p=8, nonsymmetric=False):
    K, M = _spd(n, rng), _spd(n, rng)
    if nonsymmetric:
        K = (K + sp.random(n, n, density=0.02, random_state=rng)).tocsr()
    dash = sp.diags(np.where(rng.random(n) < 0.2, 1e3 * rng.random(n), 0.0)).tocsr()
    a0, a1 = 0.37, 1.3e-3
    C = (a0 * M + a1 * K + dash).tocsr()
    law = InterfaceLaw(CohesiveParams(3e6, 3e6, 1e-4, 1e-4, 0.2), ContactParams())
    joints = SimpleNamespace(names=["base"], slices=[slice(0, p)], laws=[law])
    w = rng.random(p)
    split = EnergyBudget(K, M, C, w, joints, rayleigh=(a0, a1), C_extra=dash)
    direct = EnergyBudget(K, M, C, w, joints)
    return split, direct, law, n, p


def test_damping_work_from_the_budget_products():
    """du.C(v0+v) = a0 du.(Mv0+Mv) + a1 (v0+v).(Ku-Ku0) + du.C_d(v0+v) for C = a0 M + a1 K + C_d:
    the same E_damp as the direct product to round-off, every other term bitwise."""
    rng = np.random.default_rng(3)
    split, direct, law, n, p = _budgets(rng)
    assert split._split is not None and direct._split is None
    state = law.initial_state(p)
    u, v, f = rng.random(n), rng.random(n), rng.random(n)
    t, g = rng.random((p, 2)), rng.random((p, 2))
    for b in (split, direct):
        b.start(u, v, f, t, g, state)
    for _ in range(40):
        u = u + 1e-3 * rng.standard_normal(n)
        v, f = rng.standard_normal(n), rng.random(n)
        rs, rd = (b.step(u, v, f, t, g, state) for b in (split, direct))
        for k in rd:
            if k in ("E_damp", "residual"):
                assert abs(rs[k] - rd[k]) <= 1e-12 * max(abs(rd["E_damp"]), abs(rd["W_ext"]))
            else:
                assert rs[k] == rd[k], k
    # a restored budget continues with the same products (bitwise restart)
    again = _budgets(np.random.default_rng(3))[0]
    again.restore(split.state())
    assert all(np.array_equal(x, y) for x, y in zip(again._prods, split._prods))


def test_fused_products_are_scipy_bit_for_bit():
    """K u and M v in one pass over the union of the patterns: scipy's products bit for bit
    (same row sums in the same order), also where M has entries K has not (and the reverse),
    with negative and zero entries; non-canonical input (duplicates) is summed first."""
    rng = np.random.default_rng(11)
    n = 300
    K = sp.random(n, n, density=0.03, random_state=rng, format="csr")
    K.data -= 0.5
    M = sp.random(n, n, density=0.02, random_state=rng, format="csr")
    M = (M + sp.diags(rng.random(n))).tocsr()
    pk, pm = (set(zip(*A.nonzero())) for A in (K, M))
    assert pm - pk and pk - pm                  # each has entries the other has not
    km = FusedKM(K, M)
    assert km.Kx.size > max(K.nnz, M.nnz)
    for _ in range(5):
        u, v = rng.standard_normal(n) * 10.0 ** rng.integers(-8, 8), rng.standard_normal(n)
        u[rng.random(n) < 0.1] = 0.0
        Mv, Ku = km.products(u, v)
        assert np.array_equal(Ku, K @ u) and np.array_equal(Mv, M @ v)
    # duplicates: summed like scipy's sum_duplicates (equal to the canonical matrix's product)
    coo = K.tocoo()
    Kd = sp.csr_matrix((np.r_[coo.data, 0.25 * coo.data[:7]],
                        (np.r_[coo.row, coo.row[:7]], np.r_[coo.col, coo.col[:7]])), shape=K.shape)
    Kc = Kd.copy()
    Kc.sum_duplicates()
    Mv, Ku = FusedKM(Kd, M).products(u, v)
    assert np.array_equal(Ku, Kc @ u) and not np.array_equal(Ku, K @ u)


def test_damping_work_direct_for_nonsymmetric_matrices():
    split = _budgets(np.random.default_rng(5), nonsymmetric=True)[0]
    assert split._split is None


def test_size_scale_update_skipped_when_the_failed_length_is_unchanged():
    """The update is a function of the failed length b alone: a JointSet that skips it for an
    unchanged b has the laws and sizes of a full update from scratch at every step."""
    sc = load_scene("koyna")
    n = 40
    x = np.linspace(0.0, 70.0, n)
    w = np.full(n, 70.0 / n)
    iface = SimpleNamespace(parts={"base": slice(0, n)}, x=x, y=np.zeros(n), w=w)
    js = JointSet(sc, iface)
    law0 = js.laws[0]
    kappa = np.zeros(n)
    seq = [0, 0, 3, 3, 3, 10, 10, 25, 25, 25]          # debonded points from the heel
    changes = []
    for m in seq:
        kappa[:m] = 1.5
        st = law0.initial_state(n)
        st.kappa[:] = kappa
        changes.append(js.update(st))
        b = crack_measures(st, w)[0]
        fresh = js.scalings[0].update(js.reference[0], b)
        assert js.laws[0].cohesive == fresh.cohesive and js.laws[0].friction == fresh.friction
        assert js.sizes[0] == js.scalings[0].size(b)
    # a law changes only where the failed length grows beyond b_ref = 1 m (3 points: 5.25 m)
    assert changes == [False, False, True, False, False, True, False, True, False, False]


def test_history_buffer_grows_and_round_trips():
    keys = ("step", "t", "x")
    h = History(keys, capacity=2)
    rows = [dict(step=k, t=0.1 * k, x=np.float64(k) ** 0.5) for k in range(7)]
    for r in rows:
        h.append(**r)
    assert len(h) == 7
    A = h.arrays()
    for k in keys:
        assert np.array_equal(A[k], np.asarray([r[k] for r in rows], dtype=float))
    assert np.array_equal(h.cols["x"], A["x"])
    h2 = History.from_arrays({f"hist_{k}": v for k, v in A.items()}, keys)
    h2.append(step=7, t=0.7, x=1.0)
    assert len(h2) == 8 and np.array_equal(h2.arrays()["t"][:7], A["t"])
    assert History(keys).arrays()["t"].shape == (0,)
