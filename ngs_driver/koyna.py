"""The Koyna seismic fracture run (issue #6): static state, then the record, step by step.

``run(scene, outdir)`` builds the model (``model.build_from_scene``), the interface law from
``[interface]``, the size-scale adaptive parameters (``interfacelaw.scaling.SizeScaling``,
updated at the start of every step from the failed length b = sum of w over debonded points,
size used max(b_ref, b)), Rayleigh damping from the modal analysis (C = a0 M + a1 K, bulk K
only) and the ``NewmarkSolver``.  The static state (dead load + reservoir) is solved with the
interface law by the same solver and committed; then the ground motion (default: the shipped
SYNTHETIC Koyna-like record) enters as the effective load

    f(t) = f_static - M (r_x a_x(t) + r_y a_y(t))

(relative formulation: rock bottom fixed, displacements relative to the rigid ground motion).

Outputs (``ngs_driver.outputs``): summary.json (written last, atomically), timeseries.csv,
damage_profiles.csv, final_state.npz, PNGs, optional VTK; checkpoint.json/.npz every
``output.checkpoint_every`` steps; ``resume=True`` continues from the last checkpoint and gives
the same results as an uninterrupted run.

NGSolve is imported only when the model is built (``describe`` for --dry-run never does).
"""
from __future__ import annotations

import json
import math
import pathlib
import time
from dataclasses import replace

import numpy as np

from .io import Checkpointer, atomic_savez, atomic_write_json, environment_info

FORMULATION = ("relative (rock bottom fixed, ground acceleration as effective inertial load "
               "-M r a_g(t); displacements relative to the rigid ground motion)")
DEFAULT_RECORDS = ("synthetic", "default")
INTERFACE_LENGTH_A0 = 70.0          # a0 of Eq. 11: the whole (bonded) interface [m]

# per-step histories (name -> dtype); the CSV column order
HIST_KEYS = ("step", "t", "crest_ux", "crest_uy", "iterations", "iterations_failed", "cuts",
             "substeps", "n_active", "n_debonded", "crack_length", "crack_length_heel",
             "max_D", "D_heel", "kappa_heel", "size_b", "sigma_max", "wall")


class RunInterrupted(RuntimeError):
    """Raised by ``run(..., max_steps=k)`` after k steps (test hook for stop/resume)."""


# ---------------------------------------------------------------------------------------------
# law, scaling, ground motion (no NGSolve)
# ---------------------------------------------------------------------------------------------
def build_law(scene):
    """InterfaceLaw of the scene's [interface] table (cohesive + contact + friction + damage)."""
    from interfacelaw import (CohesiveParams, ContactParams, DamageParams, FrictionParams,
                              InterfaceLaw)

    i = scene.interface
    coh = CohesiveParams.from_fracture_energy(i.sigma_max, i.tau_max, i.G_I, i.lambda_max,
                                              i.ratio_lTc_lNc)
    con = None if i.contact == "none" else ContactParams(kind=i.contact)
    fri = FrictionParams(f=i.friction) if (con is not None and i.friction > 0) else None
    dmg = (DamageParams(g_max=i.g_max, alpha=i.alpha, beta=i.beta, F_th=i.F_th,
                        form=i.damage_form) if i.damage else None)
    return InterfaceLaw(coh, con, fri, dmg)


def build_scaling(scene, law):
    """SizeScaling with the scene's reference parameters (None if interface.scaling is off)."""
    if not scene.interface.scaling:
        return None
    from interfacelaw.scaling import SizeScaling

    f_ref = scene.interface.friction if scene.interface.friction > 0 else 0.3
    return SizeScaling(law.cohesive, f_ref=f_ref)


def law_parts(scene) -> dict:
    i = scene.interface
    return {"cohesive": "Geubelle-Baylor bilinear mixed mode",
            "contact": i.contact,
            "friction": bool(i.contact != "none" and i.friction > 0),
            "damage": bool(i.damage), "damage_form": i.damage_form, "damage_alpha": i.alpha,
            "damage_beta": i.beta, "damage_g_max": i.g_max,
            "scaling": bool(getattr(i, "scaling", False))}


def load_ground_motion(scene):
    """The scene's record in m/s^2, scaled, components selected, resampled to dt."""
    from . import ground_motion as gmod

    g = scene.ground_motion
    rec = g.record
    if rec in DEFAULT_RECORDS:
        gm = gmod.load_default()
    else:
        p = pathlib.Path(rec)
        if not p.exists():
            raise ValueError(f"ground_motion.record = {rec!r}: no such file; allowed: "
                             f"{list(DEFAULT_RECORDS)} (the shipped SYNTHETIC record) or a path "
                             "to a .AT2 / two-column (t a_x) / three-column (t a_x a_y) file")
        if p.suffix.lower() == ".at2":
            gm = gmod.read_at2(p, "x")
        else:
            ncol = None
            for ln in p.read_text(encoding="utf-8", errors="replace").splitlines():
                body = ln.split("#", 1)[0].strip()
                if body:
                    ncol = len(body.replace(",", " ").split())
                    break
            if ncol == 3:
                gm = gmod.read_three_column(p, g.units)
            else:
                gm = gmod.read_two_column(p, g.units, "x")
        if g.baseline:
            gm = gmod.baseline_correct(gm)
    if g.scale != 1.0:
        gm = gm.scaled(g.scale)
    fx = 1.0 if "x" in g.components else 0.0
    fy = 1.0 if "y" in g.components else 0.0
    if fx == 0.0 or fy == 0.0:
        gm = gm.scaled((fx, fy))
    dt = scene.time.dt
    if abs(gm.dt - dt) > 1e-12 * dt:
        gm = gmod.resample(gm, dt)
    return gm


def characteristic_times(scene, l_Nc: float) -> dict:
    """Paper Eq. 11 for the dam concrete: t1 = rho c_L l_Nc/(2 sigma_max), t2 = a0/c_L."""
    m = scene.materials.dam
    s = scene.interface.sigma_max
    try:
        from interfacelaw.scaling import characteristic_times as ct
        r = ct(m.E, m.rho, l_Nc, s, INTERFACE_LENGTH_A0)
        t1, t2, c = float(r.t1), float(r.t2), float(r.c_L)
    except ImportError:  # pragma: no cover
        c = math.sqrt(m.E / m.rho)
        t1, t2 = m.rho * c * l_Nc / (2 * s), INTERFACE_LENGTH_A0 / c
    return {"t1": t1, "t2": t2, "c_L": c, "a0": INTERFACE_LENGTH_A0, "l_Nc": l_Nc,
            "material": "dam concrete", "equation": "paper Eq. 11"}


def describe(scene) -> dict:
    """What ``run`` would build (for --dry-run); never imports NGSolve."""
    m, t = scene.mesh, scene.time
    n = int(round(t.duration / t.dt))
    l_nc = 2 * scene.interface.G_I / scene.interface.sigma_max
    return {"scene": scene.to_dict(),
            "will_build": {
                "model": f"Koyna on {scene.geometry.foundation} foundation, P{m.order} "
                         f"triangles, h_heel {m.h_heel} m, h_interface {m.h_interface} m, "
                         f"h_coarse {m.h_coarse} m, {m.gauss_points} Gauss points/segment "
                         "(mesh and DOFs: not built in a dry run)",
                "law": law_parts(scene),
                "reference_l_Nc": l_nc,
                "g_max_over_l_Nc": scene.interface.g_max / l_nc,
                "damping": f"Rayleigh {scene.damping.ratio:g} at "
                           + (f"{list(scene.damping.frequencies)} Hz"
                              if scene.damping.frequencies else
                              f"modes {list(scene.damping.modes)}"),
                "ground_motion": scene.ground_motion.record
                + (" (shipped SYNTHETIC Koyna-like record)"
                   if scene.ground_motion.record in DEFAULT_RECORDS else ""),
                "time": f"{n} steps of {t.dt} s to {t.duration} s, Newmark beta "
                        f"{t.newmark_beta}, gamma {t.newmark_gamma}",
                "formulation": FORMULATION,
                "checkpoint_every": scene.output.checkpoint_every,
                "vtk_every": scene.output.vtk_every}}


# ---------------------------------------------------------------------------------------------
# interface measures
# ---------------------------------------------------------------------------------------------
def crack_measures(state, w) -> tuple[float, float, int]:
    """(sum of w over debonded points, contiguous debonded length from the heel, n debonded).
    Points are sorted by x (heel first)."""
    deb = np.asarray(state.debonded, bool)
    total = float(np.sum(w[deb]))
    if deb.size and deb[0]:
        k = int(np.argmin(deb)) if not deb.all() else deb.size
        heel = float(np.sum(w[:k]))
    else:
        heel = 0.0
    return total, heel, int(deb.sum())


# ---------------------------------------------------------------------------------------------
class _History:
    def __init__(self):
        self.cols = {k: [] for k in HIST_KEYS}

    def append(self, **kw):
        for k in HIST_KEYS:
            self.cols[k].append(kw[k])

    def arrays(self) -> dict:
        return {k: np.asarray(v, dtype=float) for k, v in self.cols.items()}

    @classmethod
    def from_arrays(cls, d):
        h = cls()
        for k in HIST_KEYS:
            h.cols[k] = [float(x) for x in d[f"hist_{k}"]]
        return h

    def __len__(self):
        return len(self.cols["t"])


def _snapshot_steps(n_steps: int, count: int) -> list[int]:
    s = sorted({int(round(v)) for v in np.linspace(0, n_steps, count + 1)[1:]})
    return [k for k in s if k >= 1]


def run(scene, outdir=None, resume: bool = False, progress: bool = True,
        max_steps: int | None = None, model=None, plots: bool = True,
        log=print) -> dict:
    """Run the scene; returns the summary dict (also written to ``outdir/summary.json``).

    max_steps: stop (``RunInterrupted``) after this many dynamic steps of this call, with the
    checkpoint written if one is due (test hook for stop/resume).  model: a prebuilt model
    of this scene (tests).  plots: False skips PNG/VTK output (tests)."""
    from . import outputs
    from .modal import damping_from_modes, k0_from_scene, modal_analysis
    from .solver import NewmarkSolver, SolverError

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
        from .model import build_from_scene
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

    snap_steps = _snapshot_steps(n_steps, scene.output.snapshots)
    vtk = None
    if plots and scene.output.vtk_every > 0:
        vtk = outputs.VTKWriter(model, out / "vtk" / "koyna")

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
        hist = _History()
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
        hist = _History.from_arrays(arrs)
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
    files = outputs.write_run_outputs(out, model, scene, gm, H, snaps, solver, u_static,
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
                          "start": scene.ground_motion.start},
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


def results_from_history(H, snaps, x, w) -> dict:
    """The numbers the paper's statements are compared with."""
    t = H["t"]
    if t.size == 0:
        return {}

    def first(mask):
        i = np.flatnonzero(mask)
        return float(t[i[0]]) if i.size else None

    ch = H["crack_length_heel"]
    final = float(ch[-1])
    t_final = None
    if final > 0:
        i = np.flatnonzero(ch >= final - 1e-12)
        t_final = float(t[i[0]])
    return {
        "max_D_heel": float(H["D_heel"].max()), "max_D": float(H["max_D"].max()),
        "t_D_heel_reaches_1": first(H["D_heel"] >= 1.0),
        "t_D_heel_reaches_0.1": first(H["D_heel"] >= 0.1),
        "t_first_debond": first(H["n_debonded"] > 0),
        "crack_length_heel_final": final, "crack_length_heel_max": float(ch.max()),
        "t_crack_heel_reaches_final": t_final,
        "crack_length_total_final": float(H["crack_length"][-1]),
        "crack_length_total_max": float(H["crack_length"].max()),
        "crest_ux_min": float(H["crest_ux"].min()), "crest_ux_max": float(H["crest_ux"].max()),
        "crest_uy_min": float(H["crest_uy"].min()), "crest_uy_max": float(H["crest_uy"].max()),
        "D_heel_final": float(H["D_heel"][-1]),
        "max_size_b": float(H["size_b"].max()),
        "min_sigma_max": float(H["sigma_max"].min()),
    }


def format_summary(s: dict) -> str:
    r = s["results"]
    tm = s["timings"]
    ch = s["characteristic_times"]
    lines = [
        f"[{s['scene']['name']}] done: {s['n_steps']} steps; record {s['label']}",
        f"  Eq. 11: t1 = {ch['t1']:.3e} s, t2 = {ch['t2']:.3e} s (c_L = {ch['c_L']:.0f} m/s)",
        "  frequencies [Hz]: " + " ".join(f"{f:.3f}" for f in s["frequencies_hz"]),
        f"  max D at heel {r.get('max_D_heel', 0):.4g} (D=1 at t = "
        f"{r.get('t_D_heel_reaches_1')}), crack from heel {r.get('crack_length_heel_final', 0):.4g}"
        f" m (reached at t = {r.get('t_crack_heel_reaches_final')}), debonded total "
        f"{r.get('crack_length_total_final', 0):.4g} m",
        f"  Newton iterations {s['solver_totals']['iterations']}, cuts "
        f"{s['solver_totals']['cuts']}; wall: static {tm['static']:.2f} s, dynamic "
        f"{tm['dynamic']:.1f} s, per step median {1e3 * (tm['per_step_median'] or 0):.2f} ms",
    ]
    return "\n".join(lines)


def scene_for_alpha(scene, alpha: float, outdir: str | None = None):
    """The scene with interface.alpha replaced (and output.dir if given)."""
    sc = replace(scene, interface=replace(scene.interface, alpha=float(alpha)))
    if outdir is not None:
        sc = replace(sc, output=replace(sc.output, dir=str(outdir)))
    return sc
