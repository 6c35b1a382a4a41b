"""Reservoir verification (docs/reservoir.md) -> verification/out/reservoir.md.

    python verification/reservoir.py [--fast] [--out DIR]

1. Westergaard added mass on Koyna's vertical face against 7/12 rho H^2.
2. Rigid vertical wall, rigid bottom, 92 m x 300 m incompressible reservoir: force against
   Westergaard's exact 0.543 rho a H^2 and the wall pressure profile against the series.
3. Compressible water: |F(omega)| against Chopra (1967) (alpha = 1) and Fenves & Chopra (1983)
   (alpha < 1).
4. Koyna classic on a rigid base, full reservoir 91.75 m: f1 empty / Westergaard / incompressible
   acoustic, and the compressible frequency-response peak.
5. Cost per step of the paper scene with and without the compressible acoustic reservoir
   (same process, interleaved blocks of steps: the machine is shared).
"""
from __future__ import annotations

import argparse
import math
import pathlib
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def westergaard_table(lines):
    from ngs_driver.fe.model import build_from_scene
    from ngs_driver.scene import load_scene
    md = build_from_scene(load_scene("koyna_classic", ["reservoir.model=westergaard"]))
    H = 91.75
    tot = md.r_x @ (md.reservoir.added_mass @ md.r_x)
    ref = 7 / 12 * 1000 * H ** 2
    lines += ["## 1. Westergaard added mass, Koyna vertical face, H = 91.75 m", "",
              "| r_x^T M_a r_x [kg/m] | 7/12 rho H^2 | rel. error |", "|---|---|---|",
              f"| {tot:.6e} | {ref:.6e} | {tot / ref - 1:.2e} |", ""]


def rigid_wall(lines, fast):
    from ngs_driver.fe import acoustic as ac
    H, L, c, rho = 92.0, 300.0, 1440.0, 1000.0
    w1 = math.pi * c / (2 * H)
    meshes = [(2.0, 6.0)] if fast else [(4.0, 12.0), (2.0, 6.0), (1.0, 4.0)]
    lines += ["## 2. Rigid wall, rigid bottom, incompressible, 92 m x 300 m", "",
              "| h wall / far [m] | pressure DOFs | F / (rho a H^2) | exact 0.54275 | error | "
              "max profile error / p_max |", "|---|---|---|---|---|---|"]
    for hf, hm in meshes:
        mesh = ac.rectangle_water_mesh(H, L, hf, hm)
        W = ac.water_matrices(mesh, c, False, 1.0, "radiation")
        p = ac.rigid_wall_response(W, rho)
        F = ac.face_force(W, p) / (rho * H ** 2)
        ys = np.linspace(0, 0.95, 20) * H
        pe = ac.pressure_at(W, p, [(0.0, y) for y in ys])
        ps, Fs = ac.westergaard_series(ys, H, rho)
        prof = np.abs(pe - ps.real).max() / np.abs(ps).max()
        lines.append(f"| {hf:g} / {hm:g} | {W.free.size} | {-F:.5f} | "
                     f"{-Fs.real / (rho * H ** 2):.5f} | {F / (Fs.real / (rho * H ** 2)) - 1:.2e} "
                     f"| {prof:.2e} |")
    lines += ["", "## 3. Compressible: |F(omega)| / (rho a H^2), FE (2 m / 6 m) vs analytic", "",
              "| alpha | omega/omega_1 | FE | analytic | error |", "|---|---|---|---|---|"]
    mesh = ac.rectangle_water_mesh(H, L, 2.0, 6.0)
    for alpha in (1.0, 0.75, 0.5, 0.0):
        W = ac.water_matrices(mesh, c, True, alpha, "radiation")
        for r in (0.3, 0.6, 0.8, 0.9, 1.0, 1.2, 1.5):
            if alpha == 1.0 and r == 1.0:
                continue
            Fe = abs(ac.face_force(W, ac.rigid_wall_response(W, rho, r * w1)))
            Fa = abs(ac.westergaard_series([0.0], H, rho, omega=r * w1, c=c)[1] if alpha == 1
                     else ac.absorbing_bottom_series(H, r * w1, c, alpha, rho, n_terms=400))
            lines.append(f"| {alpha:g} | {r:g} | {Fe / (rho * H * H):.4f} | "
                         f"{Fa / (rho * H * H):.4f} | {Fe / Fa - 1:+.2e} |")
    lines.append("")


def koyna_f1(lines, out):
    from ngs_driver.fe.modal import modal_analysis
    from ngs_driver.setup import k0_from_scene
    from ngs_driver.apps.modal import run_modal
    from ngs_driver.fe.model import build_from_scene
    from ngs_driver.scene import load_scene
    sc = load_scene("koyna_classic")
    kn, kt = k0_from_scene(sc)
    rows = []
    for lab, sets in (("empty", []), ("Westergaard", ["reservoir.model=westergaard"]),
                      ("incompressible acoustic", ["reservoir.model=acoustic",
                                                   "reservoir.compressible=false"])):
        md = build_from_scene(load_scene("koyna_classic", sets))
        rows.append((lab, modal_analysis(md, 1, kn, kt).frequencies_hz[0]))
    s = load_scene("koyna_classic", ["reservoir.model=acoustic"])
    run_modal(s, out / "reservoir_koyna_classic_compressible", 4)
    import json
    d = json.loads((out / "reservoir_koyna_classic_compressible" / "modal.json").read_text())
    fr = d["reservoir"]["frequency_response"]
    f0 = rows[0][1]
    lines += ["## 4. Koyna classic, rigid base, reservoir 91.75 m", "",
              "| water | f1 [Hz] | f1 / f1_empty |", "|---|---|---|"]
    lines += [f"| {lab} | {f:.4f} | {f / f0:.4f} |" for lab, f in rows]
    fc = fr["fundamental_hz"]["compressible"]
    lines += [f"| compressible (alpha = 1), fundamental resonance of the crest response "
              f"(eta = 0.1) | {fc:.3f} | {fc / f0:.4f} |",
              "", "Frequency response: `reservoir_koyna_classic_compressible/"
              "frequency_response.png` / `.csv`.", ""]


def cost(lines, fast, n_steps=None):
    """Per-step wall of the paper scene's record with and without the compressible acoustic
    reservoir: both runs set up by ``run.prepare`` (the run's own set-up: laws, Rayleigh
    damping, the fluid stepper, the static state) in one process, their solvers' steps
    interleaved (step k of one, then step k of the other), so that the load of the shared
    machine hits both alike. The solver alone is timed (the joints' laws stay at b_ref)."""
    import tempfile

    from ngs_driver.fe.model import build_from_scene
    from ngs_driver.post.outputs import RunOutputs
    from ngs_driver.run import prepare
    from ngs_driver.run.analysis import seismic_load
    from ngs_driver.scene import load_scene

    n = n_steps or (50 if fast else 200)
    runs = {}
    scratch = pathlib.Path(tempfile.mkdtemp(prefix="reservoir_cost_"))
    for m in ("none", "acoustic"):
        dt = load_scene("koyna").time.dt
        sc = load_scene("koyna", [f"reservoir.model={m}", f"time.duration={(n + 1) * dt!r}"])
        t = time.perf_counter()
        md = build_from_scene(sc)
        tb = time.perf_counter() - t
        a = prepare(sc, scratch / m, model=md, progress=False, outputs=RunOutputs(plots=False),
                    log=lambda *x, **k: None, overwrite=True)
        a.static()
        npd = md.reservoir.info.get("n_pressure_dofs", 0) if md.reservoir else 0
        runs[m] = dict(s=a.solver, f=lambda k, a=a: seismic_load(a.f_static, a.Mrx, a.Mry,
                                                                  a.ax[k], a.ay[k]),
                       walls=[], build=tb, npd=npd)
    for k in range(1, n + 1):
        for m, r in runs.items():
            t = time.perf_counter()
            rep = r["s"].step(r["f"](k))
            r["walls"].append(time.perf_counter() - t)
            r.setdefault("active", []).append(rep.n_active)
    lines += ["## 5. Cost per step, paper scene (12 198 structural DOFs, 333 interface points), "
              f"first {n} steps of the record, interleaved", "",
              "| reservoir | pressure DOFs | build [s] | median per step [ms] | "
              "mean (incl. first step: factorisation) [ms] |", "|---|---|---|---|---|"]
    for m, r in runs.items():
        w = np.asarray(r["walls"])
        lines.append(f"| {m} | {r['npd']} | {r['build']:.1f} | {1e3 * np.median(w):.1f} | "
                     f"{1e3 * w.mean():.1f} |")
    if n > 400:                 # the later window: the base debonds (t ~ 0.6-1.1 s)
        for m, r in runs.items():
            w = np.asarray(r["walls"][300:])
            lines.append(f"| {m}, steps 301-{n} (base debonding) | | | {1e3 * np.median(w):.1f} | "
                         f"{1e3 * w.mean():.1f} |")
        rl = (np.median(runs["acoustic"]["walls"][300:])
              / np.median(runs["none"]["walls"][300:]))
        lines += ["", f"Ratio acoustic / none over steps 301-{n}: median **{rl:.2f}**"]
    ratio = np.median(runs["acoustic"]["walls"]) / np.median(runs["none"]["walls"])
    ratio_mean = np.mean(runs["acoustic"]["walls"][1:]) / np.mean(runs["none"]["walls"][1:])
    lines += ["", f"Ratio acoustic / none: median **{ratio:.2f}**, mean of steps 2.. "
              f"{ratio_mean:.2f} (goal < 1.3)", ""]


def main(fast: bool = False, outdir=None, cost_steps: int | None = None,
         skip_cost: bool = False, only_cost: bool = False) -> str:
    """Write reservoir.md (or reservoir_cost.md with ``only_cost``) into ``outdir`` (default
    verification/out); returns its text. ``fast``: coarser meshes and 50 cost steps."""
    out = pathlib.Path(outdir if outdir is not None else ROOT / "verification" / "out")
    out.mkdir(parents=True, exist_ok=True)
    lines = ["# Reservoir verification", "",
             "Generated by `python verification/reservoir.py`; see docs/reservoir.md.", ""]
    if not only_cost:
        westergaard_table(lines)
        rigid_wall(lines, fast)
        koyna_f1(lines, out)
    if not skip_cost:
        cost(lines, fast, cost_steps)
    text = "\n".join(lines) + "\n"
    (out / ("reservoir_cost.md" if only_cost else "reservoir.md")).write_text(text)
    return text


def _cli(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fast", action="store_true")
    ap.add_argument("--out", default=str(ROOT / "verification" / "out"))
    ap.add_argument("--skip-cost", action="store_true")
    ap.add_argument("--cost-steps", type=int, default=None,
                    help="steps of the interleaved cost measurement (default 200)")
    ap.add_argument("--only-cost", action="store_true")
    a = ap.parse_args(argv)
    print(main(a.fast, a.out, a.cost_steps, a.skip_cost, a.only_cost))


if __name__ == "__main__":
    _cli()
