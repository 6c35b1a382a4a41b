"""Material-point verification of the interface law.

Sections (REPORT.md headings): 1. the paper's Fig. 5; 2. energy table; 3. tangent table per
branch; 4. cyclic damage and an S–N-like curve; 5. stiff and extreme cases (pass/fail);
6. error against run time: (a) step-size dependence of the damage form, (b) mixed-control Newton.

    python verification/material_point.py [--fast] [--outdir DIR]

``main(fast=False, outdir=None)`` writes PNGs and REPORT.md into ``outdir`` (default
verification/out), prints a summary table and returns a dict of the headline numbers.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time
import warnings
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")
HERE = Path(__file__).resolve().parent
if str(HERE.parent) not in sys.path:
    sys.path.insert(0, str(HERE.parent))

import numpy as np  # noqa: E402

from interfacelaw import (CohesiveParams, ContactParams, DamageParams,  # noqa: E402
                          FrictionParams, InterfaceLaw, InterfaceState)
from interfacelaw import drivers as dr  # noqa: E402

# default parameters: l_Tc != l_Nc and tau != sigma so that mixed-mode numbers are not trivial
SIG = 1.0e6
COH = CohesiveParams(sigma_max=SIG, tau_max=2.0e6, l_Nc=1.0e-4, l_Tc=2.0e-4, lambda_max=0.2)


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


# ------------------------------------------------------------------------ 1. Fig. 5 ------
def sec_fig5(outdir, fast):
    coh = CohesiveParams(SIG, SIG, 1.0e-4, 1.0e-4, 0.2)       # lambda_max 0.2, l_Tc/l_Nc = 1
    law = InterfaceLaw(coh)
    nn = 21 if fast else 121
    gN = np.linspace(0, 1.0, nn) * coh.l_Nc
    gT = np.linspace(-1.0, 1.0, 2 * nn - 1) * coh.l_Tc
    GN, GT = np.meshgrid(gN, gT, indexing="ij")
    gap = np.column_stack([GN.ravel(), GT.ravel()])
    # each grid point is the end of a proportional (monotonic) path from the virgin state
    F, _, _ = law.evaluate(gap, law.initial_state(gap.shape[0]))
    FN = F[:, 0].reshape(GN.shape) / SIG
    FT = F[:, 1].reshape(GN.shape) / SIG
    plt = _plt()
    fig = plt.figure(figsize=(11, 4.6))
    for k, (Z, lab) in enumerate(((FN, "F_N / sigma_max"), (FT, "F_T / tau_max"))):
        if fast:                                   # contour plots: cheaper than surfaces
            ax = fig.add_subplot(1, 2, k + 1)
            cs = ax.contourf(GN / coh.l_Nc, GT / coh.l_Tc, Z, 20, cmap="viridis")
            fig.colorbar(cs, ax=ax, label=lab)
            ax.set_xlabel("g_N / l_Nc")
            ax.set_ylabel("g_T / l_Tc")
            continue
        ax = fig.add_subplot(1, 2, k + 1, projection="3d")
        ax.plot_surface(GN / coh.l_Nc, GT / coh.l_Tc, Z, cmap="viridis", linewidth=0,
                        rstride=2, cstride=2)
        ax.set_xlabel("g_N / l_Nc")
        ax.set_ylabel("g_T / l_Tc")
        ax.set_zlabel(lab)
        ax.view_init(25, -60 if k == 0 else -30)
    fig.suptitle("Paper Fig. 5: lambda_max = 0.2, l_Tc/l_Nc = 1 (monotonic envelope)")
    fig.tight_layout()
    p = outdir / "fig5_tractions.png"
    fig.savefig(p, dpi=110)
    plt.close(fig)
    res = {"FN_max": float(FN.max()), "FT_max": float(np.abs(FT).max())}
    text = (f"Surfaces of F_N/σ_max and F_T/τ_max over g_N ∈ [0, l_Nc], g_T ∈ [−l_Tc, l_Tc] "
            f"(each point the end of a proportional path from the virgin state). Grid "
            f"{GN.shape[0]}×{GN.shape[1]}. max F_N/σ_max = {res['FN_max']:.12f}, "
            f"max |F_T|/τ_max = {res['FT_max']:.12f} (both 1: reached on the axes at λ = 0.2, "
            f"zero beyond λ = 1). Figure: `{p.name}`.")
    return text, res


# ------------------------------------------------------------------------ 2. energy ------
def sec_energy(outdir, fast):
    law = InterfaceLaw(COH)
    rows = []
    worst = 0.0
    psis = np.arange(0, 91, 15)
    for psi_d in psis:
        psi = math.radians(psi_d)
        G = float(COH.G_mixed(psi))
        errs = {}
        for n in (1, 3, 10, 1000):
            h = dr.mixed_mode(law, psi, n, lam_end=1.5)
            errs[n] = (h.dissipated[-1] - G) / G
        hw = dr.mixed_mode(law, psi, 100, lam_end=1.5)
        e = max(abs(v) for v in errs.values())
        worst = max(worst, e)
        rows.append([f"{psi_d:.0f}", f"{G:.6f}", f"{h.dissipated[-1]:.12f}",
                     *(f"{errs[n]:.1e}" for n in (1, 3, 10, 1000)),
                     f"{(hw.work[-1] - G) / G:.2e}"])
    text = ("Proportional paths at physical angle ψ to λ = 1.5 (σ_max = 1 MPa, τ_max = 2 MPa, "
            "l_Nc = 0.1 mm, l_Tc = 0.2 mm, λ_max = 0.2). Analytic "
            "G(ψ) = (l_Nc/2)(σ_max cos²φ + τ_max sin²φ), tan φ = (l_Nc/l_Tc) tan ψ. Columns: "
            "relative error of the law's `dissipated` with 1, 3, 10, 1000 increments, and of "
            "the trapezoid work of the traction–gap curve with 100 increments (quadrature "
            "error −2.5/n², rate 2, from the cells holding the kinks at λ = λ_max and 1).\n\n"
            + _table(["ψ [°]", "G analytic [J/m²]", "dissipated (n=1000)", "err n=1",
                      "err n=3", "err n=10", "err n=1000", "trapezoid work err n=100"], rows)
            + f"\n\nMax |relative error| of dissipated: **{worst:.1e}**.")
    return text, {"energy_max_rel_err": worst}


# ------------------------------------------------------------------------ 3. tangent -----
def _state(law, path_gaps, n=1):
    """Committed state after a gap path (k, dim) applied to n identical points."""
    h = dr.gap_path(law, np.arange(len(path_gaps), dtype=float),
                    np.repeat(np.asarray(path_gaps, float)[:, None, :], n, axis=1), 4)
    return h.state


def sec_tangent(outdir, fast):
    rng = np.random.default_rng(1)
    npts = 20 if fast else 200
    lN, lT = COH.l_Nc, COH.l_Tc
    base = InterfaceLaw(COH)
    con = InterfaceLaw(COH, ContactParams(kind="rough", exponent=2.5, penalty=5 * COH.k_normal))
    fri = InterfaceLaw(COH, ContactParams(), FrictionParams(0.6))
    dmg = InterfaceLaw(COH, damage=DamageParams(g_max=2 * lN, alpha=2.0, beta=1.0,
                                                F_th=0.2 * SIG))

    def polar(lam_lo, lam_hi, ang_lo=0.05, ang_hi=math.pi / 2 - 0.05):
        lam = rng.uniform(lam_lo, lam_hi, npts)
        phi = rng.uniform(ang_lo, ang_hi, npts) * rng.choice([-1, 1], npts)
        return np.column_stack([lam * np.cos(phi) * lN, lam * np.sin(phi) * lT])

    cases = []
    z = lambda law: law.initial_state(npts)  # noqa: E731
    cases.append(("elastic", base, polar(0.01, 0.19), z(base)))
    cases.append(("softening (loading)", base, polar(0.25, 0.95), z(base)))
    st_u = _state(base, [[0, 0], [0.8 * lN, 0]], npts)
    cases.append(("unloading (secant, λ_h = 0.8)", base, polar(0.05, 0.75), st_u))
    st_d = _state(base, [[0, 0], [1.3 * lN, 0]], npts)
    cases.append(("debonded, open", base, polar(0.1, 2.0), st_d))
    g = polar(0.05, 0.15)
    g[:, 0] = -np.abs(g[:, 0]) - 0.02 * lN
    st_c = _state(con, [[0, 0], [0.6 * lN, 0]], npts)
    cases.append(("contact (rough m = 2.5, partly damaged)", con, g, st_c))
    st_f = _state(fri, [[0, 0], [0, 1.2 * lT], [-0.1 * lN, 1.2 * lT]], npts)
    K0 = COH.k_normal
    CT = COH.k_tangential
    gs = np.column_stack([-0.1 * lN * rng.uniform(0.5, 1.5, npts),
                          1.2 * lT + 0.3 * 0.6 * K0 * 0.05 * lN / CT * rng.uniform(-1, 1, npts)])
    cases.append(("stick (debonded, in contact)", fri, gs, st_f))
    gsl = np.column_stack([-0.1 * lN * rng.uniform(0.5, 1.5, npts),
                           1.2 * lT + rng.choice([-1, 1], npts) * rng.uniform(0.5, 1.0, npts)
                           * lT])
    cases.append(("slip (debonded, in contact)", fri, gsl, st_f))
    st_g = _state(dmg, [[0, 0], [0.1 * lN, 0.02 * lT]], npts)
    cases.append(("damage growth (α = 2, β = 1, F_th = 0.2σ)", dmg, polar(0.12, 0.19), st_g))
    cases.append(("damage + softening", dmg, polar(0.25, 0.9), st_g))
    rows = []
    worst = 0.0
    for name, law, gap, st in cases:
        err, T, Tfd = dr.tangent_fd_error(law, gap, st, rel_step=1e-6)
        worst = max(worst, float(err.max()))
        rows.append([name, npts, f"{err.max():.1e}", f"{np.median(err):.1e}",
                     "yes" if np.isfinite(T).all() else "NO"])
    text = ("Consistent tangent against central finite differences (step 1e-6·max(|g_j|, l_j)), "
            f"{npts} random points per branch, error = max|T − T_fd| / max|T| per point. "
            "Points are sampled away from the kinks (λ = λ_max, λ = 1, g_N = 0, stick/slip "
            "boundary), where the law is only one-sided differentiable.\n\n"
            + _table(["branch", "points", "max rel err", "median", "finite"], rows)
            + f"\n\nMax over all branches: **{worst:.1e}** (FD truncation+rounding ≈ 1e-9).")
    return text, {"tangent_max_err": worst}


# ------------------------------------------------------------------------ 4. cyclic -------
def sec_cyclic(outdir, fast):
    lN = COH.l_Nc
    A = 0.15 * lN                                  # below the peak opening 0.2 l_Nc
    ncyc = 30 if fast else 60
    plt = _plt()
    fig, axs = plt.subplots(1, 2, figsize=(11, 4.2))
    rows = []
    for alpha in (1.0, 2.0):
        for beta in (0.0, 1.0):
            # g_max chosen so that each curve fails within the plotted cycles
            gmax = 2.0 * lN if alpha == 1 else 0.2 * lN
            law = InterfaceLaw(COH, damage=DamageParams(g_max=gmax, alpha=alpha, beta=beta,
                                                        F_th=0.2 * SIG))
            h = dr.constant_amplitude_cycles(law, A, 0.0, ncyc, 20)
            nf = dr.cycles_to_failure(h)
            axs[0].plot(h.t, h.damage, label=f"α={alpha:g}, β={beta:g}")
            rows.append([f"{alpha:g}", f"{beta:g}", f"{gmax / lN:g}", f"{h.damage[40]:.4f}",
                         f"{nf:g}"])
    axs[0].set_xlabel("cycles")
    axs[0].set_ylabel("D")
    axs[0].set_title(f"gap cycles 0→{A / lN:g} l_Nc→0, 20 incr/cycle, F_th = 0.2 σ_max")
    axs[0].legend()
    # S-N-like: cycles to failure against amplitude (batch of amplitudes)
    amps = np.linspace(0.03, 0.195, 8 if fast else 16) * lN
    nmax = 300 if fast else 3000
    sn = {}
    for alpha, beta, gm in ((1.0, 1.0, 1.0 * lN), (2.0, 1.0, 0.1 * lN)):
        law = InterfaceLaw(COH, damage=DamageParams(g_max=gm, alpha=alpha, beta=beta,
                                                    F_th=0.2 * SIG))
        h = dr.constant_amplitude_cycles(law, amps, 0.0, nmax, 10)
        nf = dr.cycles_to_failure(h)
        sn[(alpha, beta)] = nf
        peak = amps / (COH.lambda_max * lN)                    # peak traction / sigma_max
        fin = np.isfinite(nf)
        axs[1].semilogx(nf[fin], peak[fin], "o-", label=f"α={alpha:g}, β={beta:g}, "
                        f"g_max={gm / lN:g} l_Nc")
        if (~fin).any():
            axs[1].semilogx(np.full((~fin).sum(), nmax), peak[~fin], "x",
                            label=f"run-out (> {nmax}) α={alpha:g}")
    axs[1].axhline(0.2, ls=":", c="k", lw=0.8)
    axs[1].set_xlabel("cycles to failure N_f")
    axs[1].set_ylabel("peak traction / σ_max (gap amplitude / λ_max l_Nc)")
    axs[1].set_title("S–N-like curve (R = 0, 10 incr/cycle)")
    axs[1].legend(fontsize=7)
    fig.tight_layout()
    p = outdir / "cyclic_damage.png"
    fig.savefig(p, dpi=110)
    plt.close(fig)
    sn_rows = [[f"{a / lN:.4f}", f"{a / (COH.lambda_max * lN):.3f}",
                *(f"{sn[k][i]:g}" for k in sn)] for i, a in enumerate(amps)]
    text = ("Gap-controlled cycles 0 → A → 0 (A = 0.15 l_Nc, peak traction 0.75 σ_max, no "
            "softening), 20 increments per cycle. D after 2 cycles and cycles to failure:\n\n"
            + _table(["α", "β", "g_max/l_Nc", "D after 2 cycles", "N_f"], rows)
            + "\n\nS–N-like curve (10 increments/cycle; amplitudes with peak traction ≤ "
              "F_th = 0.2 σ_max never damage: run-out = inf):\n\n"
            + _table(["A/l_Nc", "peak F/σ_max", "N_f α=1 β=1 g_max=l_Nc",
                      "N_f α=2 β=1 g_max=0.1 l_Nc"], sn_rows)
            + f"\n\nFigure: `{p.name}`. Note: with α = 2 the N_f numbers hold for 10 "
              "increments per cycle only (section 6a).")
    return text, {"sn": sn}


# ------------------------------------------------------------------------ 5. extreme ------
def _check_run(h, law):
    fin = bool(np.isfinite(h.traction).all() and np.isfinite(h.tangent).all()
               and np.isfinite(h.dissipated).all() and np.isfinite(h.damage).all())
    tang = bool(np.isfinite(h.tangent).all())
    return fin, tang


def _fine_work(law, times, gaps, per_seg=4000):
    return float(dr.gap_path(law, times, gaps, per_seg).work[-1])


def sec_extreme(outdir, fast):
    rows = []
    fails = []
    lN0 = COH.l_Nc

    def record(name, h, law, energy_ok, note):
        fin, tang = _check_run(h, law)
        ok = fin and tang and energy_ok and h.converged
        rows.append([name, "yes" if fin else "NO", "yes" if energy_ok else "NO",
                     "yes" if tang else "NO", "PASS" if ok else "**FAIL**", note])
        if not ok:
            fails.append(name)

    def ray_work(law, psi, lams, state=None):
        """Trapezoid work along the ray psi through the signed lambda values ``lams``: exact
        when every kink (lambda_max, 1, lambda_h, g_N = 0) is a breakpoint, because the
        traction is piecewise linear along a ray (s(λ)λ is linear in λ)."""
        L = dr.direction_length(law, psi, 1.0)
        d = np.array([math.cos(psi), math.sin(psi)]) * L
        g = np.array([lam * d for lam in lams])
        h = dr.gap_path(law, np.arange(len(lams), dtype=float), g, 2, state)
        return float(h.work[-1]), float(h.dissipated[-1])

    def monotonic(name, law, psi=0.0, n=100, lam_end=1.5):
        c = law.cohesive
        h = dr.mixed_mode(law, psi, n, lam_end)
        G = float(c.G_mixed(psi))
        err = abs(h.dissipated[-1] - G) / G
        W, _ = ray_work(law, psi, [0, c.lambda_max, 1.0, lam_end])
        bal = h.dissipated[-1] <= W * (1 + 1e-9) + 1e-12 * G
        record(name, h, law, bool(err < 1e-9 and bal),
               f"Φ/G − 1 = {h.dissipated[-1] / G - 1:.1e}, W_exact/G − 1 = {W / G - 1:.1e}, "
               f"trapezoid W(n={n})/G − 1 = {h.work[-1] / G - 1:.1e}")

    for lm in (1e-6, 1e-3, 0.2, 0.9):
        law = InterfaceLaw(COH.replace(lambda_max=lm))
        monotonic(f"λ_max = {lm:g}, mode I", law)
        monotonic(f"λ_max = {lm:g}, ψ = 45°", law, math.radians(45))
        h = dr.load_unload_reload(law, lam_unload=0.5, lam_end=1.5, psi=0.3, n=300)
        G = float(law.cohesive.G_mixed(0.3))
        lams = [0, lm, 0.5, 0, 0.5, 1.0, 1.5] if lm < 0.5 else [0, 0.5, 0, 0.5, lm, 1.0, 1.5]
        W, Phi_ex = ray_work(law, 0.3, lams)
        record(f"λ_max = {lm:g}, load–unload–reload", h, law,
               bool(abs(h.dissipated[-1] / G - 1) < 1e-9 and
                    h.dissipated[-1] <= W * (1 + 1e-9)),
               f"Φ/G − 1 = {h.dissipated[-1] / G - 1:.1e}, W_exact/G − 1 = {W / G - 1:.1e}")
    lm0 = COH.lambda_max
    nfine = 1000 if fast else 4000
    for fac in ((1.0, 1e6) if fast else (1.0, 1e3, 1e6)):
        K0 = COH.k_normal
        for variant, cp in (("C_N = K_intact", ContactParams(penalty=fac * K0,
                                                             intact_stiffness=fac * K0)),
                            ("C_N, K_intact = K0", ContactParams(penalty=fac * K0))):
            if fac == 1.0 and variant != "C_N = K_intact":
                continue
            law = InterfaceLaw(COH, cp, FrictionParams(0.5))
            h = dr.closure_reopening(law, lam_open=0.6, closure=0.1, lam_end=1.5, n=200)
            e = abs(h.dissipated[-1] / COH.G_I - 1)
            W, _ = ray_work(law, 0.0, [0, lm0, 0.6, 0, -0.1, 0, 0.6, 1.0, 1.5])
            record(f"contact penalty {fac:g}·K0 ({variant}), closure–reopening", h, law,
                   bool(e < 1e-9 and h.dissipated[-1] <= W * (1 + 1e-9)),
                   f"min F_N/σ = {np.nanmin(h.traction[:, 0]) / SIG:.3g}, Φ/G − 1 = {e:.1e}, "
                   f"W_exact/G − 1 = {W / COH.G_I - 1:.1e}")
            p = 0.5 * SIG
            h = dr.shear_under_pressure(law, p, 3 * COH.l_Tc, 1, nfine)
            late = h.t > 0.5
            plat = np.nanmax(h.traction[late, 1]) / (0.5 * p) - 1 if h.converged else np.nan
            excess = float(np.nanmax(h.dissipated - h.work))
            pred = 0.5 * p ** 2 * (1 / (cp.intact_stiffness or K0) - 1 / (fac * K0))
            okp = h.converged and abs(plat) < 1e-9 and excess <= 1e-3 * COH.G_II
            record(f"contact penalty {fac:g}·K0 ({variant}), shear under pressure p = 0.5σ "
                   "(mixed control)", h, law, bool(okp),
                   f"plateau/(f p) − 1 = {plat:.1e}, max Newton it = {h.iterations.max()}, "
                   f"max(Φ − W) = {excess:.3g} J/m² (½p²(1/K_int − 1/C_N) = {pred:.3g})"
                   + (f"; {h.message}" if h.message else ""))
    for r in (1e-3, 1.0, 1e3):
        law = InterfaceLaw(COH.replace(l_Tc=r * lN0))
        monotonic(f"l_Tc/l_Nc = {r:g}, ψ = 45°", law, math.radians(45))
        monotonic(f"l_Tc/l_Nc = {r:g}, mode II", law, math.pi / 2)
    for gf in (1.0, 1e-3, 1e-6):
        law = InterfaceLaw(CohesiveParams.from_fracture_energy(SIG, 2 * SIG, gf * COH.G_I, 0.2,
                                                               2.0))
        monotonic(f"G = {gf:g}·G_default, ψ = 30°", law, math.radians(30))
    law = InterfaceLaw(COH)
    h = dr.mode_I(law, 1, lam_end=10.0)
    e = abs(h.dissipated[-1] / COH.G_I - 1)
    W, _ = ray_work(law, 0.0, [0, lm0, 1.0, 10.0])
    record("single increment 0 → 10 l_Nc", h, law,
           bool(e < 1e-12 and h.dissipated[-1] <= W * (1 + 1e-9)),
           f"Φ/G − 1 = {e:.1e}; W_exact/G − 1 = {W / COH.G_I - 1:.1e} (the 1-increment "
           f"trapezoid, {h.work[-1]:.3g}, cannot see the curve: the exact work is the reference)")
    # D = 1 - 1e-15
    for alpha in (1.0, 2.0):
        law = InterfaceLaw(COH, ContactParams(), FrictionParams(0.5),
                           DamageParams(g_max=lN0, alpha=alpha, beta=1.0, F_th=0.1 * SIG))
        st = law.initial_state(1)
        st = InterfaceState(st.kappa, np.array([1 - 1e-15]), st.separation, st.slip,
                            st.dissipated)
        h = dr.gap_path(law, [0, 1, 2, 3], np.array([[0, 0], [0.1 * lN0, 0.05 * lN0],
                                                     [-0.05 * lN0, 0.1 * lN0],
                                                     [0.15 * lN0, 0]]), 10, st)
        record(f"D = 1 − 1e-15 (α = {alpha:g}), cycle with closure", h, law,
               bool(np.all(h.dissipated <= h.work + 1e-12 * COH.G_I + 1e-3 * COH.G_I)),
               f"D_end = {h.damage[-1]!r}, max|F|/σ = {np.nanmax(np.abs(h.traction)) / SIG:.2e}")
    # exact zero, tiny and huge gaps, for every option combination
    full = InterfaceLaw(COH, ContactParams(), FrictionParams(0.5),
                        DamageParams(g_max=lN0, alpha=2.0, beta=1.0, F_th=0.1 * SIG))
    rough = InterfaceLaw(COH, ContactParams(kind="rough", exponent=3.33), FrictionParams(0.5),
                         DamageParams(g_max=lN0, alpha=0.5, beta=0.5))
    for lname, law in (("cohesive only", InterfaceLaw(COH)), ("full (linear contact)", full),
                       ("full (rough m = 3.33, α = 0.5)", rough),
                       ("full (rough m = 20)", InterfaceLaw(
                           COH, ContactParams(kind="rough", exponent=20.0), FrictionParams(0.5),
                           DamageParams(g_max=lN0)))):
        for gname, mag in (("exactly 0", 0.0), ("1e-300", 1e-300), ("1e10", 1e10)):
            gaps = np.array([[0, 0], [mag, 0], [0, mag], [mag, mag], [-mag, mag], [-mag, 0],
                             [mag, -mag]], float)
            hs, ens = [], []
            for st_name, st0 in (("virgin", None),
                                 ("debonded", _state(law, [[0, 0], [1.2 * lN0, 0]]))):
                tt = np.arange(len(gaps), dtype=float)
                h = dr.gap_path(law, tt, gaps, 1, st0)
                hf = dr.gap_path(law, tt, gaps, 200, st0)
                hs.append(h)
                dphi = h.dissipated[-1] - h.dissipated[0]
                Wf = hf.work[-1]
                ens.append((dphi, Wf))
            fin = all(_check_run(h, law)[0] for h in hs)
            # energy: dissipation never negative, and the one-increment-per-segment dissipation
            # not above the work of the same path refined to 200 increments per segment
            # a 1e10 step crosses the whole cohesive envelope inside one fine sub-increment,
            # where no trapezoid can see it: allow the largest work of separation on top
            Gb = max(COH.G_I, COH.G_II) if mag >= 1.0 else 0.0
            en = all(dphi >= 0 and dphi <= Wf + Gb + 1e-6 * (abs(Wf) + COH.G_I)
                     for dphi, Wf in ens)
            note = "; ".join(h.message for h in hs if h.message) or (
                f"max|F| = {max(np.nanmax(np.abs(h.traction)) for h in hs):.3g} Pa, "
                + ", ".join(f"ΔΦ = {a:.3g} vs W_fine = {b:.3g}" for a, b in ens))
            tang = all(_check_run(h, law)[1] for h in hs)
            ok = fin and tang and en and all(h.converged for h in hs)
            rows.append([f"gap {gname}, {lname} (virgin + debonded)", "yes" if fin else "NO",
                         "yes" if en else "NO", "yes" if tang else "NO",
                         "PASS" if ok else "**FAIL**", note])
            if not ok:
                fails.append(rows[-1][0])
    text = ("Each case must finish with finite numbers, energy balance held (monotonic paths: "
            "dissipated = analytic G to 1e-9 and ≤ the exact work W_exact (trapezoid through all "
            "kinks, exact for the piecewise-linear traction along a ray); shear under pressure: "
            "dissipated ≤ trapezoid work (1000–4000 increments) + 1e-3 G_II; extreme gaps "
            "(one increment per segment of a 7-point path, from a virgin and a debonded state): "
            "0 ≤ ΔΦ ≤ work of the same path with 200 increments per segment, + max(G_I, G_II) "
            "for the 1e10 gaps, whose first fine sub-increment already crosses the envelope) "
            "and a finite "
            "tangent in every row. K0 = σ_max/(λ_max l_Nc).\n\n"
            + _table(["case", "finite", "energy", "finite tangent", "result", "numbers"], rows)
            + f"\n\n**{len(rows) - len(fails)} / {len(rows)} pass.**"
            + ("" if not fails else " Failures (reported to the lead, not hidden): "
               + "; ".join(fails)))
    return text, {"extreme_rows": rows, "extreme_fails": fails}


# ------------------------------------------------------------------------ 6. work-precision
def _time(fn, reps=1):
    t0 = time.perf_counter()
    for _ in range(reps):
        out = fn()
    return out, (time.perf_counter() - t0) / reps


def sec_workprec(outdir, fast):
    lN = COH.l_Nc
    A = 0.1 * lN
    N = 10
    ns = [2, 4, 8, 16] + ([] if fast else [32, 64, 128, 256, 512, 1024])
    plt = _plt()
    fig, axs = plt.subplots(1, 3, figsize=(15, 4.3))
    rows = []
    res = {}
    for alpha in (1.0, 2.0):
        law = InterfaceLaw(COH, damage=DamageParams(g_max=2 * lN, alpha=alpha))
        lawo = InterfaceLaw(COH, damage=DamageParams(g_max=2 * lN, alpha=alpha,
                                                     form="objective"))
        Dp, Do, tp = [], [], []
        for n in ns:
            h, t = _time(lambda: dr.constant_amplitude_cycles(law, A, 0.0, N, n))
            Dp.append(h.damage[-1])
            Do.append(dr.constant_amplitude_cycles(lawo, A, 0.0, N, n).damage[-1])
            tp.append(t)
        exact_obj = (N * A / (2 * lN)) ** alpha
        res[alpha] = dict(n=ns, paper=Dp, objective=Do, time=tp)
        for n, a, b, t in zip(ns, Dp, Do, tp):
            rows.append([f"{alpha:g}", n, f"{a:.6e}", f"{b:.6e}", f"{t * 1e3:.1f}"])
        axs[0].loglog(tp, Dp, "o-", label=f"paper form α={alpha:g}")
        axs[0].loglog(tp, Do, "s--", label=f"objective form α={alpha:g} (exact "
                      f"{exact_obj:.3g})")
    axs[0].set_xlabel("wall time of the run [s]")
    axs[0].set_ylabel(f"D after {N} cycles 0→A→0")
    axs[0].set_title("(a) damage vs run time (refining increments/cycle)")
    axs[0].legend(fontsize=7)
    # objective form with beta = 1, F_th > 0: D depends on the quadrature of B only
    law = InterfaceLaw(COH, damage=DamageParams(g_max=2 * lN, alpha=2.0, beta=1.0,
                                                F_th=0.2 * SIG))
    lawo = InterfaceLaw(COH, damage=DamageParams(g_max=2 * lN, alpha=2.0, beta=1.0,
                                                 F_th=0.2 * SIG, form="objective"))
    nref = 4096 if not fast else 256
    Dref = dr.constant_amplitude_cycles(lawo, A, 0.0, N, nref).damage[-1]
    eo, to, ep = [], [], []
    for n in ns:
        h, t = _time(lambda: dr.constant_amplitude_cycles(law, A, 0.0, N, n))
        d = dr.constant_amplitude_cycles(lawo, A, 0.0, N, n).damage[-1]
        eo.append(abs(d - Dref) / Dref)
        ep.append(h.damage[-1])
        to.append(t)
    rate_b = math.log(eo[-3] / eo[-1]) / math.log(ns[-1] / ns[-3])
    axs[1].loglog(ns, eo, "s-", label="objective α=2 β=1 F_th=0.2σ: rel. error")
    axs[1].loglog(ns, np.array(ep) / ep[0], "o-", label="paper α=2 β=1: D(n)/D(n=2)")
    axs[1].set_xlabel("increments per cycle")
    axs[1].set_title(f"(a) with β = 1: objective form converges at rate {rate_b:.2f}")
    axs[1].legend(fontsize=7)
    # (b) mixed-control Newton: rough contact, pressure ramp with cyclic sliding
    lawn = InterfaceLaw(COH, ContactParams(kind="rough", exponent=2.0), FrictionParams(0.5))
    st = _state(lawn, [[0, 0], [1.2 * lN, 0]])
    times = [0, 1, 2, 3]
    tg = np.array([[0, 0], [-2 * SIG, 0.5 * COH.l_Tc], [-0.5 * SIG, -0.5 * COH.l_Tc],
                   [-3 * SIG, 0.2 * COH.l_Tc]])
    nsub = 10 if fast else 40
    ref = dr.mixed_control(lawn, times, tg, "Fg", nsub, state=st, tol=1e-16, maxiter=100)
    assert ref.converged, ref.message
    tols = ([1e-2, 1e-6, 1e-10, 1e-14] if fast else
            [1e-1, 1e-2, 1e-3, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12, 1e-14])
    nrows = []
    errs, times_b, its = [], [], []
    for tol in tols:
        h, t = _time(lambda: dr.mixed_control(lawn, times, tg, "Fg", nsub, state=st, tol=tol),
                     reps=1 if fast else 3)
        e = float(np.nanmax(np.abs(h.gap[:, 0] - ref.gap[:, 0])) / np.abs(ref.gap[:, 0]).max())
        et = float(np.nanmax(np.abs(h.traction - ref.traction)) / SIG)
        errs.append(e)
        times_b.append(t)
        its.append(int(h.iterations.sum()))
        nrows.append([f"{tol:.0e}", "yes" if h.converged else "NO", its[-1], f"{e:.1e}",
                      f"{et:.1e}", f"{t * 1e3:.1f}"])
    axs[2].loglog(times_b, errs, "o-")
    for tol, x, y in zip(tols, times_b, errs):
        axs[2].annotate(f"{tol:.0e}", (x, y), fontsize=6)
    axs[2].set_xlabel("wall time [s]")
    axs[2].set_ylabel("max rel. error of g_N (ref. tol 1e-16 → 8 eps)")
    axs[2].set_title("(b) mixed-control Newton: error vs time (labels: tol)")
    fig.tight_layout()
    p = outdir / "work_precision.png"
    fig.savefig(p, dpi=110)
    plt.close(fig)
    d2 = res[2.0]["paper"]
    ratio = d2[0] / d2[-1]
    nat_p = N * (A / (2 * lN)) ** 2
    nat_o = (N * A / (2 * lN)) ** 2
    text = ("### (a) step-size dependence of the damage form\n\n"
            f"Fixed history: {N} gap cycles 0 → A → 0, A = 0.1 l_Nc (elastic), g_max = 2 l_Nc, "
            "β = 0. D after the history against increments per cycle n (wall time of the "
            "gap_path run of the paper's form; the objective column is the same path with "
            "`DamageParams(form=\"objective\")`; the rate form is studied in "
            "`verification/damage_rate.py`).\n\n"
            + _table(["α", "incr./cycle", "D paper form", "D objective form", "run ms"], rows)
            + f"\n\n**Plainly:** for α = 1 both forms are identical and exact for any n. For "
              f"α = 2 the paper's D is inversely proportional to the number of increments "
              f"per loading (D = N (A/g_max)² / (n/2)): from n = {ns[0]} to n = {ns[-1]} it "
              f"drops by a factor {ratio:.0f}; it has no limit but 0 as the step is refined, so "
              f"for α = 2 the paper's form gives a fatigue life proportional to the number of "
              f"increments per cycle — a numerical parameter. In general "
              f"D ∝ n^(1−α). The objective rate form D = (p/g_max)^α, dp = B dg⁺, gives "
              f"{res[2.0]['objective'][0]:.6e} for every n (exact {nat_o:.6e}). At the "
              f"'natural' step of one increment per loading (n = 2) the paper's form gives "
              f"N (A/g_max)^α = {nat_p:.3e} against the objective {nat_o:.3e}: they differ by "
              f"N^(α−1) = {N ** 1:.0f}: the objective form accumulates D ∝ N^α (N_f = "
              f"g_max/A, the same for every α when β = 0), the paper's at n = 2 D ∝ N "
              f"(N_f = (g_max/A)^α). With β = 1 and F_th = 0.2 σ the objective form's error "
              f"(B evaluated at the end of each increment) converges at rate {rate_b:.2f} in "
              f"n (reference n = {nref}); the paper's D still falls as 1/n.\n\n"
            "### (b) mixed-control Newton: error against tolerance against time\n\n"
            "Rough contact (m = 2) on a debonded joint, friction f = 0.5: normal traction "
            "ramped 0 → −2σ → −0.5σ → −3σ (imposed) with the tangential gap ±0.5 l_Tc "
            "(imposed), " + f"{nsub} increments per segment. Error: max over rows of |g_N − g_N,ref| / "
            "max|g_N,ref| against the run with tol = 1e-16 (floored at 8 eps = 1.8e-15).\n\n"
            + _table(["tol", "converged", "Newton its (total)", "g_N rel err",
                      "traction err/σ", "ms"], nrows)
            + f"\n\nFigures: `{p.name}`.")
    return text, {"alpha2_ratio": ratio, "rate_beta1": rate_b, "newton": nrows,
                  "damage_rows": rows}


# ------------------------------------------------------------------------ main -----------
def main(fast: bool = False, outdir=None) -> dict:
    outdir = Path(outdir) if outdir is not None else HERE / "out"
    outdir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    sections = [("1. Paper Fig. 5: tractions against (g_N, g_T)", sec_fig5),
                ("2. Energy: dissipated against analytic G(ψ)", sec_energy),
                ("3. Consistent tangent against finite differences, per branch", sec_tangent),
                ("4. Cyclic damage and cycles to failure", sec_cyclic),
                ("5. Stiff and extreme cases", sec_extreme),
                ("6. Error against run time", sec_workprec)]
    parts = [f"# Material-point verification of the interface law ({'fast' if fast else 'full'}"
             " mode)\n\nGenerated by `verification/material_point.py`; drivers in "
             "`interfacelaw/drivers.py`.\n"]
    res = {}
    timing = []
    for title, fn in sections:
        ts = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            text, r = fn(outdir, fast)
        res.update(r)
        timing.append((title, time.perf_counter() - ts))
        parts.append(f"## {title}\n\n{text}\n")
    (outdir / "REPORT.md.tmp").write_text("\n".join(parts))
    os.replace(outdir / "REPORT.md.tmp", outdir / "REPORT.md")
    summary = [
        ("Fig. 5 max F_N/σ, max|F_T|/τ", f"{res['FN_max']:.6f}, {res['FT_max']:.6f}"),
        ("energy: max |Φ/G − 1| (ψ = 0…90°, n = 1…1000)", f"{res['energy_max_rel_err']:.1e}"),
        ("tangent: max FD rel. error over branches", f"{res['tangent_max_err']:.1e}"),
        ("extreme cases passing",
         f"{len(res['extreme_rows']) - len(res['extreme_fails'])}/{len(res['extreme_rows'])}"),
        ("paper damage α=2: D(n_min)/D(n_max)", f"{res['alpha2_ratio']:.0f}"),
        ("objective form β=1 convergence rate", f"{res['rate_beta1']:.2f}"),
        ("total time [s]", f"{time.perf_counter() - t0:.1f}"),
    ]
    w = max(len(a) for a, _ in summary)
    print("material_point verification summary")
    for a, b in summary:
        print(f"  {a:<{w}}  {b}")
    for f in res["extreme_fails"]:
        print(f"  FAIL: {f}")
    res["timing"] = timing
    return res


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fast", action="store_true", help="coarser grids, fewer cycles")
    ap.add_argument("--outdir", default=None)
    a = ap.parse_args()
    main(fast=a.fast, outdir=a.outdir)
