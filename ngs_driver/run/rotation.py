"""Finite rotations of the blocks above the joints (``solver.kinematics = "finite_rotation"``).

The bulk stays linear (small strains in the block's frame); the rigid rotation theta of the
block above each joint, relative to the face below, enters where the linearisation is wrong
at large angles (docs/solver.md §11; Housner 1963, BSSA 53(2):403; Makris & Konstantinidis
2003, EESD 32:265, for the exact rocking equation):

* **the joint's gap.** B u holds the linearised rotation theta z x r of a point of the upper
  face (r from the pivot); the exact rigid rotation moves it by (R(theta) - I) r. Their
  difference d is added to the gap through the solver's offset (g = B u + g_offset,
  ``JointSolver.set_offset``: B and the factorisations are kept);
* **the body forces' moment (P-Delta).** Linear statics takes the moment of gravity about the
  pivot with the reference lever arms, M_lin = f . phi_c (phi_c the unit rotation about the
  pivot c); the exact moment of the rotated block is cos(theta) M_lin - sin(theta) Q, with
  Q = f . psi_c (psi_c = r, the lever arms). The same holds for the ground's inertial loads
  -M (r_x a_x + r_y a_y) of the relative formulation (a uniform body force, as gravity): f is
  their sum at the step's end. The difference dM is applied as a
  self-equilibrated load on the blocks above the joint, mass-proportional:
  f = dM M phi_m / (phi_m^T M phi_m), phi_m the rotation about their centre of mass (zero net
  force, moment dM about any point, its virtual work on a rigid rotation is dM). The
  hydrostatic, tailwater and uplift loads stay in the reference configuration (the water's
  mesh and its face loads do not follow the dam either, §11); they enter the toppling check
  with their reference moments.

theta is the w-weighted least-squares slope of the linear normal gap (B u)_N along the joint
(the rotation of the upper face relative to the lower one: a bonded joint's is its elastic
opening's, ~1e-6 rad, and its corrections vanish as theta^2). The pivot is the joint's end on
the compressed side: its upstream end (smallest x) for theta > 0 (counter-clockwise, the
downstream end lifts), its downstream end for theta < 0; d and dM are O(theta^2) and
continuous through theta = 0 where the pivot changes sides. The joints' corrections add up
(the base's rotation moves the blocks above the neck too; the cross terms theta_base
theta_neck are left out). Both are formed once per step from theta predicted at the step's
end from the committed u, v, a (theta_n + h theta'_n + h^2/2 theta''_n) and held through the
step's Newton iterations (the dt study of verification/rocking.py shows the lag).

As a run part (``run.parts``, listed just before the collapse rule): ``before_step`` adds the
P-Delta load to the step's load and sets the gap offset (the energy budget's gap is rebased on
it: the offset books no work), ``after_step`` sets the run's stop on toppling (when no part
set one yet), and its checkpoint holds the solver's gap offset, which it changes every step:
on resume it is put back after the pairing's (which restores the offset of its last pairing).

**The reduced bulk** (``solver.bulk = "reduced"``, fe/reduction.py): the rigid fields phi_c
and phi_m lie in the span of its basis (a block's interior is the static extension of its
boundary), so they are its ``field_rows`` and every sum of a load with them is the full bulk's
(Phi^T f . q = f . Phi q); the lever-arm field psi_c does not, so M_lin and Q (of gravity and of
the unit ground loads M r) and the centre of mass are summed on the full free DOFs with the full
model's M, f_gravity, r_x, r_y (``model.full_bulk()``), and the P-Delta shape is the reduced
load Phi^T M phi_m / (phi_m^T M phi_m). The corrections are then the full bulk's for the same
rotation: the gap's points, B and theta are the same (B touches boundary DOFs only).

**Toppling** (``toppled``, the part's ``after_step``): the block above a joint topples when the
exact moment of the static loads about its pivot turns it further (sign(theta) M_s(theta) > 0:
its weight's resultant passed the end of the joint, theta past atan(b/h) for a rigid rectangle
on a rigid base). The run ends with verdict collapse, mode "toppling", the joint, the time and
the toppling angle of the static loads (where M_s(theta) = 0).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..fe.blocks import linear_fields
from .parts import Part

__all__ = ["FiniteRotation"]


class FiniteRotation(Part):
    """The finite-rotation corrections of every joint of a run, a run part: ``before_step``
    (the gap's offset and the P-Delta load of the step: ``step_load``), ``after_step`` (the
    toppling check: ``toppled``), ``checkpoint()`` / ``restore(d)``. energy: the run's
    ``EnergyBudget`` (its gap is rebased on the offset), or None."""

    name = "rotation"

    def __init__(self, model, joints, solver, Mrx, Mry, energy=None):
        self.solver, self.energy = solver, energy
        iface = model.interface
        self.names = list(joints.names)
        self.slices = list(joints.slices)
        self.npts = iface.npts
        self.xp = np.asarray(iface.x, dtype=np.float64)
        self.yp = np.asarray(iface.y, dtype=np.float64)
        w = np.asarray(iface.w, dtype=np.float64)
        # the lever-arm sums on the full free DOFs (a reduced bulk's lever-arm fields psi are
        # not in its basis' span: its full M, f_gravity, r_x, r_y, fe/reduction.py); the
        # rigid fields phi and the P-Delta load then in the model's coordinates (module
        # docstring, "The reduced bulk")
        full = model.full_bulk()
        M = sp.csr_matrix(full.M)
        fg = np.asarray(full.f_gravity, dtype=np.float64)
        if full is not model:
            # the reduced bulk's Mrx, Mry are Phi^T M r (no absorbing rock, no incompressible
            # water there: setup/bulk.py): the full bulk's are M r
            Mrx, Mry = M @ full.r_x, M @ full.r_y
        blocks = [r for r in model.regions if r != "rock"]
        self.rot_w = []          # per joint: theta = rot_w . (B u)_N over its points
        self.pivots = []         # per joint: ((x, y) upstream end, (x, y) downstream end)
        self.moments = []        # per joint and pivot: (M_lin, Q) of gravity
        self.phis = []           # per joint and pivot: phi_c (the static loads' moment)
        self.shapes = []         # per joint: M phi_m / (phi_m^T M phi_m)
        for k, sl in enumerate(self.slices):
            x, ww = self.xp[sl], w[sl]
            xc = x - np.dot(ww, x) / ww.sum()
            self.rot_w.append(ww * xc / np.dot(ww, xc * xc))
            yj = float(np.dot(ww, self.yp[sl]) / ww.sum())
            piv = ((float(x.min()), yj), (float(x.max()), yj))
            F = linear_fields(model, blocks[k:])
            mom, phis = [], []
            for cx, cy in piv:
                phi = -(F["Yx"] - cy * F["Tx"]) + (F["Xy"] - cx * F["Ty"])
                psi = (F["Xx"] - cx * F["Tx"]) + (F["Yy"] - cy * F["Ty"])
                # (M_lin, Q) of gravity and of the unit ground accelerations' loads -M r a
                mom.append(np.array([[fg @ phi, fg @ psi], [-(Mrx @ phi), -(Mrx @ psi)],
                                     [-(Mry @ phi), -(Mry @ psi)]], dtype=np.float64))
                phis.append(model.field_rows(phi))
            MTx, MTy = M @ F["Tx"], M @ F["Ty"]
            m = float(F["Tx"] @ MTx)
            xm, ym = float(F["Xx"] @ MTx) / m, float(F["Yy"] @ MTy) / m
            phim = -(F["Yx"] - ym * F["Tx"]) + (F["Xy"] - xm * F["Ty"])
            Mphi = M @ phim
            self.shapes.append(model.load_rows(Mphi) / float(phim @ Mphi))
            self.pivots.append(piv)
            self.moments.append(mom)
            self.phis.append(phis)
        self.fg = fg if full is model else np.asarray(model.f_gravity, dtype=np.float64)
        self.d_applied = np.zeros(2 * self.npts)   # the offset's share of this class
        self.theta = np.zeros(len(self.names))     # of the last before_step
        self.dM = np.zeros(len(self.names))
        self.f = np.zeros(model.nfree)             # the P-Delta load of the current step

    # ------------------------------------------------------------------ measures
    def rotations(self, B, vec) -> np.ndarray:
        """theta (or its rate) of every joint from a displacement (velocity, acceleration)
        vector: the slope of (B vec)_N along the joint."""
        gN = (B @ vec)[0::2]
        return np.array([float(np.dot(rw, gN[sl])) for rw, sl in zip(self.rot_w, self.slices)])

    def _side(self, theta) -> int:
        return 0 if theta >= 0.0 else 1          # pivot: upstream end for theta >= 0

    def gap_correction(self, thetas) -> np.ndarray:
        """d = (R(theta) - I) r - theta z x r at every point of every joint, as a (2 npts)
        gap vector (normal, tangential)."""
        d = np.zeros(2 * self.npts)
        for i, sl in enumerate(self.slices):
            th = float(thetas[i])
            cx, cy = self.pivots[i][self._side(th)]
            rx, ry = self.xp[sl] - cx, self.yp[sl] - cy
            c1, s1 = np.cos(th) - 1.0, np.sin(th) - th
            d[2 * sl.start + 1:2 * sl.stop:2] = c1 * rx - s1 * ry     # tangential (x)
            d[2 * sl.start:2 * sl.stop:2] = s1 * rx + c1 * ry         # normal (y)
        return d

    def moment_correction(self, i, theta, ax=0.0, ay=0.0) -> float:
        """dM = (cos theta - 1) M_lin - sin theta Q about joint i's pivot of the body forces:
        gravity and the ground's inertial loads -M (r_x a_x + r_y a_y)."""
        ml, q = np.array([1.0, ax, ay]) @ self.moments[i][self._side(theta)]
        return (np.cos(theta) - 1.0) * ml - np.sin(theta) * q

    # ------------------------------------------------------------------ the step
    def before_step(self, ctx):
        """The step's gap offset and P-Delta load (added to the step's load)."""
        ax, ay = ctx.ground
        ctx.load = ctx.load + self.step_load(ctx.solver, ctx.dt, ax, ay)
        if self.energy is not None:
            self.energy.rebase_gap(ctx.solver.operator_gap())   # the offset books no work

    def after_step(self, ctx):
        """The run's stop (collapse, mode "toppling") when a block toppled and no part set a
        stop yet."""
        if ctx.stop is None:
            ctx.stop = self.toppled(ctx.solver, ctx.k, ctx.t, ctx.static_loads)

    def step_load(self, solver, h, ax=0.0, ay=0.0):
        """Form the step's corrections from theta predicted at its end (the ground's
        acceleration there ax, ay); set the solver's gap offset. Returns the P-Delta load
        (nfree) to add to the step's load."""
        B = solver.B
        th = (self.rotations(B, solver.u) + h * self.rotations(B, solver.v)
              + 0.5 * h * h * self.rotations(B, solver.a))
        d = self.gap_correction(th)
        base = np.zeros(2 * self.npts) if solver.g_offset is None else solver.g_offset
        solver.set_offset(base + (d - self.d_applied))
        self.d_applied = d
        self.theta = th
        self.dM = np.array([self.moment_correction(i, t, ax, ay) for i, t in enumerate(th)])
        f = np.zeros_like(self.f)
        for dm, s in zip(self.dM, self.shapes):
            f += dm * s
        self.f = f
        return f

    def static_moment(self, i, theta, f_static) -> float:
        """The exact moment of the static loads about joint i's pivot at rotation theta:
        gravity rotated, the other static loads in the reference configuration."""
        side = self._side(theta)
        ml, q = self.moments[i][side][0]
        other = float((f_static - self.fg) @ self.phis[i][side])
        return np.cos(theta) * ml - np.sin(theta) * q + other

    def toppling_angle(self, i, sign, f_static) -> float:
        """The rotation (of sign ``sign``) at which the static loads' moment about the pivot
        stops restoring the block (nan: none up to pi/2)."""
        ths = sign * np.linspace(0.0, 0.5 * np.pi, 20001)
        side = self._side(sign)
        ml, q = self.moments[i][side][0]
        other = float((f_static - self.fg) @ self.phis[i][side])
        m = sign * (np.cos(ths) * ml - np.sin(ths) * q + other)
        up = np.flatnonzero(m > 0.0)
        if not up.size:
            return float("nan")
        j = int(up[0])
        if j == 0:
            return 0.0
        a, b = m[j - 1], m[j]
        return float(ths[j - 1] + (ths[j] - ths[j - 1]) * (-a) / (b - a))

    def toppled(self, solver, k, t, static_loads):
        """The collapse entry (mode "toppling") if a block toppled at step k (time t), else
        None."""
        th = self.rotations(solver.B, solver.u)
        f_s = None
        for i, n in enumerate(self.names):
            if abs(th[i]) < 1e-6:
                continue
            if f_s is None:
                f_s = static_loads()
            if np.sign(th[i]) * self.static_moment(i, th[i], f_s) > 0.0:
                top = self.toppling_angle(i, np.sign(th[i]), f_s)
                return {"joint": n, "time": float(t), "step": int(k), "verdict": "collapse",
                        "mode": "toppling",
                        "reason": f"the block above joint {n!r} toppled: its rotation "
                                  f"{th[i]:.4g} rad passed the toppling angle {top:.4g} rad "
                                  f"of its static loads (their resultant passed the end of "
                                  f"the joint) (toppling)",
                        "measure": "rotation", "value": float(th[i]),
                        "toppling_angle": top}
        return None

    # ------------------------------------------------------------------ checkpoints
    def checkpoint(self) -> dict:
        """The offset's share of this part and the solver's gap offset as it was (the rotation
        changes it every step; the pairing's checkpoint holds the one of its last pairing)."""
        d = {"d_applied": self.d_applied.copy()}
        if self.solver.g_offset is not None:
            d["g_offset"] = np.array(self.solver.g_offset, copy=True)
        return d

    def restore(self, d):
        """The state of ``checkpoint()``: after the pairing's restore (the run's order of parts),
        the solver's gap offset exactly as it was."""
        self.d_applied = np.array(d["d_applied"], dtype=np.float64)
        if d.get("g_offset") is not None:
            self.solver.set_offset(np.array(d["g_offset"], dtype=np.float64))
