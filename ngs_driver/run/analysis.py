"""A dam analysis with a life cycle: ``prepare`` builds everything a run needs, then
``static()``, ``step()`` until it returns False, ``finish()``::

    a = prepare(scene, outdir)
    a.static()                 # the pre-earthquake state (or the state of the checkpoint)
    while a.step():            # one step of the record
        pass
    summary = a.finish()       # outputs, post-earthquake check, summary.json

``prepare`` validates the scene (``setup.validate``: laws, record) before anything is
written, resolves it (``setup.resolve``: the run's typed inputs; below ``setup`` nothing reads
the scene), builds the model (``fe.model.build_from_inputs``: the section, its lift joints, the
foundation), one interface law per joint with its size-scale state (``run.joints``), Rayleigh
damping from the modal analysis (``run.damping``) and the condensed ``JointSolver`` (all
joints in one gap vector). The static state (dead load + reservoir + tailwater + uplift) is
solved with the interface laws and committed; then the ground motion enters as the effective
load

    f(t) = f_static - M (r_x a_x(t) + r_y a_y(t))

(relative formulation: rock bottom fixed, displacements relative to the rigid ground motion;
with absorbing rock boundaries the displacements are total and the record enters as
free-field forces, ``fe.foundation.AbsorbingRock``). After each step's solve the run's parts
(``run.parts``: measures, safety, energy, history, size scale, pairing, snapshots, outputs,
collapse rule, checkpoints, ...) each do their job in turn (docs/run.md §3).

Files: the run writes its own -- summary.json (last, atomically), final_state.npz,
checkpoint.json + checkpoint_<step>.npz every ``output.checkpoint_every`` steps, one set
committed at once with the previous one kept (``run.checkpoint``; ``resume=True`` continues
from the last checkpoint and gives the same results as an uninterrupted run). The folder is
locked for the run and a finished run or a checkpoint in it is replaced only when asked
(``overwrite``; ``run.folder``). The output stage
writes the rest through the ``outputs`` object ``prepare`` is given (``run.outputs``; the
standard one is ``post.RunOutputs``: timeseries.csv, damage_profiles[_<joint>].csv, results.md,
PNGs, optional VTK); ``apps.dam.run`` is the whole run with those.
"""
from __future__ import annotations

import dataclasses
import pathlib
import time

import numpy as np
from numba import njit

from ..fe.foundation import AbsorbingRock
from ..fe.loads import tailwater_load
from ..fe.model import build_from_inputs
from ..fe.modal import modal_analysis
from ..setup import FORMULATION, model_inputs, resolve, validate
from ..solve.integrator import Integrator
from ..solve.joint_laws import initial_stiffness
from ..solve.massless import initial_acceleration, massless_dofs
from ..solve.joint_solver import JointSolver
from ..solve.stepping import SolverError
from . import summary as sm
from .checkpoint import (Checkpointer, CheckpointStep, SolverPart, format_error,
                         resume_difference)
from .collapse import CollapseRule
from .damping import damping_matrix, low_rank_damping, modes_to_compute, rayleigh_damping
from .energy import GUARD_SPLITS, EnergyBudget, EnergyGuard
from .folder import (FolderError, FolderLock, clean_temporaries, finished_files, probe_writable,
                     reuse_error)
from .history import (HIST_KEYS, HeelOpening, Snapshots, StepHistory,
                      results_from_history)
from .joints import Joints, SizeScale
from .outputs import Outputs
from .pairing import JointPairing
from .parts import StepContext, acting, join_checkpoint, split_checkpoint
from .post_earthquake import PostEarthquakeCheck
from .progress import OutputsStep, Progress
from .reservoir import ReservoirRun
from .rotation import FiniteRotation
from .safety import FS_DEFINITION, SlidingSafety
from .screening import Screening
from .statics import solve_pre_earthquake
from .store import atomic_savez, atomic_write_json, environment_info
from .uplift import Uplift

__all__ = ["prepare", "Analysis", "seismic_load"]


@njit(cache=True)
def seismic_load(f_static, Mrx, Mry, ax, ay):
    """f_static - Mrx ax - Mry ay in one loop (numpy's three operations, in their order)."""
    f = np.empty(f_static.size)
    for i in range(f.size):
        f[i] = f_static[i] - Mrx[i] * ax - Mry[i] * ay
    return f


def make_solver(inputs, model, C, law, C_lowrank=None, coupled=None, rayleigh=None):
    """The joint solver of the scene's [time] (integrator) and [solver] keys (``inputs``: the
    run's ``setup.RunInputs``); C_lowrank: the low-rank part of the damping
    (``run.damping.low_rank_damping``); coupled: the reservoir's water (solve/coupled.py) or
    None; rayleigh: (a0, a1) when C = a0 M + a1 K (the step's products then form C's values
    in their loop, solve/products.py)."""
    ts, sv = inputs.time, inputs.solver
    integrator = Integrator.make(ts.integrator, rho_inf=ts.rho_inf, beta=ts.newmark_beta,
                                 gamma=ts.newmark_gamma)
    return JointSolver(model.K, model.M, C, model.interface.B, model.interface.w, law,
                       dt=ts.dt, integrator=integrator, C_lowrank=C_lowrank,
                       tol_residual=sv.tol_residual, max_iter=sv.max_iter,
                       stall_iterations=sv.stall_iterations, min_dt=sv.min_dt, coupled=coupled,
                       rayleigh=rayleigh)


def _restart(out, ckp, scene_d):
    """(meta, arrays) of the checkpoint in ``out``; ValueError naming the first key whose
    value differs when the checkpoint was written for another scene."""
    meta, arrs = ckp.load()          # FileNotFoundError / CheckpointDamaged, clear messages
    why = format_error(meta, out)
    if why is not None:
        raise ValueError(why)
    diff = resume_difference(meta.get("scene") or {}, scene_d)
    if diff is not None:
        raise ValueError(f"--resume: the checkpoint in {out} was written for a different "
                         f"scene: {diff}; allowed: the same scene and overrides as the "
                         "interrupted run")
    return meta, arrs


class Analysis:
    """One dam run: built by ``prepare``, driven by ``static()``, ``step()``, ``finish()``.

    Public attributes: ``scene`` (kept for the output stage; the run itself reads
    ``inputs``, the scene resolved by ``setup.resolve``), ``inputs``, ``out`` (results
    folder), ``model``, ``joints``, ``solver``, ``modal``, ``damping`` (the Rayleigh dict),
    ``gm`` (the ground motion), ``times``, ``n_steps``, ``k`` (steps done), ``parts`` (the
    parts of a step, in their order: ``run.parts``), ``history``, ``snapshots``, ``energy``,
    ``guard``, ``uplift``, ``safety``, ``screening``, ``absorbing``, ``reservoir``,
    ``pairing``, ``stop_rule``, ``heel``, ``stopped`` (None or the stop rule's entry),
    ``static_info``, ``lock`` (the results folder's ``run.folder.FolderLock``, released by
    ``finish`` or ``release()``), ``previous_files`` (the files of the finished run this one
    replaces, or None)."""

    name = "run"              # its own share of a checkpoint (``checkpoint``)

    def __init__(self, scene, inputs, out, gm, model, checkpoints, restart, *, progress,
                 outputs, log, t0, t_build):
        self.scene, self.inputs = scene, inputs
        self.out, self.gm, self.model = out, gm, model
        inp = inputs
        self.progress, self.log = progress, log
        self.outputs = outputs if outputs is not None else Outputs()
        self._t0 = t0
        self.scene_d = inp.scene_dict
        self.checkpoints = checkpoints
        self.lock = None                  # the results folder's lock (``prepare``)
        self.previous_files = None        # the files of a finished run this one replaces
        self._restart = restart
        self.timings = {"build": t_build}

        self.collapse = None
        self.undetermined = None             # the stop entry when the model's range was left
        self.window_note = inp.window_note
        self.static_info = None
        self.stopped = None
        self.k = 0
        self.resumed_from = None
        self._t_loop = None
        self._wall_before = 0.0
        f_tail = self._build_joints(inp, model, gm)
        C = self._build_damping(inp, model)
        self._build_loads(inp, model, gm, C, f_tail)
        self._build_parts(inp, model, progress, checkpoints)
        if progress:
            c, joints, iface = self.chars, self.joints, model.interface
            log(f"[{inp.name}] nfree {model.nfree}, joints {', '.join(joints.names)} "
                f"({iface.npts} interface points), f1 = {self.modal.frequencies_hz[0]:.3f} Hz, "
                f"a0 = {self.damping['a0']:.4g} 1/s, a1 = {self.damping['a1']:.4g} s; t1 = "
                f"{c['t1']:.3e} s, t2 = {c['t2']:.3e} s (Eq. 11); record: {gm.label}"
                f"{' [SYNTHETIC]' if gm.synthetic else ''}")
            if self.window_note:
                log(f"[{inp.name}] note: {self.window_note}")

    def _build_joints(self, inp, model, gm):
        """The joints with their laws, the uplift, the sliding safety, the absorbing boundary,
        the screening and the post-earthquake check; returns the tailwater's load (or None)."""
        self.joints = joints = Joints(inp.joints, model.interface)
        self.uplift = Uplift(inp, model.interface, joints)
        self.safety = SlidingSafety(joints, pressure=lambda: self.uplift.p)
        self.absorbing = None                # fe.foundation.AbsorbingRock
        if inp.absorbing:
            self.absorbing = AbsorbingRock(model, inp.rock, gm, inp.record_start)
        self.screening = None
        if inp.screening_strength is not None:
            self.screening = Screening(inp.screening_strength, model)
        self.post_check = PostEarthquakeCheck(inp.time.max_slip, model, joints, self.safety,
                                              self.uplift, self.absorbing)
        self.reference = sm.reference_parameters(inp.g_max, joints)
        return tailwater_load(model, inp.tailwater, inp.water_density, inp.gravity)

    def _build_damping(self, inp, model):
        """The modal analysis with the joints bonded and the damping; returns the damping
        matrix C."""
        joints, iface = self.joints, model.interface
        t = time.perf_counter()
        k0p = initial_stiffness(joints.solver_law(), iface.npts)    # each joint its own k0
        self.modal = modal_analysis(self._modal_model(), modes_to_compute(inp.damping),
                                    k0p[:, 0], k0p[:, 1])
        self.damping = rayleigh_damping(self.modal, inp.damping,
                                        None if self._restart is None else self._restart[0])
        self.timings["modal"] = time.perf_counter() - t
        C = damping_matrix(model, self.damping, self.absorbing)
        self.low_damping = low_rank_damping(model, joints, self.damping)
        return C

    def _build_solver(self, inp, model, C):
        """The joint solver, with the reservoir's water as its coupled field (solve/coupled.py;
        the reservoir is built first), joints that start cracked with no cohesion."""
        joints = self.joints
        self.solver = solver = make_solver(
            inp, model, C, joints.solver_law(), self.low_damping,
            coupled=None if self.reservoir is None else self.reservoir.field,
            rayleigh=(self.damping["a0"], self.damping["a1"]))
        if self.reservoir is not None:
            self.reservoir.solver = solver
        cracked = joints.cracked_points()
        if cracked.any():                # joints that start cracked: no cohesion
            st0 = solver.state.copy()
            st0.kappa[cracked] = 1.0
            solver.set_state(st0)

    def _build_loads(self, inp, model, gm, C, f_tail):
        """The record on the time grid, the reservoir, the solver, the loads, the energy budget
        and guard (C: the damping matrix; f_tail: the tailwater's load or None)."""
        ts, joints = inp.time, self.joints
        self.n_steps = int(round(ts.duration / ts.dt))
        self.times = ts.dt * np.arange(self.n_steps + 1)
        self.ax, self.ay = gm.at(inp.record_start + self.times)
        Mrx, Mry = model.M @ model.r_x, model.M @ model.r_y
        self.reservoir = None
        if getattr(model, "reservoir", None) is not None:   # hydrodynamics (fe/reservoir.py)
            Mrx, Mry = model.reservoir.seismic_vectors(Mrx, Mry)
            self.reservoir = ReservoirRun.create(model, self.times, self.ax, self.ay,
                                                 total=self.absorbing is not None)
        self._build_solver(inp, model, C)
        self.f_base = model.f_gravity + model.f_water + (np.zeros(model.nfree)
                                                         if f_tail is None else f_tail)
        if self.absorbing is not None:       # total displacements: the record enters as
            Mrx, Mry = 0.0 * Mrx, 0.0 * Mry  # free-field forces (``step``)
        self.Mrx, self.Mry = Mrx, Mry
        self.f_reaction = np.zeros(model.nfree)   # support reactions (absorbing rock)
        self.f_static = None
        self.u_static = None
        self.chars = inp.characteristic_times
        # C = a0 M + a1 K (+ dashpots): the budget's damping work needs no product with C
        self.energy = EnergyBudget(
            model.K, model.M, C, model.interface.w, joints,
            rayleigh=(self.damping["a0"], self.damping["a1"]),
            C_extra=None if self.absorbing is None else self.absorbing.C,
            fluid=None if self.reservoir is None else self.reservoir.stepper,
            added_mass=getattr(getattr(model, "reservoir", None), "added_mass", None),
            C_lowrank=self.low_damping)
        self.guard = EnergyGuard(fraction=inp.solver.energy_guard)
        # the wall time stays the last column (everything before it is deterministic)
        self.history_keys = (list(HIST_KEYS[:-1]) + joints.history_keys()
                             + self.safety.history_keys() + self.energy.keys() + ["wall"])

    def _build_parts(self, inp, model, progress, checkpoints):
        """The parts of a step, in their order (``run.parts``): after each step each does its
        job; a checkpoint is each part's ``checkpoint()``, a resume each part's ``restore()``."""
        solver, joints, ts = self.solver, self.joints, inp.time
        self.solver_part = SolverPart(solver)
        # finite sliding: the joints that slide on a deformable face are paired anew
        self.pairing = JointPairing(model, joints.slices, joints.names, model.interface.B,
                                    inp.solver.pairing_tolerance, solver=solver)
        self.pairing.on_repair += [
            lambda s: self._operator_changed(),
            # an opened point's gap jumps by OPEN_GAP with no motion: no work is booked
            lambda s: self.energy.rebase_gap(s.operator_gap())]
        self.size_scale = SizeScale(joints, solver, self.energy)
        self.snapshots = Snapshots(self.n_steps, inp.output.snapshots)
        self._history = StepHistory(self.history_keys, model.crest_dofs)
        self.heel_opening = HeelOpening(joints.slices[0])
        # finite rotations of the blocks (run/rotation.py; None: the small-rotation kinematics)
        self.rotation = (FiniteRotation(model, joints, solver, self.Mrx, self.Mry, self.energy)
                         if inp.solver.kinematics == "finite_rotation" else None)
        self.stop_rule = CollapseRule(model, joints, ts.max_slip, ts.max_rotation,
                                      inp.solver.kinematics)
        self.progress_bar = Progress(progress, self.n_steps, inp.label, self._history)
        self._acting = None               # (parts, those acting before, after) (``step``)
        self.parts = [p for p in (
            self.solver_part, self.uplift, self.screening, self.reservoir, joints, self.safety,
            self.energy, self._history, self.guard, self.size_scale, self.pairing,
            self.snapshots, OutputsStep(self), self.progress_bar, self.heel_opening,
            self.rotation, self.stop_rule, CheckpointStep(checkpoints, self._checkpoint, solver))
            if p is not None]

    @property
    def history(self):
        """The per-step ``History`` (None before ``static()``)."""
        return self._history.history

    @property
    def heel(self) -> dict:
        """The state of the largest heel opening while the base holds: {u, t, open}."""
        h = self.heel_opening
        return {"u": h.u, "t": h.t, "open": h.open}

    def _modal_model(self):
        """The model the modal analysis sees: with absorbing (unsupported) rock boundaries,
        the static support springs (the dashpots have no stiffness)."""
        if self.absorbing is None:
            return self.model
        return dataclasses.replace(self.model,
                                   K=(self.model.K + self.absorbing.K_support).tocsr())

    # ------------------------------------------------------------------ static state
    def static(self) -> dict:
        """The pre-earthquake static state (or, resuming, the state of the checkpoint);
        returns ``static_info`` (summary.json ``static``)."""
        if self._restart is not None:
            return self._resume()
        solver = self.solver
        t = time.perf_counter()
        rep, self.f_static, self.f_reaction = solve_pre_earthquake(solver, self.f_base,
                                                                   self.uplift, self.absorbing)
        if self.screening is not None:
            self.screening.static(solver.u)
        t_static = time.perf_counter() - t
        ax0, ay0 = self.ax[0], self.ay[0]
        if self.inputs.massless:                          # M singular on the rock
            initial_acceleration(solver, self.f_static - self.Mrx * ax0 - self.Mry * ay0,
                                 massless_dofs(self.model.M), self.damping["a1"])
        else:
            solver.initial_acceleration(self.f_static - self.Mrx * ax0 - self.Mry * ay0
                                        + self._input_force(0.0))
        st = solver.state
        self.u_static = solver.u.copy()
        base = self.joints.slices[0]
        tr = solver.t[base]
        cx, cy = self.model.crest_dofs
        sigma_max = self.joints.reference[0].cohesive.sigma_max
        self.static_info = {
            "iterations": rep.iterations, "n_active": rep.n_active, "wall": t_static,
            "crest_ux": float(solver.u[cx]), "crest_uy": float(solver.u[cy]),
            "heel_traction_N": float(tr[0, 0]), "heel_traction_T": float(tr[0, 1]),
            "max_normal_traction": float(tr[:, 0].max()),
            "min_normal_traction": float(tr[:, 0].min()),
            "max_normal_traction_over_sigma_max": float(tr[:, 0].max() / sigma_max),
            "max_kappa": float(st.kappa.max()),
            "max_D": float(st.damage.max()), "D_heel": float(st.damage[0]),
            "elastic": bool(rep.n_active == 0),
            "joints": self.safety.static_measures(solver, self.uplift.p),
        }
        self.timings["static"] = t_static
        self._history.start()
        self.snapshots.take(0, 0.0, solver)
        self.heel_opening.start(self.u_static, solver.g[0, 0])
        self.energy.start(solver.u, solver.v, solver.f, solver.t, solver.g, solver.state)
        self.guard.e_static = abs(0.5 * float(solver.u @ self.f_static))
        self.guard.start()
        self.joints.set_reference(solver.g)       # slip and rotation from the static state
        self.size_scale.update(solver.state)       # the sizes for step 1
        self._prepare_loop()
        return self.static_info

    def _resume(self) -> dict:
        meta, arrays = self._restart
        own = join_checkpoint("run", arrays, meta["parts"])
        self.static_info = own["static"]
        self.f_reaction = np.array(own["f_reaction"])
        self.u_static = np.array(own["u_static"])
        self._wall_before = float(own["dynamic_wall"])
        for p in self.parts:                      # in the parts' order (run.parts)
            p.restore(join_checkpoint(p.name, arrays, meta["parts"]))
        extra = self.f_reaction.copy()
        if self.uplift.active:
            extra += self.uplift.load(self.uplift.p_static)
        self.f_static = self.f_base + extra
        if self.pairing.repairs and self.uplift.active:
            self._operator_changed()
        self.timings["static"] = self.static_info["wall"]
        self.k = self.resumed_from = int(meta["step"])
        if self.progress:
            self.log(f"[{self.inputs.name}] resuming from step {self.k} "
                     f"(t = {self.k * self.inputs.time.dt:.4g} s)")
        self._prepare_loop()
        return self.static_info

    def _prepare_loop(self):
        loads = [np.ascontiguousarray(a, dtype=float) for a in (self.f_static, self.Mrx,
                                                                  self.Mry)]
        if any(a.shape != loads[0].shape or a.ndim != 1 for a in loads):     # seismic_load
            raise RuntimeError(f"run: load vectors of shapes {[a.shape for a in loads]}")
        self.f_static, self.Mrx, self.Mry = loads

    def _operator_changed(self):
        """A joint was paired anew: the uplift acts through the new operator, and the static
        load's uplift part with it."""
        if self.uplift.active:
            self.uplift.field.set_operator(self.solver.B)
            self.f_static = np.ascontiguousarray(
                self.f_base + self.f_reaction + self.uplift.load(self.uplift.p_static))

    def _input_force(self, t: float):
        """Free-field forces of absorbing boundaries at analysis time t (else 0)."""
        return 0.0 if self.absorbing is None else self.absorbing.force(t)

    # ------------------------------------------------------------------ time steps
    @property
    def done(self) -> bool:
        """No step left: the record's end, or the stop rule fired."""
        return self.stopped is not None or self.k >= self.n_steps

    def step(self) -> bool:
        """One step of the record: solve, measure, record, checkpoint when due. Returns False
        when the run is over (this was the last step, or the stop rule fired at it; also when
        called with no step left), True when ``step()`` may be called again."""
        if self.history is None:
            raise RuntimeError("Analysis.step: call static() first")
        if self.done:
            return False
        if self.progress_bar.bar is None:
            self.progress_bar.open(self.k)
            self._t_loop = time.perf_counter()
        solver, name = self.solver, self.inputs.name
        k = self.k + 1
        tk = self.times[k]
        f_k = seismic_load(self.f_static, self.Mrx, self.Mry, self.ax[k], self.ay[k])
        if self.absorbing is not None:
            f_k = f_k + self.absorbing.force(solver.time + solver.dt)
        ctx = StepContext(k=k, t=tk, dt=self.inputs.time.dt, solver=solver, load=f_k,
                          static_loads=self._static_loads, ground=(self.ax[k], self.ay[k]))
        if self._acting is None or self._acting[0] is not self.parts:
            # the parts with a before/after hook that does something (the others' no-ops are
            # not called), in their order (run.parts)
            self._acting = (self.parts, acting(self.parts, "before_step"),
                            acting(self.parts, "after_step"))
        for part in self._acting[1]:
            part.before_step(ctx)
        ctx.report, ctx.load, ctx.energy, ctx.scan = self._solve(k, tk, ctx.load)
        self.k = k
        for part in self._acting[2]:
            part.after_step(ctx)
        if ctx.stop is not None:
            coll = dict(ctx.stop)
            verdict = coll.pop("verdict")
            if verdict == "collapse":
                self.collapse = coll
            else:                          # the model's range left (run.collapse)
                self.undetermined = coll
            self.stopped = {"reason": f"{verdict}: {coll['reason']}", "t": coll["time"],
                            "step": k, "verdict": verdict}
            if self.progress:
                self.progress_bar.write(f"[{name}] stopped at t = {tk:.3f} s: "
                                        + self.stopped["reason"])
            return False
        return k < self.n_steps

    def _solve(self, k, tk, f_k):
        """The step's solve: the uplift's fixed point (``run.uplift``) and the energy guard
        (``run.energy.EnergyGuard``: a step that breaks the energy balance is repeated from
        the committed state in 2, 4, ... uniform sub-steps). Returns (the solver's report,
        the load used, the energy row, the joints' scan)."""
        solver, name = self.solver, self.inputs.name
        # what a step changes, to repeat it: the solver's committed state with its coupled
        # water's and the energy budget's accumulators (their checkpoints), and the uplift
        # pressure in force (its fixed-point counts keep the rejected attempts' solves)
        # (the solver's arrays by reference: a commit replaces them, a restore copies)
        repeat = (self.solver_part, self.energy)
        saved = [self.solver_part.checkpoint(copy=False), self.energy.checkpoint()]
        p_uplift = self.uplift.p
        split, cuts, failed = 0, 0, 0
        while True:
            try:
                rep, f_used = self.uplift.step(solver, f_k, split)  # f_used: with the uplift
            except SolverError as e:
                raise SolverError(f"{name}: step {k} (t = {tk:.4f} s): {e}") from None
            st = solver.state
            # the per-point work of the joints', energy's and safety's measures, once
            scan = self.joints.scan(st, solver.g, solver.t)
            # K u, M v from the solver's pass that also forms the next step's right-hand side
            # (the budget and the solver are built on the same model.K, model.M)
            en = self.energy.step(solver.u, solver.v, f_used, solver.t, solver.g, st, scan,
                                  products=solver.step_products())
            ok, why = self.guard.check(en, tk)       # (fraction 0: the guard is off)
            if ok:
                break
            cuts += rep.cuts + 1
            failed += rep.iterations + rep.iterations_failed
            split += 1
            if split > GUARD_SPLITS:
                raise SolverError(f"{name}: step {k} (t = {tk:.4f} s): {why}, even in "
                                  f"{2 ** GUARD_SPLITS} sub-steps; committed state is at "
                                  f"t = {self.times[k - 1]:.6g} s")
            for p, d in zip(repeat, saved):
                p.restore(d)
            self.uplift.p = p_uplift
        rep.cuts += cuts
        rep.iterations_failed += failed
        return rep, f_used, en, scan

    def _static_loads(self):
        """Gravity, water and tailwater with the uplift now (the collapse rule's FS_static)."""
        return self.f_base + (self.uplift.load(self.uplift.p) if self.uplift.active else 0.0)

    def _dynamic_wall(self) -> float:
        return self._wall_before + (0.0 if self._t_loop is None
                                    else time.perf_counter() - self._t_loop)

    def checkpoint(self) -> dict:
        """The run's own share of a checkpoint (the parts' follow it, ``run.parts``): the
        static state and the wall time so far."""
        return {"static": self.static_info, "u_static": self.u_static,
                "f_reaction": self.f_reaction, "dynamic_wall": self._dynamic_wall()}

    def _checkpoint(self, k):
        arrays, parts = split_checkpoint([self] + self.parts)
        self.checkpoints.save(k, {"scene": self.scene_d, "parts": parts,
                                  "rayleigh": {"a0": self.damping["a0"],
                                               "a1": self.damping["a1"]},
                                  "laws": self.joints.params()}, **arrays)

    def close(self):
        """End the time loop: the progress bar closed, the last checkpoint on disk (written in
        the background). ``finish`` calls it; a caller that stops early calls it itself."""
        self.progress_bar.close()
        self.checkpoints.wait()

    # ------------------------------------------------------------------ the end
    def finish(self) -> dict:
        """Outputs, the post-earthquake check and summary.json (written last: the run is
        complete); the checkpoints are removed. Returns the summary dict."""
        self.close()
        self.solver.release_steps()        # memory for the outputs (the loop is over)
        solver, out = self.solver, self.out
        self.timings["dynamic"] = self._dynamic_wall()
        snaps = self.snapshots
        if self.stopped is not None and snaps.last_step != self.stopped["step"]:
            snaps.take(self.stopped["step"], self.stopped["t"], solver)   # D(x) at the stop
        H = self.history.arrays()
        t_out = time.perf_counter()
        files = self._write_outputs(H)
        self.timings["outputs"] = time.perf_counter() - t_out
        # post-earthquake static state from the final interface state (after final_state.npz)
        t_pe = time.perf_counter()
        ended = self.collapse if self.collapse is not None else self.undetermined
        post = (self.post_check.collapsed(ended) if ended is not None
                else self.post_check.run(solver, self.f_base))
        post["wall"] = time.perf_counter() - t_pe
        safety_sum = self.safety.summary(H, self.inputs.time.dt)
        files.extend(self.outputs.safety(self, H, post, safety_sum))
        summary = self._summary(H, post, safety_sum, files)
        atomic_write_json(out / "summary.json", summary)     # LAST: the run is complete
        self.checkpoints.remove_all()                         # nothing left to resume
        for f in set(self.previous_files or ()) - set(files) - {"summary.json"}:
            p = out / f                   # the replaced run's files this run did not write
            if p.parent == out and p.is_file():
                p.unlink()
        self.release()
        text = self.outputs.report(summary) if self.progress else None
        if text:
            self.log(text)
        return summary

    def release(self) -> None:
        """The results folder's lock released (``finish`` does it; a caller that stops early
        may, or the process's end does)."""
        if self.lock is not None:
            self.lock.release()

    def _write_outputs(self, H) -> list[str]:
        solver, out, iface = self.solver, self.out, self.model.interface
        # the finished run this one replaces (--overwrite, or resumed after one) stops looking
        # finished before the first of its files is replaced: its summary.json goes first
        (out / "summary.json").unlink(missing_ok=True)
        files = list(self.outputs.results(self, H))
        atomic_savez(out / "final_state.npz", u=solver.u, v=solver.v, a=solver.a,
                     x=iface.x, y=iface.y, w=iface.w,
                     **{f"state_{kk}": vv for kk, vv in solver.state.as_dict().items()})
        files.append("final_state.npz")
        return files

    def _summary(self, H, post, safety_sum, files) -> dict:
        inp, model, gm, iface = self.inputs, self.model, self.gm, self.model.interface
        snaps = self.snapshots.data
        summary = {
            "scene": self.scene_d,
            "label": gm.label + (" [SYNTHETIC]" if gm.synthetic else ""),
            "ground_motion": sm.ground_motion_summary(inp.record_start, gm, self.window_note),
            "formulation": FORMULATION,
            "stopped": self.stopped,
            "verdict": ("collapse" if self.collapse is not None else "undetermined"
                        if self.undetermined is not None else "no_collapse"),
            "collapse": self.collapse,
            "undetermined": self.undetermined,
            "finite_sliding": {"joints_paired": [j[0] for j in self.pairing.joints],
                               "repairings": int(self.pairing.repairs),
                               "tolerance": inp.solver.pairing_tolerance},
            "crest_point": list(model.crest_point),
            "crest_displacement_note": "upstream crest corner, relative to the rigid ground "
                                       "(rock bottom); includes the static displacement",
            "mesh": model.summary(),
            "dofs": {"nfree": int(model.nfree), "ndof": int(model.ndof),
                     "interface_points": int(iface.npts)},
            "frequencies_hz": [float(f) for f in self.modal.frequencies_hz],
            "rayleigh": self.damping,
            "law": inp.law,
            "reference_parameters": self.reference,
            "final_parameters": self.joints.params()[0],
            "joints": sm.joint_results(self.joints, H, snaps),
            "energy": {**sm.energy_summary(H, self.energy.keys()), **self.guard.summary()},
            "characteristic_times": self.chars,
            "static": self.static_info,
            "n_steps": int(self.n_steps),
            "timings": sm.timings(H["wall"], **self.timings,
                                  total_this_process=time.perf_counter() - self._t0),
            "solver_totals": sm.solver_totals(H),
            "results": results_from_history(H),
            "post_earthquake": post,
            "safety": {"joints": safety_sum,
                       "uplift_fixed_point_solves": self.uplift.fixed_point_iterations,
                       "uplift_fixed_point_unconverged": self.uplift.fixed_point_unconverged,
                       "definition": FS_DEFINITION},
            "screening": None if self.screening is None else self.screening.summary(),
            "resumed_from_step": self.resumed_from,
            "environment": environment_info(),
            "files": sorted(set(files)),
        }
        if self.reservoir is not None:
            summary["reservoir"] = self.reservoir.summary()
        return summary


def prepare(scene, outdir=None, *, resume: bool = False, progress: bool = True,
            outputs=None, model=None, log=print, plots=None, overwrite: bool = False,
            out_key: str | None = None) -> Analysis:
    """Everything a run of ``scene`` needs, built and checked; nothing solved yet.

    outdir: the results folder (default ``scene.output.dir``), created and probed for writing,
    then locked for this run (``run.folder``: a second run into it is refused naming this
    process); resume: continue from its last checkpoint (ValueError naming the key when the
    scene differs from the checkpoint's, or naming the damaged checkpoint); overwrite: a
    folder that holds a finished run or a checkpoint may be used (else refused: nothing is
    deleted unasked), its checkpoints removed now, its results replaced when this run
    finishes (a run that fails leaves them as they were); out_key: the name of ``outdir`` in
    messages (the command line's ``--out``);
    progress: a progress bar and log lines through ``log``; outputs: what the output stage
    writes (``run.outputs.Outputs``; ``post.RunOutputs()`` the standard files; None: only
    the run's own files, summary.json, final_state.npz and the checkpoints); model: a
    prebuilt model of this scene (tests, studies). plots: no longer taken here (the figures
    are the output stage's): a clear error names its replacement."""
    if plots is not None:
        raise TypeError(f"prepare(plots={plots!r}): the figures are the output stage's; pass "
                        f"outputs=ngs_driver.post.outputs.RunOutputs(plots={plots!r})")
    t0 = time.perf_counter()
    gm = validate(scene)                      # nothing is written for a bad scene
    inputs = resolve(scene, gm)               # the scene resolved once (setup.inputs)
    key = out_key or ("outdir" if outdir is not None else "output.dir")
    out = pathlib.Path(outdir if outdir is not None else inputs.output.dir)
    probe_writable(out, key)                  # created and writable before any work
    lock = FolderLock(out, key).acquire()     # one run per folder (docs/run.md §6)
    try:
        why = reuse_error(out, resume=resume, overwrite=overwrite, key=key)
        if why is not None:
            raise FolderError(why)
        checkpoints = Checkpointer(out, inputs.output.checkpoint_every)
        restart = _restart(out, checkpoints, inputs.scene_dict) if resume else None
        for note in checkpoints.notes:        # a damaged newest checkpoint passed over
            log(f"[{inputs.name}] warning: {note}")
        clean_temporaries(out)                # a killed run's half-written files
        previous = finished_files(out)
        if overwrite and not resume:          # asked for: the old checkpoints go now, the
            checkpoints.remove_all()          # finished run's files at the end (finish)
        t = time.perf_counter()
        if model is None:
            model = build_from_inputs(model_inputs(scene))
        t_build = time.perf_counter() - t
        a = Analysis(scene, inputs, out, gm, model, checkpoints, restart, progress=progress,
                     outputs=outputs, log=log, t0=t0, t_build=t_build)
        a.lock, a.previous_files = lock, previous
        a.outputs.start(a)
    except BaseException:
        lock.release()
        raise
    return a
