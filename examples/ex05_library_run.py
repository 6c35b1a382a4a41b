"""A dam run driven as a library: ``prepare``, the static state, the step loop, ``finish`` --
with an outputs object of one's own that records the base joint's resultant forces after every
step (the standard files are not written: ``ngs_driver.post.outputs.RunOutputs`` would).

Checked against statics by hand (docs/architecture.md shows the same loop): at the static state
the base joint carries the dam's weight W = rho g A (A: the profile's area by the shoelace
formula) as its normal force, and the reservoir's hydrostatic thrust P = rho_w g H^2 / 2 (the
Koyna upstream face is vertical, so the water pushes horizontally only) as its shear force;
the scene has no uplift. During the record the forces change by the inertia of the dam and the
water, and the recorded rows are one per step.

Asserts: verdict no_collapse with one recorded row per step (50), and the static normal and
shear forces of the base equal W and P to 1e-6 relative (prints N_static_over_W).

Run: python examples/ex05_library_run.py
"""
import tempfile

import numpy as np

from ngs_driver.run import Outputs, prepare
from ngs_driver.scene import load_scene


def base_forces(analysis):
    """(N, T) on the base joint [N/m]: N = -sum w t_N (compression positive), T = sum w t_T."""
    joints, solver = analysis.joints, analysis.solver
    sl = joints.slices[0]
    w, tr = joints.w[sl], solver.t[sl]
    return -float(w @ tr[:, 0]), float(w @ tr[:, 1])


class BaseForces(Outputs):
    """Records (t, N, T) of the base joint after every committed step; writes no file."""

    def __init__(self):
        self.rows = []

    def step(self, analysis, k, t):
        self.rows.append((t, *base_forces(analysis)))


scene = load_scene("koyna_smoke")          # coarse Koyna, 0.1 s of the strong phase
rec = BaseForces()
with tempfile.TemporaryDirectory() as out:
    an = prepare(scene, out, outputs=rec, progress=False, log=lambda *a, **k: None)
    try:
        an.static()
        N0, T0 = base_forces(an)
        try:
            while an.step():
                pass
        finally:
            an.close()
        summary = an.finish()
    finally:
        an.release()

# statics by hand
xy = np.asarray(scene.geometry.profile, float)
x, y = xy[:, 0], xy[:, 1]
area = 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
W = scene.materials.dam.rho * scene.loads.gravity * area
H = scene.reservoir.level
P = scene.loads.water_density * scene.loads.gravity * H ** 2 / 2
# one row per step of the record (the whole record ran: no stop rule fired)
assert summary["verdict"] == "no_collapse"
assert len(rec.rows) == an.k == round(scene.time.duration / scene.time.dt)
# 1e-6: the static solve's residual tolerance (1e-8 relative) and the Gauss sums, with margin
assert abs(N0 - W) < 1e-6 * W, (N0, W)
assert abs(abs(T0) - P) < 1e-6 * P, (T0, P)
peak = max(abs(r[2]) for r in rec.rows)
print(f"steps = {len(rec.rows)}  W = {W:.6e}  N_static = {N0:.6e}  P = {P:.6e}  "
      f"T_static = {abs(T0):.6e}  T_peak = {peak:.6e}")
print(f"N_static_over_W = {N0 / W:.9f}")
