"""Koyna run: error against run time — intensity sweep, Gauss points per segment,
time step, g_max sensitivity.  ``main(fast, outdir)`` writes ``koyna_studies.md`` (tables),
``koyna_studies_summary.txt`` (prose, recommended defaults) and PNGs into ``outdir``.

Why an intensity sweep first: with the shipped SYNTHETIC record at full scale (0.49 g) the whole
70 m base debonds at t ~ 0.8-1.1 s and the dam slides (the run stops on ``time.stop_slip``); a
convergence study of "crack length at the end" is meaningless there (70 m for every setting).
The sweep (ground_motion.scale) gives this model's fragility-like curve under this record, and the
studies are run at the largest scale whose crack stays partial (not the whole base, no sliding).

Quantities per run (from ``summary.json`` / ``timeseries.csv`` of ``ngs_driver.apps.dam.run``):
  wall         timings.dynamic [s] (the time-stepping loop only; build/modal/static excluded)
  L_end        crack length at the end, contiguous debonded length from the heel [m]
  L_max        its maximum over the window; L_tot: total debonded length at the end
  ux_peak      peak crest |u_x| over the window (upstream crest corner, relative to the ground,
               static displacement included) [m]
  D_max, D_heel  max damage over all points and time; damage at the heel point at the end
Errors against the study's reference run: |L_end - L_end,ref| in metres (0 is drawn at 1e-4 m
on the log plots), |ux_peak - ux_peak,ref| / ux_peak,ref.

Runs go through the one sweep-with-resume (``ngs_driver.studies.sweep``): each the run command
in a subprocess (``--jobs`` at a time; in-process for --fast) into
``outdir/koyna_studies/runs/<tag>``; a run whose result.json holds the same scene hash is
reused (so an interrupted study resumes).  The tables are rewritten after every run.

  python verification/koyna_studies.py [--fast] [--jobs 2] [--out DIR]
"""
from __future__ import annotations

import argparse
import json
import math
import pathlib
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from ngs_driver.post.files import read_csv  # noqa: E402
from ngs_driver.studies.sweep import Sweep, overrides_of, run_scene, scene_hash  # noqa: E402

L_NC = 2 * 250.0 / 3.0e6            # l_Nc = 2 G_I / sigma_max of the reference parameters [m]

# ---- the full study ------------------------------------------------------------------------
FULL = dict(
    scene="koyna",
    window={"time.duration": 3.0, "ground_motion.start": 0.0},          # intensity sweep
    # convergence studies: 1.504 s is a whole number of steps of every dt below (188 of 8 ms;
    # a run's duration must be, scene.py), the window the 8 ms run had when it was rounded
    study_window={"time.duration": 1.504, "ground_motion.start": 0.0},
    sweep=(0.05, 0.1, 0.15, 0.2, 0.25, 0.3),
    # the studies' scale: 0.2 = the largest of the first sweep {0.05 .. 0.3} with a partial,
    # arrested heel crack in [0, 1.5] s (None: pick it automatically from the sweep)
    scale=0.2,
    gauss=(1, 2, 3, 5, 8), gauss_ref=8, gauss_extra_ref={"mesh.h_heel": 0.05},
    dts=(0.008, 0.004, 0.002, 0.001, 0.0005), dt_ref=0.0005,
    # (alpha, g_max / l_Nc or None = scene default): alpha = 1 at the default g_max fails the whole
    # base at scale 0.2 (D = 1 everywhere), so its dt study is repeated at g_max = 40 l_Nc where
    # alpha = 1 gives a partial crack and an unsaturated D
    dt_series=((2.0, None), (1.0, None), (1.0, 40)),
    gmax=(1, 2, 4, 10, 40), alphas=(1.0, 2.0),
    repeat=False,
)
# ---- the fast version (tests, < 60 s): the coarse smoke scene, 0.1 s, 2 values per knob ------
FAST = dict(
    scene="koyna_smoke",
    window={"time.duration": 0.1},
    study_window={"time.duration": 0.1},
    sweep=(1.5, 3.0),
    gauss=(1, 3), gauss_ref=3, gauss_extra_ref=None,
    dts=(0.004, 0.002), dt_ref=0.002, dt_series=((2.0, None),),
    gmax=(4, 40), alphas=(1.0, 2.0),
    repeat=True,
    scale=3.0,
)
LAST_STATE: dict = {}     # the state of the last main() call (tests read the records from it)
DEFAULT_SCALE = 0.1      # used when no sweep result gives a partial crack


# ---------------------------------------------------------------------------------------------
def sets_list(sets: dict) -> list[str]:
    return overrides_of(sets)


def tag_of(sets: dict) -> str:
    short = {"ground_motion.scale": "s", "mesh.gauss_points": "gp", "time.dt": "dt",
             "interface.g_max": "gmax", "interface.alpha": "a", "mesh.h_heel": "hh",
             "time.duration": "T", "ground_motion.start": "t0", "_repeat": "rep"}
    parts = []
    for k, v in sorted(sets.items()):
        name = short.get(k, k.replace(".", "_"))
        if k == "interface.g_max":
            v = f"{v / L_NC:.4g}lNc"
        parts.append(f"{name}{v:g}" if isinstance(v, (int, float)) else f"{name}{v}")
    return "_".join(parts)


def _scene_sets(sets: dict) -> dict:
    return {k: v for k, v in sets.items() if not k.startswith("_")}


def read_record(run_dir: pathlib.Path, sets: dict) -> dict:
    s = json.loads((run_dir / "summary.json").read_text())
    ts = read_csv(run_dir / "timeseries.csv")
    r = s["results"]
    ux = np.atleast_1d(ts["crest_ux"])
    ux0 = s["static"]["crest_ux"]
    return {
        "tag": run_dir.name, "sets": sets,
        "wall": s["timings"]["dynamic"], "per_step_median": s["timings"]["per_step_median"],
        "n_steps_done": int(ux.size), "n_steps": s["n_steps"],
        "npts": s["dofs"]["interface_points"], "nfree": s["dofs"]["nfree"],
        "L_end": r["crack_length_heel_final"], "L_max": r["crack_length_heel_max"],
        "L_tot": r["crack_length_total_final"], "L_tot_max": r["crack_length_total_max"],
        "ux_peak": float(np.max(np.abs(ux))), "ux_dyn_peak": float(np.max(np.abs(ux - ux0))),
        "D_max": r["max_D"], "D_heel": r["D_heel_final"], "D_heel_max": r["max_D_heel"],
        "D_static_max": s["static"]["max_D"],
        "t_first_debond": r["t_first_debond"],
        "iterations": s["solver_totals"]["iterations"],
        "iterations_failed": s["solver_totals"]["iterations_failed"],
        "cuts": s["solver_totals"]["cuts"],
        "stopped": s.get("stopped"),
    }


class Runner:
    """The study's runs through the one sweep-with-resume (``ngs_driver.studies.sweep``): run
    <tag> in ``root/runs/<tag>/``, reused while its scene hash is the same; ``records``: tag ->
    ``read_record`` of every finished run."""

    def __init__(self, scene_name, root, jobs=1, in_process=False, on_done=None, log=print):
        self.scene_name = scene_name
        self.root = pathlib.Path(root)
        self.runs_dir = self.root / "runs"
        self.in_process = in_process
        self.records: dict[str, dict] = {}
        self.on_done = on_done
        self.log = log
        self._t0 = {}
        self._sets = {}
        self.sweep = Sweep(self.root, run_scene, jobs=1 if in_process else jobs,
                           on_result=self._done)

    def _spec(self, sets):
        from ngs_driver.scene import load_scene
        ov = sets_list(_scene_sets(sets))
        tag = tag_of(sets)
        self._sets[tag] = sets
        return {"id": tag, "scene_hash": scene_hash(load_scene(self.scene_name, ov)),
                "scene_name": self.scene_name, "overrides": ov, "in_process": self.in_process}

    def _record(self, tag, reused):
        rec = read_record(self.runs_dir / tag, self._sets[tag])
        rec["reused"] = reused
        self.records[tag] = rec
        t0 = self._t0.get(tag)
        self.log(f"[koyna_studies] {tag}: wall {rec['wall']:.1f} s, L_end {rec['L_end']:.3f} m, "
                 f"ux_peak {rec['ux_peak']:.4e} m, D_max {rec['D_max']:.3g}"
                 + (" (reused)" if reused else f" ({time.perf_counter() - t0:.0f} s)"))
        if self.on_done:
            self.on_done()

    def _done(self, spec, result):
        self._record(spec["id"], reused=False)

    def one(self, sets):
        return self.many([sets])[0]

    def many(self, list_of_sets):
        todo, seen = [], set()
        for s in list_of_sets:
            t = tag_of(s)
            if t not in seen and t not in self.records:
                seen.add(t)
                todo.append(s)
        # longest runs first (number of steps): the references are done before the cheap rows
        todo.sort(key=lambda s: -s.get("time.duration", 1.0) / s.get("time.dt", 0.002))
        specs = [self._spec(s) for s in todo]
        done, pending = self.sweep.plan(specs)
        for tag in done:
            self._record(tag, reused=True)
        now = time.perf_counter()
        self._t0.update({s["id"]: now for s in pending})
        res = self.sweep.run(pending)
        if res["errors"]:
            tag, msg = next(iter(res["errors"].items()))
            raise RuntimeError(f"run {tag}: {msg}")
        return [self.records[tag_of(s)] for s in list_of_sets]


# ---------------------------------------------------------------------------------------------
def _errors(rec, ref):
    eL = abs(rec["L_end"] - ref["L_end"])
    eu = abs(rec["ux_peak"] - ref["ux_peak"]) / abs(ref["ux_peak"])
    eD = abs(rec["D_max"] - ref["D_max"]) / max(abs(ref["D_max"]), 1e-300)
    return eL, eu, eD


def _sfx(a, m):
    return f"a{a:g}" + ("" if m is None else f"_g{m:g}")


def _lab(a, m):
    return f"α = {a:g}" + ("" if m is None else f", g_max = {m:g} l_Nc")


def _stop_str(rec):
    st = rec.get("stopped")
    return "no" if not st else f"yes, t = {st['t']:.3f} s"


def pick_scale(sweep_recs):
    """Largest scale whose crack stays partial (not the whole base at any time) and no sliding."""
    ok = [r for r in sweep_recs if not r["stopped"] and r["L_tot_max"] < 0.999 * 70.0
          and r["L_max"] > 0.0]
    if ok:
        return max(ok, key=lambda r: r["sets"]["ground_motion.scale"])["sets"]["ground_motion.scale"]
    ok = [r for r in sweep_recs if not r["stopped"] and r["L_tot_max"] < 0.999 * 70.0]
    if ok:
        return max(ok, key=lambda r: r["sets"]["ground_motion.scale"])["sets"]["ground_motion.scale"]
    return DEFAULT_SCALE


def write_tables(path, cfg, state):
    """Markdown report from whatever has finished so far (called after every run)."""
    R = state["runner"].records
    get = lambda s: R.get(tag_of(s))  # noqa: E731
    L = ["# Koyna run: error against run time", "",
         f"Scene `{cfg['scene']}`; intensity sweep with `"
         + " ".join(f"--set {x}" for x in sets_list(cfg['window']))
         + "`, convergence studies with `"
         + " ".join(f"--set {x}" for x in sets_list(cfg['study_window']))
         + "` plus the knob of each row; record: the shipped SYNTHETIC Koyna-like motion. "
         "wall = timings.dynamic of summary.json (time-stepping loop, one process, 1 thread; the "
         "2-core machine was shared, so wall times carry roughly ±30 %). L_end: contiguous debonded "
         "length from the heel at the end; L_max: its maximum; L_tot,max: max total debonded "
         "length; ux_peak: peak crest |u_x| (static part included). Errors: |ΔL_end| in m, "
         "|Δux_peak|/ux_peak, |ΔD_max|/D_max against the study's reference.", ""]
    # 1. sweep
    L += ["## 0. Intensity sweep (α = 2, default mesh, dt = 2 ms)", "",
          "| scale | PGA_h [g] | wall [s] | steps done | L_end [m] | L_max [m] | L_tot,max [m] | "
          "D_max | D_heel end | ux_peak [mm] | t first debond [s] | failure (stopped) |",
          "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in state.get("sweep_sets", []):
        r = get(s)
        if r is None:
            continue
        sc = s["ground_motion.scale"]
        tfd = r["t_first_debond"]
        L.append(f"| {sc:g} | {0.49 * sc * (state.get('scale_mult', 1.0)):.3g} | {r['wall']:.1f} | "
                 f"{r['n_steps_done']}/{r['n_steps']} | {r['L_end']:.3f} | {r['L_max']:.3f} | "
                 f"{r['L_tot_max']:.3f} | {r['D_max']:.3g} | {r['D_heel']:.3g} | "
                 f"{1e3 * r['ux_peak']:.3f} | {'-' if tfd is None else f'{tfd:.3f}'} | "
                 f"{_stop_str(r)} |")
    if "scale" in state:
        L += ["", f"Scale used for the studies: **{state['scale']:g}**; the automatic rule "
              "(largest scale of the sweep whose debonding stays partial, with no failure by "
              f"sliding in the window) gives {state['scale_auto']:g}.", ""]

    def study(title, rows, ref_s, label_fn, note=""):
        ref = get(ref_s) if ref_s is not None else None
        out = [f"## {title}", ""]
        if note:
            out += [note, ""]
        out += ["| setting | interface points | wall [s] | ms/step (median) | Newton it. | "
                "failed it. | cuts | L_end [m] | L_max [m] | ux_peak [mm] | D_max | "
                "D_max − D_static | D_heel end | err L_end [m] | err ux_peak | err D_max | "
                "stopped |",
                "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for s in rows:
            r = get(s)
            if r is None:
                continue
            if ref is not None:
                eL, eu, eD = _errors(r, ref)
                es = f"{eL:.3g} | {eu:.2e} | {eD:.2e}"
            else:
                es = "- | - | -"
            isref = " (ref)" if ref_s is not None and tag_of(s) == tag_of(ref_s) else ""
            out.append(f"| {label_fn(s)}{isref} | {r['npts']} | {r['wall']:.1f} | "
                       f"{1e3 * r['per_step_median']:.1f} | {r['iterations']} | "
                       f"{r['iterations_failed']} | {r['cuts']} | {r['L_end']:.4f} | "
                       f"{r['L_max']:.4f} | {1e3 * r['ux_peak']:.4f} | {r['D_max']:.4g} | "
                       f"{r['D_max'] - r['D_static_max']:.4g} | "
                       f"{r['D_heel']:.4g} | {es} | {_stop_str(r)} |")
        return out + [""]

    if "gauss_sets" in state:
        L += study("1. Gauss points per segment (α = 2, dt = 2 ms)", state["gauss_sets"],
                   state["gauss_ref"],
                   lambda s: f"n = {s['mesh.gauss_points']}"
                   + (f", h_heel = {s['mesh.h_heel']:g} m" if "mesh.h_heel" in s else ""),
                   "Reference: " + state["gauss_ref_label"])
    for a, m in cfg["dt_series"]:
        key = f"dt_sets_{_sfx(a, m)}"
        if key in state:
            L += study(f"2. Time step, {_lab(a, m)} (n = default gauss points)", state[key],
                       state[f"dt_ref_{_sfx(a, m)}"], lambda s: f"dt = {1e3 * s['time.dt']:g} ms",
                       f"Reference: dt = {1e3 * cfg['dt_ref']:g} ms.")
    if "dt_D_note" in state:
        L += [state["dt_D_note"], ""]
    if "gmax_sets" in state:
        L += ["## 3. g_max sensitivity (dt = 2 ms, n = default)", "",
              "| α | g_max / l_Nc | g_max [m] | wall [s] | D_max | D_heel end | max D_heel | "
              "L_end [m] | L_max [m] | L_tot,max [m] | ux_peak [mm] | stopped |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for s in state["gmax_sets"]:
            r = get(s)
            if r is None:
                continue
            L.append(f"| {s['interface.alpha']:g} | {s['interface.g_max'] / L_NC:.3g} | "
                     f"{s['interface.g_max']:.4g} | {r['wall']:.1f} | {r['D_max']:.4g} | "
                     f"{r['D_heel']:.4g} | {r['D_heel_max']:.4g} | {r['L_end']:.4f} | "
                     f"{r['L_max']:.4f} | {r['L_tot_max']:.4f} | {1e3 * r['ux_peak']:.4f} | "
                     f"{_stop_str(r)} |")
        L.append("")
    if "repeat" in state:
        a, b = state["repeat"]
        ra, rb = get(a), get(b)
        if ra is not None and rb is not None:
            L += ["## Repeatability", "",
                  f"Two runs with identical settings: L_end {ra['L_end']!r} vs {rb['L_end']!r}, "
                  f"ux_peak {ra['ux_peak']!r} vs {rb['ux_peak']!r}, D_max {ra['D_max']!r} vs "
                  f"{rb['D_max']!r}.", ""]
    L += [f"Runs in `{state['runner'].runs_dir}`; "
          f"total wall of the study so far {time.perf_counter() - state['t0']:.0f} s.", ""]
    tmp = path.with_suffix(".md.tmp")
    tmp.write_text("\n".join(L))
    tmp.replace(path)


# ---------------------------------------------------------------------------------------------
def _plot_wp(ax_L, ax_u, series, floor_L=1e-4, floor_u=1e-7):
    for label, recs, ref, lab_fn, mk in series:
        pts = [(r["wall"], *_errors(r, ref), lab_fn(r)) for r in recs if r is not ref]
        if not pts:
            continue
        w = [p[0] for p in pts]
        eL = [max(p[1], floor_L) for p in pts]
        eu = [max(p[2], floor_u) for p in pts]
        l1, = ax_L.loglog(w, eL, mk + "-", label=label)
        ax_u.loglog(w, eu, mk + "-", label=label, color=l1.get_color())
        for p, y1, y2 in zip(pts, eL, eu):
            ax_L.annotate(p[4], (p[0], y1), fontsize=7, xytext=(3, 3), textcoords="offset points")
            ax_u.annotate(p[4], (p[0], y2), fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax_L.set_xlabel("wall time of the dynamic run [s]")
    ax_u.set_xlabel("wall time of the dynamic run [s]")
    ax_L.set_ylabel(f"|L_end - L_end,ref| [m]  (0 drawn at {floor_L:g})")
    ax_u.set_ylabel(f"|ux_peak - ref| / ref  (0 drawn at {floor_u:g})")
    for a in (ax_L, ax_u):
        a.grid(True, which="both", alpha=0.3)
        a.legend(fontsize=8)


def make_plots(outdir, cfg, state):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    R = state["runner"].records
    get = lambda s: R[tag_of(s)]  # noqa: E731
    files = []
    # intensity sweep
    sw = [get(s) for s in state["sweep_sets"]]
    sc = np.array([r["sets"]["ground_motion.scale"] for r in sw])
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.2))
    a1.plot(sc, [r["L_end"] for r in sw], "o-", label="L_end (from heel, end of window)")
    a1.plot(sc, [r["L_max"] for r in sw], "s--", label="L_max (from heel)")
    a1.plot(sc, [r["L_tot_max"] for r in sw], "^:", label="max total debonded length")
    for r, s in zip(sw, sc):
        if r["stopped"]:
            a1.annotate("sliding\n(stopped)", (s, r["L_tot_max"]), fontsize=7, color="r",
                        xytext=(-10, -25), textcoords="offset points")
    a1.set_xlabel("ground_motion.scale (× 0.49 g / 0.34 g)")
    a1.set_ylabel("length [m]")
    a1.set_yscale("symlog", linthresh=0.1)
    a1.legend(fontsize=8)
    a1.grid(True, alpha=0.3)
    a2.semilogy(sc, [r["D_max"] for r in sw], "o-", label="max D")
    a2.semilogy(sc, [max(r["D_heel"], 1e-12) for r in sw], "s--", label="D at heel (end)")
    a2.set_xlabel("ground_motion.scale")
    a2.set_ylabel("damage")
    a2.legend(fontsize=8)
    a2.grid(True, which="both", alpha=0.3)
    fig.suptitle(f"{cfg['scene']}: intensity sweep, SYNTHETIC record, α = 2, "
                 f"window {cfg['window']}", fontsize=9)
    fig.tight_layout()
    p = outdir / "koyna_intensity_sweep.png"
    fig.savefig(p, dpi=120)
    plt.close(fig)
    files.append(p.name)
    # work-precision
    fig, axs = plt.subplots(1, 2, figsize=(11, 4.5))
    series = []
    if "gauss_sets" in state:
        series.append(("Gauss points n (α=2)", [get(s) for s in state["gauss_sets"]],
                       get(state["gauss_ref"]),
                       lambda r: f"n={r['sets']['mesh.gauss_points']}"
                       + (f",h_heel={r['sets']['mesh.h_heel']:g}" if "mesh.h_heel" in r["sets"]
                          else ""), "o"))
    for (a, m), mk in zip(cfg["dt_series"], "s^vD"):
        key = f"dt_sets_{_sfx(a, m)}"
        if key in state:
            series.append((f"dt ({_lab(a, m)})", [get(s) for s in state[key]],
                           get(state[f"dt_ref_{_sfx(a, m)}"]),
                           lambda r: f"{1e3 * r['sets']['time.dt']:g}ms", mk))
    _plot_wp(axs[0], axs[1], series)
    axs[0].set_title("crack length at the end (from the heel)", fontsize=9)
    axs[1].set_title("peak crest |u_x|", fontsize=9)
    fig.suptitle(f"Koyna work-precision (scale {state['scale']:g}, SYNTHETIC record)", fontsize=9)
    fig.tight_layout()
    p = outdir / "koyna_work_precision.png"
    fig.savefig(p, dpi=120)
    plt.close(fig)
    files.append(p.name)
    # dt and damage (step-size dependence of Eq. 7)
    fig, ax = plt.subplots(figsize=(5.5, 4.2))
    for a, m in cfg["dt_series"]:
        key = f"dt_sets_{_sfx(a, m)}"
        if key in state:
            rr = [get(s) for s in state[key]]
            ax.loglog([1e3 * r["sets"]["time.dt"] for r in rr], [r["D_max"] for r in rr],
                      "o-", label=f"max D, {_lab(a, m)}")
            ax.loglog([1e3 * r["sets"]["time.dt"] for r in rr],
                      [max(r["D_max"] - r["D_static_max"], 1e-12) for r in rr],
                      "x--", label=f"max D − D_static, {_lab(a, m)}")
    ax.set_xlabel("dt [ms]")
    ax.set_ylabel("max D over the window")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("Eq. 7: D ∝ dt^(α-1) per loading", fontsize=9)
    fig.tight_layout()
    p = outdir / "koyna_dt_damage.png"
    fig.savefig(p, dpi=120)
    plt.close(fig)
    files.append(p.name)
    # g_max
    if "gmax_sets" in state:
        fig, ax = plt.subplots(figsize=(5.5, 4.2))
        for a in cfg["alphas"]:
            rr = [get(s) for s in state["gmax_sets"] if s["interface.alpha"] == a]
            ax.loglog([r["sets"]["interface.g_max"] / L_NC for r in rr],
                      [r["D_max"] for r in rr], "o-", label=f"max D, α = {a:g}")
            ax.loglog([r["sets"]["interface.g_max"] / L_NC for r in rr],
                      [max(r["D_heel"], 1e-16) for r in rr], "s--", label=f"D_heel end, α = {a:g}")
        ax.set_xlabel("g_max / l_Nc")
        ax.set_ylabel("damage")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        p = outdir / "koyna_gmax.png"
        fig.savefig(p, dpi=120)
        plt.close(fig)
        files.append(p.name)
    return files


# Tolerances of the rule that picks the defaults (stated in the summary):
TOL_L_FRAC = 0.5     # crack length at the end within half a heel element (h_heel) of the reference
TOL_U_GAUSS = 0.01   # peak crest |u_x| within 1 % (every n is far below: the crest is global)
TOL_D_GAUSS = 0.025  # max D within 2.5 % (D_max converges monotonically in n; L_end does not)
TOL_U_DT = 1e-3      # peak crest |u_x| within 0.1 % for the time step (Newmark, 2nd order)


def _ok(r, ref, tol_L, tol_u, tol_D=None):
    if r is ref:
        return True
    eL, eu, eD = _errors(r, ref)
    return (eL <= tol_L + 1e-12 and eu <= tol_u and (tol_D is None or eD <= tol_D)
            and not r["stopped"])


def recommend(records, ref, key, tol_L, tol_u, tol_D=None):
    """Cheapest setting (wall time) whose errors against ref are within the tolerances."""
    best = min((r for r in records if _ok(r, ref, tol_L, tol_u, tol_D)), key=lambda r: r["wall"])
    return best["sets"][key], best


def recommend_dt(cfg, state, get, tol_L, tol_u):
    """Largest dt acceptable in every dt series whose reference run kept a partial crack (a failed
    base has L_end = 70 m for every dt and says nothing about the crack).  The damage D is not
    used: for alpha = 2 it has no dt -> 0 limit other than the static value (Eq. 7, D4)."""
    allowed = None
    for a, m in cfg["dt_series"]:
        ref = get(state[f"dt_ref_{_sfx(a, m)}"])
        if ref["stopped"] or ref["L_tot_max"] >= 0.999 * 70.0:
            continue
        ok = {r["sets"]["time.dt"] for r in (get(s) for s in state[f"dt_sets_{_sfx(a, m)}"])
              if _ok(r, ref, tol_L, tol_u)}
        allowed = ok if allowed is None else allowed & ok
    return max(allowed) if allowed else cfg["dt_ref"]


def write_summary_txt(path, cfg, state, fast):
    R = state["runner"].records
    get = lambda s: R[tag_of(s)]  # noqa: E731
    sw = [get(s) for s in state["sweep_sets"]]
    lines = [f"Koyna error-against-run-time studies ({'FAST smoke version' if fast else 'full'}; "
             f"scene {cfg['scene']}, sweep window {cfg['window']}, study window "
             f"{cfg['study_window']}, SYNTHETIC record).", ""]
    lines.append("Intensity sweep (alpha = 2, default mesh, dt = 2 ms):")
    for r in sw:
        lines.append(f"  scale {r['sets']['ground_motion.scale']:g}: L_end {r['L_end']:.3f} m, "
                     f"L_max {r['L_max']:.3f} m, max total debonded {r['L_tot_max']:.3f} m, "
                     f"max D {r['D_max']:.3g}, failure by sliding: {_stop_str(r)}")
    fails = [r["sets"]["ground_motion.scale"] for r in sw if r["stopped"]]
    lines.append(f"  -> studies at scale {state['scale']:g}"
                 + (f"; the base fails (whole interface debonded, sliding) from scale "
                    f"{min(fails):g}" if fails else "; no failure by sliding in the sweep") + ".")
    lines.append("")
    gref = get(state["gauss_ref"])
    tol_L = TOL_L_FRAC * state["tol_L"]
    gp, grec = recommend([get(s) for s in state["gauss_sets"] if "mesh.h_heel" not in s], gref,
                         "mesh.gauss_points", tol_L, TOL_U_GAUSS, TOL_D_GAUSS)
    dt = recommend_dt(cfg, state, get, tol_L, TOL_U_DT)
    drec = get({**state["dt_ref_a2"], "time.dt": dt})
    dref = get(state["dt_ref_a2"])
    lines.append(f"Rule (Gauss points): the cheapest n whose crack length at the end is within "
                 f"{tol_L:g} m (half a heel element) of the reference, peak crest |u_x| within "
                 f"{100 * TOL_U_GAUSS:g} % and max D within {100 * TOL_D_GAUSS:g} %.")
    lines.append(f"  -> gauss_points = {gp} (wall {grec['wall']:.1f} s; reference "
                 f"{state['gauss_ref_label']}, wall {gref['wall']:.1f} s).")
    lines.append(f"Rule (time step): the largest dt whose crack length at the end is within "
                 f"{tol_L:g} m and peak crest |u_x| within {100 * TOL_U_DT:g} % of the reference, "
                 "in every dt series whose base stays partially bonded (max D is not used: for "
                 "alpha = 2 it is step-size dependent by construction).")
    lines.append(f"  -> dt = {1e3 * dt:g} ms (wall {drec['wall']:.1f} s for alpha = 2; reference "
                 f"dt = {1e3 * cfg['dt_ref']:g} ms, wall {dref['wall']:.1f} s).")
    if "dt_D_note" in state:
        lines += ["", state["dt_D_note"]]
    if "gmax_note" in state:
        lines += ["", state["gmax_note"]]
    if "repeat" in state:
        a, b = state["repeat"]
        lines += ["", f"Repeatability: identical settings give L_end {get(a)['L_end']!r} and "
                  f"{get(b)['L_end']!r}."]
    if not fast:                    # what the tables say: docs/studies.md §6 (kept current there)
        lines += ["", "Interpretation: docs/studies.md §6."]
    path.write_text("\n".join(lines) + "\n")
    return gp, dt


def main(fast: bool = False, outdir=ROOT / "verification" / "out", jobs: int | None = None) -> str:
    outdir = pathlib.Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    cfg = FAST if fast else FULL
    if jobs is None:
        jobs = 1 if fast else 2
    md = outdir / "koyna_studies.md"
    state = {"t0": time.perf_counter()}
    global LAST_STATE
    LAST_STATE = state
    root = outdir / ("koyna_studies_fast" if fast else "koyna_studies")
    runner = Runner(cfg["scene"], root, jobs=jobs, in_process=fast,
                    on_done=lambda: write_tables(md, cfg, state))
    state["runner"] = runner
    W = dict(cfg["window"])
    if fast:
        state["scale_mult"] = 1.0
    from ngs_driver.scene import load_scene
    sc0 = load_scene(cfg["scene"])
    gp0, dt0, a0, gm0 = (sc0.mesh.gauss_points, sc0.time.dt, sc0.interface.alpha,
                         sc0.interface.g_max)
    state["tol_L"] = sc0.mesh.h_heel

    def norm(s):
        """every set names the four knobs explicitly, so equal settings get equal tags."""
        return {"mesh.gauss_points": gp0, "time.dt": dt0, "interface.alpha": a0,
                "interface.g_max": gm0, **s}

    # 0. intensity sweep
    state["sweep_sets"] = [norm({**W, "ground_motion.scale": s}) for s in cfg["sweep"]]
    runner.many(state["sweep_sets"])
    state["scale_auto"] = pick_scale([runner.records[tag_of(s)] for s in state["sweep_sets"]])
    state["scale"] = cfg.get("scale") or state["scale_auto"]
    base = {**cfg["study_window"], "ground_motion.scale": state["scale"]}

    # 1. Gauss points
    gsets = [{**base, "mesh.gauss_points": n} for n in cfg["gauss"]]
    ref_g = {**base, "mesh.gauss_points": cfg["gauss_ref"]}
    state["gauss_ref_label"] = f"n = {cfg['gauss_ref']}"
    state["gauss_sets"] = gsets
    state["gauss_ref"] = ref_g
    # 2. dt  3. g_max — all queued together so that the 2 workers stay busy
    all_sets = list(gsets)
    for a, m in cfg["dt_series"]:
        extra = {} if m is None else {"interface.g_max": m * L_NC}
        ds = [{**base, "time.dt": d, "interface.alpha": a, **extra} for d in cfg["dts"]]
        state[f"dt_sets_{_sfx(a, m)}"] = ds
        state[f"dt_ref_{_sfx(a, m)}"] = {**base, "time.dt": cfg["dt_ref"], "interface.alpha": a,
                                         **extra}
        all_sets += ds
    gms = [{**base, "interface.alpha": a,
            "interface.g_max": gm0 if abs(m * L_NC - gm0) < 1e-3 * gm0 else m * L_NC}
           for a in cfg["alphas"] for m in cfg["gmax"]]
    state["gmax_sets"] = gms
    all_sets += gms
    if cfg["repeat"]:
        rep = {**base, "_repeat": 1}
        state["repeat"] = (base, rep)
        all_sets += [base, rep]
    for k in list(state):
        if "_sets" in k and k != "sweep_sets":
            state[k] = [norm(s) for s in state[k]]
        if k.endswith("_ref") or k.startswith("dt_ref"):
            state[k] = norm(state[k])
    if "repeat" in state:
        state["repeat"] = tuple(norm(s) for s in state["repeat"])
    all_sets = [norm(s) for s in all_sets]
    if cfg["gauss_extra_ref"] and not fast:
        extra = norm({**base, "mesh.gauss_points": cfg["gauss_ref"], **cfg["gauss_extra_ref"]})
        state["gauss_sets"] = state["gauss_sets"] + [extra]
        all_sets.append(extra)
    runner.many(all_sets)
    write_tables(md, cfg, state)

    # notes: dt and D; g_max
    R = runner.records
    notes = []
    for a, m in cfg["dt_series"]:
        rr = [R[tag_of(s)] for s in state[f"dt_sets_{_sfx(a, m)}"]]
        d = np.array([r["sets"]["time.dt"] for r in rr])
        D = np.array([r["D_max"] for r in rr])
        Dd = np.array([r["D_max"] - r["D_static_max"] for r in rr])
        i, j = int(np.argmax(d)), int(np.argmin(d))
        if Dd[i] > 0 and Dd[j] > 0 and d[i] != d[j]:
            notes.append(f"{_lab(a, m)}: dynamic part of max D (D_max - D_static, D_static = "
                         f"{rr[j]['D_static_max']:.4g}) = {Dd[i]:.4g} at dt = {1e3 * d[i]:g} ms "
                         f"and {Dd[j]:.4g} at {1e3 * d[j]:g} ms (log-log slope "
                         f"{math.log(Dd[i] / Dd[j]) / math.log(d[i] / d[j]):.2f})")
        slope = (math.log(D[i] / D[j]) / math.log(d[i] / d[j])
                 if D[i] > 0 and D[j] > 0 and d[i] != d[j] else float("nan"))
        ref = R[tag_of(state[f"dt_ref_{_sfx(a, m)}"])]
        eu = [(_errors(r, ref)[1], r["sets"]["time.dt"]) for r in rr if r is not ref]
        eu.sort(key=lambda x: -x[1])
        orders = [math.log(e1 / e2) / math.log(d1 / d2) for (e1, d1), (e2, d2) in zip(eu, eu[1:])
                  if e1 > 0 and e2 > 0]
        if orders:
            notes.append(f"{_lab(a, m)}: observed orders of the peak-crest error between "
                         "successive dt: " + ", ".join(f"{o:.2f}" for o in orders))
        notes.append(f"{_lab(a, m)}: max D = {D[i]:.4g} at dt = {1e3 * d[i]:g} ms and "
                     f"{D[j]:.4g} at dt = {1e3 * d[j]:g} ms (ratio {D[i] / D[j]:.3g} for a dt "
                     f"ratio {d[i] / d[j]:g}; log-log slope {slope:.2f})")
    state["dt_D_note"] = ("Step-size dependence of the damage law (Eq. 7, docs/law.md §6.1): "
                          + "; ".join(notes) + ".")
    gl = []
    for a in cfg["alphas"]:
        rr = [R[tag_of(s)] for s in state["gmax_sets"] if s["interface.alpha"] == a]
        gl.append(f"alpha = {a:g}: max D " + ", ".join(
            f"{r['D_max']:.3g} (g_max = {r['sets']['interface.g_max'] / L_NC:.3g} l_Nc)"
            for r in rr) + "; L_end " + ", ".join(f"{r['L_end']:.3f}" for r in rr) + " m")
    state["gmax_note"] = "g_max sensitivity: " + "; ".join(gl) + "."
    write_tables(md, cfg, state)
    files = make_plots(outdir, cfg, state)
    gp, dt = write_summary_txt(outdir / "koyna_studies_summary.txt", cfg, state, fast)
    return (f"[koyna_studies] scale {state['scale']:g}; recommended gauss_points = {gp}, "
            f"dt = {1e3 * dt:g} ms; {len(runner.records)} runs; files: koyna_studies.md, "
            f"koyna_studies_summary.txt, {', '.join(files)}")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fast", action="store_true")
    ap.add_argument("--jobs", type=int, default=None)
    ap.add_argument("--out", default=str(ROOT / "verification" / "out"))
    a = ap.parse_args()
    print(main(fast=a.fast, outdir=a.out, jobs=a.jobs))
