"""Rocking beyond small rotations (solver.kinematics = "finite_rotation", run/rotation.py):
verification/rocking.py in its fast form (through make verify's own call) against the exact
rocking equation of a rigid block (Housner 1963; Makris & Konstantinidis 2003), and that
reference itself against Housner's closed form for slender blocks.

Each number would be wrong if the code were wrong (the last two: the same on the reduced bulk,
solver.bulk = "reduced"):
* free rocking from rest at 0.9 alpha: the time to the first impact within 5 % of the exact
  equation's (measured +0.00 % at dt = 4 ms); without the gap and P-Delta corrections (the
  small-rotation kinematics, run past their range) the block falls back in less than half
  the time (measured -55 %);
* an initial angular velocity 5 % above the critical one topples the block: verdict collapse,
  mode toppling, its time within 5 % of the exact equation's time to reach alpha (measured
  -1.0 %), at the toppling angle atan(b/h) of the pivot within 1 %; 5 % below it the block
  rocks and recovers: no collapse, its largest rotation and its impact within 5 % (measured
  +0.8 % and +1.4 %).
"""
import math

import numpy as np
import pytest

pytest.importorskip("ngsolve")

from conftest import run_fast_study  # noqa: E402
from ngs_driver.apps.dam import RunInterrupted, run  # noqa: E402
from ngs_driver.fe.blocks import linear_fields  # noqa: E402
from ngs_driver.post.files import read_csv  # noqa: E402
from ngs_driver.run.analysis import prepare  # noqa: E402
from verification.housner import free_rocking_quarter  # noqa: E402
from verification.rocking import block_scene, rotation_field  # noqa: E402


@pytest.fixture(scope="module")
def res(tmp_path_factory):
    out = tmp_path_factory.mktemp("rocking")
    r = run_fast_study("rocking", out)
    assert (out / "rocking.md").stat().st_size > 500
    return r


def test_exact_equation_against_housners_closed_form():
    """For a slender block (alpha = 0.01) sin(alpha - theta) ~ alpha - theta, and the time from
    rest at theta0 to the impact is acosh(alpha / (alpha - theta0)) / p, p^2 = 3 g / (4 R)
    (Housner 1963, eq. 5). Tolerance 1e-4: the linearisation's own error is O(alpha^2) = 1e-4
    relative (measured 2.9e-6 at 0.5 alpha, 7.5e-7 at 0.9 alpha)."""
    g, b, h = 9.81, 0.05, 5.0
    alpha, R = math.atan2(b, h), math.hypot(b, h)
    p = math.sqrt(3 * g / (4 * R))
    for frac in (0.5, 0.9):
        th0 = frac * alpha
        closed = math.acosh(alpha / (alpha - th0)) / p
        assert free_rocking_quarter(b, h, th0, g=g) == pytest.approx(closed, rel=1e-4)


def test_free_rocking_near_toppling_matches_the_exact_equation(res):
    rows = {r["kinematics"]: r for r in res["free"] if r["theta0_over_alpha"] == 0.9}
    fin, small = rows["finite_rotation"], rows["small"]
    # 5 %: the tolerance; the FE block is elastic (E = 1e13) on contact springs
    # (1e13 Pa/m) and its corrections lag one step (predicted rotation)
    assert abs(fin["error"]) <= 0.05, fin
    # the small-rotation kinematics keep the reference lever arms: the restoring moment stays
    # W R sin(alpha) instead of falling to 0 near alpha, the block falls back far too fast
    assert small["error"] < -0.2, small


def test_toppling_is_a_collapse_with_its_time(res):
    rows = {r["omega0_over_crit"]: r for r in res["topple"]}
    top, rec = rows[1.05], rows[0.95]
    assert top["verdict"] == "collapse" and top["mode"] == "toppling", top
    # 5 %: the tolerance on the toppling time
    assert top["fe_topple_time"] == pytest.approx(top["ref_topple_time"], rel=0.05)
    # the static loads' toppling angle is atan(b/h) of the pivot: the weight over the pivot
    # (1 %: the mesh's centre of mass is the rectangle's, the angle's root is found on a grid
    # of pi/40000)
    assert top["toppling_angle"] == pytest.approx(res["alpha"], rel=0.01)
    assert rec["verdict"] is None, rec
    assert rec["fe_theta_max"] == pytest.approx(rec["ref_theta_max"], rel=0.05)
    assert rec["fe_impact"] == pytest.approx(rec["ref_impact"], rel=0.05)
    assert np.isfinite(rec["fe_theta_max"]) and rec["fe_theta_max"] < res["alpha"]


def test_gap_and_load_of_a_finite_rigid_rotation(tmp_path):
    """The block turned rigidly by theta = 0.15 rad about its upstream pivot (the linear field
    theta phi_c): the corrected gap B u + g_offset is the exact rigid rotation's, normal
    sin(theta) r and tangential (cos(theta) - 1) r (r from the pivot along the joint), to
    round-off (1e-12 m); the P-Delta load has zero net force (1e-9 of the weight: round-off of
    the mass sums), its moment is dM = (cos - 1) M_lin - sin Q about the pivot, and for the
    rectangle dM = W (b (1 - cos) + h sin) (the difference of Housner's W R sin(alpha - theta)
    and the linear W R sin(alpha)) within 1e-9 relative."""

    sc = block_scene("finite_rotation", dt=0.004, duration=0.04)
    a = prepare(sc, tmp_path, progress=False)
    s, rot = a.solver, a.rotation
    x = np.asarray(a.model.interface.x)
    piv = (float(x.min()), 0.0)
    phi = rotation_field(a.model, piv)
    th = 0.15
    s.set_initial(u=th * phi)
    f = rot.step_load(s, 0.0)
    g = s.operator_gap()
    r = x - piv[0]
    assert np.max(np.abs(g[:, 0] - np.sin(th) * r)) < 1e-12
    assert np.max(np.abs(g[:, 1] - (np.cos(th) - 1.0) * r)) < 1e-12
    W = -float(np.sum(a.model.f_gravity))
    xdof = np.abs(a.model.r_x) > 0.5
    assert abs(float(np.sum(f[xdof]))) < 1e-9 * W
    assert abs(float(np.sum(f[~xdof]))) < 1e-9 * W
    b, h = 1.0 - piv[0], 5.0                  # the centre of mass from the pivot
    dM = W * (b * (1.0 - np.cos(th)) + h * np.sin(th))
    assert float(f @ phi) == pytest.approx(dM, rel=1e-9)
    assert rot.dM[0] == pytest.approx(dM, rel=1e-9)


def test_a_resumed_finite_rotation_run_is_the_uninterrupted_one(tmp_path):
    """The finite rotations change the solver's gap offset every step; a run stopped after
    step 120 (its checkpoint at step 100) and resumed ends bit for bit where the uninterrupted
    run ends: final state and every history column but the wall time. The rocking is real
    (the block's rotation passes 1e-3 rad before the checkpoint), so an offset put back stale
    (the pairing's, of its last pairing) or not at all changes the numbers: it did, with the
    rotation part's restore of the offset left out."""

    quiet = dict(progress=False, plots=False, log=lambda *a, **k: None)
    sc = block_scene("finite_rotation", dt=0.004, duration=0.6,
                     record="pulse:half-sine:1.0:0.3", extra=["output.checkpoint_every=50"])
    run(sc, tmp_path / "ref", **quiet)
    with pytest.raises(RunInterrupted):
        run(sc, tmp_path / "cut", max_steps=120, **quiet)
    s = run(sc, tmp_path / "cut", resume=True, **quiet)
    assert s["resumed_from_step"] == 100
    za, zb = (np.load(tmp_path / d / "final_state.npz") for d in ("ref", "cut"))
    assert za.files == zb.files
    for k in za.files:
        assert np.array_equal(za[k], zb[k]), k
    ha, hb = (read_csv(tmp_path / d / "timeseries.csv") for d in ("ref", "cut"))
    rot = np.abs(np.asarray(ha["base_rotation"]))
    assert rot[:100].max() > 1e-3, rot[:100].max()
    for k in ha:
        if k != "wall":
            assert np.array_equal(np.asarray(ha[k]), np.asarray(hb[k])), k


def test_reduced_bulk_rocks_and_topples_as_the_full(res):
    """The same cases on the reduced bulk (solver.bulk = "reduced", 40 modes; the rigid rotation
    lies in its basis, the lever-arm sums are the full bulk's: run/rotation.py): the time to
    the first impact of the free rocking, the largest rotation and the impact of the recovered
    case, and the toppling time, each within 1 % of the full bulk's (the issue's tolerance;
    measured -0.009 % on the free impact, 2.8e-7 and 1.0e-6 relative on the recovered case,
    the toppling at the same step, 1.532 s: the bulk's modal truncation is the only
    difference, the block's own modes are above 1 kHz); the toppling case topples in both,
    the other in neither."""
    rows = res["reduced"]
    assert len(rows) == 4, rows
    for r in rows:
        assert r["full"] is not None and r["reduced"] is not None, r
        assert abs(r["difference"]) <= 0.01, r
    top = [r for r in rows if r["quantity"] == "toppling time [s]"]
    assert len(top) == 1 and top[0]["mode_full"] == top[0]["mode_reduced"] == "toppling", top
    rec = [r for r in rows if r["case"].startswith("omega0") and r not in top]
    assert rec and all(r["mode_full"] is None and r["mode_reduced"] is None for r in rec), rec


def test_reduced_bulk_lever_arm_sums_and_load_are_the_full_bulks(tmp_path):
    """The block turned rigidly by 0.15 rad about its upstream pivot, the ground accelerating
    (0.3 g, 0.1 g: its inertial loads' sums enter dM): on the reduced bulk (40 modes) the
    moments (M_lin, Q) of gravity and of the unit ground loads about both pivots, the P-Delta
    moment dM and the corrected gap are the full bulk's to round-off (1e-12 relative: the same
    sums on the same full M and loads; measured equal); the reduced P-Delta load Phi^T M phi_m
    dM / (phi_m^T M phi_m) has the full load's moment about both pivots and the centre of the
    joint (1e-9 relative: Phi^T's solve with K_ii of the stiff block; measured 1.6e-15) and no
    net force (1e-9 of the weight; measured 1.3e-16); the static loads' moment and toppling
    angle (a push of the full DOFs projected on the basis beside the dead load) are the full
    bulk's (1e-9 relative; measured 1.6e-15). Q of gravity summed in the reduced coordinates
    (f_r . [psi_b, 0]) would be -1.50e6 N m instead of -2.45e6: psi is not in the basis."""

    th, ax, ay = 0.15, 0.3 * 9.81, 0.1 * 9.81
    out = {}
    for bulk in ("full", "reduced"):
        sc = block_scene("finite_rotation", dt=0.004, duration=0.04,
                         extra=[f"solver.bulk={bulk}"])
        a = prepare(sc, tmp_path / bulk, progress=False)
        s, m = a.solver, a.model
        x = np.asarray(m.interface.x)
        pivots = [(float(x.min()), 0.0), (float(x.max()), 0.0), (float(x.mean()), 0.0)]
        phis = [rotation_field(m, p) for p in pivots]
        s.set_initial(u=th * phis[0])
        f = a.rotation.step_load(s, 0.0, ax, ay)
        F = linear_fields(m, [r for r in m.regions if r != "rock"])
        net = [float(f @ m.field_rows(F[k])) for k in ("Tx", "Ty")]
        # static loads: the dead load and a load of the full DOFs (a downstream push growing
        # with height, 1e3 N a node and metre) in the model's coordinates
        f_s = a.f_base + m.load_rows(1e3 * F["Yx"])
        out[bulk] = dict(rot=a.rotation, m=m, gap=s.operator_gap(), moments=[f @ p for p in phis],
                         net=net, W=-float(np.sum(m.full_bulk().f_gravity)),
                         static=a.rotation.static_moment(0, th, f_s),
                         top=a.rotation.toppling_angle(0, 1.0, f_s))
        a.release()
    fu, re = out["full"], out["reduced"]
    red = re["m"].reduction                                 # the reduced bulk indeed: 40 of
    assert red.nm == 40 < red.idofs.size and re["m"].nfree < fu["m"].nfree   # its 90 modes
    np.testing.assert_allclose(np.array(re["rot"].moments), np.array(fu["rot"].moments),
                               rtol=1e-12, atol=1e-12 * np.abs(fu["rot"].moments).max())
    assert abs(fu["rot"].dM[0]) > 1e-3 * fu["W"]            # a real correction
    assert re["rot"].dM[0] == pytest.approx(fu["rot"].dM[0], rel=1e-12)
    assert np.abs(re["gap"] - fu["gap"]).max() <= 1e-12
    for mr, mf in zip(re["moments"], fu["moments"]):
        assert mf == pytest.approx(fu["rot"].dM[0], rel=1e-9)
        assert mr == pytest.approx(mf, rel=1e-9)
    assert max(abs(v) for v in re["net"]) <= 1e-9 * re["W"]
    assert re["static"] == pytest.approx(fu["static"], rel=1e-9)
    assert re["top"] == pytest.approx(fu["top"], rel=1e-9)
