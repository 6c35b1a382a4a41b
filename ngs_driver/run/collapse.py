"""When a run stops: collapse, or the model's range left. The rule, its sources and its
reasons: docs/run.md §4 (written there once).

A collapse is unbounded sliding (a joint cracked over its whole length slides faster than
``SLIDING_RATE`` and FS_static = f max(N_s, 0) / |T_s| < 1 on the blocks above it), sliding
off (a lift joint's mean slip reaches its length) or, with ``solver.kinematics =
"finite_rotation"``, toppling (run/rotation.py, a part of its own listed before this rule);
each collapse entry names its ``mode`` (``COLLAPSE_MODES``). |rotation| >
``time.max_rotation`` (at most ``MAX_ROTATION_SUPPORTED`` with the small-rotation kinematics,
``MAX_ROTATION_FINITE`` with the finite-rotation ones) or |slip| > ``time.max_slip`` is the
verdict undetermined. ``CollapseRule.check`` returns None or the stop entry: joint, time,
step, reason, the measure that triggered it and ``verdict`` ("collapse" or "undetermined";
"range" for the latter).
"""
from __future__ import annotations

import numpy as np

from ..fe.pairing import upper_columns
from ..scene import MAX_ROTATION_FINITE, MAX_ROTATION_SUPPORTED
from .parts import Part

__all__ = ["CollapseRule", "SLIDING_RATE", "MAX_ROTATION_SUPPORTED", "MAX_ROTATION_FINITE",
           "VERDICTS", "COLLAPSE_MODES"]

SLIDING_RATE = 1e-3     # m/s: a joint whose mean slip changes faster than this is sliding
# the bounds of time.max_rotation (scene.py checks them, docs/solver.md §11): the
# small-rotation kinematics' MAX_ROTATION_SUPPORTED (a rigid rotation theta of the linearised
# kinematics stretches the block by theta^2 / 2, 5e-3 at 0.1 rad: ~150 MPa of spurious stress
# at E = 31 GPa, 50 x concrete's tensile strength) and the finite-rotation kinematics'
# MAX_ROTATION_FINITE
# summary.json "verdict": the record's end reached, a physical collapse, or the model's range
# left (kinematic limits): nothing can be said about the dam past it
VERDICTS = ("no_collapse", "collapse", "undetermined")
# a collapse entry's "mode": the block above the joint toppled (run/rotation.py, the
# finite-rotation kinematics), slid off the face below, or slides with friction unable to
# hold the static loads of its cracked state
COLLAPSE_MODES = ("toppling", "sliding off", "friction unable to hold the static loads")



def _out_of_range(joint, t, k, measure, value, model_range, what, limit) -> dict:
    """The entry of a run that left the model's range (verdict undetermined, not a collapse)."""
    return {"joint": joint, "time": float(t), "step": int(k), "verdict": "undetermined",
            "range": model_range,
            "reason": f"{what}, left the model's range ({limit}): the verdict past it is "
                      f"undetermined, not a collapse",
            "measure": measure, "value": float(value)}

class CollapseRule(Part):
    """The collapse rule as a run part (``run.parts``): after each step it sets the step's
    ``stop`` when a joint collapsed or left the model's range (when no part set one before:
    the finite rotations' toppling)."""

    name = "collapse"
    kinematics = "small"          # solver.kinematics: names the range left by a rotation

    def __init__(self, model, joints, max_slip: float, max_rotation: float,
                 kinematics: str = "small"):
        self.joints = joints
        self.kinematics = kinematics
        self.names = list(joints.names)
        self.max_slip, self.max_rotation = float(max_slip), float(max_rotation)
        blocks = [r for r in model.regions if r != "rock"]
        xdof = np.abs(model.r_x) > 0.5
        ydof = np.abs(model.r_y) > 0.5
        self.masks = []
        for k in range(len(self.names)):      # joint k carries the blocks k, k+1, ... (bottom up)
            above = np.zeros(model.nfree, bool)
            for b in blocks[k:]:
                above |= upper_columns(model, b)
            self.masks.append((above & xdof, above & ydof))
        # the masks' DOFs as index arrays (``static_fs``: the same entries gathered in the
        # same order as the boolean masks, so the same sums, without the masks' scans)
        self.dofs = [(np.flatnonzero(mx), np.flatnonzero(my)) for mx, my in self.masks]
        self._prev = None
        # each joint's length (the sum of its integration weights): sliding off
        self.lengths = [float(np.sum(joints.w[sl])) for sl in joints.slices]

    def static_fs(self, f_static, joints, scan) -> list:
        """FS_static of every joint for the static load vector ``f_static`` (with the current
        uplift) and the step's ``JointScan`` (bonded points and their cohesive strength)."""
        out = []
        for i, (mx, my) in enumerate(self.dofs):
            T = float(np.sum(f_static[mx]))
            N = -float(np.sum(f_static[my]))
            law = joints.laws[i]
            f = 0.0 if law.friction is None else float(law.friction.f)
            wb, cpb = scan.bonded(i)
            C = float(np.dot(wb, cpb))
            num = f * max(N, 0.0) + C
            out.append(num / abs(T) if abs(T) > 1e-12 * max(num, 1.0) else np.inf)
        return out

    def check(self, k, t, dt, measures, static_loads, joints, scan):
        """The ``collapse`` entry if a joint collapsed at step k (time t), else None.
        measures: the step's joint measures ("<joint>_slip", "<joint>_rotation");
        static_loads: a function giving the static loads now (called only when a cracked joint
        slides)."""
        slip = np.array([measures[f"{n}_slip"] for n in self.names])
        rot = np.array([measures[f"{n}_rotation"] for n in self.names])
        prev, self._prev = self._prev, slip
        kin = "small-rotation" if self.kinematics == "small" else "finite-rotation"
        for i, n in enumerate(self.names):
            if i > 0 and abs(slip[i]) >= self.lengths[i]:
                return {"joint": n, "time": float(t), "step": int(k), "verdict": "collapse",
                        "mode": "sliding off",
                        "reason": f"the block above joint {n!r} slid off: its slip "
                                  f"{slip[i]:.4g} m reached the joint's length "
                                  f"{self.lengths[i]:.4g} m (sliding off)",
                        "measure": "slip", "value": float(slip[i])}
            if abs(rot[i]) > self.max_rotation:
                return _out_of_range(
                    n, t, k, "rotation", rot[i],
                    f"{kin} kinematics: |rotation| <= time.max_rotation "
                    f"= {self.max_rotation:g} rad (docs/solver.md §11)",
                    f"the rotation of the block above joint {n!r}, {rot[i]:.4g} rad",
                    f"time.max_rotation = {self.max_rotation:g} rad, the {kin} kinematics")
            if abs(slip[i]) > self.max_slip:
                return _out_of_range(
                    n, t, k, "slip", slip[i],
                    f"small-displacement sliding: |slip| <= time.max_slip = "
                    f"{self.max_slip:g} m",
                    f"the slip of joint {n!r}, {slip[i]:.4g} m",
                    f"time.max_slip = {self.max_slip:g} m")
        if prev is None:
            return None
        rate = (slip - prev) / dt
        sliding = np.abs(rate) > SLIDING_RATE
        if not sliding.any():
            return None
        cracked = scan.ints[:, 1] == 0             # no bonded point left
        if not (sliding & cracked).any():
            return None
        fs = self.static_fs(static_loads(), joints, scan)
        for i, n in enumerate(self.names):
            if sliding[i] and cracked[i] and fs[i] < 1.0:
                return {"joint": n, "time": float(t), "step": int(k), "verdict": "collapse",
                        "mode": "friction unable to hold the static loads",
                        "reason": f"joint {n!r} is cracked over its length and slides "
                                  f"({rate[i]:+.3g} m/s), and friction alone cannot hold the "
                                  f"static loads of its cracked state: FS_static = "
                                  f"{fs[i]:.3f} < 1 (unbounded sliding)",
                        "measure": "static_fs", "value": float(fs[i])}
        return None

    def after_step(self, ctx):
        if ctx.stop is None:
            ctx.stop = self.check(ctx.k, ctx.t, ctx.dt, ctx.measures, ctx.static_loads,
                                  self.joints, ctx.scan)

    def checkpoint(self) -> dict:
        return {"prev_slip": np.zeros(0) if self._prev is None else self._prev.copy()}

    def restore(self, d):
        p = np.array(d["prev_slip"], dtype=np.float64)
        self._prev = p if p.size else None
