"""The reservoir during a run: the fluid stepper coupled to the solver, the hydrodynamic
pressure on the upstream face sampled after every step, and their checkpoints. The files are
written by ``post.reservoir``.

``ReservoirRun.create(model, times, ax, ay, total)`` returns None when the model has no
hydrodynamic reservoir.  For compressible acoustic water it builds the ``FluidStepper``
(solve/fluid.py), the coupled field (``field``) that the run gives to the solver's constructor:
the pressure then lives in the solver's steps; for incompressible water and Westergaard the
pressure is recovered from the accelerations. The run sets ``solver`` once the solver is
built.
"""
from __future__ import annotations

import numpy as np

from ..fe.acoustic import PressureProbe, face_chain
from ..solve.fluid import FluidStepper, GroundPressureLoad
from ..solve.kernels import mv
from .parts import Part

__all__ = ["ReservoirRun", "FRACTIONS"]

FRACTIONS = (0.0, 0.25, 0.5, 0.75, 0.9)      # elevations / level at which p is sampled


class ReservoirRun(Part):
    """The reservoir of a run, a run part (``run.parts``): after each step the face
    pressures and the force are sampled; its checkpoint is the sampled history (the water's
    own state is the solver's: ``run.checkpoint.SolverPart``)."""

    name = "reservoir"

    def __init__(self, model, times, ax, ay, total: bool):
        self.model = model
        self.solver = None                       # set by the run once the solver is built
        self.res = model.reservoir
        self.times, self.ax, self.ay = times, ax, ay
        self.rows = {"t": [], "Fx": [], "Fy": []}
        self.stepper = None
        self.field = None                        # the coupled field given to the solver
        self.ac = self.res.acoustic
        self.level = self.res.level
        self.ys = [f * self.level for f in FRACTIONS]
        for y in self.ys:
            self.rows[f"p_y{y:.2f}"] = []
        self._cols = [self.rows[f"p_y{y:.2f}"] for y in self.ys]     # the stations' lists
        # absorbing rock boundaries (total): the run is in total displacements (the record
        # enters as free-field forces), so the face's own motion is already in u'' and only
        # the bottom / a rigid far end are driven by a_g
        self.total = bool(total)
        self.g = None
        if self.ac is not None:
            self.g = ((self.ac.W.b_x, self.ac.W.b_y) if self.total
                      else (self.ac.g_x, self.ac.g_y))
        if self.ac is not None and not self.ac.incompressible:
            self.stepper = self.field = FluidStepper(self.ac, self.ground, self.g)
        elif self.ac is not None and self.total:
            self.field = GroundPressureLoad(self.ac, self.ground)
        self._pts = self.ac.face_stations(FRACTIONS) if self.ac is not None else None
        self._mips = None
        self._probe = None

    @classmethod
    def create(cls, model, times, ax, ay, total: bool):
        """None when the model has no hydrodynamic reservoir."""
        if getattr(model, "reservoir", None) is None:
            return None
        return cls(model, times, ax, ay, total)

    def after_step(self, ctx):
        self.sample(ctx.k, ctx.t)

    def checkpoint(self) -> dict:
        """The sampled pressure history (the water state is in the solver's part)."""
        return {f"rows_{key}": np.asarray(v) for key, v in self.rows.items()}

    def restore(self, d):
        for key in self.rows:
            self.rows[key] = list(d[f"rows_{key}"])
        self._cols = [self.rows[f"p_y{y:.2f}"] for y in self.ys]

    def ground(self, t):
        """Ground acceleration at time t (linear between the record samples, as the loads)."""
        return (float(np.interp(t, self.times, self.ax)), float(np.interp(t, self.times, self.ay)))

    # ------------------------------------------------------------------------------------
    def pressure(self):
        """Hydrodynamic pressure (free water DOFs) of the committed state, or None."""
        s = self.solver
        if self.stepper is not None:
            return self.stepper.p
        if self.ac is not None:
            agx, agy = self.ground(s.time)
            return self.ac.pressure_incompressible(s.a, agx, agy, self.g)
        return None

    def sample(self, k, t):
        """After step k (time t): the face pressures and the force."""
        s = self.solver
        self.rows["t"].append(float(t))
        p = self.pressure()
        if p is not None:
            fx, fy = self.ac.face_force(p)
            vals = self._station_values(p)
        else:                                   # Westergaard: p = -m(y) a_n,total on the face
            agx, agy = self.ground(s.time)
            m = self.model
            acc = s.a if self.total else s.a + m.r_x * agx + m.r_y * agy
            f = -(self.res.added_mass @ acc)
            fx, fy = float(m.r_x @ f), float(m.r_y @ f)
            H = self.level
            vals = [-7.0 / 8.0 * self.res.water_density * np.sqrt(H * (H - y)) * ax_
                    for y, ax_ in zip(self.ys, self._face_ax(acc))]
        self.rows["Fx"].append(fx)
        self.rows["Fy"].append(fy)
        for col, v in zip(self._cols, vals):
            col.append(float(v))

    def _station_values(self, p):
        if self._probe is None:
            # stations on the face: evaluate 1 mm inside the water (the point search may return
            # the dam's element on the face itself, where the water field is not defined)
            pts = [(x - 1e-3, max(y, 1e-3)) for x, y in self._pts]
            self._probe = PressureProbe(self.ac.W, pts)
        # bitwise the probe's E @ real(p) (stored order), without scipy's per-call dispatch
        return list(mv(self._probe.E, np.ascontiguousarray(np.real(p), dtype=np.float64)))

    def _face_ax(self, acc):
        """x-acceleration of the dam at the face stations (elevations self.ys)."""
        m = self.model
        if self._mips is None:
            ch = face_chain(m.mesh, self.level)
            xs = np.interp(self.ys, [c[2] for c in ch], [c[1] for c in ch])
            self._mips = [m.mesh(float(x) + 1e-3, float(min(y, self.level - 1e-3)))
                          for x, y in zip(xs, self.ys)]
        cf = m.displacement_cf(m.to_gridfunction(acc))
        return [float(cf(mp)[0]) for mp in self._mips]

    def summary(self) -> dict:
        Fx = np.asarray(self.rows["Fx"])
        d = dict(self.res.info)
        d.update({"kind": self.res.kind, "max_abs_force_x_N_per_m":
                  float(np.abs(Fx).max()) if Fx.size else None,
                  "files": ["reservoir_pressure.csv", "reservoir_pressure.png"]})
        return d
