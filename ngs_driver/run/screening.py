"""Linear screening of the dam body during a run (USACE EM 1110-2-6053; docs/safety.md):
per dam element (P1 triangles: constant stress, ``fe.stress``) the demand-capacity ratio
DCR = max principal stress / tensile strength at the static state and every step, its maximum
over time and the cumulative inelastic duration (time with DCR > 1)."""
from __future__ import annotations

import numpy as np

from ..fe.stress import element_stress
from .parts import Part

__all__ = ["Screening"]


class Screening(Part):
    name = "screening"

    def __init__(self, tensile_strength: float, model):
        self.ft = float(tensile_strength)
        es = element_stress(model)
        self.S, self.x, self.y, self.triangles = es.S, es.x, es.y, es.triangles
        n = self.x.size
        self.max_dcr = np.full(n, -np.inf)
        self.t_max = np.zeros(n)
        self.duration = np.zeros(n)
        self.static_dcr = None

    def dcr(self, u) -> np.ndarray:
        sxx, syy, sxy = (self.S[c] @ u for c in ("xx", "yy", "xy"))
        s1 = 0.5 * (sxx + syy) + np.sqrt(0.25 * (sxx - syy) ** 2 + sxy ** 2)
        return s1 / self.ft

    def static(self, u):
        """The static state (t = 0) enters the maximum, not the duration (it is not time)."""
        self.static_dcr = self.dcr(u)
        self.max_dcr = self.static_dcr.copy()
        self.t_max = np.zeros_like(self.max_dcr)

    def update(self, u, t, dt):
        d = self.dcr(u)
        new = d > self.max_dcr
        self.max_dcr[new] = d[new]
        self.t_max[new] = t
        self.duration += dt * (d > 1.0)

    def summary(self) -> dict:
        i = int(np.argmax(self.duration)) if self.duration.any() else int(np.argmax(self.max_dcr))
        j = int(np.argmax(self.max_dcr))
        return {"method": "USACE EM 1110-2-6053 linear screening: DCR = max principal stress "
                          "/ tensile strength per dam element (P1: constant stress)",
                "tensile_strength": self.ft, "elements": int(self.x.size),
                "static_max_dcr": float(self.static_dcr.max()) if self.static_dcr is not None
                else None,
                "max_dcr": float(self.max_dcr[j]), "max_dcr_at": [float(self.x[j]),
                                                                  float(self.y[j])],
                "t_max_dcr": float(self.t_max[j]),
                "elements_dcr_over_1": int(np.count_nonzero(self.max_dcr > 1.0)),
                "worst_element": {"x": float(self.x[i]), "y": float(self.y[i]),
                                  "max_dcr": float(self.max_dcr[i]),
                                  "cumulative_inelastic_duration": float(self.duration[i])}}

    def after_step(self, ctx):
        self.update(ctx.solver.u, ctx.solver.time, ctx.solver.dt)

    def checkpoint(self) -> dict:
        return {"max": self.max_dcr.copy(), "t_max": self.t_max.copy(),
                "duration": self.duration.copy(),
                "static": np.zeros(0) if self.static_dcr is None else self.static_dcr.copy()}

    def restore(self, d):
        self.max_dcr = np.array(d["max"])
        self.t_max = np.array(d["t_max"])
        self.duration = np.array(d["duration"])
        st = np.array(d["static"])
        self.static_dcr = st if st.size else None
