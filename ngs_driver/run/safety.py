"""The sliding safety of every joint, per step and at the static state (docs/safety.md):

    N' = -sum w t_N    effective normal force [N/m] (compression positive; uplift already out)
    T  = |sum w t_T|   shear force [N/m]
    U  = sum w p       uplift force [N/m]
    L_b = sum w over bonded points;  C = sum_bonded w c_p,
    c_p = (1 - D) tau_max (l_Nc/l_Tc) min(1, (1 - kappa)/(1 - lambda_max))   (current law)
    FS = (f max(N', 0) + C) / T      (USACE EM 1110-2-2100 eq. 3-1 with the law's f and c)

The post-earthquake check is ``run.post_earthquake``; the uplift ``run.uplift``.
"""
from __future__ import annotations

import numpy as np

from .parts import Part

__all__ = ["SlidingSafety", "SAFETY_KEYS", "FS_CRITERION", "FS_CAP", "FS_DEFINITION"]

SAFETY_KEYS = ("normal_force", "shear_force", "uplift_force", "bonded_length", "sliding_fs")
FS_CRITERION = 1.3        # post-earthquake sliding criterion (FERC guidelines ch. 3)
FS_CAP = 1e6              # FS reported when the shear force vanishes
FS_DEFINITION = ("FS = (f max(N', 0) + sum over bonded points of w c) / |T| (EM 1110-2-2100 "
                 "eq. 3-1; f, c the law's current values); docs/safety.md")


class SlidingSafety(Part):
    """Forces and sliding factor of safety of every joint (module docstring); a run part
    (``run.parts``): after each step its columns go into the history row, with the uplift
    pressure in force (``pressure()``, zero without uplift)."""

    name = "safety"

    def __init__(self, joints, pressure=None):
        self.joints = joints
        self.pressure = pressure if pressure is not None else (
            lambda: np.zeros(joints.w.size))
        self._step_keys = [(n, k, f"{n}_{k}") for n in joints.names for k in SAFETY_KEYS]
        self.static = None        # the static state's measures (``static_measures``)

    def joint_measures(self, t, state, p, scan=None) -> dict:
        """{joint: {normal_force, shear_force, uplift_force, bonded_length, cohesion_force,
        friction, sliding_fs}} from tractions t, state and pressure p. scan: the
        ``JointScan`` of (state, t) if the caller has it (bonded points, their c_p)."""
        if scan is None:
            scan = self.joints.scan(state, np.zeros_like(t), t)
        out = {}
        w = self.joints.w
        for i, (name, sl, law) in enumerate(zip(self.joints.names, self.joints.slices,
                                                self.joints.laws)):
            ws = w[sl]
            N = -float(np.dot(ws, t[sl, 0]))
            T = abs(float(np.dot(ws, t[sl, 1])))
            U = float(np.dot(ws, p[sl]))
            wb, cpb = scan.bonded(i)
            C = float(np.dot(wb, cpb))
            f = 0.0 if law.friction is None else float(law.friction.f)
            num = f * max(N, 0.0) + C
            fs = num / T if T > num / FS_CAP else FS_CAP
            out[name] = {"normal_force": N, "shear_force": T, "uplift_force": U,
                         "bonded_length": float(scan.flts[i, 3]), "cohesion_force": C,
                         "friction": f, "sliding_fs": fs}
        return out

    def step_measures(self, t, state, p, scan=None) -> dict:
        """The per-step history columns "<joint>_<SAFETY_KEYS>"."""
        m = self.joint_measures(t, state, p, scan)
        return {key: m[n][k] for n, k, key in self._step_keys}

    def after_step(self, ctx):
        ctx.row.update(self.step_measures(ctx.solver.t, ctx.state, self.pressure(), ctx.scan))

    def checkpoint(self) -> dict:
        return {"static": self.static}

    def restore(self, d):
        self.static = d["static"]

    def history_keys(self) -> list[str]:
        return [f"{n}_{k}" for n in self.joints.names for k in SAFETY_KEYS]

    def static_measures(self, solver, p) -> dict:
        """The measures of the static state (kept for the summary's slips), with each joint's
        mean slip."""
        m = self.joint_measures(solver.t, solver.state, p)
        for name, sl in zip(self.joints.names, self.joints.slices):
            ws = self.joints.w[sl]
            m[name]["slip_mean"] = float(np.dot(ws, solver.g[sl, 1]) / ws.sum())
        self.static = m
        return m

    def summary(self, H, dt) -> dict:
        """Per joint: minimum FS and when, time below 1, cumulative and residual slip."""
        out = {}
        t = H["t"]
        for name in self.joints.names:
            fs = H[f"{name}_sliding_fs"] if t.size else np.zeros(0)
            sm = H[f"{name}_slip_mean"] if t.size else np.zeros(0)
            s0 = self.static[name]["slip_mean"] if self.static else 0.0
            path = np.concatenate([[s0], sm])
            i = int(np.argmin(fs)) if fs.size else None
            out[name] = {
                "min_sliding_fs": float(fs[i]) if fs.size else None,
                "t_min_sliding_fs": float(t[i]) if fs.size else None,
                "time_fs_below_1": float(dt * np.count_nonzero(fs < 1.0)),
                "cumulative_slip": float(np.sum(np.abs(np.diff(path)))),
                "residual_slip": float(path[-1] - s0),
                "max_uplift_force": float(H[f"{name}_uplift_force"].max()) if t.size
                else None,
            }
        return out
