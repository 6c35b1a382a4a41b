"""A dam run: static state, then the record, step by step (the orchestration only).

``run(scene, outdir)`` validates the scene (``setup.validate``: laws, record) before anything
is written, builds the model (``fe.model.build_from_scene``: the section, its lift joints,
the foundation), one interface law per joint with its size-scale state (``run.joints``),
Rayleigh damping from the modal analysis (C = a0 M + a1 K, bulk K only) and the condensed
``NewmarkSolver`` (all joints in one gap vector).  The static state (dead load + reservoir)
is solved with the interface laws and committed; then the ground motion enters as the
effective load

    f(t) = f_static - M (r_x a_x(t) + r_y a_y(t))

(relative formulation: rock bottom fixed, displacements relative to the rigid ground motion).
Every step records the crest, the solver's work, each joint's measures and the energy budget
(``run.energy``).

Outputs (``out``): summary.json (written last, atomically), timeseries.csv,
damage_profiles[_<joint>].csv, final_state.npz, PNGs, optional VTK; checkpoint.json/.npz every
``output.checkpoint_every`` steps; ``resume=True`` continues from the last checkpoint and gives
the same results as an uninterrupted run.
"""
from __future__ import annotations

import gc
import json
import pathlib
import time

import numpy as np
from numba import njit

from ..out.files import atomic_savez, atomic_write_json, environment_info
from ..setup import FORMULATION, characteristic_times, law_parts, validate
from ..solve.joint_laws import initial_stiffness
from .checkpoint import Checkpointer
from .energy import EnergyBudget
from .joints import JointSet
from .record import HIST_KEYS, History, results_from_history, snapshot_steps
from .safety import Safety


@njit(cache=True)
def _seismic_load(f_static, Mrx, Mry, ax, ay):
    """f_static - Mrx ax - Mry ay in one loop (numpy's three operations, in their order)."""
    f = np.empty(f_static.size)
    for i in range(f.size):
        f[i] = f_static[i] - Mrx[i] * ax - Mry[i] * ay
    return f


class RunInterrupted(RuntimeError):
    """Raised by ``run(..., max_steps=k)`` after k steps (test hook for stop/resume)."""


def run(scene, outdir=None, resume: bool = False, progress: bool = True,
        max_steps: int | None = None, model=None, plots: bool = True,
        log=print) -> dict:
    """Run the scene; returns the summary dict (also written to ``outdir/summary.json``).

    max_steps: stop (``RunInterrupted``) after this many dynamic steps of this call, with the
    checkpoint written if one is due (test hook for stop/resume).  model: a prebuilt model
    of this scene (tests).  plots: False skips PNG/VTK output (tests)."""
    # Python's full garbage collections scan every object alive (numba, NGSolve, the model:
    # ~0.1-0.2 s each, a few per run while matplotlib imports and draws): the objects that
    # exist when the time loop starts are moved out of their reach (gc.freeze) and given back
    # when the run ends (gc.unfreeze), so nothing is kept longer than before.
    mine = gc.get_freeze_count() == 0
    try:
        return _run(scene, outdir, resume, progress, max_steps, model, plots, log,
                    freeze=mine)
    finally:
        if mine:
            gc.unfreeze()


def _run(scene, outdir, resume, progress, max_steps, model, plots, log, freeze) -> dict:
    from ..fe.modal import damping_from_modes, k0_from_scene, modal_analysis
    from ..out.results import write_run_outputs
    from ..out import vtk as outvtk
    from ..out.report import format_summary
    from ..solve.newmark import NewmarkSolver, SolverError

    T0 = time.perf_counter()
    gm = validate(scene)                      # nothing is written for a bad scene
    out = pathlib.Path(outdir if outdir is not None else scene.output.dir)
    ckp = Checkpointer(out, scene.output.checkpoint_every)
    summary_path = out / "summary.json"
    scene_d = scene.to_dict()
    ck = None
    if resume:
        meta, arrs = ckp.load()          # FileNotFoundError with a clear message
        if meta.get("scene") != json.loads(json.dumps(scene_d)):
            raise ValueError(f"--resume: the checkpoint in {out} was written for a different "
                             "scene (or different --set values); allowed: the same scene and "
                             "overrides as the interrupted run")
        ck = (meta, arrs)
    out.mkdir(parents=True, exist_ok=True)
    stale = [summary_path] if resume else [summary_path, ckp.meta_path,
                                           *out.glob("checkpoint_*.npz")]
    for p in stale:                      # nothing of a previous run may look complete
        if p.exists():
            p.unlink()

    # ---- model, laws, damping ---------------------------------------------------------------
    t = time.perf_counter()
    if model is None:
        from ..fe.model import build_from_scene
        model = build_from_scene(scene)
    t_build = time.perf_counter() - t
    iface = model.interface
    w = iface.w
    joints = JointSet(scene, iface)
    safety = Safety(scene, model, joints, gm)  # uplift, forces, FS, foundation (issue #13)
    safety.set_dof_masks(model)
    base = joints.slices[0]
    ref_coh = joints.reference[0].cohesive
    k0n, k0t = joints.laws[0].cohesive.k_normal, joints.laws[0].cohesive.k_tangential
    kn_s, kt_s = k0_from_scene(scene)
    assert abs(kn_s - k0n) <= 1e-9 * k0n and abs(kt_s - k0t) <= 1e-9 * k0t

    t = time.perf_counter()
    k0p = initial_stiffness(joints.solver_law(), iface.npts)    # each joint its own k0
    modal = modal_analysis(safety.modal_model(model), 6, k0p[:, 0], k0p[:, 1])
    d = scene.damping
    damp = damping_from_modes(modal, d.ratio, d.modes, d.frequencies or None)
    # ARPACK's random start vector changes the last bits of the eigenvalues from call to call:
    # round a0, a1 to 10 significant digits so that runs (and restarts) are bitwise repeatable
    damp["a0_unrounded"], damp["a1_unrounded"] = damp["a0"], damp["a1"]
    damp["a0"], damp["a1"] = float(f"{damp['a0']:.10g}"), float(f"{damp['a1']:.10g}")
    if ck is not None and "rayleigh" in ck[0]:
        damp["a0"], damp["a1"] = ck[0]["rayleigh"]["a0"], ck[0]["rayleigh"]["a1"]
    t_modal = time.perf_counter() - t
    C = (damp["a0"] * model.M + damp["a1"] * model.K).tocsr()
    if safety.absorbing is not None:           # Lysmer-Kuhlemeyer dashpots (#13)
        C = (C + safety.absorbing.C).tocsr()
    ts, sv = scene.time, scene.solver
    solver = NewmarkSolver(model.K, model.M, C, iface.B, w, joints.solver_law(), dt=ts.dt,
                           beta=ts.newmark_beta, gamma=ts.newmark_gamma,
                           tol_residual=sv.tol_residual, max_iter=sv.max_iter,
                           min_dt=sv.min_dt)
    n_steps = int(round(ts.duration / ts.dt))
    times = ts.dt * np.arange(n_steps + 1)
    ax, ay = gm.at(scene.ground_motion.start + times)
    Mrx, Mry = model.M @ model.r_x, model.M @ model.r_y
    rres = None
    if getattr(model, "reservoir", None) is not None:     # hydrodynamics (fe/reservoir.py)
        from ..out.reservoir_outputs import ReservoirRun
        Mrx, Mry = model.reservoir.seismic_vectors(Mrx, Mry)
        rres = ReservoirRun.create(model, scene, solver, times, ax, ay, resume, out)
        if plots and scene.output.vtk_every > 0:
            rres.enable_vtk(out)
    f_base = model.f_gravity + model.f_water + safety.extra_static_load(model.nfree)
    if safety.absorbing is not None:           # total displacements: the record enters as
        Mrx, Mry = 0.0 * Mrx, 0.0 * Mry        # free-field forces (safety.step)
    f_static = f_base                          # + the static uplift, once it is known
    cx, cy = model.crest_dofs
    chars = characteristic_times(scene, ref_coh.l_Nc)
    # C = a0 M + a1 K (+ dashpots): the budget's damping work needs no product with C
    energy = EnergyBudget(model.K, model.M, C, w, joints, rayleigh=(damp["a0"], damp["a1"]),
                          C_extra=None if safety.absorbing is None else safety.absorbing.C)
    # the wall time stays the last column (everything before it is deterministic)
    hist_keys = (list(HIST_KEYS[:-1]) + joints.history_keys() + safety.history_keys()
                 + energy.keys() + ["wall"])
    if progress:
        log(f"[{scene.name}] nfree {model.nfree}, joints {', '.join(joints.names)} "
            f"({iface.npts} interface points), f1 = {modal.frequencies_hz[0]:.3f} Hz, a0 = "
            f"{damp['a0']:.4g} 1/s, a1 = {damp['a1']:.4g} s; t1 = {chars['t1']:.3e} s, "
            f"t2 = {chars['t2']:.3e} s (Eq. 11); record: {gm.label}"
            f"{' [SYNTHETIC]' if gm.synthetic else ''}")

    snap_steps = snapshot_steps(n_steps, scene.output.snapshots)
    vtk = None
    if plots and scene.output.vtk_every > 0:
        vtk = outvtk.VTKWriter(model, out / "vtk" / "dam", joints)

    def update_laws(state, book_energy=True, scan=None):
        old = list(joints.laws)
        if joints.update(state, scan):
            solver.set_law(joints.solver_law())
            if book_energy:
                energy.law_update(old, solver.g, state)

    def snapshot(snaps, k, tk):
        st = solver.state
        for key, val in (("step", k), ("t", float(tk)), ("D", st.damage.copy()),
                         ("kappa", st.kappa.copy()), ("opening", solver.g[:, 0].copy()),
                         ("slip", solver.g[:, 1].copy())):
            snaps[key].append(val)

    # ---- static state or restart -----------------------------------------------------------
    if ck is None:
        t = time.perf_counter()
        rep, f_static = safety.solve_static(solver, f_base)
        t_static = time.perf_counter() - t
        if scene.geometry.foundation == "massless":      # M singular on the rock (#13)
            from ..fe.foundation import initial_acceleration, massless_dofs
            initial_acceleration(solver, f_static - Mrx * ax[0] - Mry * ay[0],
                                 massless_dofs(model.M), damp["a1"])
        else:
            solver.initial_acceleration(f_static - Mrx * ax[0] - Mry * ay[0]
                                        + safety.input_force(0.0))
        st = solver.state
        u_static = solver.u.copy()
        tr = solver.t[base]
        static_info = {
            "iterations": rep.iterations, "n_active": rep.n_active, "wall": t_static,
            "crest_ux": float(solver.u[cx]), "crest_uy": float(solver.u[cy]),
            "heel_traction_N": float(tr[0, 0]), "heel_traction_T": float(tr[0, 1]),
            "max_normal_traction": float(tr[:, 0].max()),
            "min_normal_traction": float(tr[:, 0].min()),
            "max_normal_traction_over_sigma_max": float(tr[:, 0].max() / ref_coh.sigma_max),
            "max_kappa": float(st.kappa.max()),
            "max_D": float(st.damage.max()), "D_heel": float(st.damage[0]),
            "elastic": bool(rep.n_active == 0),
            "joints": safety.static_measures(solver),
        }
        hist = History(hist_keys)
        snaps = {k: [] for k in ("step", "t", "D", "kappa", "opening", "slip")}
        snapshot(snaps, 0, 0.0)
        k_start, dyn_wall_before, resumed_from = 0, 0.0, None
        # Fig. 12 shows the state of the largest heel opening while the base still holds
        heel = {"u": u_static.copy(), "t": 0.0, "open": float(solver.g[0, 0])}
        energy.start(solver.u, solver.v, solver.f, solver.t, solver.g, solver.state)
        update_laws(solver.state)            # the sizes for step 1
    else:
        meta, arrs = ck
        from interfacelaw import InterfaceState
        st = InterfaceState.from_dict({k[6:]: v for k, v in arrs.items()
                                       if k.startswith("state_")})
        solver.state = st
        update_laws(st, book_energy=False)
        solver.set_initial(u=arrs["u"], v=arrs["v"], a=arrs["a"], f=arrs["f"])
        # committed internals of the condensed solver (bitwise restart)
        for name in ("t", "g", "_phi", "_active"):
            if f"solver{name}" in arrs and hasattr(solver, name):
                setattr(solver, name, arrs[f"solver{name}"].copy())
        solver.time = float(meta["time"])
        static_info = meta["static"]
        safety.restore(arrs, static_info)
        f_static = f_base + safety.static_extra()
        t_static = static_info["wall"]
        u_static = arrs["u_static"]
        hist = History.from_arrays(arrs, hist_keys)
        snaps = {k: [float(v) if k == "t" else (int(v) if k == "step" else v)
                     for v in arrs[f"snap_{k}"]]
                 for k in ("step", "t", "D", "kappa", "opening", "slip")}
        heel = {"u": arrs["heel_u"], "t": float(meta["heel_t"]),
                "open": float(meta["heel_open"])}
        energy.restore(arrs)
        k_start = int(meta["step"])
        dyn_wall_before = float(meta["dynamic_wall"])
        resumed_from = k_start
        if progress:
            log(f"[{scene.name}] resuming from step {k_start} (t = {k_start * ts.dt:.4g} s)")

    def checkpoint(k, dyn_wall):
        arrays = {"u": solver.u, "v": solver.v, "a": solver.a, "f": solver.f,
                  "u_static": u_static, "heel_u": heel["u"], **energy.state(),
                  **safety.checkpoint_arrays()}
        for name in ("t", "g", "_phi", "_active"):
            if hasattr(solver, name):
                arrays[f"solver{name}"] = np.asarray(getattr(solver, name))
        arrays.update({f"state_{kk}": vv for kk, vv in solver.state.as_dict().items()})
        arrays.update({f"hist_{kk}": vv for kk, vv in hist.arrays().items()})
        arrays.update({f"snap_{kk}": np.asarray(vv) for kk, vv in snaps.items()})
        ckp.save(k, {"scene": scene_d, "time": solver.time, "static": static_info,
                     "heel_t": heel["t"], "heel_open": heel["open"],
                     "rayleigh": {"a0": damp["a0"], "a1": damp["a1"]},
                     "dynamic_wall": dyn_wall, "laws": joints.params()}, **arrays)

    # ---- time loop -----------------------------------------------------------------------
    loads = [np.ascontiguousarray(a, dtype=float) for a in (f_static, Mrx, Mry)]
    if any(a.shape != loads[0].shape or a.ndim != 1 for a in loads):     # _seismic_load
        raise RuntimeError(f"run: load vectors of shapes {[a.shape for a in loads]}")
    f_static, Mrx, Mry = loads
    from tqdm import tqdm

    if freeze:
        gc.freeze()

    # disable=None: tqdm turns itself off when stderr is not a terminal (logs stay readable)
    bar = tqdm(total=n_steps, initial=k_start, disable=None if progress else True, unit="step",
               desc=f"{scene.name} a={scene.interface.alpha:g}", dynamic_ncols=True)
    t_dyn0 = time.perf_counter()
    steps_this_call = 0
    stopped = None
    stop_slip = scene.time.stop_slip
    nb = base.stop - base.start
    n_cuts, n_cuts_at = 0, 0
    try:
        for k in range(k_start + 1, n_steps + 1):
            f_k = _seismic_load(f_static, Mrx, Mry, ax[k], ay[k])
            try:
                rep, f_k = safety.step(solver, f_k)      # f_k: with the uplift used
            except SolverError as e:
                raise SolverError(f"{scene.name}: step {k} (t = {times[k]:.4f} s): {e}") \
                    from None
            st = solver.state
            if rres is not None:
                rres.record(k, times[k])
            # the per-point work of the joints', energy's and safety's measures, once
            scan = joints.scan(st, solver.g, solver.t)
            jm = joints.measures(st, solver.g, scan)
            # K u, M v from the solver's pass that also forms the next step's right-hand side
            # (the budget and the solver are built on the same model.K, model.M)
            en = energy.step(solver.u, solver.v, f_k, solver.t, solver.g, st, scan,
                             products=solver.step_products())
            hist.append(step=k, t=times[k], crest_ux=solver.u[cx], crest_uy=solver.u[cy],
                        iterations=rep.iterations, iterations_failed=rep.iterations_failed,
                        cuts=rep.cuts, substeps=len(rep.dts), n_active=rep.n_active,
                        n_debonded=jm["base_n_debonded"],
                        crack_length=jm["base_crack_length"],
                        crack_length_heel=jm["base_crack_length_upstream"],
                        max_D=jm["base_max_D"], D_heel=float(st.damage[0]),
                        kappa_heel=float(st.kappa[0]), size_b=jm["base_size_b"],
                        sigma_max=jm["base_sigma_max"], wall=rep.wall, **jm, **en,
                        **safety.step_measures(solver.t, st, scan))
            update_laws(st, scan=scan)       # size-scale update for the next step
            if k in snap_steps:
                snapshot(snaps, k, times[k])
            if vtk is not None and k % scene.output.vtk_every == 0:
                vtk.write(solver.u, times[k], solver)
            bar.update(1)
            if progress and (k % 10 == 0 or k == n_steps):
                # the cuts so far: a running sum (summing the whole column is O(k) per call)
                n_cuts += int(np.sum(hist.cols["cuts"][n_cuts_at:]))
                n_cuts_at = len(hist)
                bar.set_postfix_str(f"t={times[k]:.3f}s it={rep.iterations} "
                                    f"cuts={n_cuts} "
                                    f"crack={jm['base_crack_length_upstream']:.3f}m "
                                    f"Dheel={st.damage[0]:.3f}", refresh=False)
            steps_this_call += 1
            ndeb = jm["base_n_debonded"]
            if ndeb < nb and solver.g[0, 0] > heel["open"]:
                heel = {"u": solver.u.copy(), "t": float(times[k]),
                        "open": float(solver.g[0, 0])}
            if stop_slip > 0 and ndeb == nb and abs(jm["base_slip_mean"]) > stop_slip:
                stopped = {"reason": "failure by sliding: the whole base is debonded and its "
                                     f"mean slip {abs(jm['base_slip_mean']):.3g} m exceeds "
                                     f"time.stop_slip = {stop_slip:g} m (small-displacement "
                                     "kinematics no longer hold)",
                           "t": float(times[k]), "step": k}
                if progress:
                    bar.write(f"[{scene.name}] stopped at t = {times[k]:.3f} s: "
                              + stopped["reason"])
                break
            if ckp.due(k):
                checkpoint(k, dyn_wall_before + time.perf_counter() - t_dyn0)
                # a run resumed here starts with a fresh solver: the uninterrupted run drops
                # what the solver carries besides the committed state (a reused Jacobian)
                solver.forget_jacobian()
            if max_steps is not None and steps_this_call >= max_steps and k < n_steps:
                raise RunInterrupted(f"stopped after {steps_this_call} steps (step {k}) by "
                                     "max_steps")
    finally:
        bar.close()
        ckp.wait()                   # the last checkpoint on disk (written in the background)
    t_dynamic = dyn_wall_before + time.perf_counter() - t_dyn0
    if stopped is not None and snaps["step"][-1] != stopped["step"]:   # D(x) where it stopped
        snapshot(snaps, stopped["step"], stopped["t"])

    # ---- outputs -------------------------------------------------------------------------
    H = hist.arrays()
    t_out = time.perf_counter()
    files = write_run_outputs(out, model, scene, gm, H, snaps, solver, u_static,
                                       joints, plots=plots, heel=heel)
    if vtk is not None:
        files.extend(vtk.files())
    atomic_savez(out / "final_state.npz", u=solver.u, v=solver.v, a=solver.a,
                 x=iface.x, y=iface.y, w=iface.w,
                 **{f"state_{kk}": vv for kk, vv in solver.state.as_dict().items()})
    files.append("final_state.npz")
    if rres is not None:
        files.extend(rres.write(out, plots))
    t_outputs = time.perf_counter() - t_out

    res = results_from_history(H, snaps, iface.x[base], w[base])
    # post-earthquake static state from the final interface state (after final_state.npz)
    t_pe = time.perf_counter()
    post = safety.post_earthquake(solver, f_base)
    post["wall"] = time.perf_counter() - t_pe
    safety_sum = safety.summary(H, ts.dt)
    from ..out.safety_plots import write_safety_outputs
    files.extend(write_safety_outputs(out, scene, gm, H, static_info.get("joints"), post,
                                      safety_sum, plots=plots, screening=safety.screening))
    walls = H["wall"]
    summary = {
        "scene": scene_d,
        "label": gm.label + (" [SYNTHETIC]" if gm.synthetic else ""),
        "ground_motion": {"label": gm.label, "synthetic": bool(gm.synthetic),
                          "source": gm.source, "dt": gm.dt,
                          "peak_g": list(gm.peak_g()),
                          "start": scene.ground_motion.start,
                          # record metadata (event, station, magnitude, PGA, citation) when
                          # the reader knows it (FEMA P695 / PEER NGA records; issue #14)
                          "metadata": dict(getattr(gm, "meta", None) or {})},
        "formulation": FORMULATION,
        "stopped": stopped,
        "crest_point": list(model.crest_point),
        "crest_displacement_note": "upstream crest corner, relative to the rigid ground "
                                   "(rock bottom); includes the static displacement",
        "mesh": model.summary(),
        "dofs": {"nfree": int(model.nfree), "ndof": int(model.ndof),
                 "interface_points": int(iface.npts)},
        "frequencies_hz": [float(f) for f in modal.frequencies_hz],
        "rayleigh": damp,
        "law": law_parts(scene),
        "reference_parameters": {"sigma_max": ref_coh.sigma_max, "tau_max": ref_coh.tau_max,
                                 "l_Nc": ref_coh.l_Nc, "l_Tc": ref_coh.l_Tc,
                                 "k_normal": k0n, "k_tangential": k0t,
                                 "g_max_over_l_Nc": scene.interface.g_max / ref_coh.l_Nc},
        "final_parameters": joints.params()[0],
        "joints": joint_results(joints, H, snaps, model),
        "energy": energy_summary(H, energy.keys()),
        "characteristic_times": chars,
        "static": static_info,
        "n_steps": int(n_steps),
        "timings": {"build": t_build, "modal": t_modal, "static": t_static,
                    "dynamic": t_dynamic,
                    "per_step_median": float(np.median(walls)) if walls.size else None,
                    "per_step_mean": float(np.mean(walls)) if walls.size else None,
                    "per_step_max": float(np.max(walls)) if walls.size else None,
                    "outputs": t_outputs,
                    "total_this_process": time.perf_counter() - T0},
        "solver_totals": {"iterations": int(H["iterations"].sum()),
                          "iterations_failed": int(H["iterations_failed"].sum()),
                          "cuts": int(H["cuts"].sum()),
                          "max_iterations_per_step": int(H["iterations"].max())
                          if walls.size else 0,
                          "steps_with_cuts": int(np.count_nonzero(H["cuts"]))},
        "results": res,
        "post_earthquake": post,
        "safety": {"joints": safety_sum, "uplift_fixed_point_solves":
                   safety.fixed_point_iterations,
                   "uplift_fixed_point_unconverged": safety.fixed_point_unconverged,
                   "definition": "FS = (f max(N', 0) + sum over bonded points of w c) / |T| "
                                 "(EM 1110-2-2100 eq. 3-1; f, c the law's current values); "
                                 "docs/safety.md §4"},
        "screening": None if safety.screening is None else safety.screening.summary(),
        "resumed_from_step": resumed_from,
        "environment": environment_info(),
        "files": sorted(set(files)),
    }
    if rres is not None:
        summary["reservoir"] = rres.summary()
    atomic_write_json(summary_path, summary)     # LAST: the run is complete
    for p in [ckp.meta_path, *out.glob("checkpoint_*.npz")]:   # nothing left to resume
        if p.exists():
            p.unlink()
    if progress:
        log(format_summary(summary))
    return summary


def joint_results(joints, H, snaps, model) -> dict:
    """summary.json ``joints.<name>``: where the joint is and what happened to it."""
    out = {}
    t = H["t"]
    for name, sl, law in zip(joints.names, joints.slices, joints.laws):
        x = joints.x[sl]
        cu = H[f"{name}_crack_length_upstream"] if t.size else np.zeros(0)
        ct = H[f"{name}_crack_length"] if t.size else np.zeros(0)
        nd = H[f"{name}_n_debonded"] if t.size else np.zeros(0)
        first = np.flatnonzero(nd > 0)
        out[name] = {
            "elevation": float(joints.y[sl][0]), "x_upstream": float(x[0]),
            "x_downstream": float(x[-1]), "length": float(joints.w[sl].sum()),
            "points": int(sl.stop - sl.start), "law": law_parts(joints.tables[joints.names
                                                                              .index(name)]),
            "crack_length_upstream_final": float(cu[-1]) if cu.size else 0.0,
            "crack_length_upstream_max": float(cu.max()) if cu.size else 0.0,
            "debonded_length_final": float(ct[-1]) if ct.size else 0.0,
            "debonded_length_max": float(ct.max()) if ct.size else 0.0,
            "max_D": float(np.max([np.max(D[sl]) for D in snaps["D"]])),
            "max_D_history": float(H[f"{name}_max_D"].max()) if t.size else 0.0,
            "t_first_debond": float(t[first[0]]) if first.size else None,
            "final_parameters": law_parts(joints.tables[joints.names.index(name)]) | {
                "sigma_max": law.cohesive.sigma_max,
                "friction": None if law.friction is None else law.friction.f},
        }
    return out


def energy_summary(H, keys) -> dict:
    """Final budget terms and the largest balance residual relative to the input work."""
    if H["t"].size == 0:
        return {}
    scale = max(float(np.max(np.abs(H["W_ext"]))), 1e-300)
    final = {k: float(H[k][-1]) for k in keys}
    return {"final": final, "max_abs_residual": float(np.max(np.abs(H["residual"]))),
            "max_residual_over_input_work": float(np.max(np.abs(H["residual"]))) / scale,
            "input_work_scale": scale,
            "definition": "residual = W_ext - (E_kin + E_bulk + E_damp + E_stored + E_diss "
                          "+ E_scaling), "
                          "from the static state; docs/solver.md §9"}
