"""Write BENCHMARKS.md from the pytest-benchmark JSON of `make bench`.

Medians only (this is a shared 2-core machine: absolute times are noisy; ratios are taken
between benchmarks of the same run). Usage: python verification/write_benchmarks.py [json] [md]
"""
from __future__ import annotations

import json
import pathlib
import platform
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]


def cpu_name() -> str:
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    src = pathlib.Path(argv[0]) if argv else ROOT / ".benchmarks.json"
    dst = pathlib.Path(argv[1]) if len(argv) > 1 else ROOT / "BENCHMARKS.md"
    koyna = ROOT / "verification" / "out" / "bench_koyna.json"
    if not src.exists():                      # only the Koyna study (bench_koyna.py) was run
        data = {"benchmarks": [], "machine_info": {"cpu": {"count": "?"}}}
    else:
        data = json.loads(src.read_text())
    rows = {}
    for b in data["benchmarks"]:
        rows[b["name"]] = (b["stats"]["median"], b.get("extra_info", {}), b["stats"]["rounds"])
    out = ["# Benchmarks", "",
           f"Machine: {cpu_name()}, {data.get('machine_info', {}).get('cpu', {}).get('count', '?')}"
           f" cores, Python {platform.python_version()}; date {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}.",
           "Command: `make bench` (pytest-benchmark medians; then this script).", "",
           "| benchmark | median | rounds | extra |", "|---|---|---|---|"]
    if not rows:
        out[-3:] = ["pytest-benchmark (`make bench`): not run for this file; only the Koyna "
                    "study below."]
    for name, (med, extra, rounds) in sorted(rows.items()):
        unit = f"{med * 1e3:.3f} ms"
        ex = ", ".join(f"{k}={v}" for k, v in extra.items())
        if "points" in extra:
            ex += f", {extra['points'] / med / 1e6:.1f} M points/s"
        out.append(f"| `{name}` | {unit} | {rounds} | {ex} |")
    # derived ratios of the same run
    out += ["", "## Ratios (same run)", ""]
    for th in ("1", "all"):
        for lay in ("interleaved", "blocked"):
            k = rows.get(f"test_bench_numba[{th}-{lay}]")
            c = rows.get(f"test_bench_copy_roofline[{th}]")
            if k and c:
                out.append(f"- law kernel ({lay}) / copy kernel, {th} thread(s): "
                           f"{k[0] / c[0]:.2f}x")
    ref = rows.get("test_bench_numpy_reference")
    k1 = rows.get("test_bench_numba[1-interleaved]")
    if ref and k1:
        out.append(f"- numpy reference / numba (1 thread): {ref[0] / k1[0]:.1f}x")
    for name, (med, extra, _) in rows.items():
        if "speedup_vs" in extra and extra["speedup_vs"] in rows:
            out.append(f"- {extra['speedup_vs']} / {name}: {rows[extra['speedup_vs']][0] / med:.1f}x")
    if koyna.exists():
        out += koyna_section(json.loads(koyna.read_text()), rows)
    else:
        out += ["", "## Koyna dam — not run", "",
                "Not run here: `python verification/bench_koyna.py` writes "
                "verification/out/bench_koyna.json, then rerun this script."]
    # hand-written sections of other studies (IDA, law kernel, solver speed, ...)
    # are kept as they are, after the generated ones
    if dst.exists():
        generated = ("## Ratios (same run)", "## Koyna dam — ", "## Koyna dam (issue #7)",
                     "## Koyna (issue #7)")
        sec = None
        for line in dst.read_text().splitlines():
            if line.startswith("## ") or line.startswith("# "):
                sec = None if line.startswith(generated) or line.startswith("# ") else [line]
                if sec is not None:
                    out += [""] if out[-1] != "" else []
            elif sec is None:
                continue
            if sec is not None:
                out.append(line)
    dst.write_text("\n".join(out) + "\n")
    print(f"wrote {dst}")
    return 0


def _ms(x) -> str:
    return "—" if x is None else f"{x:.1f}" if x >= 10 else f"{x:.2f}"


def _yes(ok: bool) -> str:
    return "**met**" if ok else "**not met**"


def koyna_section(k: dict, rows: dict | None = None) -> list[str]:
    """The Koyna study of verification/bench_koyna.py (JSON) as markdown; ratios of the
    pytest-benchmark Koyna rows of the same `make bench` run when present."""
    e = k.get("env", {})
    la = k.get("loadavg_start", [])
    out = ["", "## Koyna dam — `verification/bench_koyna.py`", "",
           f"Machine: {e.get('cpu')}, {e.get('cores')} cores (shared with other sessions), "
           f"Python {e.get('python')}, OMP/BLAS threads {e.get('threads')}; date {e.get('date')}.",
           "Commands: " + "; ".join(f"`{c}`" for c in k.get("commands", [k.get("command")]))
           + " (environment of the Makefile). Load average at "
           f"start {', '.join(f'{x:.2f}' for x in la)}, at end "
           f"{', '.join(f'{x:.2f}' for x in k.get('loadavg_end', []))} (1/5/15 min): absolute "
           "times carry roughly ±30 %; ratios are taken within one run.", ""]
    p1 = k.get("part1")
    if p1:
        out += ["### Time per step against DOFs and interface points", "",
                f"Short runs of `python -m ngs_driver run koyna` (ngs_driver.apps.dam.run on a "
                f"prebuilt model; "
                f"{p1['duration']} s = {round(p1['duration'] / 2e-3)} steps of dt = 2 ms) from "
                f"`ground_motion.start = {p1['start']}` s: {p1['record']} — its strongest "
                f"second. Per-step wall = median over the steps of a run (the first step, which "
                f"factorises and builds the condensed columns, is a separate column), median "
                f"of {p1['repeats']} repeated runs. Scene law (alpha = 2, size scaling on).", ""]
        for name, xk in (("dofs", "DOFs"), ("points", "interface points")):
            rs = p1["series"].get(name, [])
            if not rs:
                continue
            out += [f"Against {xk}:", "",
                    "| mesh | DOFs | points | ms/step (median) | ms/step (mean) | first step "
                    "[ms] | Newton its/step | max active points | cuts | debonded at end |",
                    "|---|---|---|---|---|---|---|---|---|---|"]
            for r in rs:
                out.append(f"| `{r['label']}` | {r['nfree']} | {r['npts']} | "
                           f"{_ms(1e3 * r['per_step_median'])} | {_ms(1e3 * r['per_step_mean'])}"
                           f" | {_ms(1e3 * r['first_step'])} | {r['newton_per_step']:.2f} | "
                           f"{r['n_active_max']} | {r['cuts']} | "
                           f"{r.get('n_debonded_final', '—')} |")
            if name == "points" and p1["series"].get("dofs"):
                out += ["", "(The default mesh appears in both tables: two measurements of the "
                            "same configuration in the same run — their spread is the noise "
                            "of the shared machine.)"]
            if f"exponent_{name}" in p1:
                out += ["", f"Log–log fit over {xk}: time per step ∝ n^"
                            f"{p1[f'exponent_{name}']:.2f}; Newton iterations per step ∝ n^"
                            f"{p1[f'exponent_{name}_iterations']:.2f}."]
            out.append("")
    p2 = k.get("part2", {})
    order = {"alpha2": 0, "alpha1": 1}
    for key, r in sorted(p2.items(), key=lambda kv: (order.get(kv[0], 9), kv[0])):
        if "error" in r:
            out += [f"### Full Koyna run ({key}): FAILED", "", f"`{r['command']}`: {r['error']}", ""]
            continue
        tm = r["timings"]
        done = r.get("steps_done", r["n_steps"])
        stop = r.get("stopped")
        title = (f"### Full Koyna run, alpha = {r['alpha']:g} (10 s, {r['n_steps']} steps, "
                 f"default mesh: {r['nfree']} DOFs, {r['npts']} points)") if not stop else (
                 f"### Koyna run with the scene's default stop, alpha = {r['alpha']:g} "
                 f"(stopped after {done} of {r['n_steps']} steps)")
        res_ = r.get("results", {})
        out += [title, "",
                f"Command: `{r['command']}`; load average before/after: "
                f"{' / '.join(str(x).split('load average:')[-1].strip() for x in r.get('loadavg') or [])}.",
                "",
                "| quantity | value |", "|---|---|",
                f"| wall, whole process (/usr/bin/time) | {r.get('wall_s', float('nan')):.1f} s |",
                f"| CPU share of the process | {r.get('cpu_percent', float('nan')):.0f} % |",
                f"| time loop ({done} steps) | {tm['dynamic']:.1f} s |",
                f"| build / modal / static / outputs | {tm['build']:.1f} / {tm['modal']:.1f} / "
                f"{tm['static']:.1f} / {tm['outputs']:.1f} s |",
                f"| per step median / mean / max | {_ms(1e3 * tm['per_step_median'])} / "
                f"{_ms(1e3 * tm['per_step_mean'])} / {_ms(1e3 * tm['per_step_max'])} ms |",
                f"| Newton iterations / step (mean) | "
                f"{r['solver_totals']['iterations'] / max(done, 1):.2f} |",
                f"| failed iterations, cuts, steps with cuts | "
                f"{r['solver_totals']['iterations_failed']}, {r['solver_totals']['cuts']}, "
                f"{r['solver_totals']['steps_with_cuts']} |",
                f"| peak memory (max RSS) | {r.get('peak_rss_MB', float('nan')):.0f} MB |",
                f"| steps done | {done}" + (f" — stopped at t = {stop['t']:.3f} s: {stop['reason']}"
                                            if stop else "") + " |",
                f"| whole base debonded at t | {res_.get('t_crack_heel_reaches_final')} s "
                f"(crest u_x max {res_.get('crest_ux_max', float('nan')):.3g} m) |",
                (f"| target ≤ {r['target_s']:.0f} s wall | "
                 f"{_yes(r.get('wall_s', 1e9) <= r['target_s'])} (time loop alone: "
                 f"{_yes(tm['dynamic'] <= r['target_s'])}) |") if not stop else
                "| target ≤ 60 s wall | n/a (not a 5000-step run) |", ""]
    p3 = k.get("part3")
    if p3:
        out += ["### Condensed vs full (re-factorising) Newton, default mesh", "",
                f"{p3['nfree']} DOFs, {p3['npts']} points; {p3['law']}; both solvers advance "
                f"the same {p3['n_full']} steps from the same state (after {p3['warm_steps']} "
                f"condensed steps from t = {p3['start']} s); {p3['n_active']} active points.", "",
                "| method | ms/step (median) | Newton its/step |", "|---|---|---|",
                f"| condensed (same {p3['n_full']} steps) | {_ms(p3['condensed_ms_same_steps'])} | "
                f"{p3['condensed_newton_same_steps']:.2f} |",
                f"| condensed (next {p3['n_condensed']} steps) | "
                f"{_ms(p3['condensed_ms_median_all'])} | — |",
                f"| full Newton | {_ms(p3['full_ms'])} | {p3['full_newton']:.2f} |", "",
                f"Speed-up {p3['speedup']:.0f}× (target ≥ 20×: {_yes(p3['speedup'] >= 20)}); "
                f"displacements after the {p3['n_full']} steps agree to "
                f"{p3['u_rel_diff']:.1e} relative.", ""]
    p4 = k.get("part4")
    if p4:
        out += ["### OpenSeesPy, same mesh, linear", ""]
        if "error" in p4:
            out += [f"Not run: {p4['error']}", ""]
        else:
            out += [f"OpenSees {p4.get('opensees_version')}: tri31 plane strain (lumped mass), "
                    "interface = coincident dam/rock nodes joined by zeroLength springs k0 × "
                    "tributary length (no Rayleigh on them), Rayleigh a0 = "
                    f"{p4['a0a1'][0]:.4g}, a1 = {p4['a0a1'][1]:.4g} (ours), Newmark 0.5/0.25, "
                    f"dt = 2 ms, UniformExcitation x and y with our record from t = "
                    f"{p4['start']} s, static dead load + reservoir first (our assembled vectors "
                    f"as nodal loads); `algorithm Linear -factorOnce`, numberer RCM; "
                    f"{p4['n_steps']} steps, median per step. Ours linear: the condensed solver "
                    "with an interface law that stays on its elastic branch (σ = τ = 3 GPa, "
                    "G_I scaled to keep k0; no damage or friction; "
                    f"{p4['ours_linear_active_max']} active points). {p4.get('import_note', '')}.",
                    "", "| OpenSees system | ms/step | first step [ms] | crest u_x: max abs diff / "
                    "peak dynamic | static crest rel. diff |", "|---|---|---|---|---|"]
            for name, r in p4.get("systems", {}).items():
                if "error" in r:
                    out.append(f"| {name} | failed: {r['error'][:80]} | | | |")
                else:
                    out.append(f"| {name} | {_ms(r['ms_median'])} | {_ms(r['first_step_ms'])} | "
                               f"{r['crest_max_diff_over_dyn_peak']:.1e} | "
                               f"{r['crest_static_rel_diff']:.1e} |")
            out += ["", f"Ours linear: {_ms(p4['ours_linear_default_ms'])} ms/step on the default "
                        f"(consistent-mass) model, {_ms(p4['ours_linear_lumped_ms'])} ms/step on "
                        "the lumped-mass model used for the crest comparison (the differences "
                        "come from the lumped vs consistent interface springs; tolerance 1e-2 of "
                        "the peak dynamic crest displacement)."]
            if "opensees_ms" in p4:
                out += ["", f"Fastest OpenSees system: {p4['fastest']} "
                            f"({_ms(p4['opensees_ms'])} ms/step). Ours linear / OpenSees linear = "
                            f"{p4['ratio_ours_linear_default']:.2f}."]
            out.append("")
    r = k.get("ratios")
    if r:
        out += ["### Ratio to OpenSees linear (target ours nonlinear / OpenSees linear ≤ 1)", "",
                "| ours nonlinear | / OpenSees linear | target |", "|---|---|---|"]
        names = {"full_run_median_over_opensees": "full 10 s run, median step",
                 "full_run_mean_over_opensees": "full 10 s run, mean step (incl. cuts)",
                 "strong_part_median_over_opensees": "strong-part short run, median step",
                 "condensed_strong_over_opensees": "condensed, strong part (condensed vs full "
                                                   "study)"}
        for key, lab in names.items():
            if key in r:
                out.append(f"| {lab} | {r[key]:.2f} | {_yes(r[key] <= 1)} |")
        out.append("")
    if rows:
        c = rows.get("test_bench_koyna_condensed_step")
        f = rows.get("test_bench_koyna_full_step")
        li = rows.get("test_bench_koyna_linear_step")
        o = rows.get("test_bench_koyna_opensees_linear_step")
        lines = []
        if c and f:
            lines.append(f"- full / condensed Newton (pytest-benchmark): {f[0] / c[0]:.0f}x")
        if c and o:
            lines.append(f"- ours nonlinear (condensed) / OpenSees linear: {c[0] / o[0]:.2f}")
        if li and o:
            lines.append(f"- ours linear / OpenSees linear: {li[0] / o[0]:.2f}")
        if lines:
            out += ["### Koyna pytest-benchmark ratios (same `make bench` run)", ""] + lines + [""]
    return out


if __name__ == "__main__":
    raise SystemExit(main())
