"""The Koyna run (ngs_driver.apps.dam) on the tiny smoke scene: outputs, static state, resume."""
import json
import math
import pathlib

import numpy as np
import pytest

pytest.importorskip("ngsolve")

from ngs_driver.apps.dam import RunInterrupted, run  # noqa: E402
from ngs_driver.run.joints import crack_measures  # noqa: E402
from ngs_driver.setup import build_law, describe  # noqa: E402
from ngs_driver.fe.model import build_from_scene  # noqa: E402
from ngs_driver.scene import load_scene  # noqa: E402

SMOKE = "koyna_smoke"


@pytest.fixture(scope="module")
def smoke_model():
    return build_from_scene(load_scene(SMOKE))


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory, smoke_model):
    out = tmp_path_factory.mktemp("smoke")
    s = run(load_scene(SMOKE), out, progress=False, model=smoke_model, plots=True)
    return out, s


def _finite(obj):
    if isinstance(obj, dict):
        return all(_finite(v) for v in obj.values())
    if isinstance(obj, list):
        return all(_finite(v) for v in obj)
    if isinstance(obj, float):
        return math.isfinite(obj)
    return True


def test_smoke_outputs(smoke_run):
    out, s = smoke_run
    d = json.loads((out / "summary.json").read_text())
    for k in ("scene", "ground_motion", "formulation", "mesh", "dofs", "frequencies_hz",
              "rayleigh", "characteristic_times", "timings", "solver_totals", "environment",
              "static", "results", "label"):
        assert k in d, k
    assert d["ground_motion"]["synthetic"] is True and "synthetic" in d["label"].lower()
    assert d["formulation"].startswith("relative")
    assert len(d["frequencies_hz"]) == 6 and d["frequencies_hz"][0] > 0
    assert d["rayleigh"]["a0"] > 0 and d["rayleigh"]["a1"] > 0
    ch = d["characteristic_times"]
    assert ch["t1"] == pytest.approx(2500 * math.sqrt(50e9 / 2500) * (2 * 250 / 3e6) / 6e6)
    assert ch["t2"] == pytest.approx(70 / math.sqrt(50e9 / 2500))
    for k in ("static", "dynamic", "per_step_median"):
        assert d["timings"][k] > 0
    assert d["n_steps"] == 50 and d["scene"]["interface"]["g_max"] == 6.6667e-4
    assert _finite(d)
    for f in ("timeseries.csv", "crest_displacement.csv", "damage_profiles.csv",
              "final_state.npz", "fig10_crest_displacement.png", "fig11_damage_profiles.png",
              "crack_length.png", "fig12_heel_von_mises.png", "fig8b_mesh.png"):
        assert (out / f).exists(), f
    assert not list(out.glob("checkpoint*")), "checkpoints are removed after a complete run"
    ts = (out / "timeseries.csv").read_text()
    assert "SYNTHETIC" in ts and "relative" in ts
    rows = [ln for ln in ts.splitlines() if not ln.startswith("#")]
    assert len(rows) == 51
    # the smoke record (strong phase, x3) makes the interface nonlinear
    assert d["results"]["max_D"] > 0 and d["solver_totals"]["iterations"] >= 50


def test_mesh_triangles_from_netgen_arrays(smoke_model):
    """The figures' triangles from netgen's element arrays are NGSolve's element loop's."""
    import ngsolve as ngs

    from ngs_driver.post.plots import mesh_triangles
    P, reg = mesh_triangles(smoke_model.mesh)
    mesh = smoke_model.mesh
    V = np.array([v.point for v in mesh.vertices])
    els = list(mesh.Elements(ngs.VOL))
    ref = V[np.array([[v.nr for v in el.vertices] for el in els])][:, :, :2]
    assert P.shape == (mesh.ne, 3, 2) and np.array_equal(P, ref)
    assert reg.tolist() == [el.mat for el in els] and {"dam", "rock"} <= set(reg.tolist())


def test_crack_measures():
    class S:
        debonded = np.array([True, True, False, True])
    w = np.array([0.1, 0.2, 0.3, 0.4])
    tot, heel, n = crack_measures(S, w)
    assert (tot, heel, n) == (pytest.approx(0.7), pytest.approx(0.3), 3)
    S.debonded = np.array([False, True, True, True])
    assert crack_measures(S, w)[1] == 0.0
    S.debonded = np.ones(4, bool)
    assert crack_measures(S, w)[1] == pytest.approx(1.0)


def test_static_equals_linear_when_elastic(tmp_path, smoke_model):
    """Dead load + reservoir with an intact interface: the solver's static state is the linear
    solution with the law's initial stiffness.  g_max = 10 m makes the Eq. 7 damage of the
    single static increment negligible (~1e-11; with the default g_max the static opening
    gives D ~ 2e-3 at the heel for alpha = 2, the law is then not exactly linear)."""
    sc = load_scene(SMOKE, ["interface.g_max=10.0", "time.duration=0.004"])
    s = run(sc, tmp_path, progress=False, model=smoke_model, plots=False)
    st = s["static"]
    law = build_law(sc)
    assert st["max_normal_traction"] < sc.interface.sigma_max
    assert st["max_kappa"] < law.cohesive.lambda_max          # on the initial elastic branch
    # the intact joint is bilinear elastic: k_N (cohesive) in tension, contact_stiffness in
    # compression; its linear solution by active sets on the sign of the opening (2 passes)
    iface = smoke_model.interface
    kn = np.full(iface.npts, sc.interface.contact_stiffness)
    for _ in range(10):
        u = smoke_model.static_solution(kn, law.cohesive.k_tangential)
        tension = iface.gap(u)[:, 0] > 0
        kn_new = np.where(tension, law.cohesive.k_normal, sc.interface.contact_stiffness)
        if np.array_equal(kn_new, kn):
            break
        kn = kn_new
    assert np.array_equal(kn_new, kn)
    cx, cy = smoke_model.crest_dofs
    scale = math.hypot(u[cx], u[cy])
    assert abs(st["crest_ux"] - u[cx]) <= 1e-8 * scale
    assert abs(st["crest_uy"] - u[cy]) <= 1e-8 * scale


def test_resume_equals_uninterrupted(tmp_path, smoke_model):
    sc = load_scene(SMOKE)                      # checkpoint_every = 10, 50 steps
    a = tmp_path / "a"
    b = tmp_path / "b"
    run(sc, a, progress=False, model=smoke_model, plots=False)
    with pytest.raises(RunInterrupted):
        run(sc, b, progress=False, model=smoke_model, plots=False, max_steps=27)
    assert not (b / "summary.json").exists()
    assert json.loads((b / "checkpoint.json").read_text())["step"] == 20
    s = run(sc, b, resume=True, progress=False, model=smoke_model, plots=False)
    assert s["resumed_from_step"] == 20
    za, zb = np.load(a / "final_state.npz"), np.load(b / "final_state.npz")
    for k in za.files:
        np.testing.assert_allclose(zb[k], za[k], rtol=1e-12, atol=1e-12 * np.abs(za[k]).max()
                                   + 1e-300, err_msg=k)
    ta, tb = (a / "timeseries.csv").read_text(), (b / "timeseries.csv").read_text()
    strip = [ln.split(",")[:-1] for ln in ta.splitlines()], \
        [ln.split(",")[:-1] for ln in tb.splitlines()]   # last column = wall time
    assert strip[0] == strip[1]


def test_resume_other_scene_refused(tmp_path, smoke_model):
    sc = load_scene(SMOKE)
    with pytest.raises(RunInterrupted):
        run(sc, tmp_path, progress=False, model=smoke_model, plots=False, max_steps=12)
    other = load_scene(SMOKE, ["interface.alpha=1.0"])
    with pytest.raises(ValueError, match="different scene"):
        run(other, tmp_path, resume=True, progress=False, model=smoke_model, plots=False)


def test_smoke_regression(smoke_run):
    """Koyna_smoke gives the crest displacement, D and kappa profiles and final displacement
    recorded at full precision from this round's final solver (generalized-alpha rho_inf 0.7,
    rayleigh_deformation damping, contact stiffness 9e10 Pa/m; in
    tests/data/koyna_smoke_regression.npz). A regression pin, not a verification: it catches
    any change of the results. Tolerance 1e-10 relative to the largest value: the run is
    repeatable to round-off (tests/test_koyna_studies.py), and a change of the physics or the
    integrator moves them by far more (this round's defaults moved the crest displacement by
    4.0e-4 m and max D by 0.098)."""
    out, s = smoke_run
    ref = np.load(pathlib.Path(__file__).parent / "data" / "koyna_smoke_regression.npz")
    from ngs_driver.post.files import read_csv
    H = read_csv(out / "timeseries.csv")
    fs = np.load(out / "final_state.npz")
    for got, want in ((H["crest_ux"], ref["crest_ux"]), (H["crest_uy"], ref["crest_uy"]),
                      (H["max_D"], ref["max_D"]), (fs["state_damage"], ref["D"]),
                      (fs["state_kappa"], ref["kappa"]), (fs["u"], ref["u"])):
        assert got.shape == want.shape
        assert np.max(np.abs(got - want)) <= 1e-10 * np.max(np.abs(want))
    assert np.array_equal(fs["x"], ref["x"])


def test_energy_budget_recorded(smoke_run):
    """Every step books the energy budget; the residual of this strongly nonlinear run (cuts,
    debonding over 45 m in 0.1 s) is small against the input work: measured 2.3e-3 at
    dt = 2 ms (verification/energy_balance.py); 5e-3 bounds it with a factor 2 and would catch
    a missing term of the size of the damping (29 % of the input work) or of the integrator's
    (E_alg, 3.7e-4 of the input work with generalized alpha rho_inf = 0.7, must be positive:
    the scheme dissipates). The size-scale term is booked (3.5e-3 of the input work since the
    contact stiffness no longer follows the size scaling)."""
    out, s = smoke_run
    e = s["energy"]
    assert 0 < e["max_residual_over_input_work"] < 5e-3
    f = e["final"]
    assert f["W_ext"] > 0 and f["E_damp"] > 0 and f["base_E_diss"] > 0
    assert f["E_alg"] > 0
    assert f["E_scaling"] > 1e-3 * e["input_work_scale"]
    assert (out / "energy_budget.png").exists()


def test_describe_no_build():
    d = describe(load_scene("koyna"))
    assert d["will_build"]["law"]["friction"] is True
    assert d["will_build"]["law"]["scaling"] is True
    assert d["scene"]["interface"]["g_max"] == pytest.approx(4 * 2 * 250 / 3e6, rel=1e-4)


def test_vtk_time_series_written(tmp_path):
    """output.vtk_every = k writes a VTK file every k steps (ParaView time series)."""
    from ngs_driver.apps.dam import run
    from ngs_driver.scene import load_scene
    sc = load_scene("koyna_smoke", ["output.vtk_every=10", "time.duration=0.04",
                                    "output.checkpoint_every=0"])
    run(sc, tmp_path, progress=False)
    vtus = sorted((tmp_path / "vtk").glob("*.vtu"))
    # 20 steps, one file every 10 steps: steps 10 and 20 (NGSolve numbers the files)
    assert len(vtus) == 2, [v.name for v in vtus]
    assert all(v.stat().st_size > 1000 for v in vtus)
    assert (tmp_path / "vtk" / "dam.pvd").exists()            # the time series index
    # the base as a polyline time series beside the volume, with D and the tractions
    vtps = sorted((tmp_path / "vtk").glob("joint_base_*.vtp"))
    assert len(vtps) == 2
    txt = vtps[-1].read_text()
    for name in ("D", "kappa", "opening", "slip", "traction_N", "traction_T"):
        assert f'Name="{name}"' in txt
    assert (tmp_path / "vtk" / "joint_base.pvd").read_text().count("<DataSet") == 2


def test_energy_balance_study_fast(tmp_path, study):
    """verification/energy_balance.py --fast: the linear run closes the budget to round-off
    (measured 1.4e-11; 1e-9 allows the Newton tolerance 1e-8 on the gap), and the nonlinear
    residual shrinks with dt (1.7e-3 at 2 ms, 1.5e-3 at 1 ms measured)."""
    res = study("energy_balance").main(fast=True, outdir=tmp_path)
    rows = res["rows"]
    assert rows["linear"]["residual"] < 1e-9
    assert rows["nonlinear dt=0.001"]["residual"] < rows["nonlinear dt=0.002"]["residual"] < 1e-2
    assert (tmp_path / "energy_balance.md").exists() and (tmp_path / "energy_balance.png").exists()


def test_vtk_of_the_water_written_with_the_dam(tmp_path):
    """With the acoustic water and output.vtk_every = k, the output stage writes the water's
    pressure beside the dam every k steps (post.RunOutputs; 20 steps, k = 10: two files each)
    and lists them in summary.json."""
    from ngs_driver.apps.dam import run
    from ngs_driver.scene import load_scene
    sc = load_scene("koyna_smoke", ["reservoir.model=acoustic", "output.vtk_every=10",
                                    "time.duration=0.04", "output.checkpoint_every=0"])
    s = run(sc, tmp_path, progress=False)
    water = sorted((tmp_path / "vtk").glob("water_*.vtu"))
    assert [w.name for w in water] == ["water_00000.vtu", "water_00001.vtu"]
    assert all(w.stat().st_size > 1000 for w in water)
    assert {f"vtk/{w.name}" for w in water} <= set(s["files"])
    assert len(sorted((tmp_path / "vtk").glob("dam*.vtu"))) == 2
