"""The per-step bookkeeping of a run: the energy budget's damping work formed from
the products it takes anyway, the skipped size-scale update, the history buffer. No NGSolve."""
from types import SimpleNamespace

import json

import numpy as np
import pytest
import scipy.sparse as sp

from interfacelaw import CohesiveParams, ContactParams, InterfaceLaw
from ngs_driver.run.energy import EnergyBudget
from ngs_driver.solve.products import FusedPair
from ngs_driver.run.joints import Joints, crack_measures
from ngs_driver.setup import joint_inputs
from ngs_driver.run.history import History
from ngs_driver.run.parts import Part, acting
from ngs_driver.scene import load_scene
from ngs_driver.solve.newton import Attempt, failed
from ngs_driver.solve.stepping import StepController


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
            if k in ("E_damp", "E_alg", "residual"):
                assert abs(rs[k] - rd[k]) <= 1e-12 * max(abs(rd["E_damp"]), abs(rd["W_ext"]))
            else:
                assert rs[k] == rd[k], k
    # a restored budget continues with the same products (bitwise restart)
    again = _budgets(np.random.default_rng(3))[0]
    again.restore(split.checkpoint())
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
    km = FusedPair(K, M)
    assert km.Ax.size > max(K.nnz, M.nnz)
    for _ in range(5):
        u, v = rng.standard_normal(n) * 10.0 ** rng.integers(-8, 8), rng.standard_normal(n)
        u[rng.random(n) < 0.1] = 0.0
        Ku, Mv = km.products(u, v)
        assert np.array_equal(Ku, K @ u) and np.array_equal(Mv, M @ v)
    # duplicates: summed like scipy's sum_duplicates (equal to the canonical matrix's product)
    coo = K.tocoo()
    Kd = sp.csr_matrix((np.r_[coo.data, 0.25 * coo.data[:7]],
                        (np.r_[coo.row, coo.row[:7]], np.r_[coo.col, coo.col[:7]])), shape=K.shape)
    Kc = Kd.copy()
    Kc.sum_duplicates()
    Ku, Mv = FusedPair(Kd, M).products(u, v)
    assert np.array_equal(Ku, Kc @ u) and not np.array_equal(Ku, K @ u)


def test_damping_work_direct_for_nonsymmetric_matrices():
    split = _budgets(np.random.default_rng(5), nonsymmetric=True)[0]
    assert split._split is None


def test_size_scale_update_skipped_when_the_failed_length_is_unchanged():
    """The update is a function of the failed length b alone: a Joints that skips it for an
    unchanged b has the laws and sizes of a full update from scratch at every step."""
    sc = load_scene("koyna")
    n = 40
    x = np.linspace(0.0, 70.0, n)
    w = np.full(n, 70.0 / n)
    iface = SimpleNamespace(parts={"base": slice(0, n)}, x=x, y=np.zeros(n), w=w)
    js = Joints(joint_inputs(sc), iface)
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
    h2 = History.from_arrays(A, keys)
    h2.append(step=7, t=0.7, x=1.0)
    assert len(h2) == 8 and np.array_equal(h2.arrays()["t"][:7], A["t"])
    assert History(keys).arrays()["t"].shape == (0,)


def test_numpy_pairwise_sum_replica():
    """The scan's sums are numpy's (pairwise, 8 accumulators, blocks of 128) bit for bit:
    lengths across every branch, magnitudes over 10 decades (a sequential sum differs)."""
    from ngs_driver.run.joints import np_sum
    rng = np.random.default_rng(2)
    seq_differs = 0
    for n in list(range(0, 300)) + [511, 512, 513, 1000, 4099]:
        a = rng.standard_normal(n) * 10.0 ** rng.integers(-5, 5, n)
        assert np_sum(a) == float(np.sum(a)), n
        s = 0.0
        for x in a:
            s += x
        seq_differs += s != float(np.sum(a))
    assert seq_differs > 50


def _reference_measures(js, state, gap, t, p, w):
    """The measures as computed before the scan (numpy, per joint): joints, safety, energy."""
    from ngs_driver.run.energy import stored_energy
    from ngs_driver.run.joints import debonded_measures
    from ngs_driver.run.safety import FS_CAP
    out = {}
    deb = np.asarray(state.debonded, bool)
    for name, sl, law in zip(js.names, js.slices, js.laws):
        ws = w[sl]
        total, upstream, ndeb = debonded_measures(deb[sl], ws)
        d, g = state.damage[sl], gap[sl]
        out.update({f"{name}_crack_length": total, f"{name}_crack_length_upstream": upstream,
                    f"{name}_n_debonded": ndeb, f"{name}_max_D": float(d.max()),
                    f"{name}_D_upstream": float(d[0]), f"{name}_opening_upstream": float(g[0, 0]),
                    f"{name}_slip_mean": float(np.dot(ws, g[:, 1]) / ws.sum())})
        N = -float(np.dot(ws, t[sl, 0]))
        T = abs(float(np.dot(ws, t[sl, 1])))
        bonded = ~deb[sl]
        c = law.cohesive
        soft = np.clip((1.0 - state.kappa[sl]) / (1.0 - c.lambda_max), 0.0, 1.0)
        cp = (1.0 - d) * c.tau_max * (c.l_Nc / c.l_Tc) * soft
        C = float(np.dot(ws[bonded], cp[bonded]))
        f = 0.0 if law.friction is None else float(law.friction.f)
        num = f * max(N, 0.0) + C
        out.update({f"{name}_normal_force": N, f"{name}_shear_force": T,
                    f"{name}_uplift_force": float(np.dot(ws, p[sl])),
                    f"{name}_bonded_length": float(ws[bonded].sum()),
                    f"{name}_sliding_fs": num / T if T > num / FS_CAP else FS_CAP,
                    f"{name}_stored": float(np.dot(ws, stored_energy(law, t[sl], g, state.take(sl))))})
    return out


def test_joint_scan_gives_the_numpy_measures_bit_for_bit():
    """The step's measures from one compiled pass (JointScan) are the numbers of the numpy
    code they replace, bit for bit: two joints (the base with friction), random damage,
    debonded runs from the upstream end, points in compression; and the size-scale update
    from the scan's crack length is the update from the state."""
    from ngs_driver.run.safety import SlidingSafety
    sc = load_scene("generic_gravity", ["interface.ratio_lTc_lNc=1.3"])   # l_Nc/l_Tc != 1
    rng = np.random.default_rng(7)
    n1, n2 = 137, 64
    n = n1 + n2
    w = rng.random(n) * 0.5 + 0.01
    iface = SimpleNamespace(parts={"base": slice(0, n1), "lift45": slice(n1, n)},
                            x=np.r_[np.linspace(0, 70, n1), np.linspace(3, 40, n2)],
                            y=np.r_[np.zeros(n1), np.full(n2, 45.0)], w=w)
    js = Joints(joint_inputs(sc), iface)
    assert js.laws[0].friction is not None
    assert js.law_params()[0, 1] != 1.0
    saf = SlidingSafety(js)                    # only its measures (no model needed)
    p = rng.random(n) * 1e5
    law = js.laws[0]
    checked_friction = False
    for case in range(30):
        st = law.initial_state(n)
        st.kappa[:] = rng.random(n) * 1.5
        st.damage[:] = np.where(rng.random(n) < 0.3, 1.0, rng.random(n))
        m = rng.integers(0, 40)
        st.kappa[:m] = 1.2                      # a crack from the heel
        st.kappa[n1:n1 + m // 2] = 1.1
        if case == 0:
            st.kappa[:] = 0.0
            st.damage[:] = 0.0
        gap = rng.standard_normal((n, 2)) * 1e-4
        t = rng.standard_normal((n, 2)) * 1e6
        ref = _reference_measures(js, st, gap, t, p, w)
        scan = js.scan(st, gap, t)
        got = js.measures(st, gap, scan)
        for name, sl in zip(js.names, js.slices):
            for k in ("crack_length", "crack_length_upstream", "n_debonded", "max_D",
                      "D_upstream", "opening_upstream", "slip_mean"):
                assert got[f"{name}_{k}"] == ref[f"{name}_{k}"], (case, name, k)
            m_s = saf.joint_measures(t, st, p, scan)[name]
            for k in ("normal_force", "shear_force", "uplift_force", "bonded_length",
                      "sliding_fs"):
                assert m_s[k] == ref[f"{name}_{k}"], (case, name, k)
            assert float(np.dot(w[sl], scan.stored[sl])) == ref[f"{name}_stored"]
        deb = st.debonded
        checked_friction |= bool(np.any(deb[:n1] & (t[:n1, 0] < 0)))
        # the update from the scan = the update from the state
        a, b = Joints(joint_inputs(sc), iface), Joints(joint_inputs(sc), iface)
        assert a.update(st, scan) == b.update(st)
        assert a.sizes == b.sizes and a.laws[0].cohesive == b.laws[0].cohesive
    assert checked_friction


def test_seismic_load_is_the_numpy_expression():
    """f_static - M r_x a_x - M r_y a_y of a step in one loop: numpy's bits (same order)."""
    from ngs_driver.run.analysis import seismic_load as _seismic_load
    rng = np.random.default_rng(4)
    f, mx, my = (rng.standard_normal(1000) * 10.0 ** rng.integers(-3, 9, 1000)
                 for _ in range(3))
    for ax, ay in ((0.3, -1.7), (1e-9, 2.5e3), (0.0, 0.0)):
        ax, ay = np.float64(ax), np.float64(ay)
        got = _seismic_load(f, mx, my, ax, ay)
        assert np.array_equal(got, f - mx * ax - my * ay)
        assert not np.array_equal(got, f - (mx * ax + my * ay)) or ax == 0.0


def test_csv_text_is_the_shortest_repr_of_every_value():
    """The CSV writer formats low-cardinality columns once per distinct bit pattern: the text
    is still repr() of every value, row by row (+-0.0, nan, inf kept apart)."""
    from ngs_driver.post.files import csv_text
    rng = np.random.default_rng(5)
    n = 200
    flags = np.where(rng.random(n) < 0.5, 0.0, -0.0)
    flags[::7] = np.nan
    flags[::11] = -np.inf
    cols = [np.arange(n, dtype=float), flags, np.full(n, 3e6), rng.standard_normal(n) / 3,
            rng.integers(0, 5, n).astype(float) * 0.1]
    txt = csv_text(["a", "b", "c", "d", "e"], cols, ["note"])
    rows = [",".join(repr(float(c[i])) for c in cols) for i in range(n)]
    assert txt == "# note\na,b,c,d,e\n" + "\n".join(rows) + "\n"
    assert "-0.0" in txt and ",0.0," in txt


def test_joint_scan_divides_by_zero_as_numpy():
    """lambda_max = 1 or a zero stick stiffness: inf / nan as numpy's measures, no exception."""
    from ngs_driver.run.joints import _scan
    n = 6
    kappa = np.array([0.0, 0.5, 1.0, 1.2, 0.0, 1.0])
    damage = np.array([0.0, 0.2, 0.0, 0.0, 1.0, 0.0])
    t = np.array([[-1.0, 2.0]] * n)
    g = np.ones((n, 2))
    par = np.array([[3e6, 1.0, 1.0, 1.0, 0.0]])          # lambda_max = 1, C_T = 0
    wb, cpb, stored = np.empty(n), np.empty(n), np.empty(n)
    ints, flts = np.empty((1, 2), dtype=np.int64), np.empty((1, 4))
    _scan(np.array([0]), np.array([n]), par, np.ones(n), kappa, damage, t, g, np.empty(n),
          wb, cpb, stored, ints, flts)
    with np.errstate(all="ignore"):
        x = np.clip((1.0 - kappa) / (1.0 - 1.0), 0.0, 1.0)
        cp = (1.0 - damage) * 3e6 * 1.0 * x
        deb = (kappa >= 1.0) | (damage >= 1.0)
        tang = np.where(deb & (t[:, 0] < 0), 0.5 * t[:, 1] ** 2 / 0.0, 0.5 * t[:, 1] * g[:, 1])
    nb = int(ints[0, 1])
    assert nb == 2 and np.array_equal(cpb[:nb], cp[~deb], equal_nan=True)
    assert np.array_equal(stored, 0.5 * t[:, 0] * g[:, 0] + tang)
    assert np.isinf(stored[deb]).all() and cpb[:nb].tolist() == [3e6, 0.8 * 3e6]   # x = inf -> 1


def test_checkpoints_written_in_the_background_in_order(tmp_path):
    """A checkpoint is the arrays and meta at save() (later changes of the caller's arrays do
    not reach it); written by a thread in the order npz, json (the commit point), old npz
    removed; a write error is raised by the run's next wait()."""
    from ngs_driver.run.checkpoint import Checkpointer
    ck = Checkpointer(tmp_path, 250)
    u = np.arange(5.0)
    meta = {"time": 0.5}
    ck.save(250, meta, u=u)
    u[:] = -1.0                                  # the caller moves on
    meta["time"] = 9.0
    ck.save(500, {"time": 1.0}, u=u)
    m, arrs = ck.load()                          # waits for the writer
    assert m["step"] == 500 and m["arrays"] == "checkpoint_0000500.npz"
    assert np.array_equal(arrs["u"], -np.ones(5))
    # the previous set stays until the next one is committed (a damaged newest falls back)
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "checkpoint.json", "checkpoint.prev.json", "checkpoint_0000250.npz",
        "checkpoint_0000500.npz"]
    ck.save(750, {"time": 1.5}, u=u)
    ck.wait()
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "checkpoint.json", "checkpoint.prev.json", "checkpoint_0000500.npz",
        "checkpoint_0000750.npz"]
    assert json.loads((tmp_path / "checkpoint.prev.json").read_text())["step"] == 500
    ck2 = Checkpointer(tmp_path / "a", 1)
    v, meta = np.arange(3.0), {"time": 0.0}
    ck2.save(1, meta, v=v)
    v[:] = 7.0
    meta["time"] = 7.0
    m, arrs = ck2.load()
    assert arrs["v"].tolist() == [0.0, 1.0, 2.0] and m["time"] == 0.0
    bad = Checkpointer(tmp_path / "file_not_dir", 1)
    (tmp_path / "file_not_dir").write_text("x")  # the directory is a file: the write fails
    bad.save(1, {}, u=u)
    with pytest.raises(OSError):
        bad.wait()
    bad.wait()                                   # reported once



def _toy_newmark(seed):
    """A 200-DOF Newmark solver with Rayleigh C and one interface point, and random committed
    u, v, a spanning nine decades: (solver, rng, K, M)."""
    from ngs_driver.solve.joint_solver import JointSolver
    import interfacelaw as il
    rng = np.random.default_rng(seed)
    n = 200
    K = sp.random(n, n, density=0.04, random_state=rng, format="csr")
    K = (K + K.T + sp.diags(np.full(n, 5.0))).tocsr()
    M = sp.diags(rng.random(n) + 1.0).tocsr()
    C = (0.3 * M + 1e-3 * K).tocsr()
    B = sp.csr_matrix((np.r_[1.0, -1.0, 1.0, -1.0], ([0, 0, 1, 1], [0, 1, 2, 3])), shape=(2, n))
    law = il.InterfaceLaw(il.CohesiveParams.from_fracture_energy(3e6, 3e6, 100.0, 0.2, 1.0),
                          il.ContactParams("linear"))
    s = JointSolver(K, M, C, B, np.ones(1), law, dt=1e-3)
    s.u, s.v, s.a = (rng.standard_normal(n) * 10.0 ** rng.integers(-6, 3) for _ in range(3))
    return s, rng, K, M


def test_newmark_rhs_fused_is_numpy_bit_for_bit():
    """The step's right-hand side M (c0 u + c2 v + c3 a) + C (c1 u + c4 v + c5 a) + f formed in
    one compiled pass (``JointSolver.right_hand_side`` with C given, alpha_hht = 0) equals the numpy /
    scipy expression bit for bit: the same operations in the same order."""
    s, rng, K, M = _toy_newmark(12)
    n = s.ndof
    f = rng.standard_normal(n)
    fused = s.right_hand_side(1e-3, f)
    ref = s.right_hand_side(1e-3, f, fused=False)    # the numpy / scipy path
    assert np.array_equal(fused, ref)


def test_step_products_feed_the_budget_and_the_next_rhs_bit_for_bit():
    """``JointSolver.step_products`` (K u, M v of the committed state, and the next step's
    M x, C y in the same pass) gives the energy budget the products it would form itself and
    the next step the right-hand side it would form itself, bit for bit; a step of another
    size (a cut) does not take the kept products."""
    from ngs_driver.solve.products import FusedPair
    s, rng, K, M = _toy_newmark(13)
    n = s.ndof
    Ku, Mv = s.step_products()
    Ku_ref, Mv_ref = FusedPair(K, M).products(s.u, s.v)      # the budget's own pass
    assert np.array_equal(Ku, K @ s.u) and np.array_equal(Ku, Ku_ref)
    assert np.array_equal(Mv, M @ s.v) and np.array_equal(Mv, Mv_ref)
    f = rng.standard_normal(n)
    kept = s.right_hand_side(1e-3, f)            # from the kept M x, C y
    assert s.products_kept
    s.forget_products()
    assert np.array_equal(kept, s.right_hand_side(1e-3, f))
    s.step_products()
    half = s.right_hand_side(0.5e-3, f)          # another step size: formed afresh
    s.forget_products()
    assert np.array_equal(half, s.right_hand_side(0.5e-3, f))
    assert np.array_equal(kept, s.right_hand_side(1e-3, f, fused=False))  # and numpy's expression


@pytest.mark.parametrize("name, sets", [("koyna", []), ("koyna_1967", []),
                                        ("koyna", ["interface.contact=none"])])
def test_setup_k0_is_the_run_laws_stiffness(name, sets):
    """setup's k0 of the base joint (the modal command's and the studies') is the initial
    stiffness of the law the run builds for the base, size-scaled to its start (the check
    analysis.py asserted at every run). 1e-9: the same formula through different roundings
    (l_Nc formed once or twice)."""
    from ngs_driver.setup import k0_from_scene
    from ngs_driver.solve.joint_laws import law_stiffness
    sc = load_scene(name, sets)
    law = _base_law_at_start(sc)
    kn, kt = k0_from_scene(sc)
    k0n, k0t = law_stiffness(law)
    assert abs(kn - k0n) <= 1e-9 * k0n and abs(kt - k0t) <= 1e-9 * k0t


def _base_law_at_start(sc):
    """The base's law as ``run.joints.Joints`` starts it (scaled to size 0)."""
    from ngs_driver.setup import build_law, build_scaling
    law = build_law(sc.interface)
    scal = build_scaling(sc.interface, law)
    return scal.update(law, 0.0) if scal is not None else law


def test_every_part_of_a_run_keeps_the_protocol():
    """Every class ``Analysis`` lists as a part implements ``run.parts.StepPart`` (a name,
    before_step, after_step, checkpoint, restore) and the names are unique (a checkpoint's
    namespaces); the split of a checkpoint puts arrays in the npz and the rest in the
    manifest, and joins each part's dict back unchanged."""
    from ngs_driver.run import parts as P
    from ngs_driver.run.checkpoint import CheckpointStep, SolverPart
    from ngs_driver.run.collapse import CollapseRule
    from ngs_driver.run.energy import EnergyBudget, EnergyGuard
    from ngs_driver.run.history import HeelOpening, Snapshots, StepHistory
    from ngs_driver.run.joints import SizeScale
    from ngs_driver.run.pairing import JointPairing
    from ngs_driver.run.progress import OutputsStep, Progress
    from ngs_driver.run.reservoir import ReservoirRun
    from ngs_driver.run.safety import SlidingSafety
    from ngs_driver.run.screening import Screening
    from ngs_driver.run.uplift import Uplift
    from ngs_driver.run.rotation import FiniteRotation
    classes = [SolverPart, Uplift, Screening, ReservoirRun, Joints, SlidingSafety, EnergyBudget,
               StepHistory, EnergyGuard, SizeScale, JointPairing, Snapshots, OutputsStep,
               Progress, HeelOpening, FiniteRotation, CollapseRule, CheckpointStep]
    for c in classes:
        assert all(callable(getattr(c, m, None)) for m in
                   ("before_step", "after_step", "checkpoint", "restore")), c
    names = [c.name for c in classes]
    assert len(set(names)) == len(names) and "run" not in names, names

    class A(P.Part):
        name = "a"

        def checkpoint(self):
            return {"x": np.arange(3.0), "n": 2, "d": {"t": None}}

    class B(P.Part):
        name = "b"

    arrays, meta = P.split_checkpoint([A(), B()])
    assert list(arrays) == ["a.x"] and meta == {"a": {"n": 2, "d": {"t": None}}, "b": {}}
    back = P.join_checkpoint("a", arrays, meta)
    assert np.array_equal(back["x"], np.arange(3.0))
    assert back["n"] == 2 and back["d"] == {"t": None}
    with pytest.raises(ValueError, match="two parts named 'a'"):
        P.split_checkpoint([A(), A()])


def test_step_calls_only_the_parts_that_act():
    """``run.parts.acting``: the parts whose hook is not Part's no-op, in order; a hook set on
    the instance or a class outside Part's tree counts; Analysis.step calls these only."""
    class Before(Part):
        name = "before"

        def before_step(self, ctx):
            pass

    class After(Before):
        name = "after"

        def after_step(self, ctx):
            pass

    class Plain:                          # the protocol without Part's defaults
        name = "plain"

        def before_step(self, ctx):
            pass

        def after_step(self, ctx):
            pass

    noop, b, a, p, inst = Part(), Before(), After(), Plain(), Part()
    inst.after_step = lambda ctx: None
    parts = [noop, b, a, p, inst]
    assert acting(parts, "before_step") == [b, a, p]
    assert acting(parts, "after_step") == [a, p, inst]


class ScriptedSolver:
    """The solver side of ``StepController.step``, scripted: dt = 1, the committed state
    ``cs``; ``outcome(h, fe)`` gives each attempt, recorded in ``calls`` as (h, fe[0])."""
    dt, min_dt, w = 1.0, 1e-3, np.ones(2)

    def __init__(self, cs, outcome):
        self.committed, self.outcome, self.calls, self.history = cs, outcome, [], []

    def drop_static(self):
        pass

    def attempt(self, h, fe):
        self.calls.append((h, float(fe[0])))
        return self.outcome(h, fe)

    def commit(self, h, fe, res):
        cs = self.committed
        cs.time += h
        cs.f = fe
        cs.state = res.state


def test_step_controller_first_attempt_is_not_repeated():
    """The whole step's first attempt (made without Fraction arithmetic) feeds the sub-step
    loop when it fails: each sub-step size is attempted once, as before (dt, dt/2, dt/4, then
    the second half at dt/2 after growing back), and the loads are interpolated in time."""
    st = SimpleNamespace(slip=np.zeros((2, 1)))
    cs = SimpleNamespace(f=np.array([0.0]), time=0.0, state=st, slip_sign=None,
                         active=np.array([True, False]))

    def outcome(h, fe):
        if h == 1.0 or (h == 0.5 and fe[0] == 4.0):          # the first half fails at dt/2
            return failed(3, 1.0)
        return Attempt(True, None, None, None, st, None, None, 2, 1e-9)

    solver = ScriptedSolver(cs, outcome)
    rep = StepController().step(solver, np.array([8.0]))
    assert solver.calls == [(1.0, 8.0), (0.5, 4.0), (0.25, 2.0), (0.25, 4.0), (0.5, 8.0)]
    assert rep.dts == [0.25, 0.25, 0.5] and rep.cuts == 2 and rep.iterations == 6
    assert rep.iterations_failed == 6 and cs.time == 1.0 and rep.n_active == 1
    assert solver.history == [rep]
    cs.f, cs.time = np.array([4.0]), 0.0
    solver = ScriptedSolver(cs, outcome)
    rep = StepController().step(solver, np.array([8.0]), split=1)   # no whole-step try
    assert solver.calls[0] == (0.5, 6.0) and rep.dts == [0.5, 0.5]


def test_step_controller_first_attempt_keeps_the_friction_event_rule():
    """A converged whole-step attempt in which the sliding points reverse is a friction event
    (``StepController.friction_event``): not committed, redone with half the sub-step (one
    event cut), and the committed slip signs are those of the sub-steps that were committed;
    with event_levels = 0 the same attempt is committed as it is, its signs formed by the
    commit. The signs are exact integers: compared exactly."""
    cs = SimpleNamespace(f=np.array([0.0]), time=0.0, slip_sign=None,
                         state=SimpleNamespace(slip=np.zeros((2, 1))),
                         active=np.array([True, True]))

    def outcome(h, fe):
        step = -1.0 if h == 1.0 else 1.0                     # the whole step: both reverse
        st = SimpleNamespace(slip=cs.state.slip + step)
        return Attempt(True, None, None, None, st, None, None, 2, 1e-9)

    cs.slip_sign = np.array([1, 1], np.int8)             # both points were sliding forward
    solver = ScriptedSolver(cs, outcome)
    rep = StepController(event_levels=3).step(solver, np.array([8.0]))
    assert solver.calls == [(1.0, 8.0), (0.5, 4.0), (0.5, 8.0)]
    assert rep.event_cuts == 1 and rep.dts == [0.5, 0.5] and rep.cuts == 0 and cs.time == 1.0
    assert cs.slip_sign.tolist() == [1, 1] and cs.state.slip[:, 0].tolist() == [2.0, 2.0]
    cs.f, cs.time, cs.slip_sign = np.array([0.0]), 0.0, np.array([1, 1], np.int8)
    solver = ScriptedSolver(cs, outcome)
    rep = StepController(event_levels=0).step(solver, np.array([8.0]))
    assert solver.calls == [(1.0, 8.0)] and rep.event_cuts == 0 and rep.dts == [1.0]
    assert cs.slip_sign.tolist() == [-1, -1] and solver.history == [rep]
