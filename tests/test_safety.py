"""Safety outputs: joint forces, uplift, sliding FS, post-earthquake state, on the
coarse koyna_smoke mesh with a rigid foundation (a few hundred DOFs)."""
import json

import numpy as np
import pytest

pytest.importorskip("ngsolve")

from ngs_driver.fe.model import build_from_scene  # noqa: E402
from ngs_driver.post.files import read_csv  # noqa: E402
from ngs_driver.apps.dam import run  # noqa: E402
from ngs_driver.run.joints import Joints, crack_measures  # noqa: E402
from ngs_driver.setup import joint_inputs, resolve  # noqa: E402
from ngs_driver.run.post_earthquake import PostEarthquakeCheck, resultant_verdict  # noqa: E402
from ngs_driver.run.safety import SlidingSafety  # noqa: E402
from ngs_driver.run.statics import solve_pre_earthquake  # noqa: E402
from ngs_driver.run.uplift import Uplift  # noqa: E402
from ngs_driver.scene import load_scene  # noqa: E402
from ngs_driver.solve.joint_solver import JointSolver  # noqa: E402

RIGID = ["geometry.foundation=rigid"]
RHO_G, H, B = 1000.0 * 9.81, 92.0, 70.0
W = 2500.0 * 9.81 * 3588.975          # the Koyna section's weight per metre (area by shoelace)
TAU, F = 10.0e6, 0.3


@pytest.fixture(scope="module")
def rigid_model():
    return build_from_scene(load_scene("koyna_smoke", RIGID))


@pytest.fixture(scope="module")
def elastic_run(tmp_path_factory, rigid_model):
    """Static + 5 steps at 1/60 of the smoke record, then the post-earthquake solve. The base
    stays on its initial linear branch: no damage part, and strengths of 10 MPa (at 3 MPa the
    coarse mesh's heel point, 2.5 MPa tension + 1.2 MPa shear under full uplift, softens:
    kappa = 0.27 > lambda_max)."""
    sc = load_scene("koyna_smoke", RIGID + ["uplift.model=linear", "interface.damage=false",
                                            "interface.sigma_max=10e6", "interface.tau_max=10e6",
                                            "ground_motion.scale=0.05", "time.duration=0.01",
                                            "solver.tol_residual=1e-12"])
    out = tmp_path_factory.mktemp("safety")
    return out, run(sc, out, progress=False, model=rigid_model, plots=False)


def test_static_forces_and_fs_by_hand(elastic_run):
    """Rigid foundation, no tailwater, linear uplift: N' = W - rho_w g H B / 2, T = rho_w g
    H^2 / 2, U = rho_w g H B / 2, FS = (f N' + tau_max B)/T. The interface stays on its linear
    branch, so the static solve is one linear solve and equilibrium holds to round-off; 1e-8
    relative leaves room for the ~1e-12 of the sparse solve and the quadrature of the linear
    pressure (exact with 3 Gauss points)."""
    out, s = elastic_run
    d = json.loads((out / "summary.json").read_text())
    b = d["static"]["joints"]["base"]
    U = 0.5 * RHO_G * H * B
    T = 0.5 * RHO_G * H ** 2
    assert b["uplift_force"] == pytest.approx(U, rel=1e-8)
    assert b["normal_force"] == pytest.approx(W - U, rel=1e-8)
    assert b["shear_force"] == pytest.approx(T, rel=1e-8)
    assert b["bonded_length"] == pytest.approx(B, rel=1e-12)
    assert b["sliding_fs"] == pytest.approx((F * (W - U) + TAU * B) / T, rel=1e-8)
    H_ = read_csv(out / "timeseries.csv")
    assert "base_sliding_fs" in H_ and H_["base_sliding_fs"].size == 5
    # the uplift is frozen ("unchanged") and the base elastic: U is the static value each step
    assert np.allclose(H_["base_uplift_force"], U, rtol=1e-12)


def test_post_earthquake_fs_of_an_undamaged_base_equals_static(elastic_run):
    """The record leaves no trace on an elastic base: the static solve from the final state
    is the static state again (1e-9: two linear solves of the same system, one started from
    the final dynamic state)."""
    out, s = elastic_run
    pe = s["post_earthquake"]
    assert pe["converged"] and pe["criterion"] == 1.3
    fs0 = s["static"]["joints"]["base"]["sliding_fs"]
    assert pe["joints"]["base"]["sliding_fs"] == pytest.approx(fs0, rel=1e-9)
    assert pe["joints"]["base"]["meets_criterion"] is True
    sf = s["safety"]["joints"]["base"]
    assert sf["time_fs_below_1"] == 0.0
    assert abs(sf["residual_slip"]) <= sf["cumulative_slip"] + 1e-18
    assert "Safety" in (out / "results.md").read_text()


def _precracked(model, scene, a_target):
    """Static state with the base debonded (kappa = 1) from the heel to the segment node
    nearest a_target (so that the kink of the drawing is a node and the quadrature exact)."""
    it = model.interface
    nodes = np.unique(np.round(it.segments[:, :, 0].ravel(), 12))
    a = float(nodes[np.argmin(np.abs(nodes - a_target))])
    joints = Joints(joint_inputs(scene), it)
    s = JointSolver(model.K, model.M, None, it.B, it.w, joints.solver_law(), dt=0.002,
                    tol_residual=1e-11, max_iter=60)
    st = s.state.copy()
    st.kappa[it.x < a] = 1.0
    s.state = st
    up = Uplift(resolve(scene), it, joints)
    solve_pre_earthquake(s, model.f_gravity + model.f_water, up)
    return a, s, SlidingSafety(joints).static_measures(s, up.p)["base"], up


@pytest.mark.parametrize("in_crack", ["full_headwater", "zero"])
def test_precracked_base_uplift_by_hand(rigid_model, in_crack):
    """A base cracked over a ~ 10 m from the heel: full_headwater (ICOLD; the USACE static
    cracked-base drawing) gives U = rho_w g H (a + (B - a)/2); zero (USBR) gives the uncracked
    line on the ligament only, U = rho_w g H (B - a)^2 / (2 B). Strength 10 MPa so that the
    crack does not grow (checked). 1e-10: Gauss quadrature of a piecewise-linear pressure
    with its kink at a node is exact."""
    sc = load_scene("koyna_smoke", RIGID + ["uplift.model=linear", f"uplift.in_crack={in_crack}",
                                            "interface.sigma_max=10e6", "interface.tau_max=10e6",
                                            "interface.damage=false"])
    a, s, m, up = _precracked(rigid_model, sc, 10.0)
    assert crack_measures(s.state, rigid_model.interface.w)[1] == pytest.approx(a, rel=1e-12)
    U = RHO_G * H * (a + 0.5 * (B - a)) if in_crack == "full_headwater" \
        else RHO_G * H * (B - a) ** 2 / (2 * B)
    assert m["uplift_force"] == pytest.approx(U, rel=1e-10)
    assert m["normal_force"] == pytest.approx(W - U, rel=1e-8)
    assert m["sliding_fs"] == pytest.approx((F * (W - U) + TAU * (B - a))
                                            / (0.5 * RHO_G * H ** 2), rel=1e-8)
    # the applied pressure is the one of the state the solve ended in (fixed point)
    assert np.array_equal(up.pressure(s.state), up.p_static)


def test_full_headwater_opens_the_crack_more_than_zero(rigid_model):
    """Same pre-cracked base: the heel opening with full headwater in the crack exceeds the one
    with zero pressure (measured 2.8e-4 m against 2.0e-5 m)."""
    g = {}
    for ic in ("full_headwater", "zero"):
        sc = load_scene("koyna_smoke", RIGID + ["uplift.model=linear", f"uplift.in_crack={ic}",
                                                "interface.sigma_max=10e6",
                                                "interface.tau_max=10e6",
                                                "interface.damage=false"])
        a, s, m, up = _precracked(rigid_model, sc, 10.0)
        g[ic] = s.g[0, 0]
    assert g["full_headwater"] > 5 * g["zero"] > 0


@pytest.mark.parametrize("in_crack", ["full_headwater", "zero"])
def test_crack_dependent_uplift_is_a_fixed_point_of_each_step(rigid_model, in_crack):
    """A base pre-cracked over ~10 m, then 10 steps of a ground acceleration ramped to
    -10 m/s^2 (inertia pushes the dam downstream): the heel crack runs (to ~34-38 m). Steps
    whose crack grew are re-solved from the committed state with the pressure of their own end
    state until it no longer changes: re-solves happen, none is accepted at the cap, and the
    pressure in force is exactly that of the final crack state."""
    sc = load_scene("koyna_smoke", RIGID + ["uplift.model=linear", f"uplift.in_crack={in_crack}",
                                            "interface.damage=false"])
    it = rigid_model.interface
    joints = Joints(joint_inputs(sc), it)
    s = JointSolver(rigid_model.K, rigid_model.M, None, it.B, it.w, joints.solver_law(),
                    dt=0.002, tol_residual=1e-10, max_iter=60)
    st = s.state.copy()
    st.kappa[it.x < 10.0] = 1.0
    s.state = st
    up = Uplift(resolve(sc), it, joints)
    _, f_static, _ = solve_pre_earthquake(s, rigid_model.f_gravity + rigid_model.f_water, up)
    s.initial_acceleration(f_static)
    a0 = crack_measures(s.state, it.w)[1]
    Mrx = rigid_model.M @ rigid_model.r_x
    for k in range(1, 11):
        up.step(s, f_static + Mrx * 2.0 * min(k, 5))
    assert crack_measures(s.state, it.w)[1] > a0 + 20.0
    assert up.fixed_point_iterations > 0 and up.fixed_point_unconverged == 0
    assert np.array_equal(up.pressure(s.state), up.p)


def test_post_earthquake_without_equilibrium_reports_the_resultants(rigid_model):
    """A base debonded over its whole length (friction 0.3, dry crack: in_crack = zero) cannot
    hold the reservoir: 0.3 W < T. The post-earthquake solve must say so (Newton's gap residual,
    relative to |g|, could otherwise accept a runaway slip), keep the final state, and give
    FS = f W / T from the load resultants (1e-12: sums of the assembled load vector)."""
    sc = load_scene("koyna_smoke", RIGID + ["uplift.model=linear", "uplift.in_crack=zero"])
    it = rigid_model.interface
    joints = Joints(joint_inputs(sc), it)
    s = JointSolver(rigid_model.K, rigid_model.M, None, it.B, it.w, joints.solver_law(),
                    dt=0.002, max_iter=10)
    st = s.state.copy()
    st.kappa[:] = 1.0
    s.state = st
    check = PostEarthquakeCheck(sc.time.max_slip, rigid_model, joints, SlidingSafety(joints),
                                Uplift(resolve(sc), it, joints))
    u0 = s.u.copy()
    pe = check.run(s, rigid_model.f_gravity + rigid_model.f_water)
    b = pe["joints"]["base"]
    assert pe["converged"] is False and "no static equilibrium" in pe["note"]
    assert np.array_equal(s.u, u0)
    assert b["uplift_force"] == 0.0
    assert b["normal_force"] == pytest.approx(W, rel=1e-12)
    assert b["shear_force"] == pytest.approx(0.5 * RHO_G * H ** 2, rel=1e-12)
    assert b["sliding_fs"] == pytest.approx(F * W / (0.5 * RHO_G * H ** 2), rel=1e-12)
    assert b["meets_criterion"] is False
    assert "< 1, the loads exceed the friction: the dam slides" in pe["note"]


def test_resultant_verdict_follows_the_fs():
    """The note of a post-earthquake solve without equilibrium says the dam slides only when
    the resultants' FS is below 1 (an energy-study run reported FS 1.31 with "the dam
    slides")."""
    assert "the dam slides" in resultant_verdict(0.74)
    v = resultant_verdict(1.309)
    assert "1.31 >= 1" in v and "slides" not in v.replace("sliding", "")


def test_resume_with_crack_dependent_uplift_and_screening(tmp_path):
    """koyna_smoke (rock, the heel cracks) with in_crack = zero and screening: a run stopped
    after 27 steps and resumed from its checkpoint at step 20 ends where the uninterrupted
    one does (the static pressure, the pressure in force and the screening accumulators are
    checkpointed); 1e-12 as in test_koyna_run's resume test."""
    from ngs_driver.apps.dam import RunInterrupted

    sc = load_scene("koyna_smoke", ["uplift.model=linear", "uplift.in_crack=zero",
                                    "screening.enabled=true"])
    model = build_from_scene(sc)
    a, b = tmp_path / "a", tmp_path / "b"
    sa = run(sc, a, progress=False, model=model, plots=False)
    with pytest.raises(RunInterrupted):
        run(sc, b, progress=False, model=model, plots=False, max_steps=27)
    sb = run(sc, b, resume=True, progress=False, model=model, plots=False)
    assert sb["resumed_from_step"] == 20
    assert sa["results"]["crack_length_heel_final"] > 0
    za, zb = np.load(a / "final_state.npz"), np.load(b / "final_state.npz")
    for k in za.files:
        np.testing.assert_allclose(zb[k], za[k], rtol=1e-12, atol=1e-12 * np.abs(za[k]).max()
                                   + 1e-300, err_msg=k)
    assert sa["safety"]["uplift_fixed_point_solves"] > 0       # the crack grew under p
    assert sb["screening"] == sa["screening"]
    assert sb["safety"]["uplift_fixed_point_solves"] == sa["safety"]["uplift_fixed_point_solves"]
    assert sb["safety"]["joints"] == sa["safety"]["joints"]
    assert sb["post_earthquake"]["joints"] == sa["post_earthquake"]["joints"]


def test_safety_table_without_a_post_earthquake_fs():
    """A run that collapsed has no post-earthquake solve (summary.json: skipped, sliding_fs
    null): its cell says so; a solve that found no FS says none. Neither reads "never" (the
    word of the time columns), as make run's results.md did for the paper scene."""
    from ngs_driver.post.report import safety_table

    def summary(skipped):
        return {"static": {"joints": {"base": {"sliding_fs": 5.69}}},
                "safety": {"joints": {"base": {"min_sliding_fs": 1.0, "time_fs_below_1": 0.0,
                                               "residual_slip": 0.002}}},
                "post_earthquake": {"skipped": skipped, "joints": {
                    "base": {"sliding_fs": None, "meets_criterion": False}}}}
    txt = safety_table({"a": (summary(True), None, None), "b": (summary(False), None, None)})
    assert "| a | 5.69 | 1 | 0.000 s | 0.002 m | not computed (run stopped) | NO |" in txt, txt
    assert "| b | 5.69 | 1 | 0.000 s | 0.002 m | none | NO |" in txt, txt


def test_compare_results_md_carries_the_safety_table(elastic_run, tmp_path):
    """`compare` (make run's results.md) lists each run's base FS: static, minimum, post-
    earthquake and the 1.3 check, formatted from summary.json."""
    from ngs_driver.post.report import compare_runs

    out, s = elastic_run
    compare_runs({"alpha2": out}, tmp_path)
    txt = (tmp_path / "results.md").read_text()
    fs = s["static"]["joints"]["base"]["sliding_fs"]
    assert "Sliding safety of the base" in txt
    assert f"| alpha2 | {fs:.3g} |" in txt and "| yes |" in txt


def test_damage_ordering_tells_saturated_runs_apart_by_the_heel():
    """make run's results.md said "alpha = 2 gives less damage" when both runs reached max D = 1
    (the paper scene: the base debonds in both). Equal maxima now say so and compare the
    heel's (0.00564 against 0.2847 there); unequal maxima keep their sentence."""
    from ngs_driver.post.report import damage_ordering

    txt = damage_ordering({"max_D": 1.0, "max_D_heel": 0.00564},
                          {"max_D": 1.0, "max_D_heel": 0.2847})
    assert "gives less damage" not in txt
    assert "The same largest damage in both runs" in txt
    assert "at the heel max D = 0.00564 (alpha = 2) vs 0.2847 (alpha = 1): alpha = 2 less" in txt
    assert "gives less damage" in damage_ordering({"max_D": 0.3}, {"max_D": 0.5})
    assert "gives more damage" in damage_ordering({"max_D": 0.5}, {"max_D": 0.3})
    assert "heel max D = 0.5 (alpha = 2) vs 0.2 (alpha = 1): alpha = 2 more" in damage_ordering(
        {"max_D": 1.0, "max_D_heel": 0.5}, {"max_D": 1.0, "max_D_heel": 0.2})
