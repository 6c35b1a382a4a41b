"""The Koyna seismic fracture run (issue #6): static state, then the record, step by step.

``run(scene, outdir)`` builds the model (``fe.model.build_from_scene``), the interface law from
``[interface]``, the size-scale adaptive parameters (``interfacelaw.scaling.SizeScaling``,
updated at the start of every step from the failed length b = sum of w over debonded points,
size used max(b_ref, b)), Rayleigh damping from the modal analysis (C = a0 M + a1 K, bulk K
only) and the ``NewmarkSolver``.  The static state (dead load + reservoir) is solved with the
interface law by the same solver and committed; then the ground motion (default: the shipped
SYNTHETIC Koyna-like record) enters as the effective load

    f(t) = f_static - M (r_x a_x(t) + r_y a_y(t))

(relative formulation: rock bottom fixed, displacements relative to the rigid ground motion).

Outputs (``ngs_driver.out``): summary.json (written last, atomically), timeseries.csv,
damage_profiles.csv, final_state.npz, PNGs, optional VTK; checkpoint.json/.npz every
``output.checkpoint_every`` steps; ``resume=True`` continues from the last checkpoint and gives
the same results as an uninterrupted run.

NGSolve is imported only when the model is built (``describe`` for --dry-run never does).
"""
from __future__ import annotations

import json
import pathlib
import time

import numpy as np

from ..out.files import atomic_savez, atomic_write_json, environment_info
from ..setup import (FORMULATION, build_law, build_scaling, characteristic_times, law_parts,
                     load_ground_motion)
from .checkpoint import Checkpointer
from .record import History, crack_measures, results_from_history, snapshot_steps

class RunInterrupted(RuntimeError):
    """Raised by ``run(..., max_steps=k)`` after k steps (test hook for stop/resume)."""


# ---------------------------------------------------------------------------------------------
# law, scaling, ground motion (no NGSolve)
# ---------------------------------------------------------------------------------------------
# ---------------------------------------------------------------------------------------------
# interface measures
# ---------------------------------------------------------------------------------------------
# ---------------------------------------------------------------------------------------------
def run(scene, outdir=None, resume: bool = False, progress: bool = True,
        max_steps: int | None = None, model=None, plots: bool = True,
        log=print) -> dict:
    """Run the scene; returns the summary dict (also written to ``outdir/summary.json``).

    max_steps: stop (``RunInterrupted``) after this many dynamic steps of this call, with the
    checkpoint written if one is due (test hook for stop/resume).  model: a prebuilt model
    of this scene (tests).  plots: False skips PNG/VTK output (tests)."""
    from ..fe.modal import damping_from_modes, k0_from_scene, modal_analysis
    from ..out import files as outfiles
    from ..out import plots as outplots
    from ..out.report import format_summary
    from ..solve.newmark import NewmarkSolver, SolverError

    T0 = time.perf_counter()
    out = pathlib.Path(outdir if outdir is not None else scene.output.dir)
    out.mkdir(parents=True, exist_ok=True)
    summary_path = out / "summary.json"
    ckp = Checkpointer(out, scene.output.checkpoint_every)
    scene_d = scene.to_dict()
    ck = None
    if resume:
        meta, arrs = ckp.load()          # FileNotFoundError with a clear message
        if meta.get("scene") != json.loads(json.dumps(scene_d)):
            raise ValueError(f"--resume: the checkpoint in {out} was written for a different "
                             "scene (or different --set values); allowed: the same scene and "
                             "overrides as the interrupted run")
        ck = (meta, arrs)
    else:
        # a fresh run: nothing of a previous run may look complete or resumable
        for p in [summary_path, ckp.meta_path, *out.glob("checkpoint_*.npz")]:
            if p.exists():
                p.unlink()
    if summary_path.exists():
        summary_path.unlink()

    # ---- model, law, damping --------------------------------------------------------------
    t = time.perf_counter()
    if model is None:
        from ..fe.model import build_from_scene
        model = build_from_scene(scene)
    t_build = time.perf_counter() - t
    iface = model.interface
    w = iface.w
    law = build_law(scene)
    scaling = build_scaling(scene, law)
    if scaling is not None:
        law = scaling.update(law, 0.0)
    ref_coh = law.cohesive
    k0n, k0t = law.cohesive.k_normal, law.cohesive.k_tangential
    kn_s, kt_s = k0_from_scene(scene)
    assert abs(kn_s - k0n) <= 1e-9 * k0n and abs(kt_s - k0t) <= 1e-9 * k0t

    t = time.perf_counter()
    modal = modal_analysis(model, 6, k0n, k0t)
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
    ts = scene.time
    sv = scene.solver
    solver = NewmarkSolver(model.K, model.M, C, iface.B, w, law, dt=ts.dt,
                           beta=ts.newmark_beta, gamma=ts.newmark_gamma,
                           tol_residual=sv.tol_residual, max_iter=sv.max_iter,
                           min_dt=sv.min_dt)
    gm = load_ground_motion(scene)
    n_steps = int(round(ts.duration / ts.dt))
    times = ts.dt * np.arange(n_steps + 1)
    ax, ay = gm.at(scene.ground_motion.start + times)
    Mrx, Mry = model.M @ model.r_x, model.M @ model.r_y
    f_static = model.f_gravity + model.f_water
    cx, cy = model.crest_dofs
    chars = characteristic_times(scene, ref_coh.l_Nc)
    if progress:
        log(f"[{scene.name}] nfree {model.nfree}, interface points {iface.npts}, "
            f"f1 = {modal.frequencies_hz[0]:.3f} Hz, a0 = {damp['a0']:.4g} 1/s, "
            f"a1 = {damp['a1']:.4g} s; t1 = {chars['t1']:.3e} s, t2 = {chars['t2']:.3e} s "
            f"(Eq. 11); record: {gm.label}{' [SYNTHETIC]' if gm.synthetic else ''}")

    snap_steps = snapshot_steps(n_steps, scene.output.snapshots)
    vtk = None
    if plots and scene.output.vtk_every > 0:
        vtk = outplots.VTKWriter(model, out / "vtk" / "koyna")

    def size_b(state):
        return crack_measures(state, w)[0]

    def update_law(state):
        """size-scale update at the start of a step; returns the size b used."""
        nonlocal law
        if scaling is None:
            return 0.0
        b = size_b(state)
        new = scaling.update(law, b)
        if new.cohesive != law.cohesive or new.friction != law.friction:
            law = new
            solver.set_law(law)
        return scaling.size(b)

    # ---- static state or restart ----------------------------------------------------------
    if ck is None:
        t = time.perf_counter()
        rep = solver.static(f_static)
        t_static = time.perf_counter() - t
        solver.initial_acceleration(f_static - Mrx * ax[0] - Mry * ay[0])
        st = solver.state
        u_static = solver.u.copy()
        tr = solver.t
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
        }
        hist = History()
        snaps = {"step": [0], "t": [0.0], "D": [st.damage.copy()], "kappa": [st.kappa.copy()]}
        k_start = 0
        dyn_wall_before = 0.0
        resumed_from = None
        # Fig. 12 shows the state of the largest heel opening while the base still holds
        heel = {"u": u_static.copy(), "t": 0.0, "open": float(solver.g[0, 0])}
    else:
        meta, arrs = ck
        from interfacelaw import InterfaceState
        st = InterfaceState.from_dict({k[6:]: v for k, v in arrs.items()
                                       if k.startswith("state_")})
        solver.state = st
        update_law(st)
        solver.set_initial(u=arrs["u"], v=arrs["v"], a=arrs["a"], f=arrs["f"])
        # committed internals of the condensed solver (bitwise restart)
        for name in ("t", "g", "_phi", "_active"):
            if f"solver{name}" in arrs and hasattr(solver, name):
                setattr(solver, name, arrs[f"solver{name}"].copy())
        solver.time = float(meta["time"])
        static_info = meta["static"]
        t_static = static_info["wall"]
        u_static = arrs["u_static"]
        hist = History.from_arrays(arrs)
        snaps = {"step": [int(s) for s in arrs["snap_step"]],
                 "t": [float(s) for s in arrs["snap_t"]],
                 "D": list(arrs["snap_D"]), "kappa": list(arrs["snap_kappa"])}
        heel = {"u": arrs["heel_u"], "t": float(meta["heel_t"]),
                "open": float(meta["heel_open"])}
        k_start = int(meta["step"])
        dyn_wall_before = float(meta["dynamic_wall"])
        resumed_from = k_start
        if progress:
            log(f"[{scene.name}] resuming from step {k_start} (t = {k_start * ts.dt:.4g} s)")

    def checkpoint(k, dyn_wall):
        arrays = {"u": solver.u, "v": solver.v, "a": solver.a, "f": solver.f,
                  "u_static": u_static}
        for name in ("t", "g", "_phi", "_active"):
            if hasattr(solver, name):
                arrays[f"solver{name}"] = np.asarray(getattr(solver, name))
        for kk, vv in solver.state.as_dict().items():
            arrays[f"state_{kk}"] = vv
        for kk, vv in hist.arrays().items():
            arrays[f"hist_{kk}"] = vv
        arrays["snap_step"] = np.asarray(snaps["step"])
        arrays["snap_t"] = np.asarray(snaps["t"])
        arrays["snap_D"] = np.asarray(snaps["D"])
        arrays["snap_kappa"] = np.asarray(snaps["kappa"])
        arrays["heel_u"] = heel["u"]
        coh = law.cohesive
        ckp.save(k, {"scene": scene_d, "time": solver.time, "static": static_info,
                     "heel_t": heel["t"], "heel_open": heel["open"],
                     "rayleigh": {"a0": damp["a0"], "a1": damp["a1"]},
                     "dynamic_wall": dyn_wall,
                     "law": {"sigma_max": coh.sigma_max, "tau_max": coh.tau_max,
                             "l_Nc": coh.l_Nc, "l_Tc": coh.l_Tc,
                             "friction": None if law.friction is None else law.friction.f}},
                 **arrays)

    # ---- time loop ------------------------------------------------------------------------
    from tqdm import tqdm

    # disable=None: tqdm turns itself off when stderr is not a terminal (logs stay readable)
    bar = tqdm(total=n_steps, initial=k_start, disable=None if progress else True, unit="step",
               desc=f"{scene.name} a={scene.interface.alpha:g}", dynamic_ncols=True)
    t_dyn0 = time.perf_counter()
    steps_this_call = 0
    stopped = None
    stop_slip = scene.time.stop_slip
    try:
        for k in range(k_start + 1, n_steps + 1):
            b_used = update_law(solver.state)
            f_k = f_static - Mrx * ax[k] - Mry * ay[k]
            try:
                rep = solver.step(f_k)
            except SolverError as e:
                raise SolverError(f"{scene.name}: step {k} (t = {times[k]:.4f} s): {e}") \
                    from None
            st = solver.state
            crack, crack_heel, ndeb = crack_measures(st, w)
            hist.append(step=k, t=times[k], crest_ux=solver.u[cx], crest_uy=solver.u[cy],
                        iterations=rep.iterations, iterations_failed=rep.iterations_failed,
                        cuts=rep.cuts, substeps=len(rep.dts), n_active=rep.n_active,
                        n_debonded=ndeb, crack_length=crack, crack_length_heel=crack_heel,
                        max_D=float(st.damage.max()), D_heel=float(st.damage[0]),
                        kappa_heel=float(st.kappa[0]), size_b=b_used,
                        sigma_max=law.cohesive.sigma_max, wall=rep.wall)
            if k in snap_steps:
                snaps["step"].append(k)
                snaps["t"].append(float(times[k]))
                snaps["D"].append(st.damage.copy())
                snaps["kappa"].append(st.kappa.copy())
            if vtk is not None and k % scene.output.vtk_every == 0:
                vtk.write(solver.u, times[k])
            bar.update(1)
            if progress and (k % 10 == 0 or k == n_steps):
                bar.set_postfix_str(f"t={times[k]:.3f}s it={rep.iterations} "
                                    f"cuts={int(np.sum(hist.cols['cuts']))} "
                                    f"crack={crack_heel:.3f}m Dheel={st.damage[0]:.3f}",
                                    refresh=False)
            steps_this_call += 1
            if ndeb < iface.npts and solver.g[0, 0] > heel["open"]:
                heel = {"u": solver.u.copy(), "t": float(times[k]),
                        "open": float(solver.g[0, 0])}
            if stop_slip > 0 and ndeb == iface.npts:
                slip = abs(float(np.dot(w, solver.g[:, 1]) / w.sum()))
                if slip > stop_slip:
                    stopped = {"reason": "failure by sliding: the whole interface is debonded "
                                         f"and the mean base slip {slip:.3g} m exceeds "
                                         f"time.stop_slip = {stop_slip:g} m (small-displacement "
                                         "kinematics no longer hold)",
                               "t": float(times[k]), "step": k}
                    bar.write(f"[{scene.name}] stopped at t = {times[k]:.3f} s: "
                              + stopped["reason"]) if progress else None
                    break
            if ckp.due(k):
                checkpoint(k, dyn_wall_before + time.perf_counter() - t_dyn0)
            if max_steps is not None and steps_this_call >= max_steps and k < n_steps:
                raise RunInterrupted(f"stopped after {steps_this_call} steps (step {k}) by "
                                     "max_steps")
    finally:
        bar.close()
    t_dynamic = dyn_wall_before + time.perf_counter() - t_dyn0
    if stopped is not None and snaps["step"][-1] != stopped["step"]:   # D(x) where it stopped
        snaps["step"].append(stopped["step"])
        snaps["t"].append(stopped["t"])
        snaps["D"].append(solver.state.damage.copy())
        snaps["kappa"].append(solver.state.kappa.copy())

    # ---- outputs ----------------------------------------------------------------------
    H = hist.arrays()
    t_out = time.perf_counter()
    files = outfiles.write_run_outputs(out, model, scene, gm, H, snaps, solver, u_static,
                                      plots=plots, heel=heel)
    if vtk is not None:
        files.append(str(vtk.path_hint))
    atomic_savez(out / "final_state.npz", u=solver.u, v=solver.v, a=solver.a,
                 x=iface.x, y=iface.y, w=iface.w,
                 **{f"state_{kk}": vv for kk, vv in solver.state.as_dict().items()})
    files.append("final_state.npz")
    t_outputs = time.perf_counter() - t_out

    res = results_from_history(H, snaps, iface.x, w)
    walls = H["wall"]
    summary = {
        "scene": scene_d,
        "label": gm.label + (" [SYNTHETIC]" if gm.synthetic else ""),
        "ground_motion": {"label": gm.label, "synthetic": bool(gm.synthetic),
                          "source": gm.source, "dt": gm.dt,
                          "peak_g": list(gm.peak_g()),
                          "start": scene.ground_motion.start,
                          # record metadata (event, station, magnitude, PGA, citation) when
                          # the reader knows it (FEMA P695 / PEER NGA records)
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
        "final_parameters": {"sigma_max": law.cohesive.sigma_max,
                             "tau_max": law.cohesive.tau_max, "l_Nc": law.cohesive.l_Nc,
                             "friction": None if law.friction is None else law.friction.f},
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
        "resumed_from_step": resumed_from,
        "environment": environment_info(),
        "files": sorted(set(files)),
    }
    atomic_write_json(summary_path, summary)     # LAST: the run is complete
    for p in [ckp.meta_path, *out.glob("checkpoint_*.npz")]:   # nothing left to resume
        if p.exists():
            p.unlink()
    if progress:
        log(format_summary(summary))
    return summary


