"""Reports: the run's summary line, comparison of runs (Fig. 10/11 overlays, results.md)."""
from __future__ import annotations

import json
import pathlib

import numpy as np

from .files import atomic_write_text, read_csv
from .plots import damage_xmax, plot_crack_length, plot_crest, plot_damage_profiles

def _num(v) -> float:
    return float("nan") if v is None else v


def format_summary(s: dict) -> str:
    r = s["results"]
    tm = s["timings"]
    ch = s["characteristic_times"]
    stop = s.get("stopped") or {}
    done = (f"stopped at step {stop['step']} of {s['n_steps']} (t = {stop['t']:.4g} s: "
            f"{stop['reason']})" if stop.get("step") is not None else f"{s['n_steps']} steps")
    lines = [
        f"[{s['scene']['name']}] done: {done}; record {s['label']}"
        + (f"; verdict: {s['verdict']}" if s.get("verdict") else "")
        + (f" ({s['collapse']['mode']}, joint {s['collapse']['joint']!r}, t = "
           f"{s['collapse']['time']:.4g} s)" if (s.get("collapse") or {}).get("mode") else ""),
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
    pe = s.get("post_earthquake")
    for name, st in ((s.get("static") or {}).get("joints") or {}).items():
        d = (s.get("safety") or {}).get("joints", {}).get(name, {})
        p = (pe or {}).get("joints", {}).get(name, {})
        lines.append(f"  {name}: sliding FS static {st['sliding_fs']:.3g}, min "
                     f"{d.get('min_sliding_fs') or float('nan'):.3g}, post-earthquake "
                     f"{_num(p.get('sliding_fs')):.3g} (criterion 1.3: "
                     f"{'met' if p.get('meets_criterion') else 'NOT met'}); N' "
                     f"{st['normal_force']:.4g}, T {st['shear_force']:.4g}, U "
                     f"{st['uplift_force']:.4g} N/m")
        jr = (s.get("joints") or {}).get(name) or {}
        if "slip_max" in jr:
            lines.append(f"  {name}: slip max {jr['slip_max']:.4g} m, residual "
                         f"{jr['slip_residual']:.4g} m; block rotation max "
                         f"{jr['rotation_max']:.4g} rad, residual {jr['rotation_residual']:.4g} rad")
    return "\n".join(lines)


PAPER = {"alpha2": {"t_D_heel_1": 6.0, "crack_length": 1.1, "t_crack": 6.3},
         "alpha1": {"max_D": 0.1}}



def _load_run(d):
    d = pathlib.Path(d)
    s = json.loads((d / "summary.json").read_text())
    H = read_csv(d / "timeseries.csv")
    Dp = read_csv(d / "damage_profiles.csv")
    return s, H, Dp



def compare_runs(runs: dict, out) -> list[str]:
    """Overlay runs {label: results dir} (Fig. 10 both, Fig. 11 one panel each, crack length)
    and write results.md comparing with the paper's statements.  Expects the alpha = 2 run
    first and the alpha = 1 run second when both are given."""
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    data = {k: _load_run(v) for k, v in runs.items()}
    s0 = next(iter(data.values()))[0]
    lab = s0["label"]
    title = f"Koyna -- {lab}"
    files = []
    ser = []
    for k, (s, H, Dp) in data.items():
        st = s["static"]
        ser.append((k, np.concatenate([[0.0], H["t"]]),
                    np.concatenate([[st["crest_ux"]], H["crest_ux"]]),
                    np.concatenate([[st["crest_uy"]], H["crest_uy"]])))
    files.append(plot_crest(out / "fig10_crest_displacement.png", ser, title))
    panels = []
    xm = 0.0
    for i, (k, (s, H, Dp)) in enumerate(data.items()):
        tk = [c for c in Dp if c.startswith("D_t=")]
        times = [float(c[4:]) for c in tk]
        snaps = {"D": [Dp[c] for c in tk]}
        xm = max(xm, damage_xmax(snaps, Dp["x"]))
        panels.append((f"({chr(97 + i)}) {k}", Dp["x"], times, snaps["D"]))
    files.append(plot_damage_profiles(out / "fig11_damage_profiles.png", panels, title, xmax=xm))
    files.append(plot_crack_length(out / "crack_length.png",
                                   [(k, H["t"], H["crack_length_heel"], H["crack_length"])
                                    for k, (s, H, Dp) in data.items()], title))
    atomic_write_text(out / "results.md", results_table(data, runs))
    files.append("results.md")
    return files



def _fmt(v, f="{:.3g}"):
    return "never" if v is None else f.format(v)



def _observed(template: str, data) -> str:
    """Fill the 'observed here' column from the runs' summaries (alpha -> results)."""
    by = {}
    for s, H, Dp in data.values():
        by[s["scene"]["interface"]["alpha"]] = (s, H)
    na = "n/a (run missing)"

    def res(a):
        return by[a][0]["results"] if a in by else None

    r2, r1 = res(2.0), res(1.0)
    obs = dict(obs_t2=na, obs_crack=na, obs_d1=na, obs_crest=na, obs_uy=na, obs_sens=na)
    if r2:
        obs["obs_t2"] = ("D_heel = 1 at " + _fmt(r2["t_D_heel_reaches_1"], "{:.3f} s")
                         if r2["t_D_heel_reaches_1"] is not None
                         else f"no: max D_heel = {r2['max_D_heel']:.3g}")
        obs["obs_crack"] = (f"{r2['crack_length_heel_final']:.3g} m from the heel "
                            f"(max debonded {r2['crack_length_total_max']:.3g} m)")
    if r1:
        obs["obs_d1"] = f"max D = {r1['max_D']:.3g}"
    if r1 and r2:
        rng = [1e3 * (r["crest_ux_max"] - r["crest_ux_min"]) for r in (r2, r1)]
        obs["obs_crest"] = f"u_x range {rng[0]:.1f} mm (alpha 2) vs {rng[1]:.1f} mm (alpha 1)"
        obs["obs_sens"] = f"max D {r2['max_D']:.3g} (alpha 2) vs {r1['max_D']:.3g} (alpha 1)"
    fr = []
    for a, (s, H) in sorted(by.items()):
        uy = np.asarray(H["crest_uy"])
        fr.append(f"{100 * np.mean(uy < 0):.0f} % of steps (alpha {a:g})")
    if fr:
        obs["obs_uy"] = "u_y < 0 in " + ", ".join(fr)
    stops = [f"- alpha = {a:g}: **stopped at t = {s['stopped']['t']:.3f} s** — "
             f"{s['stopped']['reason']}." for a, (s, H) in sorted(by.items())
             if s.get("stopped")]
    obs["stops"] = ("**Failure by sliding.**\n" + "\n".join(stops) + "\n" if stops else "")
    return template.format(**obs)



def damage_ordering(r2: dict, r1: dict) -> str:
    """The observed line under Eq. 7's analysis in results.md: the runs' largest damage
    (``results.max_D``) with alpha = 2 (r2) and alpha = 1 (r1) and which is smaller; when both
    are equal (saturated at 1 where the base debonds) the heel's maxima (``max_D_heel``) tell
    them apart."""
    d1, d2 = r1["max_D"], r2["max_D"]
    h1, h2 = r1.get("max_D_heel"), r2.get("max_D_heel")
    if d2 < d1:
        verdict = ("alpha = 2 gives less damage than alpha = 1, as the analysis predicts and "
                   "against the paper's ordering.")
    elif d2 > d1:
        verdict = ("alpha = 2 gives more damage than alpha = 1 here (the opening histories "
                   "differ between the runs; see timeseries.csv).")
    elif h1 is not None and h2 is not None:
        verdict = (f"The same largest damage in both runs; at the heel max D = {h2:.4g} "
                   f"(alpha = 2) vs {h1:.4g} (alpha = 1): alpha = 2 "
                   + ("less, as the analysis predicts." if h2 < h1 else
                      "more (the opening histories differ between the runs)." if h2 > h1
                      else "the same."))
    else:
        verdict = "The same largest damage in both runs."
    return (f"**Observed:** max D = {d2:.4g} (alpha = 2) vs {d1:.4g} (alpha = 1); "
            f"D(alpha=1)^2 = {d1 ** 2:.4g}. " + verdict)


def results_table(data, runs) -> str:
    rows = []
    for k, (s, H, Dp) in data.items():
        r = s["results"]
        tm = s["timings"]
        rows.append(
            f"| {k} | {s['scene']['interface']['alpha']:g} | {r['max_D_heel']:.4g} | "
            f"{_fmt(r['t_D_heel_reaches_1'], '{:.3f} s')} | {r['max_D']:.4g} | "
            f"{r['crack_length_heel_final']:.3g} m | "
            f"{_fmt(r['t_crack_heel_reaches_final'], '{:.3f} s')} | "
            f"{r['crack_length_total_max']:.3g} m | "
            f"{1e3 * (r['crest_ux_max'] - r['crest_ux_min']):.2f} mm | "
            f"{s['solver_totals']['iterations']} / {s['solver_totals']['cuts']} | "
            f"{tm['dynamic']:.1f} s ({1e3 * tm['per_step_median']:.2f} ms) |")
    s0 = next(iter(data.values()))[0]
    gmax = s0["scene"]["interface"]["g_max"]
    lnc = s0["reference_parameters"]["l_Nc"]
    ch = s0["characteristic_times"]
    synth = s0["ground_motion"]["synthetic"]
    txt = f"""# Koyna seismic interface fracture: our runs against the paper (§5)

Record: **{s0['label']}**. {'This is a SYNTHETIC Koyna-like motion, not the 1967 accelerogram the paper used (Fig. 9): no digitised record is public.' if synth else ''}
Formulation: {s0['formulation']}.
Interface: sigma_max = tau_max = {s0['scene']['interface']['sigma_max']:.3g} Pa, G_I = {s0['scene']['interface']['G_I']:g} N/m, l_Nc = {lnc:.4g} m,
f = {s0['scene']['interface']['friction']:g}, beta = {s0['scene']['interface']['beta']:g}, g_max = {gmax:.4g} m = {gmax / lnc:.3g} l_Nc (not given by the paper),
size-scale laws {'on' if s0['scene']['interface']['scaling'] else 'off'}. dt = {s0['scene']['time']['dt']} s, {s0['n_steps']} steps.
Characteristic times (Eq. 11, dam concrete): t1 = {ch['t1']:.3e} s, t2 = {ch['t2']:.3e} s (c_L = {ch['c_L']:.0f} m/s, a0 = {ch['a0']:g} m).

| run | alpha | max D at heel | t(D_heel = 1) | max D anywhere | crack from heel, final | reached at | max debonded length (sum w) | crest u_x range | Newton its / cuts | dynamic wall (per-step median) |
|---|---|---|---|---|---|---|---|---|---|---|
""" + "\n".join(rows) + _observed("""

## The paper's statements, and what our runs show

| statement (paper §5) | paper | what can match with a synthetic record | observed here |
|---|---|---|---|
| alpha = 2: D reaches 1 at the heel | t ≈ 6.0 s | not the time (record-specific); whether it happens in the strong phase | {obs_t2} |
| alpha = 2: interface crack length | 1.1 m at t ≈ 6.3 s | the order of magnitude only, if the base does not fail as a whole | {obs_crack} |
| alpha = 1: D < 0.1 throughout | max D < 0.1 | qualitatively (but see below: Eq. 7 reverses the ordering) | {obs_d1} |
| crest displacements hardly depend on alpha (Fig. 10) | qualitative | yes: a global response | {obs_crest} |
| vertical crest displacement often negative (contact) | qualitative | yes | {obs_uy} |
| strong alpha-sensitivity of damage | qualitative | expected, in the direction Eq. 7 dictates (below) | {obs_sens} |

{stops}
""", data) + """## Why alpha = 2 cannot give more damage than alpha = 1 with Eq. 7 and one g_max

With beta = 0 the damage increment of a step (Eq. 7) is ΔD = x^alpha with x = Δg/g_max (only
for Δg > 0). For x ≤ 1 (every step's opening below g_max, which holds here: Δg per 2 ms step is
a small fraction of l_Nc) x² ≤ x, and summed over the same history
Σ x² ≤ (Σ x)², i.e. **D(alpha=2) ≤ D(alpha=1)²**, and D(alpha=2) ≤ D(alpha=1) whenever D(alpha=1) ≤ 1.
So along the same opening history alpha = 2 accumulates *less* damage than alpha = 1, the
opposite of the paper's ordering (alpha = 2 fails at the heel, alpha = 1 stays below 0.1). The
paper's ordering cannot come from Eq. 7 with a common g_max (it would need, e.g., a much smaller
g_max for alpha = 2, x > 1 steps, or a different normalisation). The histories of the two runs
differ (damage feeds back on the opening), but the inequality holds step by step for the
increments, and what we observe is reported in the table above.
"""
    a = {s['scene']['interface']['alpha']: s['results'] for s, H, Dp in data.values()}
    if 1.0 in a and 2.0 in a:
        txt += "\n" + damage_ordering(a[2.0], a[1.0]) + "\n"
        t1 = a[2.0]["t_D_heel_reaches_1"]
        txt += (f"Debonding at the heel (kappa ≥ 1, cohesive failure, independent of D): first at "
                f"t = {_fmt(a[2.0]['t_first_debond'], '{:.3f} s')} (alpha = 2), "
                f"{_fmt(a[1.0]['t_first_debond'], '{:.3f} s')} (alpha = 1); D_heel = 1 at "
                f"{_fmt(t1, '{:.3f} s')} (alpha = 2), "
                f"{_fmt(a[1.0]['t_D_heel_reaches_1'], '{:.3f} s')} (alpha = 1).\n")
    txt += safety_table(data)
    txt += "\nRuns: " + ", ".join(f"{k}: `{v}`" for k, v in runs.items()) + "\n"
    return txt


def safety_table(data) -> str:
    """The base's sliding safety of each run (docs/safety.md); empty for runs
    written before the safety outputs existed."""
    rows = []
    for k, (s, H, Dp) in data.items():
        st = ((s.get("static") or {}).get("joints") or {}).get("base")
        if st is None:
            continue
        d = ((s.get("safety") or {}).get("joints") or {}).get("base", {})
        pe = ((s.get("post_earthquake") or {}).get("joints") or {}).get("base", {})
        # no post-earthquake FS: the run stopped (collapse or undetermined: no solve) or friction
        # cannot hold the final state -- not "never", which the time columns use
        fs_pe = pe.get("sliding_fs")
        fs_pe = _fmt(fs_pe) if fs_pe is not None else (
            "not computed (run stopped)" if (s.get("post_earthquake") or {}).get("skipped")
            else "none")
        rows.append(f"| {k} | {st['sliding_fs']:.3g} | {_fmt(d.get('min_sliding_fs'))} | "
                    f"{_fmt(d.get('time_fs_below_1'), '{:.3f} s')} | "
                    f"{_fmt(d.get('residual_slip'), '{:.3g} m')} | "
                    f"{fs_pe} | "
                    f"{'yes' if pe.get('meets_criterion') else 'NO'} |")
    if not rows:
        return ""
    return ("\n## Sliding safety of the base (FS = (f N' + c L_bonded)/|T|, EM 1110-2-2100 "
            "eq. 3-1 with the law's f and c)\n\n| run | FS static | min FS | time FS < 1 | "
            "residual slip | FS post-earthquake | >= 1.3 |\n|---|---|---|---|---|---|---|\n"
            + "\n".join(rows) + "\n")
