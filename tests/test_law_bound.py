"""The law bound to a state (``InterfaceLaw.bind``, the solver's per-iteration call): the same
numbers as ``evaluate`` bit for bit, and the same errors (docs/solver.md §6)."""
import re
from dataclasses import fields

import numpy as np
import pytest

from interfacelaw import (CohesiveParams, ContactParams, DamageParams, FrictionParams,
                          InterfaceLaw, InterfaceState)
from interfacelaw.law import GAP_LIMIT
from ngs_driver.solve.joint_laws import JointLaws

COH = CohesiveParams.from_fracture_energy(sigma_max=3e6, tau_max=3e6, G_I=250.0,
                                          lambda_max=0.2, ratio_lTc_lNc=1.0)

LAWS = {
    "cohesive": lambda: InterfaceLaw(COH),
    "friction": lambda: InterfaceLaw(COH, contact=ContactParams("linear"),
                                     friction=FrictionParams(0.6)),
    "full": lambda: InterfaceLaw(COH, contact=ContactParams("linear"),
                                 friction=FrictionParams(0.4),
                                 damage=DamageParams(g_max=20 * COH.l_Nc, alpha=2.0)),
    # dt enters the kernel (rdt = dt / t_ref): a wrong rdt would change the damage
    "rate": lambda: InterfaceLaw(COH, contact=ContactParams("linear"),
                                 friction=FrictionParams(0.4),
                                 damage=DamageParams(g_max=20 * COH.l_Nc, alpha=2.0,
                                                     form="rate", t_ref=0.5)),
}


def history(law, n, rng):
    """A state with a history: random gaps around the elastic limit, twice."""
    s = law.initial_state(n)
    for _ in range(2):
        g = rng.normal(scale=0.5 * COH.l_Nc, size=(n, 2))
        _, _, s = law.evaluate(g, s, dt=0.01)
    return s


def same(a, b):
    """Bitwise equality of the three outputs (traction, tangent, state)."""
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    for f in fields(InterfaceState):
        x, y = getattr(a[2], f.name), getattr(b[2], f.name)
        assert x.shape == y.shape and np.array_equal(x, y), f.name


@pytest.mark.parametrize("name", sorted(LAWS))
@pytest.mark.parametrize("n", [1, 249, 600])      # 600: the parallel kernel (>= 512 points)
def test_bound_law_equals_evaluate_bitwise(name, n):
    law = LAWS[name]()
    rng = np.random.default_rng(7)
    st = history(law, n, rng)
    bound = law.bind(st, dt=0.004)
    for _ in range(3):
        g = rng.normal(scale=COH.l_Nc, size=2 * n)          # flat, as the solver passes it
        ref = law.evaluate(g.reshape(-1, 2), st, dt=0.004)
        out = bound(g)
        same(out, ref)
        assert not np.array_equal(out[2].kappa, st.kappa)    # the state did evolve
        # a strided gap is copied, as evaluate does
        g2 = np.repeat(g.reshape(-1, 2), 2, axis=0)[::2]
        same(bound(g2), law.evaluate(g.reshape(-1, 2), st, dt=0.004))
    # the outputs are fresh arrays (a solver keeps the current and the trial iterate)
    a, b = bound(g), bound(g)
    assert a[0] is not b[0] and a[2].kappa is not b[2].kappa


def test_bound_law_large_finite_gap_passes_like_evaluate():
    """A gap above the quick accept (sum g^2 > 1e199) but within GAP_LIMIT takes the full
    check and is evaluated; one above GAP_LIMIT raises evaluate's message."""
    law = LAWS["full"]()
    st = law.initial_state(3)
    g = np.array([0.0, 0.0, 0.9 * GAP_LIMIT, 0.0, -0.5 * GAP_LIMIT, 1e-4])
    same(law.bind(st)(g), law.evaluate(g.reshape(-1, 2), st))
    g[3] = 2 * GAP_LIMIT
    with pytest.raises(ValueError) as ref:
        law.evaluate(g.reshape(-1, 2), st)
    with pytest.raises(ValueError, match=re.escape(str(ref.value))):
        law.bind(st)(g)
    assert "gap[1]" in str(ref.value)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_bound_law_raises_evaluates_message_on_a_bad_gap(bad):
    law = LAWS["friction"]()
    st = law.initial_state(5)
    g = np.zeros(10)
    g[7] = bad
    with pytest.raises(ValueError) as ref:
        law.evaluate(g.reshape(-1, 2), st)
    with pytest.raises(ValueError) as got:
        law.bind(st)(g)
    assert str(got.value) == str(ref.value) and "gap[3]" in str(got.value)


def test_bound_law_checks_dt_and_shapes_like_evaluate():
    law = LAWS["rate"]()
    st = law.initial_state(4)
    g = np.zeros(8)
    for dt in (None, -1.0, "x"):
        with pytest.raises(ValueError) as ref:
            law.evaluate(g.reshape(-1, 2), st, dt=dt)
        b = law.bind(st, dt)                  # binding does not raise: each call does
        with pytest.raises(ValueError) as got:
            b(g)
        assert str(got.value) == str(ref.value)
    with pytest.raises(ValueError, match="do not match"):
        law.bind(st, 0.01)(np.zeros(10))      # 5 points for a state of 4
    with pytest.raises(ValueError, match="float64"):
        law.bind(st, 0.01)(np.zeros(8, np.float32))
    # n * dim values in another shape: evaluate's message where it has one (a transposed
    # gap would otherwise be read as 4 points with the wrong components), else the bound
    # law's (a flat gap of 7 values is no whole number of points)
    for bad in (np.zeros((2, 4)), np.zeros((8, 1)), np.zeros((4, 2, 1))):
        with pytest.raises(ValueError) as ref:
            law.evaluate(bad, st, dt=0.01)
        with pytest.raises(ValueError) as got:
            law.bind(st, 0.01)(bad)
        assert str(got.value) == str(ref.value)
    with pytest.raises(ValueError, match=r"gap of shape \(7,\) is not allowed; allowed: 8 "):
        law.bind(st, 0.01)(np.zeros(7))


def test_joint_laws_bind_equals_evaluate_bitwise():
    a, b = LAWS["full"](), LAWS["friction"]()
    jl = JointLaws([a, b], [slice(0, 7), slice(7, 20)])
    rng = np.random.default_rng(3)
    st = history(a, 20, rng)
    g = rng.normal(scale=COH.l_Nc, size=40)
    same(jl.bind(st, 0.01)(g), jl.evaluate(g.reshape(-1, 2), st, dt=0.01))


@pytest.mark.parametrize("order", ["C", "F"])          # F: no quick accept, the full pass
def test_evaluate_gap_check_at_the_limit(order):
    """evaluate's check (the quick accept g.g <= 1e199, else one pass over |g|): values up to
    GAP_LIMIT pass (also where the squares sum above 1e199), just above it raise, whatever the
    array's layout."""
    law = LAWS["cohesive"]()
    st = law.initial_state(3)
    g = np.asfortranarray(np.array([[GAP_LIMIT, 0.0], [-GAP_LIMIT, 1.0], [0.0, 0.0]]),
                          dtype=float) if order == "F" else \
        np.array([[GAP_LIMIT, 0.0], [-GAP_LIMIT, 1.0], [0.0, 0.0]])
    t = law.evaluate(g, st)[0]
    assert np.all(np.isfinite(t))
    g[2, 1] = np.nextafter(GAP_LIMIT, np.inf)
    with pytest.raises(ValueError, match=r"gap\[2\] = \[0.0, 1.0000000000000002e\+100\]"):
        law.evaluate(g, st)
