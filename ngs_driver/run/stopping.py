"""When a run stops: the collapse rule (docs/sliding.md).

A run goes to the end of its record unless a joint collapses:

* **unbounded sliding**: the joint is cracked over its whole length, it slides (its mean
  slip changes faster than ``SLIDING_RATE``), and friction alone can no longer hold the static
  loads of the cracked state: FS_static = f max(N_s, 0) / |T_s| < 1, with N_s, T_s the static
  loads (gravity, hydrostatic, the current uplift, tailwater) resolved on the blocks above the
  joint and f the joint's current friction (EM 1110-2-2100 eq. 3-1 without cohesion, the
  post-earthquake check applied while it slides). Nothing then brings the block to rest:
  without the earthquake it accelerates down the slope of its static loads. (A joint with a
  bonded ligament left is not collapsing yet: the ligament either holds or debonds, and then
  the rule applies);
* **a kinematic limit**: |slip| > ``time.max_slip`` or |rotation of the block above| >
  ``time.max_rotation`` (from the static state), beyond which the small-rotation kinematics
  and the user's interest end.

``CollapseRule.check`` returns None or the ``collapse`` entry of summary.json: joint, time,
step, reason (and the measure that triggered it).
"""
from __future__ import annotations

import numpy as np

__all__ = ["CollapseRule", "SLIDING_RATE"]

SLIDING_RATE = 1e-3     # m/s: a joint whose mean slip changes faster than this is sliding


class CollapseRule:
    def __init__(self, model, joints, max_slip: float, max_rotation: float):
        from ..fe.pairing import upper_columns

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
        self._prev = None

    def static_fs(self, f_static, joints, scan) -> list:
        """FS_static of every joint for the static load vector ``f_static`` (with the current
        uplift) and the step's ``JointScan`` (bonded points and their cohesive strength)."""
        out = []
        for i, (mx, my) in enumerate(self.masks):
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
        for i, n in enumerate(self.names):
            if abs(slip[i]) > self.max_slip:
                return {"joint": n, "time": float(t), "step": int(k),
                        "reason": f"the slip of joint {n!r}, {slip[i]:.4g} m, passed "
                                  f"time.max_slip = {self.max_slip:g} m",
                        "measure": "slip", "value": float(slip[i])}
            if abs(rot[i]) > self.max_rotation:
                return {"joint": n, "time": float(t), "step": int(k),
                        "reason": f"the rotation of the block above joint {n!r}, "
                                  f"{rot[i]:.4g} rad, passed time.max_rotation = "
                                  f"{self.max_rotation:g} rad",
                        "measure": "rotation", "value": float(rot[i])}
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
                return {"joint": n, "time": float(t), "step": int(k),
                        "reason": f"joint {n!r} is cracked over its length and slides "
                                  f"({rate[i]:+.3g} m/s), and friction alone cannot hold the "
                                  f"static loads of its cracked state: FS_static = "
                                  f"{fs[i]:.3f} < 1 (unbounded sliding)",
                        "measure": "static_fs", "value": float(fs[i])}
        return None

    def state(self) -> dict:
        return {"collapse_prev_slip": np.zeros(0) if self._prev is None else self._prev}

    def restore(self, arrs):
        p = arrs.get("collapse_prev_slip") if hasattr(arrs, "get") else None
        if p is not None and np.size(p):
            self._prev = np.array(p, dtype=np.float64)
