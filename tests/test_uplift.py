"""Uplift drawings (ngs_driver.setup.uplift; no NGSolve) against the USACE/FERC formulas by hand."""
import numpy as np
import pytest

from ngs_driver.scene import Uplift, load_scene
from ngs_driver.setup.uplift import (describe_uplift, pressure_profile,
                                     uplift_force_uncracked)

RG = 1000.0 * 9.81
L, H, T = 70.0, 92.0, 10.0


def _trapz(p, s):
    return float(np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(s)))


def test_linear_and_zero_efficiency_drains_coincide():
    """E = 0: the drain-line value is the linear one, so the two drawings are one (to
    round-off: the same straight line evaluated two ways)."""
    s = np.linspace(0.0, L, 141)
    lin = pressure_profile(s, L, RG * H, RG * T, Uplift(model="linear"))
    dr = pressure_profile(s, L, RG * H, RG * T,
                          Uplift(model="drains", drain_x=7.0, drain_efficiency=0.0))
    assert np.allclose(lin, RG * (H + (T - H) * s / L), rtol=1e-14, atol=0)
    assert np.allclose(dr, lin, rtol=1e-13, atol=1e-6)


def test_drain_line_value_and_resultant():
    """USACE EM 1110-2-2200 fig. 3-2: h_d = h_t + K (h_h - h_t)(L - x_d)/L, K = 1 - E; the
    resultant is the two trapezoids (exact on a grid through the drain line)."""
    up = Uplift(model="drains", drain_x=7.0, drain_efficiency=0.6)
    s = np.linspace(0.0, L, 701)                 # step 0.1 m: 7 m is a grid point
    p = pressure_profile(s, L, RG * H, RG * T, up)
    hd = T + 0.4 * (H - T) * (L - 7.0) / L
    assert p[70] == pytest.approx(RG * hd, rel=1e-14)
    U = 0.5 * RG * (H + hd) * 7.0 + 0.5 * RG * (hd + T) * (L - 7.0)
    assert _trapz(p, s) == pytest.approx(U, rel=1e-12)
    assert uplift_force_uncracked(L, RG * H, RG * T, up) == pytest.approx(U, rel=1e-14)


def test_cracked_base_redrawn_with_full_headwater():
    """Crack a from the heel: h_h on the crack, then linear (drains: to
    h_t + K (h_h - h_t)(L - x_d)/(L - a)); a crack past the drains makes them ineffective."""
    s = np.linspace(0.0, L, 701)
    a = 4.0
    up = Uplift(model="drains", drain_x=7.0, drain_efficiency=0.5)
    p = pressure_profile(s, L, RG * H, 0.0, up, crack=a)
    assert np.all(p[s <= a] == RG * H)
    hd = 0.5 * H * (L - 7.0) / (L - a)
    assert p[70] == pytest.approx(RG * hd, rel=1e-14)
    # past the drains: full head to the tip then linear to the tail
    p2 = pressure_profile(s, L, RG * H, 0.0, up, crack=20.0)
    U2 = RG * H * 20.0 + 0.5 * RG * H * (L - 20.0)
    assert _trapz(p2, s) == pytest.approx(U2, rel=1e-12)
    # the whole base cracked: full head everywhere
    assert np.all(pressure_profile(s, L, RG * H, 0.0, Uplift(model="linear"), crack=L)
                  == RG * H)


def test_none_and_dry_joint_give_nothing():
    s = np.linspace(0, L, 11)
    assert not pressure_profile(s, L, RG * H, 0.0, Uplift()).any()
    assert not pressure_profile(s, L, 0.0, 0.0, Uplift(model="linear")).any()


def test_joint_override_and_describe():
    """A joint's own uplift table overrides the scene-wide one key by key; describe reports
    the heads at each joint (neck at 66.5 m: 92 - 66.5 = 25.5 m of head)."""
    sc = load_scene("koyna", ["uplift.model=linear", "uplift.in_crack=zero",
                              "joints=[{name='neck', elevation=66.5, "
                              "uplift={model='drains', drain_x=3.0}}]"])
    base, neck = sc.uplift_tables()
    assert base[1].model == "linear" and neck[1].model == "drains"
    assert neck[1].in_crack == "zero" and neck[1].drain_x == 3.0
    d = describe_uplift(sc)
    assert d["neck"]["head"] == pytest.approx(25.5, abs=1e-12)
    assert d["base"]["uplift_force_uncracked"] == pytest.approx(0.5 * RG * H * L, rel=1e-14)
