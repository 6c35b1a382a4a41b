"""An S-N-like curve from single-point cycles (interfacelaw.drivers), in a few lines.

Gap-controlled opening cycles 0 -> A -> 0 below the peak (A <= lambda_max l_Nc: no softening),
cyclic damage of the paper's Eq. 7 with alpha = 2, beta = 0, F_th = 0. Each of the m loading
increments of a cycle adds (A / (m g_max))^alpha, so a cycle adds A^2 / (m g_max^2) and the
cycles to failure follow N_f ~ m (g_max / A)^2: a straight S-N line of slope -alpha in log-log
(and, for alpha != 1, proportional to m: the step-size dependence of docs/law.md §6.1).

Asserts: the cycles to failure of the 5 amplitudes equal the count by hand exactly (prints
[472, 336, 252, 189, 139]), and the log-log slope is -alpha within 0.02 (prints -1.995).

Run: python examples/ex04_sn_curve.py
"""
import math

import numpy as np

from interfacelaw import CohesiveParams, DamageParams, InterfaceLaw, drivers

coh = CohesiveParams.from_fracture_energy(sigma_max=3e6, tau_max=3e6, G_I=250.0,
                                          lambda_max=0.2)
g_max, alpha, m = coh.l_Nc, 2.0, 5                       # m loading increments per cycle
law = InterfaceLaw(coh, damage=DamageParams(g_max=g_max, alpha=alpha))

A = coh.l_Nc * np.array([0.103, 0.122, 0.141, 0.163, 0.19])   # amplitudes: a batch of 5 points
h = drivers.constant_amplitude_cycles(law, A, R=0.0, n_cycles=480, n_per_cycle=2 * m)
N_f = drivers.cycles_to_failure(h)

# the count by hand: the k-th damaging increment, k = ceil(1 / (A/(m g_max))^alpha), fails the
# point in cycle ceil(k / m) (amplitudes chosen away from ties, so rounding cannot shift k)
N_hand = [math.ceil(math.ceil((m * g_max / a) ** alpha) / m) for a in A]
assert list(N_f) == N_hand, (N_f, N_hand)

slope = np.polyfit(np.log(A), np.log(N_f), 1)[0]
print(f"N_f = {N_f.astype(int).tolist()} cycles; S-N slope d ln N_f / d ln A = {slope:.3f}")
# -alpha up to the rounding of N_f to whole cycles (at most 1 in 120: < 0.02 on the slope)
assert abs(slope + alpha) < 0.02
