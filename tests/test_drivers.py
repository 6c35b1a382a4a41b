"""Tests of interfacelaw.drivers: each ready path checks one physical number.

Tolerances: the law's dissipation formula is exact for proportional paths whatever the number of
increments (docs/law.md §3), so energies are checked to 1e-10 relative (rounding of a
few hundred to a thousand additions is ~1e-13). Tractions on a breakpoint are closed-form
arithmetic: 1e-12 relative.
"""
from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest

from interfacelaw import (CohesiveParams, ContactParams, DamageParams, FrictionParams,
                          InterfaceLaw)
from interfacelaw import drivers as dr

ROOT = Path(__file__).resolve().parents[1]

# l_Tc != l_Nc and tau_max != sigma_max so that mode-II numbers differ from mode-I ones
COH = CohesiveParams(sigma_max=1.0e6, tau_max=2.0e6, l_Nc=1.0e-4, l_Tc=2.0e-4, lambda_max=0.2)


@pytest.fixture(scope="module")
def law():
    return InterfaceLaw(COH)


# ---------------------------------------------------------------- peaks -------------------
def test_mode_I_peak_traction_at_lambda_max(law):
    # 150 increments of 0.01 in lambda: the peak lambda_max = 0.2 is a breakpoint (row 20)
    h = dr.mode_I(law, n=150, lam_end=1.5)
    k = int(np.argmax(h.traction[:, 0]))
    assert h.traction[k, 0] == pytest.approx(COH.sigma_max, rel=1e-12)
    assert h.gap[k, 0] == pytest.approx(COH.lambda_max * COH.l_Nc, rel=1e-12)
    assert np.all(h.traction[:, 1] == 0.0)


def test_mode_II_peak_is_tau_max_lNc_over_lTc(law):
    h = dr.mode_II(law, n=150, lam_end=1.5)
    k = int(np.argmax(h.traction[:, 1]))
    # Eq. 3 as written: tau_max * l_Nc / l_Tc = 1e6 here, NOT tau_max = 2e6
    assert h.traction[k, 1] == pytest.approx(COH.tau_max * COH.l_Nc / COH.l_Tc, rel=1e-12)
    assert h.gap[k, 1] == pytest.approx(COH.lambda_max * COH.l_Tc, rel=1e-12)


# ---------------------------------------------------------------- energies ----------------
@pytest.mark.parametrize("n", [1, 3, 10, 1000])
@pytest.mark.parametrize("path", ["I", "II", "psi30", "psi60"])
def test_dissipated_equals_work_of_separation(law, n, path):
    if path == "I":
        h, G = dr.mode_I(law, n), COH.G_I
    elif path == "II":
        h, G = dr.mode_II(law, n), COH.G_II
    else:
        psi = math.radians(float(path[3:]))
        h, G = dr.mixed_mode(law, psi, n), float(COH.G_mixed(psi))
    assert h.converged
    assert h.dissipated[-1] == pytest.approx(G, rel=1e-10)
    assert h.lambda_h[-1] >= 1.0


def test_trapezoid_work_converges_to_G_at_rate_2(law):
    # Measured: W(n) - G_I = -2.5 G_I / n^2 for lam_end = 1.5 (the traction is piecewise linear
    # in g, the trapezoid rule is exact except in the two cells holding the kinks at lambda =
    # 0.2 and 1, each O(h^2)). n = 100 and 400 put both kinks at the same fraction of their
    # cell, so the ratio of errors is exactly 16 -> rate 2 (rounding ~1e-13 relative).
    e = [abs(dr.mode_I(law, n, lam_end=1.5).work[-1] - COH.G_I) / COH.G_I for n in (100, 400)]
    rate = math.log(e[0] / e[1]) / math.log(4.0)
    assert rate == pytest.approx(2.0, abs=1e-6)
    assert e[0] == pytest.approx(2.5 / 100 ** 2, rel=1e-6)


# ---------------------------------------------------------------- unload / reload --------
def test_unload_reload_follows_secant_and_rejoins_envelope(law):
    lu = 0.5
    h = dr.load_unload_reload(law, lam_unload=lu, lam_end=1.5, n=300)
    lam = h.gap[:, 0] / COH.l_Nc
    ku = int(np.argmax(lam >= lu - 1e-12))               # first arrival at lambda_h = 0.5
    after = np.arange(len(lam)) > ku
    inside = after & (lam < lu - 1e-12)
    s_u = (1 - lu) / (lu * (1 - COH.lambda_max))        # secant factor at lambda_h
    # secant to the origin with the stiffness reached at lambda_h (no healing)
    np.testing.assert_allclose(h.traction[inside, 0], COH.sigma_max * s_u * lam[inside],
                               rtol=1e-12)
    assert np.all(h.lambda_h[inside] == pytest.approx(lu, rel=1e-12))
    assert np.all(np.diff(h.lambda_h) >= 0)               # lambda_h never decreases
    assert np.all(np.diff(h.dissipated[inside]) == 0)     # no dissipation on the secant
    # rejoins the envelope beyond lambda_h: F = sigma (1 - lam)/(1 - lam_max)
    beyond = after & (lam > lu + 1e-12) & (lam < 1)
    # atol: just below lambda = 1 the traction is sigma*(1 - lam)/(1 - lm), a cancellation
    # whose rounding is ~1e-16 sigma (measured 1.4e-10 Pa of difference at lam = 1 - 1e-16)
    np.testing.assert_allclose(h.traction[beyond, 0],
                               COH.sigma_max * (1 - lam[beyond]) / (1 - COH.lambda_max),
                               rtol=1e-12, atol=1e-14 * COH.sigma_max)
    assert h.dissipated[-1] == pytest.approx(COH.G_I, rel=1e-10)


def test_closure_reopening_contact_mixture_and_energy():
    K0 = COH.k_normal
    law = InterfaceLaw(COH, ContactParams(penalty=10 * K0))
    lo, cl = 0.6, 0.1
    h = dr.closure_reopening(law, lam_open=lo, closure=cl, lam_end=1.5, n=400)
    gN = -cl * COH.l_Nc
    # a linear law with a penalty is one spring in compression (K_intact defaults to C_N,
    # docs §1.3), whatever the damage
    expected = 10 * K0 * gN
    assert h.traction[:, 0].min() == pytest.approx(expected, rel=1e-12)
    # linear contact is elastic: the closure dissipates nothing; total = G_I
    assert h.dissipated[-1] == pytest.approx(COH.G_I, rel=1e-10)


# ---------------------------------------------------------------- cycles ------------------
@pytest.mark.parametrize("R", [0.0, 0.3])
@pytest.mark.parametrize("npc", [2, 10, 40])
def test_cycles_to_failure_hand_checked(R, npc):
    # alpha = 1, beta = 0, F_th = 0, A = 0.1 l_Nc < lambda_max l_Nc (no softening). Every
    # increment with dg > 0 and r > 0 adds dg/g_max (alpha = 1: independent of npc). The first
    # loading 0 -> A adds A/g_max, each later cycle (R A -> A) adds (1 - R) A/g_max, so
    # N_f = 1 + ceil((g_max/A - 1)/(1 - R)). g_max/A = 7.5 (not an integer: no rounding tie).
    A = 0.1 * COH.l_Nc
    law = InterfaceLaw(COH, damage=DamageParams(g_max=7.5 * A))
    h = dr.constant_amplitude_cycles(law, A, R=R, n_cycles=20, n_per_cycle=npc)
    assert dr.cycles_to_failure(h) == 1 + math.ceil((7.5 - 1) / (1 - R))  # 8 and 11


def test_cycles_batch_equals_single_runs():
    law = InterfaceLaw(COH, damage=DamageParams(g_max=0.75 * COH.l_Nc, alpha=2.0, beta=1.0))
    A = np.array([0.04, 0.1, 0.17]) * COH.l_Nc
    hb = dr.constant_amplitude_cycles(law, A, n_cycles=5, n_per_cycle=8)
    for p, a in enumerate(A):
        hs = dr.constant_amplitude_cycles(law, float(a), n_cycles=5, n_per_cycle=8)
        np.testing.assert_array_equal(hb.point(p).damage, hs.damage)
        np.testing.assert_array_equal(hb.point(p).traction, hs.traction)


def test_paper_damage_alpha2_scales_with_step_and_objective_and_rate_forms_do_not():
    # paper: per loading of amplitude A in k equal increments, sum (A/(k g_max))^2 = (A/g_max)^2/k
    A = 0.1 * COH.l_Nc
    laws = {f: InterfaceLaw(COH, damage=DamageParams(g_max=50 * A, alpha=2.0, form=f,
                                                     t_ref=0.2))
            for f in ("paper", "objective", "rate")}
    period = 0.5                      # [s]: each leg A in period/2, rate 2 A / period
    for npc in (2, 8, 32):
        h = {f: dr.constant_amplitude_cycles(law, A, n_cycles=5, n_per_cycle=npc, period=period)
             for f, law in laws.items()}
        assert h["paper"].damage[-1] == pytest.approx(5 * (1 / 50) ** 2 / (npc // 2), rel=1e-12)
        # the objective form gives D = (p/g_max)^alpha, p = 5 A: independent of the step
        assert h["objective"].damage[-1] == pytest.approx((5 / 50) ** 2, rel=1e-12)
        # the rate form: 5 loadings at the rate 2A/period during period/2 each:
        # D = 5 (2 A t_ref/(period g_max))^2 (period/2)/t_ref — independent of the step
        rate = 2 * A / period
        assert h["rate"].damage[-1] == pytest.approx(
            5 * (rate * 0.2 / (50 * A)) ** 2 * (period / 2) / 0.2, rel=1e-12)
        np.testing.assert_array_equal(h["rate"].t, h["paper"].t)
        assert h["rate"].t[-1] == pytest.approx(5 * period, rel=1e-15)


def test_rate_form_time_stamps_and_cycles_to_failure_in_periods():
    """Time-stamped paths: the row-0 step (dt0) and the period are what the law sees. A single
    increment 0 -> A in dt0 gives (A/g_max)^2 t_ref/dt0 for alpha = 2; cycles_to_failure counts
    cycles whatever the period."""
    A = 0.1 * COH.l_Nc
    law = InterfaceLaw(COH, damage=DamageParams(g_max=2 * A, alpha=2.0, form="rate", t_ref=1.0))
    h = dr.gap_path(law, [0.0], np.array([[A, 0.0]]), dt0=0.5)
    assert h.damage[0] == pytest.approx(0.25 / 0.5, rel=1e-14)
    with pytest.raises(ValueError, match="dt0 = 0.0 is not allowed"):
        dr.gap_path(law, [0.0], np.array([[A, 0.0]]), dt0=0.0)
    # alpha = 1 (rate form = paper form): failure after g_max/A = 2 loadings -> cycle 2
    law1 = InterfaceLaw(COH, damage=DamageParams(g_max=2 * A, alpha=1.0, form="rate"))
    for period in (1.0, 0.01):
        h = dr.constant_amplitude_cycles(law1, A, n_cycles=4, n_per_cycle=4, period=period)
        assert dr.cycles_to_failure(h) == 2
    # mixed control passes each increment's dt too: replaying its converged gaps with gap_path
    # (same time stamps) gives the same damage (the same evaluations: 1e-14)
    lawm = InterfaceLaw(COH, damage=DamageParams(g_max=5 * COH.l_Nc, alpha=2.0, form="rate",
                                                 t_ref=1.0))
    hm = dr.mixed_control(lawm, [0.0, 0.05], np.array([[0.0, 0.0], [0.5 * COH.sigma_max, 0.0]]),
                          "Fg", 4)
    assert hm.converged, hm.message
    hg = dr.gap_path(lawm, hm.t, hm.gap, 1)
    assert hm.damage[-1] > 1e-3
    np.testing.assert_allclose(hg.damage, hm.damage, rtol=1e-14, atol=0)


# ---------------------------------------------------------------- mixed control -----------
def test_shear_under_pressure_friction_plateau():
    f, p = 0.6, 3.0e5
    law = InterfaceLaw(COH, ContactParams(), FrictionParams(f))
    h = dr.shear_under_pressure(law, p, 3 * COH.l_Tc, n_cycles=1, n_per_cycle=200, tol=1e-12)
    assert h.converged, h.message
    # imposed normal traction (ramp on t <= 1/4, then -p) met to tol * max(sigma_max, |target|)
    assert np.abs(h.traction[:, 0] - h.info["target"][:, 0]).max() <= 1e-12 * COH.sigma_max
    assert np.all(h.traction[h.t >= 0.25, 0] == pytest.approx(-p, rel=1e-12))
    late = h.t > 0.5                           # after the first debonding quarter cycle
    assert np.all(h.lambda_h[late] >= 1)
    assert h.traction[late, 1].max() == pytest.approx(f * p, rel=1e-12)
    assert h.traction[late, 1].min() == pytest.approx(-f * p, rel=1e-12)


@pytest.mark.parametrize("contact", [ContactParams(penalty=1e3 * COH.k_normal),
                                     ContactParams("rough")], ids=["stiff_linear", "rough"])
def test_energy_balance_shear_under_pressure_stiff_penalty(contact):
    # regression: a linear penalty stiffer than the intact bond once created energy at
    # debonding under pressure (2.5 J/m^2 here); the linear default K_int = C_N and the capped
    # rough law with its release term (docs/law.md §4) keep dissipated <= work
    law = InterfaceLaw(COH, contact, FrictionParams(0.5))
    h = dr.shear_under_pressure(law, 0.5 * COH.sigma_max, 3 * COH.l_Tc, 1, 1000)
    assert h.converged
    # trapezoid quadrature error at 1000 increments/cycle is 0.04 J/m^2 = 4e-4 G_II
    assert np.max(h.dissipated - h.work) <= 1e-3 * COH.G_II


def test_energy_balance_shear_under_pressure_consistent_penalty():
    # same test with K_int = C_N (no stiffness change at debonding): balance holds
    K = 1e3 * COH.k_normal
    law = InterfaceLaw(COH, ContactParams(penalty=K, intact_stiffness=K), FrictionParams(0.5))
    h = dr.shear_under_pressure(law, 0.5 * COH.sigma_max, 3 * COH.l_Tc, 1, 1000)
    assert h.converged
    assert np.max(h.dissipated - h.work) <= 1e-3 * COH.G_II


@pytest.mark.parametrize("tol", [1e-4, 1e-8, 1e-12])
def test_mixed_control_reaches_imposed_traction(law, tol):
    # normal traction ramp to 0.9 sigma_max with a fixed tangential gap: elastic, lambda < lm
    gT = 0.05 * COH.l_Tc
    h = dr.mixed_control(law, [0, 1], [[0, gT], [0.9 * COH.sigma_max, gT]], "Fg", 30, tol=tol)
    assert h.converged, h.message
    tgt = h.info["target"][:, 0]
    assert np.all(np.abs(h.traction[:, 0] - tgt) <= tol * COH.sigma_max)
    # and the gap is the elastic one, to the same relative accuracy
    np.testing.assert_allclose(h.gap[:, 0], tgt / COH.k_normal,
                               atol=tol * COH.sigma_max / COH.k_normal)
    assert np.all(h.gap[:, 1] == gT)


def test_mixed_control_flags_limit_point(law):
    # target ramps 0 -> 1.2 sigma_max in 24 increments of 0.05 sigma: increments 1..20 are
    # below the peak, increment 21 asks for 1.05 sigma_max > sigma_max -> limit point
    h = dr.mixed_control(law, [0, 1], [[0, 0], [1.2 * COH.sigma_max, 0]], "Fg", 24)
    assert not h.converged
    assert np.all(h.status[:21] == dr.OK)
    assert h.status[21] == dr.LIMIT_POINT
    assert np.all(h.status[22:] == dr.SKIPPED)
    assert np.all(np.isnan(h.traction[21:])) and np.all(np.isnan(h.gap[21:]))
    assert "increment 21" in h.message and "1050000" in h.message
    assert "limit point" in h.message
    assert h.traction[20, 0] == pytest.approx(COH.sigma_max, rel=1e-10)   # exactly at the peak
    v = h.valid()
    assert len(v.t) == 21 and np.isfinite(v.traction).all()


def test_mixed_control_singular_when_debonded_and_open(law):
    st = dr.mode_I(law, 5, lam_end=1.5).state            # fully debonded, no contact
    h = dr.mixed_control(law, [0, 1], [[1e3, 0], [1e3, 0]], "Fg", 2, state=st)
    assert h.status[0] == dr.SINGULAR and "singular" in h.message


# ---------------------------------------------------------------- misc --------------------
def test_batch_gap_path_equals_single_runs(law):
    gaps = np.zeros((3, 2, 2))
    gaps[1, 0] = [0.7 * COH.l_Nc, 0.1 * COH.l_Tc]
    gaps[1, 1] = [0.1 * COH.l_Nc, 0.9 * COH.l_Tc]
    gaps[2] = gaps[1] * 2
    hb = dr.gap_path(law, [0, 1, 2], gaps, [7, 3])
    assert hb.gap.shape == (11, 2, 2)
    for p in range(2):
        hs = dr.gap_path(law, [0, 1, 2], gaps[:, p], [7, 3])
        np.testing.assert_array_equal(hb.point(p).traction, hs.traction)
        np.testing.assert_array_equal(hb.point(p).dissipated, hs.dissipated)


def test_energy_balance_non_proportional_path(law):
    # mode I to lambda 0.5, shear at fixed g_N to lambda 0.71, unload to 0, proportional to 1.7.
    # W - (dissipated + stored) with stored = F.g/2 (secant law) is not zero at finite n: the
    # law evaluates q(phi) at the end of the step on the non-proportional leg (first order) and
    # the trapezoid work is second order. Measured residual: 9.2e-4, 2.0e-4, 4.7e-5, 1.2e-5 G_I
    # for n = 100, 400, 1600, 6400 -> rate 1 (ratio 4.2 per factor 4 at n = 400 -> 1600).
    g = np.array([[0, 0], [0.5e-4, 0], [0.5e-4, 1.0e-4], [0, 0], [1.2e-4, 2.4e-4]])
    res = []
    for n in (400, 1600):
        h = dr.gap_path(law, np.arange(5.0), g, n)
        stored = 0.5 * np.einsum("md,md->m", h.traction, h.gap)
        res.append(np.abs(h.work - h.dissipated - stored).max() / COH.G_I)
        # dissipated <= work + O(h) discretisation error (here 2e-4 G_I at n = 400)
        assert np.all(h.dissipated <= h.work + 4.0 / n * COH.G_I * 0.25)
    assert 3.5 < res[0] / res[1] < 4.8
    assert res[1] < 1e-4


def test_to_csv_atomic_roundtrip(law, tmp_path):
    h = dr.mode_I(law, 10)
    p = h.to_csv(tmp_path / "h.csv")
    assert sorted(os.listdir(tmp_path)) == ["h.csv"]        # no temp file left
    data = np.genfromtxt(p, delimiter=",", names=True)
    np.testing.assert_array_equal(data["FN"], h.traction[:, 0])
    np.testing.assert_array_equal(data["dissipated"], h.dissipated)


def test_tangent_fd_error_small_on_smooth_branches():
    law = InterfaceLaw(COH, ContactParams(), FrictionParams(0.5),
                       DamageParams(g_max=1e-3, alpha=2.0, beta=1.0, F_th=1e5))
    st = law.initial_state(3)
    gap = np.array([[0.05e-4, 0.03e-4], [0.5e-4, 0.4e-4], [-0.1e-4, 0.2e-4]])
    err, T, Tfd = dr.tangent_fd_error(law, gap, st)
    # central differences with h = 1e-6 l: truncation ~ h^2, rounding ~ 1e-16/1e-6
    assert err.max() < 1e-6


def test_verification_fast_writes_all_sections(tmp_path):
    from conftest import run_fast_study
    res = run_fast_study("material_point", tmp_path)
    text = (tmp_path / "REPORT.md").read_text()
    for sec in ("## 1.", "## 2.", "## 3.", "## 4.", "## 5.", "## 6."):
        assert sec in text
    # the energy table is a real check: every psi row within 1e-10
    assert res["energy_max_rel_err"] < 1e-10
    assert res["tangent_max_err"] < 1e-5
    assert list(tmp_path.glob("*.png"))
