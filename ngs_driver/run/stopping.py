"""When a run stops before the end of its record: the whole base debonded and sliding past
``time.stop_slip`` (beyond it the small-displacement kinematics of the joints no longer
hold). A rule is an object with ``check(k, t, measures) -> dict | None`` (None: go on; else
the ``stopped`` entry of summary.json: reason, t, step)."""
from __future__ import annotations

__all__ = ["SlidingStop"]


class SlidingStop:
    def __init__(self, scene, joints):
        self.limit = scene.time.stop_slip
        base = joints.slices[0]
        self.n_base = base.stop - base.start

    def check(self, k, t, jm) -> dict | None:
        """jm: the step's joint measures (``Joints.measures``)."""
        if self.limit > 0 and jm["base_n_debonded"] == self.n_base \
                and abs(jm["base_slip_mean"]) > self.limit:
            return {"reason": "failure by sliding: the whole base is debonded and its mean slip "
                              f"{abs(jm['base_slip_mean']):.3g} m exceeds time.stop_slip = "
                              f"{self.limit:g} m (small-displacement kinematics no longer hold)",
                    "t": float(t), "step": k}
        return None
