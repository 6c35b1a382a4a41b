"""DCB (mode I) error against run time: Gauss points per segment n and interface mesh size
h_int ("Error against run time").  ``main(fast, outdir)`` writes
dcb_n.png, dcb_h.png, dcb_oscillation.png and dcb.md into ``outdir``.

Errors of each run against (i) the corrected beam theory + LEFM (Kanninen root rotation
chi = 0.64 and Timoshenko shear; ``ngs_driver.apps.dcb.beam_theory_curve``) and (ii) a fine-mesh
numerical reference of the same cohesive model (the discretisation error that n and h_int
control; (i) also contains the model error of a finite process zone).
  peak : |P_max - P_max,ref| / P_max,ref
  L2   : sqrt( int (P - P_ref)^2 d delta / int P_ref^2 d delta ) over the post-peak range
         [1.3, 2.8] x delta_c (delta_c: beam-theory opening at the peak).
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from ngs_driver.apps import dcb  # noqa: E402

NS = (1, 2, 3, 5, 8)


def _errors(res, spec, ref_curve, d_lo, d_hi):
    """(peak error, L2 post-peak error, covered fraction of the post-peak range)."""
    P_peak = res.P.max()
    if ref_curve is None:
        dr = np.linspace(0.0, d_hi, 4001)
        Pr = dcb.beam_theory_curve(spec, dr)
        P_ref_peak = dcb.beam_theory_peak(spec)[1]
    else:
        dr, Pr = ref_curve
        P_ref_peak = Pr.max()
    e_peak = abs(P_peak - P_ref_peak) / P_ref_peak
    d_end = min(res.delta[-1], d_hi)
    grid = np.linspace(d_lo, d_hi, 400)
    g = grid[grid <= d_end]
    if g.size < 2:
        return e_peak, np.nan, 0.0
    P = np.interp(g, res.delta, res.P)
    Q = np.interp(g, dr, Pr)
    e_l2 = np.sqrt(np.trapezoid((P - Q) ** 2, g) / np.trapezoid(Q ** 2, g))
    return e_peak, e_l2, (g[-1] - d_lo) / (d_hi - d_lo)


def main(fast: bool = False, outdir=ROOT / "verification" / "out") -> str:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    outdir = pathlib.Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    spec = dcb.DCBSpec()
    d_c, P_c = dcb.beam_theory_peak(spec)
    if fast:
        h_coarse, hs, h_ref, n_ref, n_steps, n_h = 0.04, (0.04, 0.02), 0.02, 3, 25, 2
    else:
        h_coarse, hs, h_ref, n_ref, n_steps, n_h = 0.02, (0.04, 0.02, 0.01, 0.005), 0.004, 3, \
            60, 2
    d_max, d_lo, d_hi = 3.0 * d_c, 1.3 * d_c, 2.8 * d_c
    targets = np.concatenate([[0.6 * d_c], np.linspace(0.6 * d_c, d_max, n_steps + 1)[1:]])

    def run(h_int, n):
        t0 = time.perf_counter()
        prob = dcb.build_dcb(spec, h_int, n)
        t_build = time.perf_counter() - t0
        res = dcb.solve_dcb(prob, targets)
        return res, prob, t_build

    ref, ref_prob, _ = run(h_ref, n_ref)
    ref_curve = (ref.delta, ref.P)
    rows = []
    curves = {}
    for study, cases in (("n", [(h_coarse, n) for n in NS]),
                         ("h", [(h, n_h) for h in hs])):
        for h_int, n in cases:
            res, prob, tb = run(h_int, n)
            curves[(h_int, n)] = res
            ep_b, el_b, cov = _errors(res, spec, None, d_lo, d_hi)
            ep_n, el_n, _ = _errors(res, spec, ref_curve, d_lo, d_hi)
            rows.append(dict(study=study, h_int=h_int, n=n, npts=prob.interface.npts,
                             ndof=prob.ndof, wall=res.wall, build=tb, iters=res.n_iter,
                             cuts=res.n_cuts, complete=res.complete, cov=cov,
                             peak_bt=ep_b, l2_bt=el_b, peak_num=ep_n, l2_num=el_n,
                             P_max=res.P.max(), stop=res.delta[-1]))

    # ---- figures: work-precision ----
    for study, xlab in (("n", "n (Gauss points per segment)"), ("h", "h_int")):
        fig, ax = plt.subplots(1, 2, figsize=(10, 4))
        rs = [r for r in rows if r["study"] == study]
        for k, (key, lab) in enumerate((("num", "vs fine-mesh reference"),
                                        ("bt", "vs corrected beam theory"))):
            for m, (e, name) in enumerate(((f"peak_{key}", "peak load"),
                                           (f"l2_{key}", "post-peak L2"))):
                x = np.array([r["wall"] for r in rs])
                y = np.array([max(r[e], 1e-6) if np.isfinite(r[e]) else np.nan for r in rs])
                ax[k].loglog(x, y, "o-" if m == 0 else "s--", label=name)
                for r, xi, yi in zip(rs, x, y):
                    if np.isfinite(yi):
                        tag = f"n={r['n']}" if study == "n" else f"h={r['h_int']:g}"
                        ax[k].annotate(tag + ("" if r["complete"] else " (stopped)"),
                                       (xi, yi), fontsize=7)
            ax[k].set_xlabel("solver wall time [s]")
            ax[k].set_ylabel("relative error")
            ax[k].set_title(lab, fontsize=9)
            ax[k].legend(fontsize=8)
        fig.suptitle(f"DCB: error against run time, varying {xlab}"
                     + (f" (h_int = {h_coarse:g} m)" if study == "n" else f" (n = {n_h})"),
                     fontsize=10)
        fig.tight_layout()
        fig.savefig(outdir / f"dcb_{study}.png", dpi=110)
        plt.close(fig)

    # ---- figure: oscillations with too few points per process zone ----
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    dd = np.linspace(0, d_max, 600)
    ax.plot(dd * 1e3, dcb.beam_theory_curve(spec, dd) / 1e3, "k--", lw=1,
            label="corrected beam theory + LEFM")
    ax.plot(dd * 1e3, dcb.beam_theory_curve(spec, dd, chi=0.0, shear=False) / 1e3, "k:",
            lw=1, label="simple beam theory + LEFM")
    ax.plot(ref.delta * 1e3, ref.P / 1e3, "k-", lw=1.5,
            label=f"reference h_int={h_ref:g}, n={n_ref}")
    for n in (1, 2, 8):
        r = curves[(h_coarse, n)]
        ax.plot(r.delta * 1e3, r.P / 1e3, lw=1,
                label=f"h_int={h_coarse:g}, n={n}" + ("" if r.complete else " (stopped)"))
    ax.set_xlabel("opening delta [mm]")
    ax.set_ylabel("P [kN/m]")
    ax.set_title("Too few Gauss points per process zone: stepwise P(delta)", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(outdir / "dcb_oscillation.png", dpi=110)
    plt.close(fig)

    # ---- table ----
    C_fe = dcb.elastic_compliance(ref_prob)
    lines = [
        "## DCB (mode I): error against run time" + (" — fast mode" if fast else ""), "",
        f"Arms h = {spec.h} m, L = {spec.L} m, a0 = {spec.a0} m, b = {spec.b} m, plane strain "
        f"E = {spec.E:.3g} Pa, nu = {spec.nu} (E' = {spec.E_prime:.4g} Pa); interface "
        f"sigma_max = {spec.sigma_max:.3g} Pa, G_I = {spec.G_I} N/m, lambda_max = "
        f"{spec.lambda_max}, with contact; l_ch = E'G_I/sigma^2 = {spec.l_ch:.3f} m "
        f"(= {spec.l_ch / spec.h:.1f} h). Order-2 triangles.", "",
        f"Corrected beam theory (chi = 0.64 + shear): delta_c = {d_c * 1e3:.4f} mm, "
        f"P_c = {P_c:.1f} N; simple beam theory P_c = "
        f"{dcb.beam_theory_peak(spec, 0.0, False)[1]:.1f} N. Elastic compliance FE / "
        f"corrected = {C_fe / dcb.beam_theory_compliance(spec, spec.a0):.4f}, FE / simple = "
        f"{C_fe / dcb.beam_theory_compliance(spec, spec.a0, 0.0, False):.4f}.", "",
        f"Reference run h_int = {h_ref} m, n = {n_ref}: P_max = {ref.P.max():.1f} N "
        f"({ref.P.max() / P_c - 1:+.2%} vs corrected beam theory), post-peak L2 vs beam "
        f"theory {_errors(ref, spec, None, d_lo, d_hi)[1]:.2e}, solver time "
        f"{ref.wall:.1f} s, complete = {ref.complete}.", "",
        "| study | h_int [m] | n | points | wall [s] | Newton it | cuts | complete "
        "| P_max [N] | peak err (num) | L2 err (num) | peak err (beam) | L2 err (beam) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r['study']} | {r['h_int']:g} | {r['n']} | {r['npts']} | {r['wall']:.2f} | "
            f"{r['iters']} | {r['cuts']} | {'yes' if r['complete'] else 'stopped at %.3g mm' % (r['stop'] * 1e3)} | "
            f"{r['P_max']:.0f} | {r['peak_num']:.2e} | {r['l2_num']:.2e} | "
            f"{r['peak_bt']:.2e} | {r['l2_bt']:.2e} |")
    lines += ["", "Errors 'num' are against the reference run, 'beam' against the corrected "
              "beam theory + LEFM; L2 over delta in [1.3, 2.8] delta_c (a stopped run: over "
              "the part it reached). Wall time = solver only (incl. the one-off static "
              "condensation), single thread.", ""]
    (outdir / "dcb.md").write_text("\n".join(lines))
    return "\n".join(lines)


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--fast", action="store_true")
    ap.add_argument("--out", default=str(ROOT / "verification" / "out"))
    a = ap.parse_args()
    print(main(fast=a.fast, outdir=a.out))
