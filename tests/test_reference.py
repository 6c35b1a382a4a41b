"""The numba kernel against the independent numpy reference (interfacelaw/testing.py), and the
reference's tangent against finite differences. Specification: docs/law.md."""
from __future__ import annotations

import itertools
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from interfacelaw import (CohesiveParams, ContactParams, DamageParams, FrictionParams,
                          InterfaceLaw, InterfaceState)
from interfacelaw.testing import evaluate_reference

COH = CohesiveParams(sigma_max=3.0e6, tau_max=2.0e6, l_Nc=1.0e-4, l_Tc=1.5e-4, lambda_max=0.3)
RTOL = 1e-12

CONTACTS = [None, ContactParams("linear"), ContactParams("rough"),
            ContactParams("rough", exponent=2.7, penalty=5e10, intact_stiffness=8e10)]
DAMAGES = [None, DamageParams(g_max=2e-4),
           DamageParams(g_max=1.5e-4, alpha=2.0, beta=1.5, F_th=3e5),
           DamageParams(g_max=8e-4, alpha=0.5, beta=0.0, F_th=1e6),
           DamageParams(g_max=3e-4, alpha=2.0, beta=1.0, F_th=2e5, form="objective"),
           DamageParams(g_max=3e-4, alpha=2.0, beta=1.0, F_th=2e5, form="rate", t_ref=0.2),
           DamageParams(g_max=5e-4, alpha=0.7, form="rate", t_ref=3.0)]
# the step's time increment passed to every evaluation (used by the "rate" form only);
# dt/t_ref = 0.25 and 0.017 above, so the factor (dt/t_ref)^(1-alpha) is far from 1
DT = 0.05


def all_laws(coh=COH, parallel=None):
    """Every combination contact (none/linear/rough) x friction (only with contact) x damage
    (``parallel``: InterfaceLaw's choice of the serial or parallel loop; None by size)."""
    for con, dmg in itertools.product(CONTACTS, DAMAGES):
        for fri in ([None] if con is None else [None, FrictionParams(0.4)]):
            yield InterfaceLaw(coh, con, fri, dmg, parallel=parallel)


def scales(coh):
    """Absolute scale of each output: errors are measured relative to max(|value|, scale)."""
    K0 = coh.k_normal
    return dict(traction=coh.sigma_max, tangent=max(K0, coh.k_tangential), kappa=1.0,
                damage=1.0, separation=coh.l_Nc, slip=coh.l_Nc, dissipated=coh.G_I)


def compare(law, gap, state, rtol=RTOL, dt=DT):
    """Max of |numba - reference| / max(|reference|, scale) per output; both outputs.
    """
    F, T, new = law.evaluate(gap, state, dt=dt)
    Fr, Tr, newr = evaluate_reference(law, gap, state, dt=dt)
    sc = scales(law.cohesive)
    pairs = dict(traction=(F, Fr), tangent=(T, Tr))
    pairs.update({k: (getattr(new, k), getattr(newr, k))
                  for k in ("kappa", "damage", "separation", "slip", "dissipated")})
    bad = {}
    if law.contact is not None:
        # the contact release term (docs §1.3) is a difference of energies ~ K g_N^2/2: its
        # rounding scales with that, not with G_I
        K = law.contact.as_array(law.cohesive)[:2].max()
        sc["dissipated"] = np.maximum(sc["dissipated"], 0.5 * K * np.minimum(gap[:, 0], 0) ** 2)
    for k, (x, y) in pairs.items():
        assert np.all(np.isfinite(y)), f"reference {k} not finite"
        err = np.abs(x - y) / np.maximum(np.abs(y), sc[k])
        err = err.reshape(err.shape[0], -1).max(axis=1) if err.ndim > 1 else err
        err = np.where(np.isnan(err), np.inf, err)
        if err.max() > rtol:
            i = int(np.argmax(err))
            bad[k] = dict(point=i, err=float(err[i]), gap=gap[i].tolist(),
                          state={f: np.asarray(getattr(state, f)[i]).tolist()
                                 for f in ("kappa", "damage", "separation", "slip",
                                           "dissipated")},
                          numba=np.asarray(x[i]).tolist(), reference=np.asarray(y[i]).tolist())
    return bad


# ----------------------------------------------------------------------------------------
def random_state(rng, n, dim, coh=COH):
    k = rng.uniform(0.0, 1.5, n)
    k[rng.random(n) < 0.15] = 0.0
    k[rng.random(n) < 0.05] = 1.0
    D = rng.uniform(0.0, 1.0, n)
    D[rng.random(n) < 0.4] = 0.0
    hi = rng.random(n) < 0.15
    D[hi] = rng.uniform(0.95, 1.0, hi.sum())          # close to clipping
    D[rng.random(n) < 0.1] = 1.0
    sep = rng.uniform(0.0, 1.5, n) * coh.l_Nc * rng.choice([0.0, 0.1, 1.0], n)
    slip = rng.uniform(-1.0, 1.0, (n, dim - 1)) * coh.l_Nc
    clip = rng.random(n) < 0.10                       # any damage growth clips D at 1
    D[clip], sep[clip] = 1.0 - 1e-6, 0.0
    diss = rng.uniform(0.0, 1.0, n) * coh.G_I
    return InterfaceState(k, D, sep, slip, diss)


def random_gap(rng, n, dim, coh=COH):
    scale = rng.choice([0.05, 0.3, 1.0, 2.0, 4.0], n)[:, None]
    g = rng.uniform(-1.0, 1.0, (n, dim)) * scale
    g[:, 0] *= coh.l_Nc
    g[:, 1:] *= coh.l_Tc
    # some pure mode I / mode II / pure closure points
    m = rng.random(n)
    g[m < 0.05, 1:] = 0.0
    mII = (m >= 0.05) & (m < 0.1)                    # mode II, on either side of g_N = 0
    g[mII, 0] = rng.choice([-1e-20, 0.0, 1e-20], mII.sum()) * coh.l_Nc
    return g


def branches(law, gap, state):
    """Boolean masks of the branches of §1 (recomputed from the spec, for coverage only)."""
    c = law.cohesive
    gN = gap[:, 0]
    gT = np.linalg.norm(gap[:, 1:], axis=1)
    lam = np.hypot(np.maximum(gN, 0) / c.l_Nc, gT / c.l_Tc)
    _, _, new = evaluate_reference(law, gap, state, dt=DT)
    kap = new.kappa
    deb = (kap >= 1) | (new.damage >= 1)
    out = dict(elastic=kap <= c.lambda_max,
               softening=(lam > state.kappa) & (lam > c.lambda_max) & (lam < 1),
               unloading=(state.kappa > lam) & (state.kappa > c.lambda_max) & (state.kappa < 1),
               debonded_open=deb & (gN > 0))
    if law.contact is not None:
        out.update(contact_intact=(gN < 0) & ~deb & (kap < c.lambda_max) & (state.damage == 0),
                   contact_debonded=(gN < 0) & deb)
    if law.friction is not None:
        moved = np.any(new.slip != state.slip, axis=1)
        act = (gN < 0) & deb
        out.update(stick=act & ~moved, slip=act & moved)
    if law.damage is not None:
        out.update(damage_growing=(new.damage > state.damage) & (new.damage < 1),
                   damage_clipped=(new.damage == 1) & (state.damage < 1))
    return out


@pytest.mark.parametrize("dim", [2, 3])
def test_numba_matches_reference_random(dim):
    """~20 000 points over all 30 laws through the serial kernel plus one large batch through
    the parallel kernel; every branch is populated (checked). The serial loop is asked for by
    name: 700 points would pick the parallel one (PARALLEL_MIN_POINTS = 512), which runs the
    same serial loop on one chunk here (CHUNK = 4096) but is a separate compilation per kind
    of law (~2 CPU-s each on a cold numba cache, 2 x 11 of them); the parallel path's own
    code (chunks, views) is checked below on two chunks, and against the serial loop bit for
    bit in test_law.py."""
    rng = np.random.default_rng(1234 + dim)
    laws = list(all_laws(parallel=False))
    n = 700                                          # per law (30 laws)
    failures = {}
    for law in laws:
        gap = random_gap(rng, n, dim)
        state = random_state(rng, n, dim)
        for name, mask in branches(law, gap, state).items():
            assert mask.sum() >= 3, f"{law}: branch {name} has {mask.sum()} points"
        bad = compare(law, gap, state)
        if bad:
            failures[repr(law)] = bad
    # the parallel kernel (n >= PARALLEL_MIN_POINTS) on the richest law
    law = InterfaceLaw(COH, ContactParams("rough"), FrictionParams(0.4), DAMAGES[2])
    gap, state = random_gap(rng, 5000, dim), random_state(rng, 5000, dim)
    bad = compare(law, gap, state)
    if bad:
        failures["parallel " + repr(law)] = bad
    assert not failures, failures


# ----------------------------------------------------------------------------------------
# Finite differences of the reference.
#   Step h = 1e-7 l_c (l_Nc for g_N, l_Tc for g_T): the traction is computed with a relative
#   round-off of ~1e-15, so the centred difference carries a round-off error ~1e-15 |F|/h ~
#   1e-8 K0 and a truncation error ~(h/delta)^2 ~ 1e-8 relative, where delta = 1e-3 (in units of
#   l_c / of the normalised quantities) is the smallest distance from a kink that is kept.
#   Tolerance 1e-5 relative to max(|tangent|, K0): ~1000x above both error estimates, and
#   far below any real tangent error (a missing term is O(1) relative).
FD_H = 1e-7
FD_DELTA = 1e-3
FD_TOL = 1e-5


def near_kink(law, gap, state):
    """Points within FD_DELTA of a kink of the law (where a centred difference is meaningless)."""
    c = law.cohesive
    gN = gap[:, 0]
    gTv = gap[:, 1:]
    gT = np.linalg.norm(gTv, axis=1)
    gNp = np.maximum(gN, 0.0)
    lam = np.hypot(gNp / c.l_Nc, gT / c.l_Tc)
    kap = np.maximum(lam, state.kappa)
    near = (np.abs(lam - c.lambda_max) < FD_DELTA) | (np.abs(lam - 1.0) < FD_DELTA) \
        | (np.abs(lam - state.kappa) < FD_DELTA) | (np.abs(gN) < FD_DELTA * c.l_Nc) \
        | (lam < FD_DELTA)
    _, _, new = evaluate_reference(law, gap, state, dt=DT)
    if law.damage is not None:
        al, be, gmax, fth, _ = law.damage.as_array(c)
        sep = np.hypot(gNp, gT)
        dg = sep - state.separation
        ks = np.where(kap > c.lambda_max, kap, 1.0)
        s = np.where(kap <= c.lambda_max, 1 / c.lambda_max,
                     np.where(kap < 1, (1 - ks) / (ks * (1 - c.lambda_max)), 0.0))
        a = np.hypot(c.sigma_max * gNp / c.l_Nc, c.tau_max * c.l_Nc / c.l_Tc ** 2 * gT)
        r = s * a / c.sigma_max
        B = np.where(r > fth, np.maximum(r - fth, 0.0) ** be, 0.0)
        raw = np.where(dg > 0, (np.maximum(dg, 0) / gmax) ** al * B, 0.0)
        if law.damage.form == "rate":
            raw = raw * (DT / law.damage.t_ref) ** (1.0 - al)
        near |= (np.abs(dg) < FD_DELTA * c.l_Nc) | (np.abs(r - fth) < FD_DELTA) \
            | ((dg > 0) & (np.abs(raw - 1) < FD_DELTA)) \
            | ((dg > 0) & (np.abs(state.damage + np.minimum(raw, 1) - 1) < FD_DELTA)) \
            | ((dg > 0) & (np.abs(new.damage - 1) < FD_DELTA))     # objective form's clip
    if law.friction is not None:
        f, CT = law.friction.as_array(c)
        F, _, _ = evaluate_reference(law, gap, state, dt=DT)
        tn = CT * np.linalg.norm(gTv - state.slip, axis=1)
        lim = f * np.abs(F[:, 0])
        near |= np.abs(tn - lim) < FD_DELTA * np.maximum(np.maximum(tn, lim), c.sigma_max)
    return near


def rep_state(state, k):
    return InterfaceState(*(np.repeat(getattr(state, f), k, axis=0)
                            for f in ("kappa", "damage", "separation", "slip", "dissipated")))


@pytest.mark.parametrize("dim", [2, 3])
def test_reference_tangent_finite_differences(dim):
    rng = np.random.default_rng(99 + dim)
    c = COH
    steps = np.array([c.l_Nc] + [c.l_Tc] * (dim - 1)) * FD_H
    tol_scale = max(c.k_normal, c.k_tangential)
    kept_total = 0
    for law in all_laws():
        n = 300
        gap, state = random_gap(rng, n, dim), random_state(rng, n, dim)
        keep = ~near_kink(law, gap, state)
        gap, state = gap[keep], state.take(keep)
        m = gap.shape[0]
        kept_total += m
        _, T, _ = evaluate_reference(law, gap, state, dt=DT)
        # (m, 2 dim) perturbed gaps: +h e_j, -h e_j
        E = np.eye(dim) * steps
        gp = (gap[:, None, :] + E[None]).reshape(-1, dim)
        gm = (gap[:, None, :] - E[None]).reshape(-1, dim)
        sd = rep_state(state, dim)
        Fp = evaluate_reference(law, gp, sd, dt=DT)[0].reshape(m, dim, dim)   # [point, j, i]
        Fm = evaluate_reference(law, gm, sd, dt=DT)[0].reshape(m, dim, dim)
        Tfd = np.transpose((Fp - Fm) / (2 * steps[None, :, None]), (0, 2, 1))   # dF_i/dg_j
        err = np.abs(Tfd - T) / np.maximum(np.abs(T), tol_scale)
        i = int(np.unravel_index(np.argmax(err), err.shape)[0]) if m else 0
        assert m == 0 or err.max() < FD_TOL, (law, gap[i], state.take([i]), T[i], Tfd[i])
    # ~10 % of the points are put exactly on the kinks g_N = 0 or kappa_old = 0, 1 on purpose
    assert kept_total > 0.6 * 300 * len(list(all_laws()))


# ----------------------------------------------------------------------------------------
_f = dict(allow_nan=False, allow_infinity=False)


@st.composite
def law_gap_state(draw):
    sig = draw(st.floats(1e5, 1e8))
    l_Nc = draw(st.floats(1e-6, 1e-2))
    coh = CohesiveParams(sigma_max=sig, tau_max=sig * draw(st.floats(0.1, 10.0)), l_Nc=l_Nc,
                         l_Tc=l_Nc * draw(st.floats(0.2, 5.0)),
                         lambda_max=draw(st.floats(0.01, 0.99)))
    kind = draw(st.sampled_from([None, "linear", "rough"]))
    con = None
    if kind is not None:
        pen = draw(st.none() | st.floats(1e-2, 1e2))
        con = ContactParams(kind, penalty=None if pen is None else pen * coh.k_normal,
                            exponent=None if kind == "linear" else draw(st.floats(1.0, 4.0)))
    fri = None
    if con is not None and draw(st.booleans()):
        fri = FrictionParams(draw(st.floats(0.0, 2.0)))
    dmg = None
    if draw(st.booleans()):
        dmg = DamageParams(g_max=coh.l_Nc * draw(st.floats(0.1, 100.0)),
                           alpha=draw(st.sampled_from([1.0, 2.0, 0.5, 1.7])),
                           beta=draw(st.sampled_from([0.0, 1.0, 1.5, 0.5])),
                           F_th=sig * draw(st.floats(0.0, 1.5)),
                           form=draw(st.sampled_from(["paper", "objective", "rate"])),
                           t_ref=draw(st.floats(1e-3, 1e3)))
    law = InterfaceLaw(coh, con, fri, dmg)
    dim = draw(st.sampled_from([2, 3]))
    n = draw(st.integers(1, 4))
    lc = coh.l_Nc
    gscale = st.floats(-1e3, 1e3, **_f)
    gap = np.array([[draw(gscale) * lc for _ in range(dim)] for _ in range(n)])
    state = InterfaceState(
        kappa=np.array([draw(st.floats(0.0, 10.0)) for _ in range(n)]),
        damage=np.array([draw(st.floats(0.0, 1.0)) for _ in range(n)]),
        separation=np.array([draw(st.floats(0.0, 1e3)) * lc for _ in range(n)]),
        slip=np.array([[draw(gscale) * lc for _ in range(dim - 1)] for _ in range(n)]),
        dissipated=np.array([draw(st.floats(0.0, 1e3)) * coh.G_I for _ in range(n)]))
    dt = draw(st.floats(1e-4, 1e2))
    return law, gap, state, dt


@settings(max_examples=int(os.environ.get("REFERENCE_HYPOTHESIS_EXAMPLES", 300)), deadline=None, suppress_health_check=list(HealthCheck))
@given(law_gap_state())
def test_numba_matches_reference_hypothesis(lgs):
    law, gap, state, dt = lgs
    bad = compare(law, gap, state, dt=dt)
    assert not bad, (law, bad)


# ----------------------------------------------------------------------------------------
def test_reference_tangent_at_zero_normal_gap():
    """g_N = 0 with an intact interface and the default K_intact: both one-sided slopes of F_N
    are K0 (docs §1.3: 'no jump for an intact interface'), so the tangent is K0 there."""
    law = InterfaceLaw(COH, ContactParams("linear"))
    gap = np.array([[0.0, 0.0], [0.0, 1e-6], [1e-12, 0.0], [-1e-12, 0.0]])
    _, T, _ = evaluate_reference(law, gap, law.initial_state(4))
    np.testing.assert_allclose(T[:, 0, 0], COH.k_normal, rtol=1e-12)


def test_tangent_at_zero_normal_gap():
    """Regression: the kernel once took d<g_N>/dg_N = 0 at g_N == 0 exactly, so the first
    Newton iteration from the initial state had no normal stiffness."""
    law = InterfaceLaw(COH, ContactParams("linear"))
    gap = np.array([[0.0, 0.0], [0.0, 1e-6]])
    _, T, _ = law.evaluate(gap, law.initial_state(2))
    np.testing.assert_allclose(T[:, 0, 0], COH.k_normal, rtol=1e-12)
