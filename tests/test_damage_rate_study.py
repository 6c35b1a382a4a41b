"""The material-point study of the damage forms (verification/damage_rate.py) in fast
mode: its numbers against closed forms derived independently here.

History: N cycles g_N = A (1 − cos 2πft)/2 sampled with n equal steps per cycle (n even), β = 0.
Per loading half, Δg_k = A sin(π/n) sin θ_k with Σ sin²θ_k = n/4 (n ≥ 4), so for α = 2
  paper: N (A/g_max)² n sin²(π/n)/4,   rate: N (A/g_max)² f t_ref n² sin²(π/n)/4,
and for n = 2 (one step per half) paper N (A/g_max)², rate N (A/g_max)² 2 f t_ref.
Tolerance 1e-12 relative: sums of a few hundred terms (rounding ~1e-14).
"""
import math
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    from conftest import run_fast_study
    out = tmp_path_factory.mktemp("damage_rate")
    return run_fast_study("damage_rate", out), out


def expected(form, alpha, f, n, N, x, t_ref):
    if alpha == 1.0:
        return N * x
    if form == "objective":
        return (N * x) ** 2
    s2n = 0.25 * n * math.sin(math.pi / n) ** 2 if n >= 4 else 1.0   # Σ (Δg/A)² per loading
    if form == "paper":
        return N * x * x * s2n
    return N * x * x * s2n * f * t_ref * n                           # 1/Δt = n f


def test_study_numbers_match_closed_forms(study):
    r, _ = study
    N, x, t_ref = r["cycles"], r["amplitude"] / r["g_max"], r["t_ref"]
    assert x == pytest.approx(0.025, rel=1e-12) and N == 3
    for form in ("paper", "objective", "rate"):
        for alpha in (1.0, 2.0):
            key = f"{form}_a{alpha:g}"
            for n, d in zip(r["ns"], r["D_step"][key]):
                assert d == pytest.approx(expected(form, alpha, r["f_fixed"], n, N, x, t_ref),
                                          rel=1e-12), (key, n)
            for f, d in zip(r["fs"], r["D_freq"][key]):
                assert d == pytest.approx(expected(form, alpha, f, r["n_fixed"], N, x, t_ref),
                                          rel=1e-12), (key, f)


def test_study_classifies_step_and_rate_dependence(study):
    r, out = study
    # paper alpha = 2: D ∝ 1/n at large n (n sin²(π/n) -> π²/n): slope between n = 16 and 64
    # is log(64 sin²(π/64)/(16 sin²(π/16)))/log 4 = -0.987
    s = math.log(64 * math.sin(math.pi / 64) ** 2 / (16 * math.sin(math.pi / 16) ** 2)) / \
        math.log(4)
    assert r["slope_step"]["paper_a2"] == pytest.approx(s, rel=1e-9)
    # rate alpha = 2: proportional to the frequency (slope 1), step-converged to 1 %
    assert r["slope_freq"]["rate_a2"] == pytest.approx(1.0, rel=1e-12)
    assert abs(r["D_step"]["rate_a2"][-1] / r["rate_limit_f_fixed"] - 1) < 1e-3
    for key in ("paper_a1", "objective_a1", "rate_a1", "objective_a2", "paper_a2"):
        assert abs(r["slope_freq"][key]) < 1e-12, key
    for key in ("paper_a1", "objective_a1", "rate_a1", "objective_a2"):
        assert abs(r["slope_step"][key]) < 1e-12, key
    # crossover f* = 4 g_max/(π² A t_ref): above it alpha = 2 damages more (rate form)
    assert r["f_crossover"] == pytest.approx(4 / (math.pi ** 2 * 0.025), rel=1e-12)
    fs, D1, D2 = r["fs"], r["D_freq"]["rate_a1"], r["D_freq"]["rate_a2"]
    for f, d1, d2 in zip(fs, D1, D2):
        assert (d2 > d1) == (f > r["f_crossover"] * (1 + 0.02)), f   # n = 32: D2 within 0.4 %
    assert r["closed_form_max_rel_err"] < 1e-12
    assert (out / "damage_rate.png").stat().st_size > 10_000
    assert "| rate | 2 |" in (out / "damage_rate.md").read_text()
