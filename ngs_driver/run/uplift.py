"""Uplift: the pore pressure on the joints and the solves that use it (docs/safety.md).

Uplift enters the condensed solver as an **external load vector**

    f_U = B^T W (p e_N)          (p >= 0 the pore pressure at each joint point)

i.e. a traction p on both faces of every point pushing them apart (the virtual work of the
pressure is p dg_N). For a given p it is linear in u and leaves the solver's equations and its
Newton loop untouched. p depends on the crack state only through ``uplift.in_crack``
("zero", "full_headwater"; "unchanged" freezes the pre-earthquake p): for those, each static
solve and each time step is repeated from the committed state with the p of the crack state it
ended in until the crack state no longer changes (a fixed point over the whole step, not a lag:
the accepted step satisfies the equations with the p of its own end-of-step crack state).
Pressure profiles: USACE EM 1110-2-2100 §3-3 and FERC guidelines ch. 3 (linear, drains),
USBR (zero in the crack), ICOLD 1986 (full headwater in the crack); ``setup.uplift``.
"""
from __future__ import annotations

import numpy as np

from ..setup.uplift import pressure_profile
from ..solve.kernels import mv
from .checkpoint import SolverPart
from .joints import debonded_measures
from .parts import Part

__all__ = ["UpliftField", "Uplift"]


class UpliftField:
    """The pore pressure at the interface points (all joints) and its load vector."""

    def __init__(self, joints, rho_g, iface, names, slices):
        """joints: the ``setup.JointInput``s (uplift tables, extents, heads); rho_g: the
        water's density x gravity [N/m^3]."""
        self.names, self.slices = list(names), list(slices)
        self.B, self.w = iface.B, iface.w
        self.BT = iface.B.T.tocsr()
        given = {j.name: j for j in joints}
        self.spec = []
        for name, sl in zip(self.names, self.slices):
            j = given[name]
            xu, xd = j.x_upstream, j.x_downstream
            self.spec.append((j.uplift, iface.x[sl] - xu, xd - xu, rho_g * j.head,
                              rho_g * j.tail))
        self.active = any(s[0].model != "none" for s in self.spec)
        self.state_dependent = any(s[0].model != "none" and s[0].in_crack != "unchanged"
                                   for s in self.spec)
        self.p_pre = None              # frozen pre-earthquake pressure ("unchanged")
        self.p = np.zeros(iface.w.size)

    def pressure(self, state) -> np.ndarray:
        """p [Pa] at every point for the crack state ``state`` (module docstring)."""
        p = np.zeros(self.w.size)
        deb = None
        for (up, s, L, ph, pt), sl in zip(self.spec, self.slices):
            if up.model == "none":
                continue
            if deb is None:
                deb = np.asarray(state.debonded, bool)
            if up.in_crack == "unchanged" and self.p_pre is not None:
                p[sl] = self.p_pre[sl]
            elif up.in_crack == "zero":
                p[sl] = np.where(deb[sl], 0.0, pressure_profile(s, L, ph, pt, up))
            else:      # full_headwater; "unchanged" before the shaking: the cracked drawing
                a = debonded_measures(deb[sl], self.w[sl])[1]
                p[sl] = pressure_profile(s, L, ph, pt, up, crack=a)
        return p

    def load(self, p) -> np.ndarray:
        """B^T W (p e_N): the free-DOF load of the pressure p."""
        gv = np.zeros(2 * self.w.size)
        gv[0::2] = self.w * p
        return mv(self.BT, gv)          # bitwise scipy's BT @ gv, without its dispatch

    def set_operator(self, B):
        """The gap operator of a joint paired anew (finite sliding, run/pairing.py): the
        pressure acts on the faces that are now in contact."""
        self.B = B
        self.BT = B.T.tocsr()


class Uplift(Part):
    """The uplift of a run: the field, the pre-earthquake pressure ``p_static``, the pressure
    in force ``p``, and the solves with the pressure of the crack state they end in."""

    MAX_FIXED_POINT = 20

    def __init__(self, inputs, iface, joints):
        """inputs: the run's ``setup.RunInputs`` (its joints and rho_g)."""
        self.field = UpliftField(inputs.joints, inputs.rho_g, iface, joints.names,
                                 joints.slices)
        self.active = self.field.active
        self.state_dependent = self.field.state_dependent
        self.p_static = np.zeros(joints.w.size)
        self.fixed_point_iterations = 0     # extra solves spent on the p(crack) fixed point
        self.fixed_point_unconverged = 0    # steps accepted at the iteration cap

    @property
    def p(self) -> np.ndarray:
        """The pressure in force (that of the last accepted solve)."""
        return self.field.p

    @p.setter
    def p(self, value):
        self.field.p = value

    def pressure(self, state) -> np.ndarray:
        return self.field.pressure(state)

    def load(self, p) -> np.ndarray:
        return self.field.load(p)

    def solve(self, solver, call, f_base, p0, dependent):
        """``call(f)`` (solver.static or solver.step) with f = f_base + f_U(p), p consistent
        with the crack state the solve ends in. Returns (report, p, f)."""
        p = p0
        if not dependent:
            f = f_base + self.field.load(p) if self.active else f_base
            return call(f), p, f
        saved = SolverPart(solver)
        snap = saved.checkpoint()
        for k in range(self.MAX_FIXED_POINT):
            f = f_base + self.field.load(p)
            rep = call(f)
            p_new = self.field.pressure(solver.state)
            if np.array_equal(p_new, p):
                return rep, p, f
            self.fixed_point_iterations += 1
            if k == self.MAX_FIXED_POINT - 1:
                break
            saved.restore(snap)
            p = p_new
        self.fixed_point_unconverged += 1
        return rep, p, f

    def solve_static(self, solver, f_base):
        """The pre-earthquake static solve: before the shaking every drawing depends on the
        static crack (cracked-base rule), so any active uplift is solved to its fixed point.
        Returns (report, p, f)."""
        p0 = self.field.pressure(solver.state)
        return self.solve(solver, solver.static, f_base, p0, self.active)

    def freeze(self, p):
        """The pre-earthquake pressure: kept as ``p_static`` ("unchanged" keeps it in the
        crack) and in force."""
        self.p_static = p.copy()
        self.field.p_pre = p.copy()
        self.field.p = p.copy()

    def step(self, solver, f_k, split: int = 0):
        """One time step; f_k already holds the static uplift. Returns (report, load used).
        split: sub-steps of at most dt / 2^split (``JointSolver.step``)."""
        if not self.state_dependent:
            return solver.step(f_k, split), f_k
        f_base = f_k - self.field.load(self.p_static)
        rep, p, f = self.solve(solver, lambda f: solver.step(f, split), f_base, self.field.p,
                               True)
        self.field.p = p
        return rep, f

    name = "uplift"           # a run part (run.parts): its step is in the solve (``step``)

    def checkpoint(self) -> dict:
        return {"p_static": self.p_static.copy(), "p": np.array(self.field.p, copy=True),
                "fixed_point_iterations": int(self.fixed_point_iterations),
                "fixed_point_unconverged": int(self.fixed_point_unconverged)}

    def restore(self, d):
        self.p_static = np.array(d["p_static"])
        self.field.p_pre = self.p_static.copy()
        self.field.p = np.array(d["p"])
        self.fixed_point_iterations = int(d["fixed_point_iterations"])
        self.fixed_point_unconverged = int(d["fixed_point_unconverged"])
