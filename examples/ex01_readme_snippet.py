"""The README snippet as a script: evaluate a batch of points, commit, unload.

One loading step opens 1000 points to g_N = 5e-5 m (past the peak: softening), the state is
committed, and a second step closes them to half that opening. Checked against the hand
formulas of docs/law.md §2 and §6:

* loading: F_N = (1 - D) s(lambda) sigma_max u, u = g_N/l_Nc, s = (1/u - 1)/(1 - lambda_max),
  D = (g_N/g_max)^alpha (one damage increment from a virgin point);
* unloading to g_N/2: the secant to the origin, so the traction halves exactly, and neither the
  history kappa nor the damage change (closing does not damage).

Asserts: the loading traction equals the hand formula and the unloaded one half of it, both to
1e-12 relative; no tangential traction; kappa and D unchanged by the unloading. Prints F_N
(2.610249e+06 Pa).

Run: python examples/ex01_readme_snippet.py
"""
# ---- the README snippet, verbatim (tests/test_examples.py checks that it stays so) ----
import numpy as np
from interfacelaw import CohesiveParams, ContactParams, FrictionParams, DamageParams, InterfaceLaw

coh = CohesiveParams.from_fracture_energy(sigma_max=3e6, tau_max=3e6, G_I=250.0,
                                          lambda_max=0.2, ratio_lTc_lNc=1.0)
law = InterfaceLaw(coh, contact=ContactParams("rough"), friction=FrictionParams(f=0.3),
                   damage=DamageParams(g_max=6.67e-4, alpha=2.0))
state = law.initial_state(n=1000, dim=2)             # committed history, struct of arrays
gap = np.zeros((1000, 2)); gap[:, 0] = 5e-5            # (g_N, g_T) at the end of the step [m]
traction, tangent, trial = law.evaluate(gap, state)    # tangent = d traction / d gap
state = trial                                          # commit only when the step converged
# ---- end of the snippet ----

# the hand formula of the loading step
u = 5e-5 / coh.l_Nc
D = (5e-5 / 6.67e-4) ** 2.0
F_hand = (1.0 - D) * (1.0 / u - 1.0) / (1.0 - coh.lambda_max) * coh.sigma_max * u
# 1e-12: the kernel evaluates the same closed form in a different order (a few roundings)
assert np.allclose(traction[:, 0], F_hand, rtol=1e-12, atol=0.0)
assert np.all(traction[:, 1] == 0.0) and np.all(state.dissipated > 0.0)

# unload to half the opening from the committed state: secant to the origin, no new damage
unloaded, _, trial2 = law.evaluate(gap * 0.5, state)
# 1e-12: the secant traction is the same product with u halved (a few roundings)
assert np.allclose(unloaded[:, 0], 0.5 * traction[:, 0], rtol=1e-12, atol=0.0)
assert np.array_equal(trial2.kappa, state.kappa) and np.array_equal(trial2.damage, state.damage)

print(f"F_N = {traction[0, 0]:.6e} Pa")
