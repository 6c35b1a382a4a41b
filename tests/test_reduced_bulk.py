"""The reduced bulk (``solver.bulk = "reduced"``, fe/reduction.py): Craig-Bampton basis of the
joints' DOFs, exact statically, the full bulk when every mode is kept, and its bad inputs.

Each number would be wrong if the code were wrong:
* every interior mode kept: the basis is square, the run is the full bulk's to the solver's
  tolerance (crest history; measured 3.7e-13 of the peak on koyna_smoke);
* dead load + water on a cracked base: the static joint tractions are the same with 1 mode as
  with the full bulk (the constraint modes are the exact static condensation; measured 1e-12
  relative); the interior displacement is not (body loads: modal truncation), shown too;
* the sliding block: the same permanent slip in both bulks within 1 % (measured -0.13908
  against -0.13911 m, 0.02 %); Housner's rocking block the same largest rotation (1.4e-8);
* the energy budget closes in the reduced bulk as in the full one;
* bad inputs: refused at --dry-run naming key, value and what is allowed.
"""
import numpy as np
import pytest
import scipy.sparse as sp

pytest.importorskip("ngsolve")

from conftest import run_fast_study  # noqa: E402
from ngs_driver.apps.dam import RunInterrupted, run  # noqa: E402
from ngs_driver.cli import main  # noqa: E402
from ngs_driver.fe.blocks import block_rigid_modes  # noqa: E402
from ngs_driver.fe.model import build_from_scene  # noqa: E402
from ngs_driver.fe.reduction import (ReducedCoordinates, available_modes,  # noqa: E402
                                     reduce_model)
from ngs_driver.post.files import read_csv  # noqa: E402
from ngs_driver.run.analysis import prepare  # noqa: E402
from ngs_driver.scene import load_scene  # noqa: E402
from ngs_driver.setup import validate  # noqa: E402
from ngs_driver.solve.sparse import DenseFactor, SparseFactor  # noqa: E402
from verification.sliding import STIFF_E  # noqa: E402

SMOKE = "koyna_smoke"


@pytest.fixture(scope="module")
def smoke_model():
    return build_from_scene(load_scene(SMOKE))


@pytest.mark.parametrize("sets", [["reservoir.model=westergaard", "reservoir.level=92"],
                                  ["reservoir.model=acoustic", "reservoir.level=92"],
                                  ["geometry.foundation=massless"]],
                         ids=["westergaard", "acoustic", "massless"])
def test_every_mode_kept_equals_full_variants(tmp_path, sets):
    """The same with the reservoir -- Westergaard's added mass (a boundary-DOF mass), the
    compressible acoustic water coupled through the wet face's DOFs (its own factor, unreduced)
    -- and with the massless rock (no rock modes, zero rows of M_r, the start-up of
    solve/massless.py). Tolerance 1e-7 of the peak, as in
    test_every_mode_kept_equals_full below (measured below 1e-12 of the peak)."""
    sc = load_scene(SMOKE, sets)
    full = build_from_scene(sc)
    red = reduce_model(full, n_modes=available_modes(full))
    run(sc, tmp_path / "full", progress=False, model=full, plots=False)
    s = run(sc, tmp_path / "red", progress=False, model=red, plots=False)
    if "reservoir" in sets[0]:
        assert s["reservoir"]["kind"] == sets[0].split("=")[1]
    hf = read_csv(tmp_path / "full" / "timeseries.csv")
    hr = read_csv(tmp_path / "red" / "timeseries.csv")
    a, b = np.asarray(hf["crest_ux"], float), np.asarray(hr["crest_ux"], float)
    assert np.abs(a).max() > 0
    assert np.abs(b - a).max() <= 1e-7 * np.abs(a).max()


def test_rigid_block_motion_in_the_basis(smoke_model):
    """The deformation damping keeps the blocks' rigid sliding and rocking undamped only if
    they lie in the basis: Phi R_r equals the full model's rigid modes R to round-off (1e-9 of
    their largest entry, the rotation's lever arm ~100 m), with 3 modes kept."""
    red = reduce_model(smoke_model, n_modes=3)
    R, _ = block_rigid_modes(smoke_model)
    Rr, _ = block_rigid_modes(red)
    assert Rr.shape == (red.nfree, R.shape[1])
    assert np.abs(red.expand(Rr) - R).max() <= 1e-9 * np.abs(R).max()


def test_resume_equals_uninterrupted(tmp_path):
    """A reduced run interrupted and resumed (the basis built anew from the scene) gives the
    uninterrupted run's results: the basis is deterministic (eigsh's start vector and the modes'
    signs fixed). Tolerance 1e-12 relative, as tests/test_koyna_run.py's resume test."""
    sc = load_scene(SMOKE, ["solver.bulk=reduced", "solver.bulk_modes=20"])
    a, b = tmp_path / "a", tmp_path / "b"
    run(sc, a, progress=False, plots=False)
    with pytest.raises(RunInterrupted):
        run(sc, b, progress=False, plots=False, max_steps=27)
    s = run(sc, b, resume=True, progress=False, plots=False)
    assert s["resumed_from_step"] == 20
    za, zb = np.load(a / "final_state.npz"), np.load(b / "final_state.npz")
    for k in za.files:
        np.testing.assert_allclose(zb[k], za[k], rtol=1e-12, atol=1e-12 * np.abs(za[k]).max()
                                   + 1e-300, err_msg=k)


def test_every_mode_kept_equals_full(tmp_path, smoke_model):
    """koyna_smoke (coarse Koyna on rock, 0.1 s of the strong phase, the default damping with
    its low-rank deformation part): with every fixed-interface mode kept Phi is square and
    invertible, the reduced system is the full one in other coordinates. Tolerance 1e-7 of the
    peak: the Newton tolerance is 1e-8 on the gaps; the two runs differ by the factorisation's
    round-off only (dense Cholesky against sparse LDL^T)."""
    sc = load_scene(SMOKE)
    red = reduce_model(smoke_model, n_modes=available_modes(smoke_model))
    assert isinstance(red, ReducedCoordinates) and red.nfree == smoke_model.nfree
    sf = run(sc, tmp_path / "full", progress=False, model=smoke_model, plots=False)
    sr = run(sc, tmp_path / "red", progress=False, model=red, plots=False)
    hf = read_csv(tmp_path / "full" / "timeseries.csv")
    hr = read_csv(tmp_path / "red" / "timeseries.csv")
    for key in ("crest_ux", "crest_uy"):
        a, b = np.asarray(hf[key], float), np.asarray(hr[key], float)
        peak = np.abs(a).max()
        assert peak > 0 and a.size == b.size
        assert np.abs(b - a).max() <= 1e-7 * peak, key
    assert sr["mesh"]["bulk"]["modes_kept"] == red.reduction.nm
    assert abs(sr["frequencies_hz"][0] - sf["frequencies_hz"][0]) <= 1e-9 * sf["frequencies_hz"][0]


def _static(scene, model, tmp):
    a = prepare(scene, tmp, progress=False, model=model)
    a.static()
    t = a.solver.t.copy()
    u = a.model.expand(a.solver.u)
    a.release()
    return t, u


def test_static_tractions_exact_at_any_cutoff(tmp_path, smoke_model):
    """Dead load + hydrostatic water on a cracked base (friction 0.8): the joint tractions of
    the static solve with 1 and 5 modes are the full bulk's to 1e-8 of the largest traction
    (Newton's gap tolerance; measured ~1e-12): the constraint modes condense the static problem
    exactly onto the joints. The interior displacements are not exact (the body loads' interior
    response is truncated to the modes): the test asserts they differ, so that it would notice a
    basis that were silently the full one."""
    sc = load_scene(SMOKE, ["interface.cracked=true", "interface.friction=0.8"])
    assert np.linalg.norm(smoke_model.f_water) > 0
    t_full, u_full = _static(sc, smoke_model, tmp_path / "f")
    scale = np.abs(t_full).max()
    for n in (1, 5):
        red = reduce_model(smoke_model, n_modes=n)
        t_red, u_red = _static(sc, red, tmp_path / f"r{n}")
        assert np.abs(t_red - t_full).max() <= 1e-8 * scale, n
        b = red.reduction.bdofs
        assert np.abs(u_red[b] - u_full[b]).max() <= 1e-8 * np.abs(u_full).max()
        assert np.abs(u_red - u_full).max() > 1e-6 * np.abs(u_full).max()


def test_sliding_block_same_slip(tmp_path):
    """The 40 x 10 m block on a cracked base (f = 0.5) under the 0.8 g half-sine pulse: the
    permanent slip with the reduced bulk (default 40 modes, through the scene keys) within 1 %
    of the full bulk's (the Craig-Bampton basis holds the block's rigid sliding exactly; 1 %:
    the tolerance set for the reduced bulk against the full, as in tests/test_rocking.py;
    measured 0.02 %)."""
    sf = run(load_scene("sliding_block"), tmp_path / "f", progress=False, plots=False)
    sr = run(load_scene("sliding_block", ["solver.bulk=reduced"]), tmp_path / "r",
             progress=False, plots=False)
    hf = read_csv(tmp_path / "f" / "timeseries.csv")
    hr = read_csv(tmp_path / "r" / "timeseries.csv")
    s_f, s_r = float(hf["base_slip"][-1]), float(hr["base_slip"][-1])
    assert abs(s_f) > 0.05, s_f
    assert abs(s_r - s_f) <= 0.01 * abs(s_f), (s_f, s_r)
    assert sr["mesh"]["bulk"]["modes_kept"] == 40


def test_dense_factor_same_solves():
    """The dense factor's split and partial solves against numpy's solve (tolerance 1e-10
    relative: round-off of a condition ~1e3 matrix)."""
    rng = np.random.default_rng(0)
    n = 300
    X = rng.standard_normal((n, n))
    A = X @ X.T + n * np.eye(n)
    F = SparseFactor(sp.csr_matrix(A))
    assert isinstance(F, DenseFactor)
    b = rng.standard_normal(n)
    x = np.linalg.solve(A, b)
    assert np.allclose(F.backward(F.forward(b)), x, rtol=1e-10, atol=1e-12)
    dofs = np.array([3, 17, 200])
    F.restrict(dofs)
    bd = rng.standard_normal(3)
    bb = np.zeros(n)
    bb[dofs] = bd
    assert np.allclose(F.solve_at(bd), np.linalg.solve(A, bb)[dofs], rtol=1e-10, atol=1e-12)
    # a finite-element matrix keeps the sparse factor (never dense enough)
    assert not isinstance(SparseFactor(sp.diags(np.arange(1.0, n + 1)).tocsr()), DenseFactor)


BAD = [
    (["solver.bulk=condensed"], r"solver.bulk = 'condensed'.*allowed.*'full'.*'reduced'"),
    (["solver.bulk_modes=0"], r"solver.bulk_modes = 0: out of range"),
    (["solver.bulk_cutoff_hz=-5"], r"solver.bulk_cutoff_hz = -5.0: out of range"),
    (["solver.bulk=reduced", "solver.bulk_cutoff_hz=500"],
     r"solver.bulk_cutoff_hz = 500.0: above what the mesh resolves.*allowed: \(0, 136.4\] Hz"),
    (["solver.bulk=reduced", "geometry.rock_sides=absorbing"],
     r"geometry.rock_sides = 'absorbing' with solver.bulk = 'reduced': not supported"),
    (["solver.bulk_modes=20"],
     r"solver.bulk_modes = 20 with solver.bulk = 'full': read only by the reduced bulk.*allowed"),
    (["solver.bulk_cutoff_hz=50"],
     r"solver.bulk_cutoff_hz = 50.0 with solver.bulk = 'full': read only by the reduced bulk"),
    (["solver.bulk=reduced", "solver.bulk_cutoff_hz=50", "solver.bulk_modes=20"],
     r"solver.bulk_modes = 20 with solver.bulk_cutoff_hz = 50.0: the cut-off decides.*allowed"),
    (["solver.bulk=reduced", "screening.enabled=true"],
     r"screening.enabled = true with solver.bulk = 'reduced': not supported.*allowed"),
    (["solver.bulk=reduced", "reservoir.compressible=false"],
     r"reservoir.compressible = false with solver.bulk = 'reduced'.*allowed"),
]


@pytest.mark.parametrize("sets,pat", BAD, ids=[s[0][-1] for s in BAD])
def test_bad_inputs(sets, pat):
    with pytest.raises(ValueError, match=pat):
        validate(load_scene("koyna", sets))


def test_finite_rotation_accepted():
    """The finite-rotation kinematics run on the reduced bulk (run/rotation.py sums the lever
    arms on the full DOFs; tests/test_rocking.py checks them): koyna_1967, whose default they
    are, validates with solver.bulk = "reduced"."""
    sc = load_scene("koyna_1967", ["solver.bulk=reduced"])
    assert sc.solver.kinematics == "finite_rotation"
    validate(sc)


def test_cutoff_keeps_the_modes_below_it(smoke_model):
    """solver.bulk_cutoff_hz: every fixed-interface mode up to the cut-off and none above it;
    the same modes as the count that reaches it (frequencies to 1e-8 relative: two eigsh runs
    with different subspace sizes)."""
    by_count = reduce_model(smoke_model, n_modes=60).reduction.freqs_hz
    cut = 0.5 * (by_count[29] + by_count[30])
    red = reduce_model(smoke_model, cutoff_hz=cut).reduction
    assert red.nm == 30 and red.freqs_hz.max() <= cut
    np.testing.assert_allclose(red.freqs_hz, by_count[:30], rtol=1e-8)
    assert red.summary()["cutoff_hz"] == cut


def test_cutoff_on_koyna_shift_invert():
    """The same on Koyna's default mesh (12 198 DOFs, no water), whose rock interior goes
    through eigsh's shift-invert Lanczos (its subspace doubled until the cut-off is passed):
    a cut-off between the 80th and 81st mode keeps those 80 (frequencies to 1e-8 relative;
    measured 1.5e-15)."""
    model = build_from_scene(load_scene("koyna", ["reservoir.model=none"]))
    by_count = reduce_model(model, n_modes=100).reduction.freqs_hz
    cut = 0.5 * (by_count[79] + by_count[80])
    red = reduce_model(model, cutoff_hz=cut).reduction
    assert red.nm == 80
    np.testing.assert_allclose(red.freqs_hz, by_count[:80], rtol=1e-8)


def test_cutoff_keeping_no_mode(smoke_model):
    """A cut-off below the lowest fixed-interface mode keeps none: refused naming the key."""
    with pytest.raises(ValueError, match=r"solver.bulk_cutoff_hz = 0.01: keeps no mode"):
        reduce_model(smoke_model, cutoff_hz=0.01)


def test_dry_run_exit_2(capsys):
    rc = main(["run", "koyna", "--dry-run", "--set", "solver.bulk=reduced", "--set",
               "geometry.rock_sides=absorbing"])
    err = capsys.readouterr().err
    assert rc == 2 and "solver.bulk = 'reduced'" in err


def test_error_against_run_time_fast(tmp_path):
    """verification/reduced_bulk.py's fast form (make verify's own call): koyna_smoke and the
    sliding block, full against 5 and 20 modes. With 20 modes the crest history is within 1 %
    of its peak on both (measured 3.1e-3 and 3.0e-3), the smoke's heel crack is the full bulk's
    (measured equal: 2.805 m) and the block's permanent slip within 1 % (measured 0.05 %); the
    smoke's crest error falls from 5 to 20 modes (measured 1.6e-2 -> 3.1e-3): a basis that did
    not converge with the count would not."""
    rows = run_fast_study("reduced_bulk", tmp_path)["rows"]
    assert (tmp_path / "reduced_bulk.md").stat().st_size > 500
    by = {(r["case"], r["modes"]): r for r in rows}
    for case in ("koyna_smoke", "sliding_block"):
        full, r20 = by[(case, None)], by[(case, 20)]
        assert r20["crest_err"] <= 1e-2, case
        assert abs(r20["slip_m"] - full["slip_m"]) <= 0.01 * abs(full["slip_m"]), case
    # one interface element of the smoke mesh (mesh.h_heel = 1 m)
    assert abs(by[("koyna_smoke", 20)]["crack_m"] - by[("koyna_smoke", None)]["crack_m"]) <= 1.0
    assert by[("koyna_smoke", 20)]["crest_err"] < 0.5 * by[("koyna_smoke", 5)]["crest_err"]
    # the energy budget closes as in the full bulk (the same formulas on K_r, M_r, C_r):
    # residual within 1.5x the full bulk's + 1e-4 (measured 2.0e-3 against 2.2e-3 on the smoke,
    # 7.5e-3 against 8.7e-3 on the block)
    for case in ("koyna_smoke", "sliding_block"):
        assert by[(case, 20)]["energy_residual"] <= (1.5 * by[(case, None)]["energy_residual"]
                                                     + 1e-4), case


def test_rocking_block_same_rotation(tmp_path):
    """Housner's rocking block of verification/sliding.py (4 x 20 m stiff block, friction 2: no
    sliding, half-sine pulse of 2 s at 1.25 times g b/h: it rocks): the largest rotation with
    the reduced bulk (40 modes, 76 DOFs against 882) within 1 % of the full bulk's (measured
    0.0188441288 against 0.0188441285 rad), the energy budget closing as well (residual within
    1.5x the full bulk's + 1e-4 of the input work: the same formulas on the reduced matrices;
    measured 3.35e-2 in both, the rocking block's own integrator error)."""
    B, Hb, kc = 4.0, 20.0, 1.0e11
    A = 1.25 * (B / 2) / (Hb / 2)
    sets = [f"geometry.profile=[[0,0],[{B},0],[{B},{Hb}],[0,{Hb}]]",
            "interface.friction=2.0", "mesh.h_interface=0.25", "mesh.h_heel=0.25",
            "mesh.h_coarse=0.5", f"materials.dam.E={STIFF_E!r}",
            f"ground_motion.record=\"pulse:half-sine:{A!r}:2.0\"", "time.duration=2.5",
            f"interface.contact_stiffness={kc!r}", "output.checkpoint_every=0"]
    out = {}
    for bulk in ("full", "reduced"):
        s = run(load_scene("sliding_block", sets + [f"solver.bulk={bulk}"]), tmp_path / bulk,
                progress=False, plots=False)
        h = read_csv(tmp_path / bulk / "timeseries.csv")
        rot = np.asarray(h["base_rotation"], float)
        res = np.abs(np.asarray(h["residual"], float)).max() / np.abs(
            np.asarray(h["W_ext"], float)).max()
        out[bulk] = (np.abs(rot).max(), res, s)
    (rf, ef, _), (rr, er, sr) = out["full"], out["reduced"]
    assert sr["mesh"]["bulk"]["modes_kept"] == 40
    assert rf > 1e-3                       # it rocks (10 x the elastic rotation is ~1e-5)
    assert abs(rr - rf) <= 0.01 * rf, (rf, rr)
    assert er <= 1.5 * ef + 1e-4, (ef, er)
