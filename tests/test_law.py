"""Unit and regression tests of the interface law (docs/law.md)."""
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from interfacelaw import (CohesiveParams, ContactParams, DamageParams, FrictionParams,
                          InterfaceLaw, InterfaceState)

COH = CohesiveParams.from_fracture_energy(sigma_max=3e6, tau_max=3e6, G_I=250.0,
                                          lambda_max=0.2, ratio_lTc_lNc=1.0)
# an unsymmetric set: tau != sigma and l_Tc != l_Nc exercise every factor of Eq. 3
COH2 = CohesiveParams(sigma_max=3e6, tau_max=5e6, l_Nc=2e-4, l_Tc=5e-4, lambda_max=0.3)


def full_law(coh=COH, kind="linear", **dmg):
    return InterfaceLaw(coh, contact=ContactParams(kind), friction=FrictionParams(0.4),
                        damage=DamageParams(**({"g_max": 20 * coh.l_Nc, "alpha": 2.0} | dmg)))


def drive(law, gaps, state=None):
    """Drive one point through a sequence of gaps (rows); return tractions and final state."""
    gaps = np.atleast_2d(np.asarray(gaps, dtype=float))
    state = state or law.initial_state(1, gaps.shape[1])
    F = np.empty_like(gaps)
    for k, g in enumerate(gaps):
        f, _, state = law.evaluate(g[None, :].copy(), state)
        F[k] = f[0]
    return F, state


# ---------------------------------------------------------------------------------------------
# energy: the law's own dissipation is exact whatever the number of increments (no lag)
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("nsteps", [1, 3, 10, 1000])
@pytest.mark.parametrize("coh", [COH, COH2], ids=["paper", "unsym"])
def test_mode_I_and_II_energy_exact_for_any_increments(nsteps, coh):
    law = InterfaceLaw(coh)
    for comp, G in ((0, coh.G_I), (1, coh.G_II)):
        scale = coh.l_Nc if comp == 0 else coh.l_Tc
        gaps = np.zeros((nsteps, 2))
        gaps[:, comp] = np.linspace(0, 1.5 * scale, nsteps + 1)[1:]
        F, s = drive(law, gaps)
        # 1e-10: the increment formula is exact, only round-off remains
        assert s.dissipated[0] == pytest.approx(G, rel=1e-10)
        assert np.all(F[-1] == 0.0)


def test_mode_II_energy_is_independent_of_lTc_and_peak_is_tau_lN_over_lT():
    for r in (0.25, 1.0, 4.0):
        coh = CohesiveParams.from_fracture_energy(3e6, 2e6, 250.0, 0.2, ratio_lTc_lNc=r)
        law = InterfaceLaw(coh)
        g = np.linspace(0, 1.2 * coh.l_Tc, 1201)[1:]
        F, s = drive(law, np.c_[np.zeros_like(g), g])
        assert s.dissipated[0] == pytest.approx(0.5 * 2e6 * coh.l_Nc, rel=1e-10)
        # the grid hits lambda = lambda_max exactly (1200 * 0.2/1.2 = 200)
        assert F[:, 1].max() == pytest.approx(2e6 / r, rel=1e-12)


@pytest.mark.parametrize("psi_deg", [0, 30, 45, 60, 90])
def test_proportional_mixed_mode_energy(psi_deg):
    psi = math.radians(psi_deg)
    law = InterfaceLaw(COH2)
    g = np.linspace(0, 3 * COH2.l_Tc, 300)[1:, None] * np.array([[math.cos(psi), math.sin(psi)]])
    _, s = drive(law, g)
    assert s.dissipated[0] == pytest.approx(float(COH2.G_mixed(psi)), rel=1e-10)


def test_trapezoid_work_converges_to_G_at_second_order():
    """Work integrated from the traction-gap curve: error O(h^2) from the two kink intervals."""
    law = InterfaceLaw(COH)
    errs = []
    ns = (101, 1001)
    for n in ns:  # grids chosen so that no node falls on a kink (0.2 l_Nc, l_Nc)
        g = np.linspace(0, 1.5 * COH.l_Nc, n + 1)
        F, s = drive(law, np.c_[g[1:], np.zeros(n)])
        F = np.r_[0.0, F[:, 0]]
        W = np.sum(0.5 * (F[1:] + F[:-1]) * np.diff(g))
        errs.append(abs(W - COH.G_I) / COH.G_I)
    rate = math.log(errs[0] / errs[1]) / math.log(ns[1] / ns[0])
    assert 1.7 < rate < 2.3, (errs, rate)        # trapezoid rule on piecewise-linear F: p = 2


# ---------------------------------------------------------------------------------------------
# envelope, irreversibility, contact
# ---------------------------------------------------------------------------------------------
def test_peak_and_envelope_mode_I():
    law = InterfaceLaw(COH)
    lm, lN, s = COH.lambda_max, COH.l_Nc, COH.sigma_max
    for lam in (0.1, 0.2, 0.5, 0.9, 1.0, 2.0):
        F, _ = drive(law, [[lam * lN, 0.0]])
        expect = s * lam / lm if lam <= lm else max(0.0, s * (1 - lam) / (1 - lm))
        assert F[0, 0] == pytest.approx(expect, rel=1e-12, abs=1e-9)


def test_unload_reload_follows_secant_and_rejoins_envelope_no_healing():
    law = InterfaceLaw(COH)
    lN = COH.l_Nc
    F, st0 = drive(law, [[0.5 * lN, 0.0]])
    k_sec = F[0, 0] / (0.5 * lN)
    F2, st1 = drive(law, [[0.25 * lN, 0.0], [0.0, 0.0], [0.3 * lN, 0.0], [0.5 * lN, 0.0]], st0)
    assert F2[0, 0] == pytest.approx(k_sec * 0.25 * lN, rel=1e-12)
    assert F2[1, 0] == 0.0
    assert F2[2, 0] == pytest.approx(k_sec * 0.3 * lN, rel=1e-12)      # no healing at 0
    assert F2[3, 0] == pytest.approx(F[0, 0], rel=1e-12)               # rejoins at lambda_h
    assert st1.dissipated[0] == pytest.approx(st0.dissipated[0], rel=1e-14)  # cycle below lambda_h
    F3, _ = drive(law, [[0.6 * lN, 0.0]], st1)                         # envelope beyond
    assert F3[0, 0] == pytest.approx(COH.sigma_max * 0.4 / 0.8, rel=1e-12)


@pytest.mark.parametrize("kind", ["linear", "rough"])
def test_contact_never_tension_and_continuous_at_zero(kind):
    law = full_law(kind=kind)
    rng = np.random.default_rng(0)
    n = 5000
    state = random_states(law, n, rng)
    gap = np.c_[-rng.uniform(0, 2, n) * COH.l_Nc, rng.uniform(-2, 2, n) * COH.l_Tc]
    F, _, _ = law.evaluate(gap, state)
    assert np.all(F[:, 0] <= 0.0)
    # continuity at g_N = 0: |F_N(+e) - F_N(-e)| <= (max slope) * 2e
    e = 1e-12 * COH.l_Nc
    gp, gm = gap.copy(), gap.copy()
    gp[:, 0], gm[:, 0] = e, -e
    Fp, _, _ = law.evaluate(gp, state)
    Fm, _, _ = law.evaluate(gm, state)
    assert np.max(np.abs(Fp[:, 0] - Fm[:, 0])) <= 2 * e * COH.k_normal * 1.0001


def test_intact_interface_is_symmetric_in_compression_rough_crack_starts_soft():
    law = InterfaceLaw(COH, contact=ContactParams("rough"))
    g = 0.1 * COH.l_Nc
    Ft, _ = drive(law, [[g, 0.0]])
    Fc, _ = drive(law, [[-g, 0.0]])
    assert Fc[0, 0] == pytest.approx(-Ft[0, 0], rel=1e-14)
    # debonded crack: rough law p = -C_N g_ref (c)^2, zero stiffness at first contact
    _, deb = drive(law, [[2 * COH.l_Nc, 0.0]])
    F, T, _ = law.evaluate(np.array([[-1e-9 * COH.l_Nc, 0.0]]), deb)
    # p' = m C_N c^(m-1) = 2 K0 (1e-9/0.2): vanishes linearly at first contact
    assert T[0, 0, 0] == pytest.approx(2 * COH.k_normal * 5e-9, rel=1e-9)
    gref = COH.lambda_max * COH.l_Nc
    K0 = COH.k_normal
    # power law below the cap (stiffness 2 K0 c reaches K0 at c* = 0.5), K0 beyond, C1 at c*
    F, T, _ = law.evaluate(np.array([[-0.25 * gref, 0.0]]), deb)
    assert F[0, 0] == pytest.approx(-K0 * gref / 16, rel=1e-12)
    assert T[0, 0, 0] == pytest.approx(0.5 * K0, rel=1e-12)
    F, T, _ = law.evaluate(np.array([[-gref, 0.0]]), deb)
    assert F[0, 0] == pytest.approx(-0.75 * K0 * gref, rel=1e-12)
    assert T[0, 0, 0] == pytest.approx(K0, rel=1e-12)
    e = 1e-9 * gref
    Fa, _, _ = law.evaluate(np.array([[-0.5 * gref + e, 0.0], [-0.5 * gref - e, 0.0]]),
                            deb.take([0, 0]))
    assert abs(Fa[0, 0] - Fa[1, 0]) <= 2 * e * K0 * 1.0001


def test_debonding_in_compression_releases_energy_never_creates_it():
    """Shear to debonding under a deep closure g_N (fixed): tangential work W_T = stick-spring
    energy + dissipated - released normal energy; the bonded area turning into crack area
    releases (omega - omega_old)(K g^2/2 - Pi) >= 0 (the capped crack law stores less)."""
    K0 = COH.k_normal
    gN = -3 * COH.l_Nc
    gref = COH.lambda_max * COH.l_Nc
    c, cs = -gN / gref, 0.5                       # rough default: stiffness 2 K0 c capped at c*
    Pi_rough = gref ** 2 * (K0 * cs ** 2 * cs / 3 + K0 * cs ** 2 * (c - cs)
                            + 0.5 * K0 * (c - cs) ** 2)
    for kind, release in (("linear", 0.0), ("rough", 0.5 * K0 * gN ** 2 - Pi_rough)):
        law = InterfaceLaw(COH, contact=ContactParams(kind), friction=FrictionParams(0.5))
        g = np.linspace(0, 1.5 * COH.l_Tc, 3001)
        F, s = drive(law, np.c_[np.full_like(g, gN), g])
        W = np.sum(0.5 * (F[1:, 1] + F[:-1, 1]) * np.diff(g))
        assert s.debonded[0] and release >= 0.0
        spring = 0.5 * F[-1, 1] ** 2 / COH.k_tangential     # stick spring (|F_T| < f|F_N|)
        assert abs(F[-1, 1]) < 0.5 * abs(F[-1, 0])
        # trapezoid error from the kink cells, O(h^2) at 3000 steps: 1e-4 relative
        assert s.dissipated[0] == pytest.approx(W - spring + release, rel=1e-4)
        assert s.dissipated[0] >= COH.G_II * (1 - 1e-9)


def test_linear_penalty_stiffer_than_intact_bond_is_refused():
    with pytest.raises(ValueError, match=r"penalty = 200000000000.0 exceeds intact_stiffness = 100000000000.0; allowed"):
        InterfaceLaw(COH, contact=ContactParams(penalty=2e11, intact_stiffness=1e11))


# ---------------------------------------------------------------------------------------------
# friction
# ---------------------------------------------------------------------------------------------
def debonded_in_compression(law, gN):
    _, s = drive(law, [[2 * COH.l_Nc, 0.0], [gN, 0.0]])
    assert s.debonded[0]
    return s


def test_friction_cone_stick_and_slip_direction():
    law = InterfaceLaw(COH, contact=ContactParams(), friction=FrictionParams(0.3))
    gN = -COH.l_Nc * 0.05
    s = debonded_in_compression(law, gN)
    FN = COH.k_normal * gN
    CT = COH.k_tangential
    # stick: a small tangential increment inside the cone
    dg = 0.1 * 0.3 * abs(FN) / CT
    F, T, s1 = law.evaluate(np.array([[gN, dg]]), s)
    assert F[0, 1] == pytest.approx(CT * dg, rel=1e-12) and T[0, 1, 1] == CT
    # slip both ways: |F_T| = f|F_N|, sign of the slip increment, work F_T ds_p >= 0
    for sign in (1, -1):
        F, T, s2 = law.evaluate(np.array([[gN, sign * 50 * dg]]), s)
        assert F[0, 1] == pytest.approx(sign * 0.3 * abs(FN), rel=1e-12)
        assert np.sign(s2.slip[0, 0] - s.slip[0, 0]) == sign
        assert s2.dissipated[0] > s.dissipated[0]
        assert T[0, 1, 0] == pytest.approx(-0.3 * COH.k_normal * sign, rel=1e-12)


def test_stick_slip_loop_dissipates_and_respects_cone():
    law = InterfaceLaw(COH, contact=ContactParams("rough"), friction=FrictionParams(0.5))
    gN = -COH.l_Nc * 0.1
    s = debonded_in_compression(law, gN)
    d0 = s.dissipated[0]
    gt = 2e-5 * np.sin(np.linspace(0, 4 * np.pi, 401))
    F, s = drive(law, np.c_[np.full_like(gt, gN), gt], s)
    assert np.all(np.abs(F[:, 1]) <= 0.5 * np.abs(F[:, 0]) * (1 + 1e-12))
    W = np.sum(0.5 * (F[1:, 1] + F[:-1, 1]) * np.diff(gt))
    assert s.dissipated[0] - d0 > 0
    # closed loop: work in = dissipated (the stick spring ends nearly unloaded); the trapezoid
    # work and the backward-Euler dissipation differ by O(step): 2 % at 400 steps
    assert W == pytest.approx(s.dissipated[0] - d0, rel=2e-2)


# ---------------------------------------------------------------------------------------------
# damage
# ---------------------------------------------------------------------------------------------
def test_damage_monotone_bounded_closing_adds_nothing_and_D1_no_cohesion():
    law = InterfaceLaw(COH, contact=ContactParams(),
                       damage=DamageParams(g_max=10 * COH.l_Nc, alpha=1.0))
    amp = 0.1 * COH.l_Nc
    cyc = np.r_[np.linspace(0, amp, 5)[1:], np.linspace(amp, -amp, 9)[1:],
                np.linspace(-amp, 0, 5)[1:]]
    s = law.initial_state(1)
    D = [0.0]
    for k in range(120):
        for j, g in enumerate(cyc):
            prev = s
            _, _, s = law.evaluate(np.array([[g, 0.0]]), s)
            if j >= 4:  # closing / compression part of the cycle
                assert s.damage[0] == prev.damage[0]
        D.append(s.damage[0])
    D = np.array(D)
    assert np.all(np.diff(D) >= 0) and D.max() <= 1.0
    # alpha = 1, beta = 0, F_th = 0: each cycle adds amp/g_max = 0.01 -> failure at cycle 100
    # (sums of 0.0025 accumulate round-off of a few ulps: D[100] = 1 to 1e-12, then clipped)
    assert D[99] == pytest.approx(0.99, rel=1e-12)
    assert D[100] == pytest.approx(1.0, abs=1e-12) and D[101] == 1.0
    F, _, _ = law.evaluate(np.array([[0.5 * amp, 0.5 * amp]]), s)
    assert np.all(F == 0.0)


@pytest.mark.parametrize("alpha", [1.0, 2.0, 3.0])
def test_objective_damage_form_is_independent_of_the_step_and_paper_form_is_not(alpha):
    """10 cycles 0 -> A -> 0 in k increments per half cycle (beta = 0): the objective form gives
    (N A/g_max)^alpha for every k; the paper's form gives N k (A/(k g_max))^alpha."""
    A, gmax, N = 0.05 * COH.l_Nc, 10 * COH.l_Nc, 10
    for k in (1, 4, 64):
        up = np.linspace(0, A, k + 1)[1:]
        cyc = np.r_[up, up[::-1][1:], 0.0]
        path = np.c_[np.tile(cyc, N), np.zeros(N * len(cyc))]
        D = {}
        for form in ("paper", "objective"):
            law = InterfaceLaw(COH, damage=DamageParams(g_max=gmax, alpha=alpha, form=form))
            D[form] = drive(law, path)[1].damage[0]
        assert D["objective"] == pytest.approx((N * A / gmax) ** alpha, rel=1e-10)
        assert D["paper"] == pytest.approx(N * k * (A / (k * gmax)) ** alpha, rel=1e-10)


def test_damage_threshold_beta():
    law = InterfaceLaw(COH, damage=DamageParams(g_max=COH.l_Nc, alpha=1.0, beta=1.0,
                                               F_th=0.5 * COH.sigma_max))
    # below the threshold traction (F/sigma^t = 0.25 at lam = 0.05): no damage
    _, s = drive(law, [[0.05 * COH.l_Nc, 0.0]])
    assert s.damage[0] == 0.0
    # above: r = 0.75 -> dD = (dg/g_max) (0.75 - 0.5)
    _, s = drive(law, [[0.15 * COH.l_Nc, 0.0]])
    assert s.damage[0] == pytest.approx(0.15 * 0.25, rel=1e-12)


# ---------------------------------------------------------------------------------------------
# consistent tangent vs centred finite differences on >= 10 000 states over every branch
# ---------------------------------------------------------------------------------------------
def random_states(law, n, rng, dim=2):
    c = law.cohesive
    lm = c.lambda_max
    pick = rng.integers(0, 4, n)
    kappa = np.choose(pick, [np.zeros(n), rng.uniform(0, lm, n), rng.uniform(lm, 1, n),
                             rng.uniform(1, 1.5, n)])
    dmg = np.choose(rng.integers(0, 3, n), [np.zeros(n), rng.uniform(0, 1, n), np.ones(n)])
    sep = rng.uniform(0, 1.5, n) * c.l_Nc
    slip = rng.uniform(-1, 1, (n, dim - 1)) * c.l_Tc
    return InterfaceState(kappa, dmg, sep, slip, rng.uniform(0, 10, n))


def signature(law, gap, s0, s1):
    """Which branch each point is on (used to skip points whose FD stencil crosses a kink)."""
    lm = law.cohesive.lambda_max
    gT = gap[:, 1:]
    return np.c_[s1.kappa > s0.kappa, s1.kappa <= lm, s1.kappa >= 1, gap[:, 0] > 0,
                 s1.damage > s0.damage, s1.damage >= 1,
                 np.all(s1.slip == s0.slip, axis=1), np.all(s1.slip == gT, axis=1)]


def branch_names(law, gap, s0, s1):
    lm = law.cohesive.lambda_max
    deb = s1.debonded
    contact = gap[:, 0] < 0
    stick = deb & contact & np.all(s1.slip == s0.slip, axis=1)
    return {
        "elastic": (s1.kappa <= lm) & (s1.damage == s0.damage) & ~deb,
        "softening": (s1.kappa > s0.kappa) & (s1.kappa > lm) & ~deb,
        "unloading": (s1.kappa == s0.kappa) & (s1.kappa > lm) & ~deb,
        "debonded_open": deb & ~contact,
        "contact_bonded": contact & ~deb,
        "stick": stick,
        "slip": deb & contact & ~stick,
        "damage": (s1.damage > s0.damage) & (s1.damage < 1),
    }


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("kind", ["linear", "rough"])
@pytest.mark.parametrize("beta", [0.0, 1.5])
@pytest.mark.parametrize("form", ["paper", "rate"])
def test_tangent_matches_centred_finite_differences(dim, kind, beta, form):
    rng = np.random.default_rng(1 + dim + 10 * (kind == "rough") + int(beta))
    # rate form: dt/t_ref = 0.3 scales the damage increment by 0.3^(1 - alpha) = 3.3 (alpha 2)
    dt = 0.3 if form == "rate" else None
    law = full_law(COH2, kind=kind, beta=beta, F_th=0.2 * COH2.sigma_max if beta else 0.0,
                   form=form)
    n = 12000
    s0 = random_states(law, n, rng, dim)
    scale = np.r_[COH2.l_Nc, [COH2.l_Tc] * (dim - 1)]
    gap = rng.uniform(-1.3, 1.3, (n, dim)) * scale
    F, T, s1 = law.evaluate(gap, s0, dt=dt)
    sig = signature(law, gap, s0, s1)
    # h: centred FD truncation error h^2 F''' / 6 vs round-off eps |F| / h; with h = 1e-6 of
    # the gap scale both are ~1e-10..1e-12 relative to the tangent, so 1e-6 relative (of the
    # largest entry of the point's tangent, rows have different scales) is a safe bound
    h = 1e-6 * scale
    Tfd = np.empty_like(T)
    ok = np.ones(n, bool)
    for j in range(dim):
        gp, gm = gap.copy(), gap.copy()
        gp[:, j] += h[j]
        gm[:, j] -= h[j]
        Fp, _, sp = law.evaluate(gp, s0, dt=dt)
        Fm, _, sm = law.evaluate(gm, s0, dt=dt)
        ok &= np.all(signature(law, gp, s0, sp) == sig, axis=1)
        ok &= np.all(signature(law, gm, s0, sm) == sig, axis=1)
        Tfd[:, :, j] = (Fp - Fm) / (2 * h[j])
    # in units of traction per gap scale so that the N and T columns compare
    err = np.abs((Tfd - T) * scale[None, None, :]).max(axis=(1, 2))
    ref = np.abs(T * scale[None, None, :]).max(axis=(1, 2)) + 1e-3 * COH2.sigma_max
    rel = err / ref
    names = branch_names(law, gap, s0, s1)
    for name, mask in names.items():
        m = mask & ok
        assert m.sum() >= 50, f"branch {name} covered by only {m.sum()} points"
        assert rel[m].max() < 1e-6, (name, rel[m].max(), np.flatnonzero(m)[np.argmax(rel[m])])
    assert ok.sum() >= 10000


# ---------------------------------------------------------------------------------------------
# properties (hypothesis)
# ---------------------------------------------------------------------------------------------
gap_el = st.floats(-2.0, 2.0, allow_nan=False)
# gaps for comparing the 2D and 3D kernels: zero or at least 1e-100 l (1e-104 m here). Below,
# hypothesis finds subnormal gaps (g = -9e-298 m) whose stick trial C_T (g_T - s) squares to 0
# in the 3D norm |t_T| but not in the 2D |t_T|: the 3D point sticks and the 2D one slips, and
# the tangents differ by C_T. No physical gap is within 90 orders of magnitude of that.
gap_el_3d = gap_el.map(lambda v: 0.0 if abs(v) < 1e-100 else v)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(gap_el, gap_el), min_size=1, max_size=12))
def test_dissipation_nonnegative_over_random_closed_cycles(pts):
    law = full_law(COH2, kind="rough")
    scale = np.array([COH2.l_Nc, COH2.l_Tc])
    gaps = np.r_[np.array(pts) * scale, [[0.0, 0.0]]]
    s = law.initial_state(1)
    prev = 0.0
    for g in gaps:
        _, _, s = law.evaluate(g[None, :].copy(), s)
        assert s.dissipated[0] >= prev - 1e-12 * abs(prev)      # never decreases
        prev = s.dissipated[0]
    assert np.isfinite(s.dissipated[0]) and s.dissipated[0] >= 0.0


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(gap_el_3d, gap_el_3d, gap_el_3d), min_size=1, max_size=8))
def test_odd_in_gT_and_2d_equals_3d(pts):
    law = full_law(COH2)
    scale = np.array([COH2.l_Nc, COH2.l_Tc, COH2.l_Tc])
    g3 = np.array(pts) * scale
    g2 = g3[:, :2].copy()
    g2m = g2 * np.array([1.0, -1.0])
    s2, s2m = law.initial_state(1, 2), law.initial_state(1, 2)
    s3 = law.initial_state(1, 3)
    for a, b in zip(g2, g2m):
        F, T, s2 = law.evaluate(a[None, :].copy(), s2)
        Fm, Tm, s2m = law.evaluate(b[None, :].copy(), s2m)
        c = np.r_[a, 0.0][None, :]
        F3, T3, s3 = law.evaluate(c, s3)
        assert Fm[0, 0] == F[0, 0] and Fm[0, 1] == -F[0, 1]
        # atol 1e-30 Pa: hypothesis finds gaps of ~1e-256 m whose squares underflow in the 3D
        # norm |g_T| but not in the 2D |g_T|, giving tractions of 1e-245 vs 1e-304 Pa — both
        # zero at any physical scale; every traction above 1e-30 Pa is compared to 1e-12
        np.testing.assert_allclose(F3[0, :2], F[0], rtol=1e-12, atol=1e-30)
        np.testing.assert_allclose(T3[0, :2, :2], T[0], rtol=1e-12, atol=1e-9)
        assert F3[0, 2] == 0.0
        assert s3.dissipated[0] == pytest.approx(s2.dissipated[0], rel=1e-12, abs=1e-300)


# ---------------------------------------------------------------------------------------------
# batch = per point; parallel = serial; never mutates the input state; out= buffers
# ---------------------------------------------------------------------------------------------
def test_parallel_equals_serial_and_state_not_mutated_and_out_buffers():
    rng = np.random.default_rng(5)
    law_s = full_law(COH2)
    law_p = InterfaceLaw(law_s.cohesive, law_s.contact, law_s.friction, law_s.damage,
                         parallel=True)
    n = 3000
    s0 = random_states(law_s, n, rng)
    keep = s0.copy()
    gap = rng.uniform(-1.3, 1.3, (n, 2)) * np.array([COH2.l_Nc, COH2.l_Tc])
    F1, T1, n1 = law_s.evaluate(gap, s0)
    F2, T2, n2 = law_p.evaluate(gap, s0)
    assert np.array_equal(F1, F2) and np.array_equal(T1, T2)
    for k, v in n1.as_dict().items():
        assert np.array_equal(v, n2.as_dict()[k])
        assert np.array_equal(getattr(s0, k), getattr(keep, k))
    out = (np.empty((n, 2)), np.empty((n, 2, 2)), law_s.initial_state(n))
    F3, T3, n3 = law_s.evaluate(gap, s0, out=out)
    assert F3 is out[0] and np.array_equal(F3, F1) and np.array_equal(n3.kappa, n1.kappa)


def test_fast_loop_code_carries_the_law_damage_values():
    """The fast loop is compiled per kind of law with (alpha, form, F_th = 0) as constants
    (_kernels.code/_decode): they must be the law's own values. Pure Python (no
    compile); the compiled specialisations are compared with the generic loop of the C ABI
    (runtime parameters) along random walks in test_cabi.py."""
    from interfacelaw import _kernels
    coh = COH2
    seen = set()
    for alpha in (1.0, 2.0, 1.5):
        for F_th in (0.0, 0.3 * coh.sigma_max):
            for form in ("paper", "objective", "rate"):
                for beta in (0.0, 1.0):
                    law = full_law(coh, "rough", alpha=alpha, F_th=F_th, form=form, beta=beta)
                    _, con, _, dmg = law.kernel_params
                    c = _kernels.code(con, dmg)
                    if alpha == 1.5 or beta != 0.0:
                        assert c == -1 and not law._fast      # pow calls: the general loop
                        continue
                    assert law._fast and 0 <= c < 12
                    fast, spec = _kernels._decode.py_func(c)
                    a, b_, g, fth, code = dmg
                    assert fast and spec == (a, code, float(fth == 0.0 and b_ == 0.0))
                    seen.add(c)
    assert len(seen) == 10                                    # rate with alpha 1 = paper
    assert _kernels.code(None, None) == 2 and _kernels._decode.py_func(-1)[0] is False


# ---------------------------------------------------------------------------------------------
# extreme inputs: finite everywhere
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("g", [0.0, 1e-300, -1e-300, 1e10, -1e10, 5e-324])
def test_extreme_gaps_finite(g):
    for kind in ("linear", "rough"):
        law = full_law(COH, kind=kind)
        rng = np.random.default_rng(2)
        s = random_states(law, 200, rng)
        for gap in ([g, 0.0], [0.0, g], [g, g], [g, -g]):
            G = np.tile(np.array(gap, float), (200, 1))
            F, T, s1 = law.evaluate(G, s)
            for a in (F, T, *s1.as_dict().values()):
                assert np.all(np.isfinite(a)), (gap, kind)


def test_damage_one_minus_eps_and_tiny_lambda_max():
    law = InterfaceLaw(CohesiveParams(3e6, 3e6, 1e-4, 1e-4, 1e-6), contact=ContactParams(),
                       friction=FrictionParams(), damage=DamageParams(g_max=1e-3, alpha=2.0))
    s = law.initial_state(1)
    s = InterfaceState(s.kappa, np.array([1 - 1e-15]), s.separation, s.slip, s.dissipated)
    F, T, s1 = law.evaluate(np.array([[1e-12, 1e-12]]), s)
    assert np.all(np.isfinite(F)) and np.all(np.isfinite(T))
    assert abs(F[0, 0]) <= 3e6 * 1e-14       # (1 - D) sigma scale


# ---------------------------------------------------------------------------------------------
# validation: every error path names the field, the value and the allowed range
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kw,field", [
    (dict(sigma_max=0.0), "sigma_max"), (dict(sigma_max=-1.0), "sigma_max"),
    (dict(tau_max=float("nan")), "tau_max"), (dict(l_Nc=0.0), "l_Nc"),
    (dict(l_Tc=float("inf")), "l_Tc"), (dict(lambda_max=0.0), "lambda_max"),
    (dict(lambda_max=1.0), "lambda_max"), (dict(sigma_max="x"), "sigma_max"),
])
def test_cohesive_validation(kw, field):
    base = dict(sigma_max=3e6, tau_max=3e6, l_Nc=1e-4, l_Tc=1e-4, lambda_max=0.2) | kw
    with pytest.raises(ValueError, match=rf"CohesiveParams\.{field} = .*allowed"):
        CohesiveParams(**base)


def test_from_fracture_energy_validation():
    with pytest.raises(ValueError, match=r"G_I = -1.*allowed"):
        CohesiveParams.from_fracture_energy(3e6, 3e6, -1.0, 0.2)
    with pytest.raises(ValueError, match=r"ratio_lTc_lNc = 0.*allowed"):
        CohesiveParams.from_fracture_energy(3e6, 3e6, 250.0, 0.2, 0.0)


@pytest.mark.parametrize("make,pat", [
    (lambda: ContactParams("soft"), r"ContactParams\.kind = 'soft'.*allowed"),
    (lambda: ContactParams("linear", exponent=2.0), r"ContactParams\.exponent = 2.0.*allowed"),
    (lambda: ContactParams("rough", exponent=0.5), r"ContactParams\.exponent = 0.5.*allowed"),
    (lambda: ContactParams(penalty=-1.0), r"ContactParams\.penalty = -1.0.*allowed"),
    (lambda: ContactParams(g_ref=0.0), r"ContactParams\.g_ref = 0.0.*allowed"),
    (lambda: FrictionParams(f=-0.1), r"FrictionParams\.f = -0.1.*allowed"),
    (lambda: FrictionParams(penalty=0.0), r"FrictionParams\.penalty = 0.0.*allowed"),
    (lambda: DamageParams(g_max=0.0), r"DamageParams\.g_max = 0.0.*allowed"),
    (lambda: DamageParams(g_max=1.0, alpha=0.0), r"DamageParams\.alpha = 0.0.*allowed"),
    (lambda: DamageParams(g_max=1.0, beta=-1.0), r"DamageParams\.beta = -1.0.*allowed"),
    (lambda: DamageParams(g_max=1.0, F_th=-1.0), r"DamageParams\.F_th = -1.0.*allowed"),
    (lambda: DamageParams(g_max=1.0, form="exact"), r"DamageParams\.form = 'exact'.*allowed"),
    (lambda: DamageParams(g_max=1.0, form="rate", t_ref=-1.0),
     r"DamageParams\.t_ref = -1.0.*allowed"),
    (lambda: InterfaceLaw("x"), r"InterfaceLaw\.cohesive = 'x'.*allowed"),
    (lambda: InterfaceLaw(COH, friction=FrictionParams()), r"friction.*contact = None"),
    (lambda: InterfaceLaw(COH, damage=FrictionParams()), r"InterfaceLaw\.damage = .*allowed"),
    (lambda: InterfaceLaw.initial_state(-1), r"n = -1.*allowed"),
    (lambda: InterfaceLaw.initial_state(3, dim=4), r"dim = 4.*allowed"),
])
def test_param_and_law_validation(make, pat):
    with pytest.raises(ValueError, match=pat):
        make()


def test_evaluate_validation_names_first_bad_point():
    law = InterfaceLaw(COH)
    s = law.initial_state(3)
    g = np.zeros((3, 2))
    g[1, 1] = np.nan
    g[2, 0] = np.inf
    with pytest.raises(ValueError, match=r"gap\[1\] = \[0.0, nan\] is not finite or exceeds 1e\+100 m"):
        law.evaluate(g, s)
    with pytest.raises(ValueError, match=r"dtype float32.*allowed"):
        law.evaluate(np.zeros((3, 2), np.float32), s)
    with pytest.raises(ValueError, match=r"shape \(3,\).*allowed"):
        law.evaluate(np.zeros(3), s)
    with pytest.raises(ValueError, match=r"do not match"):
        law.evaluate(np.zeros((4, 2)), s)
    with pytest.raises(ValueError, match=r"state = dict.*allowed"):
        law.evaluate(np.zeros((3, 2)), {})


def test_rough_contact_with_exponent_near_one_has_no_cap():
    """A rough contact of exponent m -> 1 with K_intact >> C_N: the closure c* at which the
    crack stiffness C_N m c^(m-1) reaches K_intact is (K_intact / (C_N m))^(1/(m-1)), here
    (1.28e13 / 8.03e5)^256, far beyond the float range. It is inf (never capped, the value of
    m = 1), not an OverflowError (found by tests/test_reference.py's hypothesis search), and
    the kernel then agrees with the pure-Python reference law (interfacelaw.testing) in
    compression, where the cap would act."""
    coh = CohesiveParams(sigma_max=1e5, tau_max=1e5, l_Nc=0.0078125, l_Tc=0.0078125,
                         lambda_max=0.5)
    con = ContactParams(kind="rough", penalty=8e5, exponent=1.00390625)
    arr = con.as_array(coh)
    assert math.isinf(arr[-1]) and np.all(np.isfinite(arr[:-1]))
    law = InterfaceLaw(coh, contact=con)
    from interfacelaw.testing import evaluate_reference
    g = np.array([[-1e-3, 0.0], [-1e-1, 1e-4], [-10.0, 0.0]])
    t, T, _ = law.evaluate(g, law.initial_state(3))
    t_ref, T_ref, _ = evaluate_reference(law, g, law.initial_state(3))
    assert np.all(np.isfinite(t)) and np.all(t[:, 0] < 0.0)
    np.testing.assert_allclose(t, t_ref, rtol=1e-12, atol=0.0)
    np.testing.assert_allclose(T, T_ref, rtol=1e-10, atol=0.0)
