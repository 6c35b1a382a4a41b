"""The base debonding "in one or two implicit steps" of the rate damage form at large t_ref:
a jump of the implicit step to another solution branch, or physics? Step refinement
(docs/sliding.md, "Base debonding in one or two steps at large t_ref").

    python verification/debonding_step_refinement.py [--fast] [--out DIR]
        -> DIR/debonding_step_refinement.md, .png, .json

The case is docs/studies.md §7's (verification/damage_rate_koyna.py FULL): Koyna as shipped,
the 0.05x SYNTHETIC record, ``damage_form = rate``, alpha = 2, g_max = 40 l_Nc, whose base
debonds over its 70 m "in one or two steps" once the heel's damage reaches 1:

* ``record``  t_ref = 300 s from t = 0 (the study's run; the base unzips at 2.816 s);
* ``window``  t_ref = 1000 s in a window from the record time 2.75 s (the same unzipping after
  0.23 s: short enough to refine dt to 7.8 us, below the solver's own cut sub-steps);
* ``no_scaling``  the window with ``interface.scaling = false`` (the mechanism: the size-scale
  law softens every point of the joint the moment the failed length grows).

Every run goes through ``ngs_driver.run.prepare`` (the ``dam-seismic run`` path) with
``--set`` overrides; the only addition is an observer of the solver's accepted sub-steps
(``JointSolver.commit_observers``: time, sub-step, debonded length, max D and each point's
debonding time), because the event happens inside the cut sub-steps of one or two steps. Per
run: the times at which the debonded length of the base passes 10 % and reaches 100 %, that
duration in seconds, in nominal steps and in accepted sub-steps, the Newton iterations (accepted
and failed) and cuts of those steps, max D, the energy budget around the event, the mean speed
of the debonding and the part of the base that debonded before a P wave from the first
debonded point could have reached it.

Verdict rule (fixed before the full runs): a jump of the implicit step would take one or two
steps whatever dt, i.e. a duration ~ dt; physics takes the same time at every dt. With T(dt)
the 10 % -> 100 % duration, q = T(dt_min) / T(dt_ref), dt_ref the finest dt >= 4 dt_min (not
the coarsest: at 2 ms the cut sub-steps smear the event in time, 1.4 ms on koyna_smoke against
0.05 ms converged): "physics" when q >= 0.5 and the event spans >= 4 nominal steps at dt_min;
"jump" when q <= 0.4 and it spans <= 2 steps at every dt; otherwise "undecided".

Full (``make verify``): 17 runs, about 12 min on one core (the window at 7.8 us: 3 min).
``fast=True`` (tests/test_debonding_step_refinement.py): koyna_smoke at 0.1x with t_ref = 1e4
s, the same unzipping at 2 ms, 31.25 us and 7.8 us, and without the size-scale update at 31.25 us: about 12 s.
"""
from __future__ import annotations

import json
import math
import pathlib
import sys
import time

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from verification.study_cli import run_from_command_line, study_dir  # noqa: E402

L_NC = 2 * 250.0 / 3.0e6                 # l_Nc of the paper's interface [m] (1/6000 m)
RATE = ["interface.alpha=2.0", "interface.damage_form=rate",
        f"interface.g_max={40 * L_NC!r}", "output.checkpoint_every=0"]

FULL = {
    "record": {"scene": "koyna", "title": "0.05x record from t = 0, t_ref = 300 s",
               "sets": RATE + ["ground_motion.scale=0.05", "interface.t_ref=300.0",
                               "time.duration=2.83"],
               "dts": [2e-3, 1e-3, 5e-4, 2.5e-4]},
    "window": {"scene": "koyna", "title": "0.05x record from 2.75 s, t_ref = 1000 s",
               "sets": RATE + ["ground_motion.scale=0.05", "interface.t_ref=1000.0",
                               "ground_motion.start=2.75", "time.duration=0.24"],
               "dts": [2e-3, 1e-3, 5e-4, 2.5e-4, 1.25e-4, 6.25e-5, 3.125e-5, 1.5625e-5,
                       7.8125e-6]},
    "no_scaling": {"scene": "koyna",
                   "title": "the window with interface.scaling = false",
                   "sets": RATE + ["ground_motion.scale=0.05", "interface.t_ref=1000.0",
                                   "ground_motion.start=2.75", "time.duration=0.245",
                                   "interface.scaling=false"],
                   "dts": [5e-4, 1.25e-4, 3.125e-5, 7.8125e-6]},
}
# koyna_smoke (coarse mesh, 0.1 s from the record time 3.0 s) at 0.1x with t_ref = 1e4 s:
# the same unzipping (heel D 0.2 -> 1 and the whole base within 0.15 ms, at 0.078 s); 2 ms
# shows it in one step with cuts, 31.25 and 7.8 us resolve it (measured 10 % -> 100 % in 58,
# 51, 49.5, 45, 44.5 us at 31.25, 15.6, 7.8, 3.9, 1.95 us: 2, 4, 7, 12, 23 steps)
FAST = {
    "smoke": {"scene": "koyna_smoke", "title": "koyna_smoke at 0.1x, t_ref = 1e4 s",
              "sets": RATE + ["ground_motion.scale=0.1", "interface.t_ref=10000.0",
                              "time.duration=0.086"],
              "dts": [2e-3, 3.125e-5, 7.8125e-6]},
    # the mechanism's check: without the size-scale update the same base unzips as a front
    # from the heel, about 25 times slower (measured 1.54 ms against 0.058 ms at 31.25 us)
    "no_scaling": {"scene": "koyna_smoke", "title": "the same with interface.scaling = false",
                   "sets": RATE + ["ground_motion.scale=0.1", "interface.t_ref=10000.0",
                                   "time.duration=0.1", "interface.scaling=false"],
                   "dts": [3.125e-5]},
}
FIGURE_HALF_WINDOW = 0.012   # s of the debonded-length history kept around the event
# the solver's time is a sum of sub-steps (rounding drifts over 3e4 steps); sub-steps are
# >= dt/2^10, so times within 1e-6 dt are the same instant
TIME_TOL = 1e-6
BEFORE_EVENT = 2e-3       # s: the energy budget "before" is this long before the onset
VERDICT_STEPS = 4        # physics: the event spans at least this many nominal steps at dt_min
Q_PHYSICS, Q_JUMP = 0.5, 0.4


# ---------------------------------------------------------------------------------------------
def wave_speeds(scene) -> dict:
    """P, S and Rayleigh wave speeds of the dam's concrete (plane strain or stress as the
    scene; Rayleigh by Viktorov's fit c_R = c_S (0.862 + 1.14 nu)/(1 + nu), within 0.5 % of
    the root of the Rayleigh equation for 0 <= nu <= 0.5)."""
    m = scene.materials.dam
    E, nu, rho = m.E, m.nu, m.rho
    if scene.materials.plane == "stress":
        cL = math.sqrt(E / (rho * (1 - nu ** 2)))
    else:
        cL = math.sqrt(E * (1 - nu) / (rho * (1 + nu) * (1 - 2 * nu)))
    cS = math.sqrt(E / (2 * (1 + nu) * rho))
    return {"c_L": cL, "c_S": cS, "c_R": cS * (0.862 + 1.14 * nu) / (1 + nu)}


class SubstepLog:
    """Observer of the solver's accepted sub-steps: t, h, debonded length of the base, max D,
    Newton iterations; and each base point's debonding time (first accepted sub-step at which
    it is debonded)."""

    def __init__(self, analysis):
        self.solver = s = analysis.solver
        self.sl = analysis.joints.slices[0]
        self.w = np.asarray(analysis.model.interface.w[self.sl], float)
        self.x = np.asarray(analysis.model.interface.x[self.sl], float)
        self.length = float(self.w.sum())
        self.rows = []
        self.t_debond = np.full(self.w.size, np.nan)
        s.commit_observers.append(self.committed)

    def committed(self, s, h, iterations):
        if h is None:                                   # the static solve
            return
        st = s.state
        deb = np.asarray(st.debonded[self.sl], bool)
        new = deb & np.isnan(self.t_debond)
        if new.any():
            self.t_debond[new] = s.time
        self.rows.append((s.time, h, float(self.w[deb].sum()),
                          float(st.damage[self.sl].max()), int(iterations)))

    def arrays(self):
        a = np.array(self.rows, float).reshape(-1, 5)
        return {"t": a[:, 0], "h": a[:, 1], "L": a[:, 2], "maxD": a[:, 3], "it": a[:, 4]}


def run_one(scene_name, sets, dt, outdir) -> dict:
    """One run of ``scene_name`` with ``sets`` and time.dt = dt through ``prepare`` (the run
    command's path), observed sub-step by sub-step."""
    from ngs_driver.post.outputs import RunOutputs
    from ngs_driver.run import prepare
    from ngs_driver.scene import load_scene
    sc = load_scene(scene_name, list(sets) + [f"time.dt={dt!r}"])
    t0 = time.perf_counter()
    a = prepare(sc, outdir, progress=False, outputs=RunOutputs(plots=False), overwrite=True)
    a.static()
    log = SubstepLog(a)
    try:
        while a.step():
            pass
    finally:
        a.close()
    summary = a.finish()
    wall = time.perf_counter() - t0
    return {"scene": sc, "H": a.history.arrays(), "sub": log.arrays(), "x": log.x, "w": log.w,
            "t_debond": log.t_debond, "length": log.length, "summary": summary, "wall": wall}


def _crossing(t, L, level):
    """First time L(t) >= level, linear between accepted sub-steps (None if never)."""
    idx = np.nonzero(L >= level)[0]
    if idx.size == 0:
        return None
    i = int(idx[0])
    if i == 0 or L[i] == L[i - 1]:
        return float(t[i])
    return float(t[i - 1] + (level - L[i - 1]) / (L[i] - L[i - 1]) * (t[i] - t[i - 1]))


def measures(r, speeds) -> dict:
    """The event's numbers of one run (see the module docstring)."""
    H, sub, Lb, dt = r["H"], r["sub"], r["length"], r["scene"].time.dt
    tt, LL = sub["t"], sub["L"]
    full = Lb * (1 - 1e-9)
    t_on = float(tt[np.argmax(LL > 0)]) if (LL > 0).any() else None
    t10, t90 = _crossing(tt, LL, 0.1 * Lb), _crossing(tt, LL, 0.9 * Lb)
    t100 = float(tt[np.argmax(LL >= full)]) if (LL >= full).any() else None
    m = {"dt": dt, "wall": r["wall"], "t_onset": t_on, "t10": t10, "t90": t90, "t100": t100,
         "stopped": r.get("stopped"),
         "max_D": float(H["base_max_D"].max())}
    if t10 is None or t100 is None:
        m["complete"] = False
        return m
    m["complete"] = True
    m["duration"] = t100 - t10
    m["duration_10_90"] = t90 - t10
    tol = TIME_TOL * dt
    ev = (tt > t10 - tol) & (tt <= t100 + tol)
    # the accepted sub-steps of the event: those that end after the 10 % crossing up to the
    # one that completes it
    m["substeps"] = int(ev.sum()) + 1
    m["h_min"] = float(sub["h"][ev].min()) if ev.any() else dt
    # nominal steps: step k covers (t_{k-1}, t_k]; the event runs from the step that contains
    # t10 to the one that contains t100
    tH = H["t"]
    k10 = min(int(np.searchsorted(tH, t10 - tol)), tH.size - 1)
    k100 = min(int(np.searchsorted(tH, t100 - tol)), tH.size - 1)
    m["steps"] = k100 - k10 + 1
    sel = slice(k10, k100 + 1)
    m["newton"] = int(H["iterations"][sel].sum())
    m["newton_failed"] = int(H["iterations_failed"][sel].sum())
    m["cuts"] = int(H["cuts"][sel].sum())
    # the energy budget around the event: the last step ending BEFORE_EVENT before the onset
    # (the same physical time for every dt) and the step that completes the debonding
    kb = max(int(np.searchsorted(tH, t_on - BEFORE_EVENT + tol, side="right")) - 1, 0)
    keys = ["W_ext", "E_kin", "E_diss", "E_scaling", "E_alg", "residual"]
    m["energy_before"] = {k: float(H[k][kb]) for k in keys if k in H}
    m["energy_after"] = {k: float(H[k][k100]) for k in keys if k in H}
    m["t_before"], m["t_after"] = float(tH[kb]), float(tH[k100])
    m["max_D_before"] = float(H["base_max_D"][kb])
    # how fast, against the waves
    td = r["t_debond"]
    ok = ~np.isnan(td)
    i0 = int(np.nanargmin(td))
    m["speed_mean"] = Lb / max(t100 - t_on, 1e-300)
    reach = np.abs(r["x"] - r["x"][i0]) / speeds["c_L"]
    early = ok & (td - td[i0] < reach - 1e-12)
    m["acausal_fraction"] = float(r["w"][early].sum() / Lb)
    m["first_to_last"] = float(np.nanmax(td) - td[i0])
    return m


def verdict(rows) -> dict:
    """The rule of the module docstring on one dt series."""
    rows = [r for r in rows if r.get("complete")]
    if len(rows) < 2:
        return {"verdict": "undecided", "q": None}
    rows = sorted(rows, key=lambda r: r["dt"])
    fine = rows[0]
    ref = [r for r in rows if r["dt"] >= 4 * fine["dt"] * (1 - 1e-9)]
    ref = ref[0] if ref else rows[-1]
    q = fine["duration"] / ref["duration"]
    if q >= Q_PHYSICS and fine["steps"] >= VERDICT_STEPS:
        v = "physics"
    elif q <= Q_JUMP and all(r["steps"] <= 2 for r in rows):
        v = "jump"
    else:
        v = "undecided"
    return {"verdict": v, "q": q, "dt_min": fine["dt"], "dt_ref": ref["dt"],
            "steps_at_dt_min": fine["steps"], "duration_at_dt_min": fine["duration"],
            "duration_at_dt_ref": ref["duration"]}


# ---------------------------------------------------------------------------------------------
def figure(res, path):
    """Top: the debonded length of the base against time around the event, one line per dt
    (accepted sub-steps; dots at the ends of the nominal steps). Bottom: each point's
    debonding time after the first against its position, with the arrival of a P wave from
    the first debonded point."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = list(res["cases"])
    fig, axes = plt.subplots(2, len(names), figsize=(5.2 * len(names), 8.0), squeeze=False)
    cL = res["speeds"]["c_L"]
    for col, name in enumerate(names):
        c = res["cases"][name]
        ax, bx = axes[0, col], axes[1, col]
        cmap = plt.get_cmap("viridis")
        n = len(c["runs"])
        span = max((r["m"].get("duration") or 0.0) for r in c["runs"])
        for j, run in enumerate(c["runs"]):
            m = run["m"]
            if not m.get("complete"):
                continue
            t10, colr = m["t10"], cmap(j / max(n - 1, 1))
            lab = f"dt = {1e3 * m['dt']:g} ms ({m['steps']} steps)"
            ts, Ls = np.asarray(run["sub_t"]), np.asarray(run["sub_L"])
            ax.plot(1e3 * (ts - t10), Ls, "-", color=colr, lw=1.2, label=lab)
            tk, Lk = np.asarray(run["step_t"]), np.asarray(run["step_L"])
            ax.plot(1e3 * (tk - t10), Lk, "o", color=colr, ms=3.5)
            if "x" in run:
                x, td = np.asarray(run["x"]), np.asarray(run["td"])
                ok = td >= 0
                bx.plot(x[ok], 1e3 * td[ok], ".-", color=colr, ms=2, lw=0.8, label=lab)
        ax.set_xlim(-0.5 * span * 1e3 - 0.05, 2.0 * span * 1e3 + 0.05)
        ax.set_xlabel("t - t(10 %) [ms]   (lines: accepted sub-steps; dots: step ends)",
                      fontsize=8)
        ax.set_ylabel("debonded length of the base [m]")
        ax.set_title(c["title"], fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
        xs = np.linspace(0.0, res["base_length"], 50)
        top = bx.get_ylim()[1]
        bx.plot(xs, 1e3 * xs / cL, "k--", lw=1, label=f"P wave from x = 0 ({cL:.0f} m/s)")
        bx.set_ylim(0, top)
        bx.set_xlabel("x along the base from the heel [m]")
        bx.set_ylabel("debonding time after the first point [ms]")
        bx.grid(alpha=0.3)
        bx.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _fmt(x, f="{:.3g}"):
    return "—" if x is None else f.format(x)


def report(res) -> str:
    sp = res["speeds"]
    Lb = res["base_length"]
    L = ["# Base debonding in one or two steps at large t_ref: jump or physics?", "",
         "Generated by `python verification/debonding_step_refinement.py"
         + (" --fast" if res["fast"] else "")
         + "`. Every run is `dam-seismic run` with the overrides below and `time.dt` of its "
         "row (through `ngs_driver.run.prepare`); an observer records the solver's accepted "
         "sub-steps (the event happens inside the cut sub-steps of the coarse steps). "
         "Duration: from the debonded length of the base passing 10 % (linear between "
         "accepted sub-steps) to the first accepted sub-step at which the whole base is "
         "debonded. Steps: nominal steps from the one containing the 10 % crossing to the one "
         "completing it; Newton: iterations accepted / failed, and cuts, over those steps. "
         "Acausal: the part of the base that debonded before a P wave from the first "
         "debonded point could have reached it. Max D and energies [J/m] before: at the end of "
         "the last step 2 ms or more before the onset -> at the end of the step that completes the "
         "debonding (the run stops there or one step later: collapse rule).", "",
         f"Waves in the dam's concrete: c_L = {sp['c_L']:.0f} m/s, c_S = {sp['c_S']:.0f} m/s, "
         f"c_R = {sp['c_R']:.0f} m/s; a front at c_R crosses the {Lb:.0f} m base in "
         f"{1e3 * Lb / sp['c_R']:.1f} ms, a P wave in {1e3 * Lb / sp['c_L']:.1f} ms.", ""]
    for name, c in res["cases"].items():
        v = c["verdict"]
        L += [f"## {c['title']}", "", f"`dam-seismic run {c['scene']} "
              + " ".join(f"--set {s}" for s in c["sets"]) + " --set time.dt=DT`", "",
              "| dt [ms] | onset [s] | 10 % -> 100 % [ms] | nominal steps | accepted sub-steps "
              "(smallest [us]) | Newton acc./failed, cuts | mean speed [km/s] (/ c_R) | "
              "acausal | max D before | E_kin before -> after [J/m] | E_diss | "
              "E_scaling | residual | wall [s] |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for run in c["runs"]:
            m = run["m"]
            if not m.get("complete"):
                L.append(f"| {1e3 * m['dt']:g} | {_fmt(m['t_onset'], '{:.5f}')} | not complete "
                         f"| | | | | | | | | | | {m['wall']:.0f} |")
                continue
            eb, ea = m["energy_before"], m["energy_after"]
            L.append(
                f"| {1e3 * m['dt']:g} | {m['t_onset']:.5f} | {1e3 * m['duration']:.3f} | "
                f"{m['steps']} | {m['substeps']} ({1e6 * m['h_min']:.3g}) | "
                f"{m['newton']}/{m['newton_failed']}, {m['cuts']} | "
                f"{m['speed_mean'] / 1e3:.0f} ({m['speed_mean'] / sp['c_R']:.0f}) | "
                f"{100 * m['acausal_fraction']:.0f} % | {m['max_D_before']:.3f} | "
                f"{eb['E_kin']:.0f} -> {ea['E_kin']:.0f} | "
                f"{eb['E_diss']:.0f} -> {ea['E_diss']:.0f} | "
                f"{eb.get('E_scaling', 0):.0f} -> {ea.get('E_scaling', 0):.0f} | "
                f"{eb['residual']:.2g} -> {ea['residual']:.3g} | {m['wall']:.0f} |")
        L += ["", f"Verdict ({c['title']}): **{v['verdict']}** — q = T(dt_min)/T(dt_ref) = "
              + (f"{v['q']:.2f} (dt_min = {1e3 * v['dt_min']:g} ms, dt_ref = "
                 f"{1e3 * v['dt_ref']:g} ms), {v['steps_at_dt_min']} nominal steps at dt_min"
                 if v["q"] is not None else "n/a") + ".", ""]
    L += ["![debonded length against time](debonding_step_refinement.png)", ""] + reading(res)
    return "\n".join(L) + "\n"


def _ratio_residual(m):
    """|energy residual| after the event over the energy the joints dissipated in it."""
    de = m["energy_after"]["E_diss"] - m["energy_before"]["E_diss"]
    return abs(m["energy_after"]["residual"]) / de if de > 0 else float("nan")


def reading(res) -> list[str]:
    """The conclusion in words, from the numbers of the tables."""
    sp, Lb = res["speeds"], res["base_length"]
    cases = {n: c for n, c in res["cases"].items() if n != "no_scaling"}
    name = max(cases, key=lambda n: cases[n]["verdict"].get("steps_at_dt_min") or 0)
    c = cases[name]
    v = c["verdict"]
    runs = sorted((r["m"] for r in c["runs"] if r["m"].get("complete")), key=lambda m: m["dt"])
    if not runs or v["q"] is None:
        return ["## Reading", "", "No complete unzipping: nothing to read.", ""]
    fine, coarse = runs[0], runs[-1]
    T = fine["duration"]
    t_ref, g_max = c["t_ref"], c["g_max"]
    dg = g_max * math.sqrt(T / t_ref)
    out = ["## Reading", "",
           f"**{'Not a jump: a converged event' if v['verdict'] == 'physics' else v['verdict']}"
           f".** ({c['title']}) At dt = {1e3 * coarse['dt']:g} ms the whole base debonds in "
           f"{coarse['steps']} nominal step(s), which the solver resolves by cutting them "
           f"({coarse['cuts']} cuts, {coarse['newton_failed']} Newton iterations in failed "
           f"attempts, {coarse['substeps']} accepted sub-steps down to "
           f"{1e6 * coarse['h_min']:.3g} us): the 'one or two steps' of docs/studies.md §7 are "
           f"nominal steps. Refined to dt = {1e6 * fine['dt']:.3g} us the 10 % -> 100 % "
           f"debonding takes {1e3 * T:.3f} ms over {fine['steps']} steps (q = "
           f"T({1e6 * v['dt_min']:.3g} us)/T({1e6 * v['dt_ref']:.3g} us) = {v['q']:.2f}; a "
           f"jump would keep one or two steps, q <= 0.5), every accepted sub-step converging "
           f"in a few Newton iterations, and the energy budget closes on it: |residual| = "
           f"{100 * _ratio_residual(fine):.2g} % of the energy dissipated in the event, "
           f"against {100 * _ratio_residual(coarse):.0f} % at {1e3 * coarse['dt']:g} ms.", "",
           f"**Faster than any wave, and not a crack front.** {Lb:.0f} m in "
           f"{1e3 * T:.3f} ms is {fine['speed_mean'] / 1e3:.0f} km/s mean, "
           f"{fine['speed_mean'] / sp['c_R']:.0f} times the Rayleigh speed ({sp['c_R']:.0f} "
           f"m/s; a front at c_R needs {1e3 * Lb / sp['c_R']:.1f} ms), and "
           f"{100 * fine['acausal_fraction']:.0f} % of the base debonds before a P wave from "
           f"the first debonded point could reach it: the base fails everywhere at once "
           f"(figure, bottom row), each point by its own slip, not by a crack running from the "
           f"heel.", "",
           "**Mechanism: the rate law's unbounded damage rate, made global by the size-scale "
           "update.** (1) docs/law.md §6.3 and interfacelaw/_kernels.py (form 2): "
           "ΔD = (Δg⁺/g_max)^α (Δt/t_ref)^(1−α), for α = 2 ΔD = (Δg⁺/g_max)² t_ref/Δt, "
           "the "
           "step of Ḋ = t_ref ġ²/g_max² (β = 0: every separation rate damages, whatever the "
           "traction). At a fixed opening rate this is objective (ΔD ∝ Δt, no step "
           "dependence); what has no bound is the damage of a given separation increment as "
           "it gets faster: D = 0 -> 1 needs only Δg = g_max √(T/t_ref) within T, here "
           f"{1e6 * dg:.2g} um in {1e3 * T:.3f} ms (g_max = {1e3 * g_max:.3g} mm, t_ref = "
           f"{t_ref:g} s), no more than the elastic slip the bonded base carries under the "
           "water thrust (shear 0.4–0.5 MPa over the joint's 9e10 Pa/m: about 5 um). "
           "(2) What moves every point at once is the size-scale law "
           "(docs/scaling.md §1–2): once the failed length b passes b_ref = 1 m, the next "
           "step gives every point of the joint the stiffness of size b, K0 ∝ b^−0.66 (b from "
           "1 to 2 m: −37 %, so +58 % elastic slip everywhere at the same instant, no wave "
           "involved); the points slip, damage, debond, b grows, the rest softens again.", ""]
    ns = res["cases"].get("no_scaling")
    if ns:
        nr = sorted((r["m"] for r in ns["runs"] if r["m"].get("complete")),
                    key=lambda m: m["dt"])
        if nr:
            f0 = nr[0]
            out += [f"**Check: without the size-scale update** ({ns['title']}) the base "
                    f"debonds from the heel to the toe in {1e3 * f0['duration']:.2f} ms "
                    f"(10 % -> 100 % at dt = {1e6 * f0['dt']:.3g} us; "
                    + ", ".join(f"{1e3 * m['duration']:.2f}" for m in nr[::-1])
                    + f" ms from dt = {1e6 * nr[-1]['dt']:.3g} us down), "
                    f"{f0['duration'] / T:.0f} times longer than with it: a front, still "
                    f"faster than the P wave over {100 * f0['acausal_fraction']:.0f} % of the "
                    "base (why it outruns the waves — the record loading every point at once, "
                    "each giving way in the order of its own damage, or the coarse bulk mesh "
                    "carrying the load across an element within a step — was not examined "
                    "further).",
                    ""]
    out += ["**What it means.** The implicit step does not jump to another branch: the "
            "solver's cuts already follow the event, and its history converges as dt shrinks "
            "(the coarse steps smear it in time, they do not skip it). The event is the "
            "model's own, from two of its idealisations acting together "
            "— a damage rate without bound (the rate reading of Eq. 7 at large t_ref) and "
            "strength and stiffness of every point set at once by the failed length of the "
            "whole joint (paper §2, a quasi-static law applied in dynamics) — so its speed "
            "says nothing about how fast a real base would unzip. What would change it is the "
            "model, not the solver: a damage rate bound (the delayed-damage form "
            "Ḋ ≤ 1/τ_c of Allix & Deü 1997), or a size update that cannot outrun the waves "
            "(b growing at most c_R Δt per step). The solver could resolve it more cheaply "
            "with a cut on the damage increment per sub-step instead of failed Newton "
            f"attempts ({coarse['newton_failed']} of the "
            f"{coarse['newton'] + coarse['newton_failed']} Newton iterations of the event at "
            f"{1e3 * coarse['dt']:g} ms are in failed attempts), which changes the cost, not "
            "the answer.", ""]
    return out


HIST_COLS = ("t", "iterations", "iterations_failed", "cuts", "base_crack_length",
             "base_max_D", "D_heel", "W_ext", "E_kin", "E_diss", "E_scaling", "E_alg",
             "residual")


def observed_run(scene_name, sets, dt, d: pathlib.Path) -> dict:
    """``run_one``, its arrays kept in ``d/debonding_step_refinement_run.npz`` (sub-step log,
    the history columns the report reads, each point's debonding time) and reused while the
    scene and its keys are the same (an interrupted study resumes; the measures are recomputed
    from the arrays)."""
    from ngs_driver.scene import load_scene
    key = json.dumps({"scene": scene_name, "sets": list(sets), "dt": dt})
    cache = d / "debonding_step_refinement_run.npz"
    sc = load_scene(scene_name, list(sets) + [f"time.dt={dt!r}"])
    if cache.exists():
        z = np.load(cache, allow_pickle=False)
        if str(z["key"]) == key:
            return {"scene": sc, "sub": {k[4:]: z[k] for k in z.files if k.startswith("sub_")},
                    "H": {k[2:]: z[k] for k in z.files if k.startswith("H_")},
                    "x": z["x"], "w": z["w"], "t_debond": z["t_debond"],
                    "length": float(z["length"]), "wall": float(z["wall"]),
                    "stopped": str(z["stopped"]), "reused": True}
    r = run_one(scene_name, sets, dt, d)
    stopped = (r["summary"].get("stopped") or {}).get("reason") or ""
    np.savez(cache, key=key, x=r["x"], w=r["w"], t_debond=r["t_debond"], length=r["length"],
             wall=r["wall"], stopped=stopped,
             **{f"sub_{k}": v for k, v in r["sub"].items()},
             **{f"H_{k}": np.asarray(r["H"][k]) for k in HIST_COLS if k in r["H"]})
    r["stopped"], r["reused"] = stopped, False
    return r


def _figure_data(r, m) -> dict:
    """The debonded length around the event (sub-steps and step ends) and each point's
    debonding time after the first."""
    sub, H = r["sub"], r["H"]
    near = (lambda t: np.abs(t - m["t10"]) <= FIGURE_HALF_WINDOW) if m.get("t10") is not None \
        else (lambda t: np.ones(t.size, bool))
    ks, kH = near(sub["t"]), near(H["t"])
    rec = {"m": m, "sub_t": sub["t"][ks], "sub_L": sub["L"][ks], "step_t": H["t"][kH],
           "step_L": H["base_crack_length"][kH]}
    td = r["t_debond"]
    if np.isfinite(td).any():
        o = np.argsort(r["x"])
        rec["x"] = r["x"][o]
        rec["td"] = np.where(np.isfinite(td[o]), td[o] - np.nanmin(td), -1.0)
    return rec


def main(fast: bool = False, outdir=None) -> dict:
    cfg = FAST if fast else FULL
    out = study_dir(outdir, HERE)
    work = out / "debonding_step_refinement_runs"
    res = {"fast": fast, "cases": {}}
    for name, c in cfg.items():
        runs = []
        for dt in c["dts"]:
            r = observed_run(c["scene"], c["sets"], dt, work / f"{name}_dt{1e6 * dt:g}us")
            res.setdefault("speeds", wave_speeds(r["scene"]))
            res.setdefault("base_length", r["length"])
            m = measures(r, res["speeds"])
            runs.append(_figure_data(r, m))
            print(f"[debonding_step_refinement] {name} dt = {1e3 * dt:g} ms: "
                  + (f"10->100 % in {1e3 * m['duration']:.3f} ms, {m['steps']} steps, "
                     f"{m['substeps']} sub-steps, {m['cuts']} cuts"
                     if m.get("complete") else "no complete unzipping")
                  + f" ({m['wall']:.0f} s{', reused' if r['reused'] else ''})", flush=True)
        ifc = r["scene"].interface
        res["cases"][name] = {"title": c["title"], "scene": c["scene"], "sets": c["sets"],
                              "runs": runs, "t_ref": ifc.t_ref, "g_max": ifc.g_max,
                              "verdict": verdict([r["m"] for r in runs])}
    figure(res, out / "debonding_step_refinement.png")
    (out / "debonding_step_refinement.md").write_text(report(res))
    slim = {"fast": fast, "speeds": res["speeds"], "base_length": res["base_length"],
            "cases": {n: {"title": c["title"], "verdict": c["verdict"], "t_ref": c["t_ref"],
                          "g_max": c["g_max"],
                          "runs": [r["m"] for r in c["runs"]]}
                      for n, c in res["cases"].items()}}
    (out / "debonding_step_refinement.json").write_text(json.dumps(slim, indent=1, default=float))
    return slim


if __name__ == "__main__":
    run_from_command_line(main, __doc__, "debonding_step_refinement", HERE,
                          fast_help="the tests' version (koyna_smoke)")
