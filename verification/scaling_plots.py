"""Verification plots of the size-scale laws (interfacelaw.scaling; docs/scaling.md).

Writes to verification/out/ (or --out DIR):
  scaling_fig1.png      paper Fig. 1(a)(b): tensile strength (k = -0.14) and fracture energy
                        (k = +0.38) against size, log-log (the laws; the paper's data points are
                        not available in the text, only the captions)
  scaling_friction.png  Fig. 4-style friction coefficient against size, log-log
  scaling_lengths.png   l_Nc(b) and l_ch = E G / sigma^2 against b
  scaling_times.png     t1, t2 (paper Eq. 11) against b for the Koyna material, with the 2 ms step
  scaling.md            table of the same quantities + the energy effect of the updates

Usage: python verification/scaling_plots.py [--fast] [--out DIR]
"""
from __future__ import annotations

import argparse
import os
import pathlib
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
os.environ.setdefault("MPLBACKEND", "Agg")

from interfacelaw.scaling import (  # noqa: E402
    SizeScaling, characteristic_length, characteristic_times, mode_one_update_energy,
)

E_KOYNA = 50e9        # Pa, paper §5
RHO_KOYNA = 2500.0    # kg/m^3, concrete, paper §5
A0_KOYNA = 70.0       # m, bonded interface length ahead of the tip at the start
DT_PAPER = 2.0e-3     # s, paper §5


def main(fast: bool = False, outdir=None):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dpi = 50 if fast else 110

    def save(fig, name):
        if not fast:                       # tight_layout measures every tick label: slow
            fig.tight_layout()
        fig.savefig(out / name, dpi=dpi)
        plt.close(fig)

    out = pathlib.Path(outdir if outdir is not None else ROOT / "verification" / "out")
    out.mkdir(parents=True, exist_ok=True)
    s = SizeScaling.paper()
    npt = 40 if fast else 400
    b = np.geomspace(0.05, 100.0, npt)
    bb = np.maximum(b, s.b_ref)                 # what the adaptive update uses

    # ---- Fig. 1 (a)(b)
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    ax[0].loglog(b, s.sigma_law(b) / 1e6, "k-", label=r"$\sigma_u = 3\,(b/b_{ref})^{-0.14}$ MPa")
    ax[1].loglog(b, s.energy_law(b), "k-", label=r"$G_F = 250\,(b/b_{ref})^{0.38}$ N/m")
    for a, y in ((ax[0], 3.0), (ax[1], 250.0)):
        a.plot([s.b_ref], [y], "ro", label=f"reference, b_ref = {s.b_ref:g} m")
        a.axvspan(b[0], s.b_ref, color="0.9", label="b < b_ref: reference values used")
        a.set_xlabel("size b [m]")
        a.grid(True, which="both", alpha=0.3)
        a.legend(fontsize=8)
    ax[0].set_ylabel("tensile strength [MPa]")
    ax[0].set_title("(a) tensile strength, k = -0.14")
    ax[1].set_ylabel("fracture energy [N/m]")
    ax[1].set_title("(b) fracture energy, k = +0.38")
    save(fig, "scaling_fig1.png")

    # ---- Fig. 4 style friction
    bf = np.geomspace(0.03, 1.0e4, npt)
    fr = s.friction
    fig, a = plt.subplots(figsize=(5.5, 4))
    a.loglog(bf, fr(bf), "k-", label=f"f = 0.6 (b/0.1 m)^{fr.exponent:.3f}, floor {fr.f_floor}")
    a.plot([fr.b_lab, fr.b_floor], [fr.f_lab, fr.f_floor], "ro", label="anchors")
    a.axhline(fr.f_floor, color="b", ls=":", label="floor (large faults, paper f = 0.3)")
    a.axvline(s.b_ref, color="0.5", ls="--", label=f"b_ref = {s.b_ref:g} m")
    a.set_xlabel("size b [m]")
    a.set_ylabel("friction coefficient f")
    a.set_ylim(0.2, 1.0)
    a.grid(True, which="both", alpha=0.3)
    a.legend(fontsize=8)
    a.set_title("friction coefficient vs size")
    save(fig, "scaling_friction.png")

    # ---- lengths
    sig = s.sigma_law(bb)
    G = s.energy_law(bb)
    lN = 2.0 * G / sig
    lch = characteristic_length(E_KOYNA, G, sig)
    fig, a = plt.subplots(figsize=(5.5, 4))
    a.loglog(b, lN, "k-", label=r"$l_{Nc} = 2G/\sigma_{max}$")
    a.loglog(b, lch, "b-", label=r"$l_{ch} = EG/\sigma^2$ (E = 50 GPa)")
    a.axvline(s.b_ref, color="0.5", ls="--", label=f"b_ref = {s.b_ref:g} m")
    a.set_xlabel("size b (failed length) [m]")
    a.set_ylabel("length [m]")
    a.grid(True, which="both", alpha=0.3)
    a.legend(fontsize=8)
    save(fig, "scaling_lengths.png")

    # ---- times (Koyna): a0 = remaining bonded length 70 m - b
    bt = np.geomspace(s.b_ref, 60.0, npt)
    sig_t = s.sigma_law(bt)
    lN_t = 2.0 * s.energy_law(bt) / sig_t
    t = characteristic_times(E_KOYNA, RHO_KOYNA, lN_t, sig_t, A0_KOYNA - bt)
    t2_const = characteristic_times(E_KOYNA, RHO_KOYNA, lN_t, sig_t, A0_KOYNA).t2
    fig, a = plt.subplots(figsize=(5.5, 4))
    a.loglog(bt, t.t1, "k-", label=r"$t_1 = \rho c_L l_{Nc}/(2\sigma_{max})$")
    a.loglog(bt, t.t2, "b-", label=r"$t_2 = a_0/c_L$, $a_0 = 70\,m - b$")
    a.loglog(bt, t2_const * np.ones_like(bt), "b:", label=r"$t_2$ with $a_0 = 70$ m")
    a.axhline(DT_PAPER, color="r", ls="--", label="time step 2 ms (paper)")
    a.set_xlabel("size b (failed length) [m]")
    a.set_ylabel("time [s]")
    a.grid(True, which="both", alpha=0.3)
    a.legend(fontsize=8)
    a.set_title(f"Koyna: E = 50 GPa, rho = 2500 kg/m3, c_L = {float(np.atleast_1d(t.c_L)[0]):.0f} m/s")
    save(fig, "scaling_times.png")

    # ---- table + energy effect
    rows = []
    for bi in (0.1, 0.5, 1.0, 1.1, 2.0, 5.0, 10.0, 20.0, 50.0):
        coh, fri = s.params_for(bi)
        tt = characteristic_times(E_KOYNA, RHO_KOYNA, coh.l_Nc, coh.sigma_max, A0_KOYNA - max(bi, s.b_ref))
        rows.append(f"| {bi:g} | {max(bi, s.b_ref):g} | {coh.sigma_max / 1e6:.4f} | {coh.G_I:.2f} "
                    f"| {coh.l_Nc * 1e3:.4f} | {characteristic_length(E_KOYNA, coh.G_I, coh.sigma_max):.3f} "
                    f"| {fri.f:.3f} | {s.friction(bi):.3f} | {tt.t1 * 1e6:.4f} | {tt.t2 * 1e3:.3f} |")
    n_en = 200 if fast else 4000
    en = []
    for b_final in ((1.1, 4.0) if fast else (1.1, 2.0, 4.0, 10.0, 70.0)):
        r = mode_one_update_energy(s, b_final, n_steps=n_en)
        en.append(f"| {b_final:g} | {r['G_ref']:.2f} | {r['G_final']:.2f} | {r['dissipated']:.2f} "
                  f"| {r['released']:.2f} | {r['work']:.2f} "
                  f"| {r['work'] - r['dissipated'] - r['released']:.3f} |")
    md = [
        "# Size-scale laws: values (generated by verification/scaling_plots.py"
        + (" --fast" if fast else "") + ")",
        "",
        f"Reference (paper §5): sigma = tau = 3 MPa, G = 250 N/m, f = 0.3 at b_ref = {s.b_ref:g} m; "
        "lambda_max = 0.2, l_Tc/l_Nc = 1. Koyna: E = 50 GPa, rho = 2500 kg/m^3, "
        "a0 = 70 m - b_eff, time step 2 ms.",
        "",
        "| b [m] | b_eff [m] | sigma_max [MPa] | G [N/m] | l_Nc [mm] | l_ch [m] | f (adaptive) "
        "| f law(b) | t1 [us] | t2 [ms] |",
        "|---|---|---|---|---|---|---|---|---|---|",
        *rows,
        "",
        f"## Energy effect of the updates (mode I, one point, {n_en} steps, b from b_ref to b_final)",
        "",
        "Phi: the law's dissipated energy; J: stored energy released at the updates; W: external "
        "work. Fixed parameters dissipate exactly G_ref (at b_ref) or G_final (at b_final).",
        "",
        "| b_final [m] | G_ref | G_final | Phi | J | W | W - Phi - J |",
        "|---|---|---|---|---|---|---|",
        *en,
        "",
    ]
    (out / "scaling.md").write_text("\n".join(md))
    print(f"wrote {out}/scaling_*.png and scaling.md")
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fast", action="store_true", help="fewer points (for the tests)")
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    main(fast=a.fast, outdir=a.out)
