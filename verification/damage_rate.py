"""Material-point study of the three readings of the damage law, Eq. 7.

One interface point (the paper's parameters, rough contact, friction 0.3) is opened and closed in
mode I through N sinusoidal cycles g_N(t) = A (1 − cos 2π f t)/2 (A = 0.1 l_Nc: elastic, half the
peak opening), sampled with n equal time steps per cycle, and the damage D at the end is
recorded for the forms

* ``paper``     ΔD = (Δg⁺/g_max)^α B per step (Eq. 7 as a per-step increment, the default);
* ``objective`` D = (p/g_max)^α, dp = B dg⁺ (docs/law.md (damage forms));
* ``rate``      ΔD = (Δg⁺/g_max)^α (Δt/t_ref)^(1−α) B (Eq. 7 as a rate, docs §1.5),

and α = 1, 2 (β = 0, F_th = 0, so B = 1 while opening), against n at a fixed frequency and
against f at a fixed n. Closed forms (n even, n ≥ 4; derived in the report) are printed beside the
measured values.

    python verification/damage_rate.py [--fast] [--outdir DIR]

``main(fast=False, outdir=None)`` writes ``damage_rate.png`` and ``damage_rate.md`` into
``outdir`` (default verification/out) and returns a dict of the numbers.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")
HERE = Path(__file__).resolve().parent
if str(HERE.parent) not in sys.path:
    sys.path.insert(0, str(HERE.parent))

import numpy as np  # noqa: E402

from interfacelaw import (CohesiveParams, ContactParams, DamageParams,  # noqa: E402
                          FrictionParams, InterfaceLaw)
from interfacelaw import drivers as dr  # noqa: E402

# the paper's interface (sigma = tau = 3 MPa, G_I = 250 N/m, lambda_max = 0.2) and the g_max of
# the Koyna scene (6.67e-4 m = 4 l_Nc); t_ref = 1 s
COH = CohesiveParams.from_fracture_energy(3e6, 3e6, 250.0, 0.2, 1.0)
G_MAX = 4 * COH.l_Nc
T_REF = 1.0
AMP = 0.1 * COH.l_Nc
FORMS = ("paper", "objective", "rate")
ALPHAS = (1.0, 2.0)


def make_law(form: str, alpha: float) -> InterfaceLaw:
    return InterfaceLaw(COH, ContactParams("rough"), FrictionParams(0.3),
                        DamageParams(g_max=G_MAX, alpha=alpha, form=form, t_ref=T_REF))


def final_damage(law: InterfaceLaw, f: float, n: int, cycles: int) -> float:
    """D after ``cycles`` sinusoidal cycles at frequency f [Hz], n equal steps per cycle."""
    t = np.arange(cycles * n + 1) / (n * f)
    g = np.zeros((t.size, 2))
    g[:, 0] = 0.5 * AMP * (1.0 - np.cos(2.0 * np.pi * f * t))
    g[::n, 0] = 0.0                       # the troughs exactly (cos(2 pi k) rounds to 1 anyway)
    g[n // 2::n, 0] = AMP                 # the peaks exactly (n even)
    h = dr.gap_path(law, t, g, 1)         # time-stamped: each row's dt goes to the law
    return float(h.damage[-1])


def closed_form(form: str, alpha: float, f: float, n: int, cycles: int) -> float | None:
    """Exact D of the sampled history (n even, n >= 4), or None where there is none.

    Per loading half the increments are Δg_k = A sin(h/2) sin(θ_k), θ_k the midpoints of n/2
    equal steps h = 2π/n over (0, π), and Σ sin²θ_k = n/4 (n/2 >= 2). So for α = 2:
    paper Σ(Δg/g_max)² = (A/g_max)² sin²(π/n) n/4 per cycle (→ π²/(4n) (A/g_max)², no limit
    but 0); rate Σ(Δg/g_max)² t_ref/Δt = (A/g_max)² f t_ref n² sin²(π/n)/4 per cycle
    (→ π² f t_ref/4 (A/g_max)², second order in 1/n). α = 1: N A/g_max for every form;
    objective: (N A/g_max)^α (the positive increments sum to N A exactly)."""
    x = AMP / G_MAX
    if alpha == 1.0:
        return cycles * x
    if form == "objective":
        return (cycles * x) ** alpha
    if alpha != 2.0 or n < 4 or n % 2:
        return None
    s2 = math.sin(math.pi / n) ** 2
    if form == "paper":
        return cycles * x * x * s2 * n / 4
    return cycles * x * x * f * T_REF * n * n * s2 / 4


def rate_limit(alpha: float, f: float, cycles: int) -> float:
    """The rate form's D as the step -> 0 (α = 2): N (A/g_max)² π² f t_ref/4."""
    x = AMP / G_MAX
    return cycles * x if alpha == 1.0 else cycles * x * x * math.pi ** 2 * f * T_REF / 4


def _slope(x, y):
    """d log y / d log x between the last two points (0 where y does not change)."""
    if y[-1] == y[-2]:
        return 0.0
    return math.log(y[-1] / y[-2]) / math.log(x[-1] / x[-2])


def _table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def main(fast: bool = False, outdir=None) -> dict:
    outdir = Path(outdir) if outdir is not None else HERE / "out"
    outdir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    cycles = 3 if fast else 10
    f_fix = 3.0                                               # Hz (Koyna's first mode ~ 3 Hz)
    n_fix = 32 if fast else 128
    ns = [2, 4, 16, 64] if fast else [2, 4, 8, 16, 32, 64, 128, 256, 512]
    fs = [0.3, 3.0, 30.0] if fast else [0.1, 0.3, 1.0, 3.0, 10.0, 30.0]
    D_step, D_freq, slope_step, slope_freq, max_err = {}, {}, {}, {}, 0.0
    for form in FORMS:
        for alpha in ALPHAS:
            key = f"{form}_a{alpha:g}"
            law = make_law(form, alpha)
            D_step[key] = [final_damage(law, f_fix, n, cycles) for n in ns]
            D_freq[key] = [final_damage(law, f, n_fix, cycles) for f in fs]
            slope_step[key] = _slope(ns, D_step[key])
            slope_freq[key] = _slope(fs, D_freq[key])
            for n, d in zip(ns, D_step[key]):
                c = closed_form(form, alpha, f_fix, n, cycles)
                if c is not None:
                    max_err = max(max_err, abs(d - c) / c)
            for f, d in zip(fs, D_freq[key]):
                c = closed_form(form, alpha, f, n_fix, cycles)
                if c is not None:
                    max_err = max(max_err, abs(d - c) / c)
    # rate form: alpha = 2 damages more than alpha = 1 above f* (limit values equal)
    x = AMP / G_MAX
    f_cross = 4.0 / (math.pi ** 2 * x * T_REF)
    wall = time.perf_counter() - t0

    # ---- figure -------------------------------------------------------------------------
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.6))
    style = {"paper": "o-", "objective": "s--", "rate": "^-"}
    color = {1.0: "C0", 2.0: "C3"}
    for form in FORMS:
        for alpha in ALPHAS:
            key = f"{form}_a{alpha:g}"
            lab = f"{form}, α = {alpha:g}"
            ax[0].loglog(ns, D_step[key], style[form], color=color[alpha], label=lab,
                         alpha=0.8, ms=4)
            ax[1].loglog(fs, D_freq[key], style[form], color=color[alpha], label=lab,
                         alpha=0.8, ms=4)
    ax[0].axhline(rate_limit(2.0, f_fix, cycles), color="0.5", lw=0.8, ls=":",
                  label="rate α = 2, limit Δt → 0")
    ax[1].loglog(fs, [rate_limit(2.0, f, cycles) for f in fs], color="0.5", lw=0.8, ls=":",
                 label="rate α = 2, limit Δt → 0")
    ax[1].axvline(f_cross, color="k", lw=0.6, ls="-.", label=f"f* = {f_cross:.3g} Hz")
    ax[0].set_xscale("log", base=2)
    ax[0].set_xticks(ns, [str(n) for n in ns])
    ax[0].minorticks_off()
    ax[0].text(0.02, 0.97, "α = 1: the three forms coincide (blue)", transform=ax[0].transAxes,
               fontsize=7, va="top")
    ax[0].set_xlabel("increments per cycle n")
    ax[0].set_title(f"(a) D after {cycles} cycles at f = {f_fix:g} Hz")
    ax[1].set_xlabel("loading frequency f [Hz]")
    ax[1].set_title(f"(b) D after {cycles} cycles, n = {n_fix} per cycle")
    for a in ax:
        a.set_ylabel("damage D")
        a.grid(alpha=0.3, which="both")
        a.legend(fontsize=7)
    fig.suptitle(f"Eq. 7 read three ways: A = {AMP:.3g} m (0.1 l_Nc), g_max = {G_MAX:.3g} m, "
                 f"t_ref = {T_REF:g} s, β = 0", fontsize=9)
    fig.tight_layout()
    png = outdir / "damage_rate.png"
    fig.savefig(png, dpi=110)
    plt.close(fig)

    # ---- table --------------------------------------------------------------------------
    def verdict(key, s_n, s_f):
        step = ("no (exact)" if abs(s_n) < 1e-9 else
                f"yes, D ∝ n^{s_n:.2f}: no limit" if s_n < -0.5 else
                f"converges (slope {s_n:.1e})")
        rate = "no" if abs(s_f) < 1e-9 else f"yes, D ∝ f^{s_f:.2f}"
        return step, rate

    rows_n, rows_f, rows_v = [], [], []
    for form in FORMS:
        for alpha in ALPHAS:
            key = f"{form}_a{alpha:g}"
            rows_n.append([form, f"{alpha:g}"] + [f"{d:.4e}" for d in D_step[key]]
                          + [f"{max(D_step[key]) / min(D_step[key]):.3g}"])
            rows_f.append([form, f"{alpha:g}"] + [f"{d:.4e}" for d in D_freq[key]]
                          + [f"{max(D_freq[key]) / min(D_freq[key]):.3g}"])
            rows_v.append([form, f"{alpha:g}", *verdict(key, slope_step[key], slope_freq[key])])
    lim = rate_limit(2.0, f_fix, cycles)
    text = (
        "# Eq. 7 read three ways: which damage depends on the step, which on the rate\n\n"
        "Command: `python verification/damage_rate.py" + (" --fast" if fast else "") + "` "
        f"({wall:.1f} s). docs/law.md (damage forms).\n\n"
        f"One point of the paper's interface (σ = τ = 3 MPa, G_I = 250 N/m, λ_max = 0.2, "
        f"l_Nc = {COH.l_Nc:.4g} m; rough contact, friction 0.3), mode I, {cycles} cycles "
        f"g_N(t) = A (1 − cos 2πft)/2 with A = 0.1 l_Nc = {AMP:.3g} m (elastic), sampled with n "
        f"equal time steps per cycle (`drivers.gap_path`, time-stamped: each step's Δt goes to "
        f"the law). g_max = {G_MAX:.4g} m (4 l_Nc, the Koyna scene's), t_ref = {T_REF:g} s, "
        "β = 0, F_th = 0.\n\n"
        f"## (a) D against increments per cycle n (f = {f_fix:g} Hz)\n\n"
        + _table(["form", "α"] + [f"n = {n}" for n in ns] + ["max/min"], rows_n)
        + f"\n\n## (b) D against the loading frequency f (n = {n_fix})\n\n"
        + _table(["form", "α"] + [f"f = {f:g} Hz" for f in fs] + ["max/min"], rows_f)
        + "\n\n## Which depends on what (slopes between the last two columns)\n\n"
        + _table(["form", "α", "depends on the step?", "depends on the rate?"], rows_v)
        + "\n\n"
        f"Every measured value that has a closed form (n even ≥ 4) matches it to "
        f"{max_err:.1e} relative (rounding): α = 1, N A/g_max = {cycles * x:.4g} for every form, "
        f"step and rate; objective (N A/g_max)^α; α = 2 paper (A/g_max)² N n sin²(π/n)/4 "
        f"(→ π²N(A/g_max)²/(4n): **D ∝ 1/n, no limit but 0**); α = 2 rate "
        f"(A/g_max)² N f t_ref n² sin²(π/n)/4 (→ {lim:.4e} at {f_fix:g} Hz, second order in "
        f"1/n; exactly independent of n at a constant opening rate — tests/test_damage_rate.py)."
        "\n\n**Plainly.** For α = 1 the three forms are one and depend on neither. For α = 2 "
        "the paper's form depends on the number of steps per cycle (a numerical parameter) "
        "and not on the rate; the objective form on neither; the rate form converges with the "
        "step and is proportional to the frequency: it is the only one of the three in which "
        "the loading rate matters, as a rate law Ḋ must. With t_ref = 1 s the rate form's "
        f"α = 2 damages more than α = 1 only above f* = 4 g_max/(π² A t_ref) = {f_cross:.3g} Hz "
        "for this amplitude (peak opening rate πfA above (4/π) g_max/t_ref): the paper's "
        "ordering (α = 2 worse) needs fast openings relative to g_max/t_ref, and t_ref, like "
        "g_max, is not given by the paper.\n\n"
        f"Figure: `{png.name}`.\n")
    md = outdir / "damage_rate.md"
    md.write_text(text)
    print(text)
    return {"ns": ns, "fs": fs, "f_fixed": f_fix, "n_fixed": n_fix, "cycles": cycles,
            "amplitude": AMP, "g_max": G_MAX, "t_ref": T_REF,
            "D_step": D_step, "D_freq": D_freq, "slope_step": slope_step,
            "slope_freq": slope_freq, "closed_form_max_rel_err": max_err,
            "rate_limit_f_fixed": lim, "f_crossover": f_cross,
            "files": [str(png), str(md)], "wall": wall}


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fast", action="store_true")
    ap.add_argument("--outdir", default=None)
    a = ap.parse_args()
    main(fast=a.fast, outdir=a.outdir)
