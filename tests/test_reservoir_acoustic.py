"""Acoustic reservoir: rigid-wall verification problems on a rectangular water mesh
(92 m x 300 m, the paper's reservoir) against the analytic solutions, and the incompressible
acoustic added mass of the Koyna classic section."""
import math

import numpy as np
import pytest

ngs = pytest.importorskip("ngsolve")

from ngs_driver.fe import acoustic as ac  # noqa: E402
from ngs_driver.scene import load_scene  # noqa: E402

H, L, C, RHO = 92.0, 300.0, 1440.0, 1000.0
W1 = math.pi * C / (2 * H)                     # first resonance of the rigid-bottom reservoir


@pytest.fixture(scope="module")
def rect():
    # P1, 2 m on the wall, 6 m far from it (12 elements per wavelength at 20 Hz)
    return ac.rectangle_water_mesh(H, L, 2.0, 6.0)


def test_westergaard_exact_force_and_profile(rect):
    """Rigid vertical wall, rigid bottom, long incompressible reservoir, unit ground
    acceleration: F = 0.543 rho a H^2 (Westergaard's series, 14 zeta(3)/pi^3 = 0.54275)
    within 1 % (the issue's tolerance; measured 0.23 %: P1 on a 2 m wall mesh with the
    sqrt-singular corner at the free surface), and the wall pressure profile against the
    series within 1 % of its maximum rho a H 0.7425."""
    W = ac.water_matrices(rect, C, False, 1.0, "radiation")
    p = ac.rigid_wall_response(W, RHO)
    F = ac.face_force(W, p)
    _, Fs = ac.westergaard_series([0.0], H, RHO)
    assert Fs.real / (RHO * H ** 2) == pytest.approx(-14 * 1.2020569031595942 / math.pi ** 3,
                                                     rel=1e-6)
    assert F == pytest.approx(-0.54275 * RHO * H ** 2, rel=0.01)
    ys = np.array([0.0, 0.25, 0.5, 0.75, 0.9]) * H
    pe = ac.pressure_at(W, p, [(0.0, y) for y in ys])
    ps, _ = ac.westergaard_series(ys, H, RHO)
    assert np.abs(pe - ps.real).max() <= 0.01 * abs(ps.real).max()
    # and the Westergaard parabola 7/12 is 7.5 % above the exact value: not what we computed
    assert abs(F) < 0.99 * 7.0 / 12.0 * RHO * H ** 2


def test_pressure_probe_is_pressure_at(rect):
    """The probe's precomputed functionals give the field's values at its points (the
    Westergaard solution and a random vector: not a smooth field, every shape function
    counts) as NGSolve's own point evaluation does, to 1e-12 of the largest pressure (both
    sum the same products of shape functions and dofs)."""
    W = ac.water_matrices(rect, C, False, 1.0, "radiation")
    pts = [(-1.0, 0.5), (-0.3, 45.2), (-17.7, 91.0), (-250.0, 3.3), (0.0, 60.0)]
    probe = ac.PressureProbe(W, pts)
    rng = np.random.default_rng(3)
    for p in (ac.rigid_wall_response(W, RHO).real, rng.standard_normal(len(W.free))):
        want = ac.pressure_at(W, p, pts)
        assert np.abs(probe(p) - want).max() <= 1e-12 * np.abs(p).max()
        assert np.abs(want).max() > 0


@pytest.mark.parametrize("alpha,ratios", [(1.0, (0.3, 0.6, 0.8)), (0.5, (0.5, 0.9, 1.0, 1.5)),
                                          (0.0, (1.0, 1.5))])
def test_compressible_frequency_response(rect, alpha, ratios):
    """|F(omega)| under a harmonic unit ground acceleration against the analytic solution
    (Chopra 1967 for the rigid bottom, Fenves & Chopra 1983 for an absorbing bottom of
    reflection coefficient alpha) within 2 % (the issue's tolerance; measured <= 0.35 % for
    alpha = 1 below 0.8 omega_1, <= 0.55 % for alpha = 0.5 incl. the resonance).  Not tested:
    alpha = 1 above omega_1 (the plane-wave Sommerfeld far end reflects the first channel
    mode, 38 % off at 1.2 omega_1, docs/reservoir.md §8)."""
    W = ac.water_matrices(rect, C, True, alpha, "radiation")
    for r in ratios:
        Fe = ac.face_force(W, ac.rigid_wall_response(W, RHO, r * W1))
        if alpha == 1.0:
            Fa = ac.westergaard_series([0.0], H, RHO, omega=r * W1, c=C)[1]
        else:
            Fa = ac.absorbing_bottom_series(H, r * W1, C, alpha, RHO, n_terms=400)
        assert abs(Fe) == pytest.approx(abs(Fa), rel=0.02), (alpha, r)


def test_absorbing_bottom_bounds_the_peak(rect):
    """alpha < 1 bounds the resonance: the analytic force at omega_1 is infinite for a rigid
    bottom (the series diverges as the first term ~ 1/mu_1) and finite for alpha = 0.5
    (0.82 rho H^2); the FE peak over 0.9-1.1 omega_1 falls with alpha, and its imaginary part
    equals the power absorbed by the bottom and the far end (omega p^H C_f p / (rho a): the
    absorption enters with the dissipative sign; identity of the discrete system, 1e-9)."""
    near = [ac.westergaard_series([0.0], H, RHO, omega=(1 - e) * W1, c=C)[1]
            for e in (1e-2, 1e-4)]
    assert abs(near[1]) > 5 * abs(near[0])                 # ~ 1/sqrt(e): diverges
    Fa = ac.absorbing_bottom_series(H, W1, C, 0.5, RHO, n_terms=400)
    assert 0.7 < abs(Fa) / (RHO * H ** 2) < 1.0
    peaks = []
    for alpha in (1.0, 0.75, 0.5):
        W = ac.water_matrices(rect, C, True, alpha, "radiation")
        best = (0, None)
        for r in np.linspace(0.9, 1.1, 11):
            p = ac.rigid_wall_response(W, RHO, r * W1)
            F = ac.face_force(W, p)
            if abs(F) > best[0]:
                best = (abs(F), (r, p, F))
        r, p, F = best[1]
        power = r * W1 * np.real(np.conj(p) @ (W.Cf @ p)) / RHO
        assert F.imag == pytest.approx(power, rel=1e-9)
        peaks.append(best[0])
    assert peaks[0] > 3 * peaks[1] > 3 * peaks[2]
    assert peaks[2] / (RHO * H ** 2) == pytest.approx(abs(Fa) / (RHO * H ** 2), rel=0.02)


@pytest.fixture(scope="module")
def classic_acoustic():
    from ngs_driver.fe.model import build_from_scene
    return build_from_scene(load_scene("koyna_classic", ["reservoir.model=acoustic",
                                                          "reservoir.compressible=false"]))


def test_koyna_incompressible_added_mass(classic_acoustic):
    """Koyna classic (vertical upstream face), water 91.75 m x 300 m glued to the dam mesh,
    incompressible, condensed exactly: r_x^T M_a r_x is the rigid-wall force 0.543 rho H^2
    (within 1 %: coarse water mesh, measured about 0.2 %); the vertical ground acceleration adds the
    force of p = rho a_gy (H - y) (rigid bottom), rho H^2 / 2 in x, exact for P1 (1e-9)."""
    md = classic_acoustic
    Hl = 91.75
    r = md.reservoir
    Ma = r.added_mass
    assert md.r_x @ (Ma @ md.r_x) == pytest.approx(0.54275 * RHO * Hl ** 2, rel=0.01)
    assert abs(Ma - Ma.T).max() <= 1e-12 * abs(Ma).max()
    sx, sy = r.seismic_vectors(md.M @ md.r_x, md.M @ md.r_y)
    assert np.abs(sx - md.M @ md.r_x).max() <= 1e-9 * np.abs(sx).max()
    assert (sy - md.M @ md.r_y).sum() == pytest.approx(-RHO * Hl ** 2 / 2, rel=1e-9)
    assert "water" in md.mesh.GetMaterials() and r.info["n_pressure_dofs"] > 500


def test_koyna_f1_ratios(classic_acoustic):
    """f1 of the classic section on a rigid base: empty 3.08 Hz; the full reservoir lowers it,
    Westergaard (7/12 rho H^2, all at the face) more than the incompressible acoustic water
    (0.543 rho H^2, distributed): f1_w < f1_ac < f1_empty, ratios 0.85-0.95 (measured 0.876 and
    0.919; the literature order for full reservoirs is a 10 % drop, docs/reservoir.md §7)."""
    from ngs_driver.fe.modal import modal_analysis
    from ngs_driver.setup import k0_from_scene
    from ngs_driver.fe.model import build_from_scene

    sc = load_scene("koyna_classic")
    kn, kt = k0_from_scene(sc)
    f = {}
    for name, md in (("empty", build_from_scene(sc)),
                     ("westergaard", build_from_scene(load_scene(
                         "koyna_classic", ["reservoir.model=westergaard"]))),
                     ("acoustic", classic_acoustic)):
        f[name] = modal_analysis(md, 1, kn, kt).frequencies_hz[0]
    assert f["empty"] == pytest.approx(3.076, rel=0.01)
    assert f["westergaard"] < f["acoustic"] < f["empty"]
    assert 0.85 < f["westergaard"] / f["empty"] < 0.9
    assert 0.9 < f["acoustic"] / f["empty"] < 0.95


def test_incompressible_is_the_limit_of_compressible(classic_acoustic):
    """The crest frequency response (harmonic ground acceleration, hysteretic damping) with
    compressible water tends to the incompressible one as c -> infinity: c = 1e7 m/s agrees to
    1e-4 at every frequency (measured 1.4e-8, O((omega H / c)^2)); with c = 1440 m/s the two
    agree at half the reservoir's first resonance f_r = c / 4H within 10 % (measured 2.9 %) and
    differ near it by more than 20 % (measured 43 %)."""
    import dataclasses

    from ngs_driver.fe import reservoir as rv
    from ngs_driver.fe.model import build_from_scene

    sc = load_scene("koyna_classic", ["reservoir.model=acoustic", "reservoir.far_end=rigid"])
    # c = 1e7 m/s is outside the scene's range (a numerical limit, not water): set it directly
    md = build_from_scene(sc, reservoir=dataclasses.replace(sc.reservoir, sound_speed=1e7))
    kn, kt = 9e10, 9e10
    f = np.array([1.0, 2.5, 3.9, 6.0])
    _, acc_c = rv.frequency_response(md, kn, kt, f, 0.1, "compressible")
    _, acc_i = rv.frequency_response(md, kn, kt, f, 0.1, "incompressible")
    assert np.abs(acc_c - acc_i).max() <= 1e-4 * np.abs(acc_i).max()
    md2 = build_from_scene(load_scene("koyna_classic", ["reservoir.model=acoustic",
                                                         "reservoir.far_end=rigid"]))
    fr = 1440.0 / (4 * 91.75)
    _, a_c = rv.frequency_response(md2, kn, kt, np.array([0.5 * fr, fr]), 0.1, "compressible")
    _, a_i = rv.frequency_response(md2, kn, kt, np.array([0.5 * fr, fr]), 0.1, "incompressible")
    assert abs(a_c[0] / a_i[0] - 1) < 0.1
    assert abs(abs(a_c[1]) / abs(a_i[1]) - 1) > 0.2


def test_lift_joint_does_not_double_the_face():
    """With a lift joint the dam has one displacement field per block; each block's field is
    taken on its own face band, so the face coupling of a rigid translation is the face integral
    itself (Q^T r_x = int_face n_x psi, round-off; without the bands the joint's edges counted
    twice: 20 % at the joint's pressure DOF) and the added masses keep their values (1e-3: the
    joint changes the face mesh a little)."""
    from ngs_driver.fe.model import build_from_scene

    j = "joints=[{name='neck', elevation=66.5}]"
    md = build_from_scene(load_scene("koyna_classic", ["reservoir.model=acoustic",
                                                        "reservoir.compressible=false", j]))
    ac = md.reservoir.acoustic
    assert np.abs(ac.Q.T @ md.r_x - ac.W.face_x).max() <= 1e-12 * np.abs(ac.W.face_x).max()
    assert md.r_x @ (ac.added_mass @ md.r_x) == pytest.approx(0.54275 * RHO * 91.75 ** 2,
                                                               rel=0.01)
    mw = build_from_scene(load_scene("koyna_classic", ["reservoir.model=westergaard", j]))
    assert mw.r_x @ (mw.reservoir.added_mass @ mw.r_x) == pytest.approx(
        7 / 12 * RHO * 91.75 ** 2, rel=1e-5)
