"""A dam analysis with a life cycle: ``prepare`` builds everything a run needs, then
``static()``, ``step()`` until it returns False, ``finish()``::

    a = prepare(scene, outdir)
    a.static()                 # the pre-earthquake state (or the state of the checkpoint)
    while a.step():            # one step of the record
        pass
    summary = a.finish()       # outputs, post-earthquake check, summary.json

``prepare`` validates the scene (``setup.validate``: laws, record) before anything is
written, builds the model (``fe.model.build_from_scene``: the section, its lift joints, the
foundation), one interface law per joint with its size-scale state (``run.joints``), Rayleigh
damping from the modal analysis (``run.damping``) and the condensed ``JointSolver`` (all
joints in one gap vector). The static state (dead load + reservoir + tailwater + uplift) is
solved with the interface laws and committed; then the ground motion enters as the effective
load

    f(t) = f_static - M (r_x a_x(t) + r_y a_y(t))

(relative formulation: rock bottom fixed, displacements relative to the rigid ground motion;
with absorbing rock boundaries the displacements are total and the record enters as
free-field forces, ``fe.foundation.AbsorbingRock``). Every step records the crest, the
solver's work, each joint's measures, its sliding safety and the energy budget
(``run.energy``) in the history (``run.history``).

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

import pathlib
import time

import numpy as np
from numba import njit

from .store import atomic_savez, atomic_write_json, environment_info
from ..setup import FORMULATION, characteristic_times, law_parts, validate, window_note
from ..solve.joint_laws import initial_stiffness, law_stiffness
from . import summary as sm
from .checkpoint import (Checkpointer, interface_state, restore_solver_arrays,
                         resume_difference, solver_arrays)
from .damping import damping_matrix, low_rank_damping, modes_to_compute, rayleigh_damping
from .energy import GUARD_SPLITS, EnergyBudget, EnergyGuard
from .folder import (FolderError, FolderLock, clean_temporaries, finished_files, probe_writable,
                     reuse_error)
from .history import HIST_KEYS, History, Snapshots, results_from_history
from .joints import Joints
from .outputs import Outputs
from .post_earthquake import PostEarthquakeCheck
from .safety import FS_DEFINITION, SlidingSafety
from .statics import solve_pre_earthquake
from .rotation import FiniteRotation
from .sliding import JointPairing
from .stopping import CollapseRule
from .uplift import Uplift

__all__ = ["prepare", "Analysis", "seismic_load"]


@njit(cache=True)
def seismic_load(f_static, Mrx, Mry, ax, ay):
    """f_static - Mrx ax - Mry ay in one loop (numpy's three operations, in their order)."""
    f = np.empty(f_static.size)
    for i in range(f.size):
        f[i] = f_static[i] - Mrx[i] * ax - Mry[i] * ay
    return f


def make_solver(scene, model, C, law, C_lowrank=None, coupled=None):
    """The joint solver of the scene's [time] (integrator) and [solver] keys; C_lowrank:
    the low-rank part of the damping (``run.damping.low_rank_damping``); coupled: the
    reservoir's water (solve/coupled.py) or None."""
    from ..solve.integrator import Integrator
    from ..solve.joint_solver import JointSolver
    ts, sv = scene.time, scene.solver
    integrator = Integrator.make(ts.integrator, rho_inf=ts.rho_inf, beta=ts.newmark_beta,
                                 gamma=ts.newmark_gamma)
    return JointSolver(model.K, model.M, C, model.interface.B, model.interface.w, law,
                       dt=ts.dt, integrator=integrator, C_lowrank=C_lowrank,
                       tol_residual=sv.tol_residual, max_iter=sv.max_iter,
                       stall_iterations=sv.stall_iterations, min_dt=sv.min_dt, coupled=coupled)


def _restart(scene, out, ckp, scene_d):
    """(meta, arrays) of the checkpoint in ``out``; ValueError naming the first key whose
    value differs when the checkpoint was written for another scene."""
    meta, arrs = ckp.load()          # FileNotFoundError / CheckpointDamaged, clear messages
    diff = resume_difference(meta.get("scene") or {}, scene_d)
    if diff is not None:
        raise ValueError(f"--resume: the checkpoint in {out} was written for a different "
                         f"scene: {diff}; allowed: the same scene and overrides as the "
                         "interrupted run")
    return meta, arrs


class Analysis:
    """One dam run: built by ``prepare``, driven by ``static()``, ``step()``, ``finish()``.

    Public attributes: ``scene``, ``out`` (results folder), ``model``, ``joints``,
    ``solver``, ``modal``, ``damping`` (the Rayleigh dict), ``gm`` (the ground motion),
    ``times``, ``n_steps``, ``k`` (steps done), ``history``, ``snapshots``, ``energy``,
    ``uplift``, ``safety``, ``screening``, ``absorbing``, ``reservoir``, ``stopped`` (None
    or the stop rule's entry), ``static_info``, ``lock`` (the results folder's
    ``run.folder.FolderLock``, released by ``finish`` or ``release()``), ``previous_files``
    (the files of the finished run this one replaces, or None)."""

    def __init__(self, scene, out, gm, model, checkpoints, restart, *, progress, outputs, log,
                 t0, t_build):
        from ..fe.modal import k0_from_scene, modal_analysis

        self.scene, self.out, self.gm, self.model = scene, out, gm, model
        self.progress, self.log = progress, log
        self.outputs = outputs if outputs is not None else Outputs()
        self._t0 = t0
        self.scene_d = scene.to_dict()
        self.checkpoints = checkpoints
        self.lock = None                  # the results folder's lock (``prepare``)
        self.previous_files = None        # the files of a finished run this one replaces
        self._restart = restart
        resume = restart is not None
        self.timings = {"build": t_build}

        # ---- joints, loads besides gravity and water, safety measures ------------------------
        iface = model.interface
        self.joints = joints = Joints(scene, iface)
        self.uplift = Uplift(scene, iface, joints)
        self.safety = SlidingSafety(joints)
        self.absorbing = None                # fe.foundation.AbsorbingRock
        if scene.geometry.rock_sides == "absorbing":
            from ..fe.foundation import AbsorbingRock
            self.absorbing = AbsorbingRock(model, scene.materials.rock, gm,
                                           scene.ground_motion.start)
        self.screening = None
        if scene.screening.enabled:
            from .screening import Screening
            self.screening = Screening(scene, model)
        from ..fe.loads import tailwater_load
        u = scene.uplift
        f_tail = tailwater_load(model, u.tailwater, scene.loads.water_density,
                                scene.loads.gravity)
        self.post_check = PostEarthquakeCheck(scene, model, joints, self.safety, self.uplift,
                                              self.absorbing)
        self.reference = sm.reference_parameters(scene, joints)
        kn_s, kt_s = k0_from_scene(scene)
        k0n, k0t = law_stiffness(joints.laws[0])
        assert abs(kn_s - k0n) <= 1e-9 * k0n and abs(kt_s - k0t) <= 1e-9 * k0t

        # ---- modal analysis, damping, solver ---------------------------------------------------
        t = time.perf_counter()
        k0p = initial_stiffness(joints.solver_law(), iface.npts)    # each joint its own k0
        self.modal = modal_analysis(self._modal_model(), modes_to_compute(scene), k0p[:, 0],
                                    k0p[:, 1])
        self.damping = rayleigh_damping(self.modal, scene,
                                        None if self._restart is None else self._restart[0])
        self.timings["modal"] = time.perf_counter() - t
        C = damping_matrix(model, self.damping, self.absorbing)
        self.low_damping = low_rank_damping(model, joints, self.damping)
        # finite sliding: the joints that slide on a deformable face are paired anew
        self.pairing = JointPairing(model, joints.slices, joints.names, model.interface.B,
                                    scene.solver.pairing_tolerance)

        # ---- the record on the time grid, the loads ---------------------------------------------
        ts = scene.time
        self.n_steps = int(round(ts.duration / ts.dt))
        self.times = ts.dt * np.arange(self.n_steps + 1)
        self.ax, self.ay = gm.at(scene.ground_motion.start + self.times)
        Mrx, Mry = model.M @ model.r_x, model.M @ model.r_y
        self.reservoir = None
        if getattr(model, "reservoir", None) is not None:   # hydrodynamics (fe/reservoir.py)
            from .reservoir import ReservoirRun
            Mrx, Mry = model.reservoir.seismic_vectors(Mrx, Mry)
            self.reservoir = ReservoirRun.create(model, scene, self.times, self.ax, self.ay,
                                                 restart, out)
        # the solver, with the reservoir's water as its coupled field (solve/coupled.py)
        self.solver = solver = make_solver(
            scene, model, C, joints.solver_law(), self.low_damping,
            coupled=None if self.reservoir is None else self.reservoir.field)
        if self.reservoir is not None:
            self.reservoir.solver = solver
        cracked = joints.cracked_points()
        if cracked.any():                # joints that start cracked: no cohesion
            st0 = solver.state.copy()
            st0.kappa[cracked] = 1.0
            solver.set_state(st0)
        self.f_base = model.f_gravity + model.f_water + (np.zeros(model.nfree) if f_tail is None
                                                         else f_tail)
        if self.absorbing is not None:       # total displacements: the record enters as
            Mrx, Mry = 0.0 * Mrx, 0.0 * Mry  # free-field forces (``step``)
        self.Mrx, self.Mry = Mrx, Mry
        self.f_reaction = np.zeros(model.nfree)   # support reactions (absorbing rock)
        self.f_static = None
        self.chars = characteristic_times(scene, joints.reference[0].cohesive.l_Nc)
        # C = a0 M + a1 K (+ dashpots): the budget's damping work needs no product with C
        self.energy = EnergyBudget(
            model.K, model.M, C, iface.w, joints,
            rayleigh=(self.damping["a0"], self.damping["a1"]),
            C_extra=None if self.absorbing is None else self.absorbing.C,
            fluid=None if self.reservoir is None else self.reservoir.stepper,
            added_mass=getattr(getattr(model, "reservoir", None), "added_mass", None),
            C_lowrank=self.low_damping)
        # the wall time stays the last column (everything before it is deterministic)
        self.history_keys = (list(HIST_KEYS[:-1]) + joints.history_keys()
                             + self.safety.history_keys() + self.energy.keys() + ["wall"])
        self.stop_rule = CollapseRule(model, joints, ts.max_slip, ts.max_rotation,
                                      scene.solver.kinematics)
        # finite rotations of the blocks (run/rotation.py; off: the small-rotation kinematics)
        self.rotation = (FiniteRotation(model, joints, solver, self.Mrx, self.Mry)
                         if scene.solver.kinematics == "finite_rotation" else None)
        self.collapse = None
        self.undetermined = None             # the stop entry when the model's range was left
        self.window_note = window_note(scene, gm)
        self.snapshots = Snapshots(self.n_steps, scene.output.snapshots)
        self.history = None
        self.static_info = None
        self.stopped = None
        self.k = 0
        self.resumed_from = None
        self._bar = None
        self._t_loop = None
        self._wall_before = 0.0
        self._n_cuts, self._n_cuts_at = 0, 0
        if progress:
            c = self.chars
            log(f"[{scene.name}] nfree {model.nfree}, joints {', '.join(joints.names)} "
                f"({iface.npts} interface points), f1 = {self.modal.frequencies_hz[0]:.3f} Hz, "
                f"a0 = {self.damping['a0']:.4g} 1/s, a1 = {self.damping['a1']:.4g} s; t1 = "
                f"{c['t1']:.3e} s, t2 = {c['t2']:.3e} s (Eq. 11); record: {gm.label}"
                f"{' [SYNTHETIC]' if gm.synthetic else ''}")
            if self.window_note:
                log(f"[{scene.name}] note: {self.window_note}")

    def _modal_model(self):
        """The model the modal analysis sees: with absorbing (unsupported) rock boundaries,
        the static support springs (the dashpots have no stiffness)."""
        if self.absorbing is None:
            return self.model
        import dataclasses
        return dataclasses.replace(self.model,
                                   K=(self.model.K + self.absorbing.K_support).tocsr())

    def _update_laws(self, state, book_energy=True, scan=None):
        """Size-scale update of every joint's law from its failed length (paper §2)."""
        old = list(self.joints.laws)
        if self.joints.update(state, scan):
            self.solver.set_law(self.joints.solver_law())
            if book_energy:
                self.energy.law_update(old, self.solver.g, state)

    # ------------------------------------------------------------------ static state
    def static(self) -> dict:
        """The pre-earthquake static state (or, resuming, the state of the checkpoint);
        returns ``static_info`` (summary.json ``static``)."""
        if self._restart is not None:
            return self._resume()
        solver, scene = self.solver, self.scene
        t = time.perf_counter()
        rep, self.f_static, self.f_reaction = solve_pre_earthquake(solver, self.f_base,
                                                                   self.uplift, self.absorbing)
        if self.screening is not None:
            self.screening.static(solver.u)
        t_static = time.perf_counter() - t
        ax0, ay0 = self.ax[0], self.ay[0]
        if scene.geometry.foundation == "massless":      # M singular on the rock
            from ..solve.massless import initial_acceleration, massless_dofs
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
        self.history = History(self.history_keys)
        self.snapshots.take(0, 0.0, solver)
        # Fig. 12 shows the state of the largest heel opening while the base still holds
        self.heel = {"u": self.u_static.copy(), "t": 0.0, "open": float(solver.g[0, 0])}
        self.energy.start(solver.u, solver.v, solver.f, solver.t, solver.g, solver.state)
        self.guard = EnergyGuard(0.5 * float(solver.u @ self.f_static),
                                 fraction=scene.solver.energy_guard)
        self.guard.start()
        self.joints.set_reference(solver.g)       # slip and rotation from the static state
        self._update_laws(solver.state)            # the sizes for step 1
        self._prepare_loop()
        return self.static_info

    def _resume(self) -> dict:
        meta, arrs = self._restart
        solver = self.solver
        solver.state = interface_state(arrs)
        self._update_laws(solver.state, book_energy=False)
        restore_solver_arrays(solver, arrs, meta["time"])
        self.static_info = meta["static"]
        self.uplift.restore(arrs)
        self.f_reaction = np.array(arrs["f_reaction"])
        if self.screening is not None:
            self.screening.restore(arrs)
        self.safety.static = (self.static_info or {}).get("joints")
        extra = self.f_reaction.copy()
        if self.uplift.active:
            extra += self.uplift.load(self.uplift.p_static)
        self.f_static = self.f_base + extra
        self.timings["static"] = self.static_info["wall"]
        self.u_static = arrs["u_static"]
        self.history = History.from_arrays(arrs, self.history_keys)
        self.snapshots.restore(arrs)
        self.heel = {"u": arrs["heel_u"], "t": float(meta["heel_t"]),
                     "open": float(meta["heel_open"])}
        self.energy.restore(arrs)
        self.guard = EnergyGuard(fraction=self.scene.solver.energy_guard)
        self.guard.restore(meta.get("guard") or {},
                           {kk: c[-1] for kk, c in self.history.cols.items()}
                           if len(self.history) else None)
        self.joints.static_motion = arrs["joints_static_motion"]
        self.stop_rule.restore(arrs)
        self.pairing.restore(arrs, solver, arrs.get("solver_g_offset") if hasattr(arrs, "get")
                             else None)
        if self.pairing.repairs and self.uplift.active:
            self._operator_changed()
        if self.rotation is not None:
            self.rotation.restore(arrs, solver)
        self.k = self.resumed_from = int(meta["step"])
        self._wall_before = float(meta["dynamic_wall"])
        if self.progress:
            self.log(f"[{self.scene.name}] resuming from step {self.k} "
                     f"(t = {self.k * self.scene.time.dt:.4g} s)")
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
        from ..solve.stepping import SolverError

        if self.history is None:
            raise RuntimeError("Analysis.step: call static() first")
        if self.done:
            return False
        if self._bar is None:
            self._start_loop()
        solver, joints, scene = self.solver, self.joints, self.scene
        k = self.k + 1
        tk = self.times[k]
        f_k = seismic_load(self.f_static, self.Mrx, self.Mry, self.ax[k], self.ay[k])
        if self.absorbing is not None:
            f_k = f_k + self.absorbing.force(solver.time + solver.dt)
        if self.rotation is not None:        # the step's gap offset and P-Delta load
            f_k = f_k + self.rotation.before_step(solver, scene.time.dt, self.ax[k],
                                                  self.ay[k])
            self.energy.rebase_gap(solver.operator_gap())   # the offset books no work
        snap = self._snapshot()
        split, cuts, failed = 0, 0, 0
        while True:
            try:
                rep, f_used = self.uplift.step(solver, f_k, split)  # f_used: with the uplift
            except SolverError as e:
                raise SolverError(f"{scene.name}: step {k} (t = {tk:.4f} s): {e}") from None
            st = solver.state
            # the per-point work of the joints', energy's and safety's measures, once
            scan = joints.scan(st, solver.g, solver.t)
            # K u, M v from the solver's pass that also forms the next step's right-hand side
            # (the budget and the solver are built on the same model.K, model.M)
            en = self.energy.step(solver.u, solver.v, f_used, solver.t, solver.g, st, scan,
                                  products=solver.step_products())
            ok, why = self.guard.check(en, tk)       # (fraction 0: the guard is off)
            if ok:
                break
            # the step broke the energy balance: never accepted; repeated from the committed
            # state in 2, 4, ... uniform sub-steps (run.energy.EnergyGuard)
            cuts += rep.cuts + 1
            failed += rep.iterations + rep.iterations_failed
            split += 1
            if split > GUARD_SPLITS:
                raise SolverError(f"{scene.name}: step {k} (t = {tk:.4f} s): {why}, even in "
                                  f"{2 ** GUARD_SPLITS} sub-steps; committed state is at "
                                  f"t = {self.times[k - 1]:.6g} s")
            self._restore(snap)
        rep.cuts += cuts
        rep.iterations_failed += failed
        f_k = f_used
        if self.screening is not None:
            self.screening.update(solver.u, solver.time, solver.dt)
        self.k = k
        if self.reservoir is not None:
            self.reservoir.sample(k, tk)
        jm = joints.measures(st, solver.g, scan)
        cx, cy = self.model.crest_dofs
        self.history.append(
            step=k, t=tk, crest_ux=solver.u[cx], crest_uy=solver.u[cy],
            iterations=rep.iterations, iterations_failed=rep.iterations_failed, cuts=rep.cuts,
            substeps=len(rep.dts), n_active=rep.n_active, n_debonded=jm["base_n_debonded"],
            crack_length=jm["base_crack_length"],
            crack_length_heel=jm["base_crack_length_upstream"], max_D=jm["base_max_D"],
            D_heel=float(st.damage[0]), kappa_heel=float(st.kappa[0]),
            size_b=jm["base_size_b"], sigma_max=jm["base_sigma_max"], wall=rep.wall, **jm,
            **en, **self.safety.step_measures(solver.t, st, self.uplift.p, scan))
        self._update_laws(st, scan=scan)       # size-scale update for the next step
        if self.pairing.active and self.pairing.update(solver):   # finite sliding
            self._operator_changed()
            # an opened point's gap jumps by OPEN_GAP with no motion: no work is booked
            self.energy.rebase_gap(solver.operator_gap())
        if self.snapshots.due(k):
            self.snapshots.take(k, tk, solver)
        self.outputs.step(self, k, tk)
        self._show(k, rep, jm)
        base = joints.slices[0]
        if jm["base_n_debonded"] < base.stop - base.start and solver.g[0, 0] > self.heel["open"]:
            self.heel = {"u": solver.u.copy(), "t": float(tk), "open": float(solver.g[0, 0])}
        coll = None if self.rotation is None else self.rotation.after_step(
            solver, k, tk, self._static_loads)
        if coll is None:
            coll = self.stop_rule.check(k, tk, scene.time.dt, jm, self._static_loads, joints,
                                        scan)
        if coll is not None:
            verdict = coll.pop("verdict")
            if verdict == "collapse":
                self.collapse = coll
            else:                          # the model's range left (run.stopping)
                self.undetermined = coll
            self.stopped = {"reason": f"{verdict}: {coll['reason']}", "t": coll["time"],
                            "step": k, "verdict": verdict}
        if self.stopped is not None:
            if self.progress:
                self._bar.write(f"[{scene.name}] stopped at t = {tk:.3f} s: "
                                + self.stopped["reason"])
            return False
        if self.checkpoints.due(k):
            self._checkpoint(k)
            # a run resumed here starts with a fresh solver: the uninterrupted run drops
            # what the solver carries besides the committed state (a reused Jacobian)
            solver.forget_jacobian()
        return k < self.n_steps

    def _snapshot(self):
        """What a step changes, to repeat it (the energy guard): the solver's committed state
        with its coupled water's (``JointSolver.checkpoint``), the uplift in force and the
        energy budget's accumulators."""
        # the solver's arrays by reference (``checkpoint(copy=False)``): restored at once
        return (self.solver.checkpoint(copy=False), self.uplift.field.p, self.energy.state())

    def _restore(self, snap):
        sv, p, budget = snap
        self.solver.restore(sv)
        self.uplift.field.p = p
        self.energy.restore(budget)

    def _static_loads(self):
        """Gravity, water and tailwater with the uplift now (the collapse rule's FS_static)."""
        return self.f_base + (self.uplift.load(self.uplift.p) if self.uplift.active else 0.0)

    def _start_loop(self):
        from tqdm import tqdm
        sc = self.scene
        # disable=None: tqdm turns itself off when stderr is not a terminal (logs stay readable)
        self._bar = tqdm(total=self.n_steps, initial=self.k,
                         disable=None if self.progress else True, unit="step",
                         desc=f"{sc.name} a={sc.interface.alpha:g}", dynamic_ncols=True)
        self._t_loop = time.perf_counter()

    def _show(self, k, rep, jm):
        self._bar.update(1)
        if self.progress and (k % 10 == 0 or k == self.n_steps):
            # the cuts so far: a running sum (summing the whole column is O(k) per call)
            self._n_cuts += int(np.sum(self.history.cols["cuts"][self._n_cuts_at:]))
            self._n_cuts_at = len(self.history)
            self._bar.set_postfix_str(f"t={self.times[k]:.3f}s it={rep.iterations} "
                                      f"cuts={self._n_cuts} "
                                      f"crack={jm['base_crack_length_upstream']:.3f}m "
                                      f"Dheel={self.solver.state.damage[0]:.3f}",
                                      refresh=False)

    def _dynamic_wall(self) -> float:
        return self._wall_before + (0.0 if self._t_loop is None
                                    else time.perf_counter() - self._t_loop)

    def _checkpoint(self, k):
        solver = self.solver
        arrays = {**solver_arrays(solver), "u_static": self.u_static, "heel_u": self.heel["u"],
                  "f_reaction": self.f_reaction, **self.energy.state(),
                  **self.uplift.checkpoint_arrays(), **self.stop_rule.state(),
                  **self.pairing.state(), "joints_static_motion": self.joints.static_motion,
                  **({} if self.rotation is None else self.rotation.checkpoint())}
        if self.screening is not None:
            arrays.update(self.screening.checkpoint_arrays())
        if self.reservoir is not None:             # the water state, in the same set
            arrays.update(self.reservoir.checkpoint_arrays())
        arrays.update({f"hist_{kk}": vv for kk, vv in self.history.arrays().items()})
        arrays.update(self.snapshots.arrays())
        self.checkpoints.save(k, {"scene": self.scene_d, "time": solver.time,
                                  "static": self.static_info, "heel_t": self.heel["t"],
                                  "heel_open": self.heel["open"],
                                  "rayleigh": {"a0": self.damping["a0"],
                                               "a1": self.damping["a1"]},
                                  "dynamic_wall": self._dynamic_wall(),
                                  "guard": self.guard.state(),
                                  "laws": self.joints.params()}, **arrays)

    def close(self):
        """End the time loop: the progress bar closed, the last checkpoint on disk (written in
        the background). ``finish`` calls it; a caller that stops early calls it itself."""
        if self._bar is not None:
            self._bar.close()
        self.checkpoints.wait()

    # ------------------------------------------------------------------ the end
    def finish(self) -> dict:
        """Outputs, the post-earthquake check and summary.json (written last: the run is
        complete); the checkpoints are removed. Returns the summary dict."""
        self.close()
        self.solver.release_steps()        # memory for the outputs (the loop is over)
        scene, solver, joints, out = self.scene, self.solver, self.joints, self.out
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
        safety_sum = self.safety.summary(H, scene.time.dt)
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
        if self.reservoir is not None:
            self.reservoir.clear_checkpoints()                # the run is complete
        return files

    def _summary(self, H, post, safety_sum, files) -> dict:
        scene, model, gm, iface = self.scene, self.model, self.gm, self.model.interface
        snaps = self.snapshots.data
        summary = {
            "scene": self.scene_d,
            "label": gm.label + (" [SYNTHETIC]" if gm.synthetic else ""),
            "ground_motion": sm.ground_motion_summary(scene, gm, self.window_note),
            "formulation": FORMULATION,
            "stopped": self.stopped,
            "verdict": ("collapse" if self.collapse is not None else "undetermined"
                        if self.undetermined is not None else "no_collapse"),
            "collapse": self.collapse,
            "undetermined": self.undetermined,
            "finite_sliding": {"joints_paired": [j[0] for j in self.pairing.joints],
                               "repairings": int(self.pairing.repairs),
                               "tolerance": scene.solver.pairing_tolerance},
            "crest_point": list(model.crest_point),
            "crest_displacement_note": "upstream crest corner, relative to the rigid ground "
                                       "(rock bottom); includes the static displacement",
            "mesh": model.summary(),
            "dofs": {"nfree": int(model.nfree), "ndof": int(model.ndof),
                     "interface_points": int(iface.npts)},
            "frequencies_hz": [float(f) for f in self.modal.frequencies_hz],
            "rayleigh": self.damping,
            "law": law_parts(scene),
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
    key = out_key or ("outdir" if outdir is not None else "output.dir")
    out = pathlib.Path(outdir if outdir is not None else scene.output.dir)
    probe_writable(out, key)                  # created and writable before any work
    lock = FolderLock(out, key).acquire()     # one run per folder (docs/solver.md §8.5)
    try:
        why = reuse_error(out, resume=resume, overwrite=overwrite, key=key)
        if why is not None:
            raise FolderError(why)
        checkpoints = Checkpointer(out, scene.output.checkpoint_every)
        restart = _restart(scene, out, checkpoints, scene.to_dict()) if resume else None
        for note in checkpoints.notes:        # a damaged newest checkpoint passed over
            log(f"[{scene.name}] warning: {note}")
        clean_temporaries(out)                # a killed run's half-written files
        previous = finished_files(out)
        if overwrite and not resume:          # asked for: the old checkpoints go now, the
            checkpoints.remove_all()          # finished run's files at the end (finish)
        t = time.perf_counter()
        if model is None:
            from ..fe.model import build_from_scene
            model = build_from_scene(scene)
        t_build = time.perf_counter() - t
        a = Analysis(scene, out, gm, model, checkpoints, restart, progress=progress,
                     outputs=outputs, log=log, t0=t0, t_build=t_build)
        a.lock, a.previous_files = lock, previous
        a.outputs.start(a)
    except BaseException:
        lock.release()
        raise
    return a
