"""Plot the default ground motion: ax, ay, velocity, displacement, 5 %-damped Sa spectra.

    python verification/ground_motion_plot.py [--fast] [--out verification/out/ground_motion.png]

The default record is SYNTHETIC (see docs/model.md §9.1); the figure says so.
``--fast`` uses fewer spectral periods and a lower resolution (for the test-suite).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from ngs_driver.setup.ground_motion import G, load_default, response_spectrum, significant_duration  # noqa: E402


def main(fast: bool = False, outdir=None) -> Path:
    """Writes ``outdir/ground_motion.png`` (default verification/out); returns its path."""
    out = Path(outdir if outdir is not None else ROOT / "verification" / "out")
    if out.suffix == ".png":                         # a file name was given
        out.parent.mkdir(parents=True, exist_ok=True)
    else:
        out.mkdir(parents=True, exist_ok=True)
        out = out / "ground_motion.png"

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    gm = load_default()
    v, d = gm.integrate()
    periods = np.geomspace(0.05, 3.0, 15) if fast else np.geomspace(0.02, 3.0, 120)
    sa_x = response_spectrum(gm.ax, gm.dt, periods, 0.05) / G
    sa_y = response_spectrum(gm.ay, gm.dt, periods, 0.05) / G

    tag = "SYNTHETIC Koyna-like motion (not the 1967 record)"
    fig, axs = plt.subplots(5, 1, figsize=(9, 13), constrained_layout=True)
    fig.suptitle(f"{tag}\n{gm.label}, dt = {gm.dt:g} s, peaks {gm.peak_g()[0]:.2f} g / {gm.peak_g()[1]:.2f} g",
                 color="darkred")
    axs[0].plot(gm.t, gm.ax / G, lw=0.6, label="horizontal ax")
    axs[0].set_ylabel("ax [g]")
    axs[1].plot(gm.t, gm.ay / G, lw=0.6, color="C1", label="vertical ay")
    axs[1].set_ylabel("ay [g]")
    for k, (lab, c) in enumerate((("horizontal", "C0"), ("vertical", "C1"))):
        axs[2].plot(gm.t, v[:, k], lw=0.8, color=c, label=lab)
        axs[3].plot(gm.t, 100 * d[:, k], lw=0.8, color=c, label=lab)
    axs[2].set_ylabel("velocity [m/s]")
    axs[3].set_ylabel("displacement [cm]")
    axs[3].set_xlabel("t [s]")
    for ax in axs[:4]:
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
        ax.text(0.01, 0.9, "SYNTHETIC", transform=ax.transAxes, color="darkred", fontsize=9, va="top")
    axs[4].loglog(periods, sa_x, label="horizontal")
    axs[4].loglog(periods, sa_y, label="vertical")
    axs[4].set_xlabel("period T [s]")
    axs[4].set_ylabel("Sa (5 %) [g]")
    axs[4].grid(alpha=0.3, which="both")
    axs[4].legend(fontsize=8)
    axs[4].set_title("5 %-damped pseudo-acceleration spectra (Newmark average acceleration) -- SYNTHETIC")

    if out.is_dir() or not out.suffix:          # a directory: write ground_motion.png in it
        out = out / "ground_motion.png"
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=50 if fast else 120)
    plt.close(fig)

    t5x, t95x = significant_duration(gm.ax, gm.dt)
    print(f"{tag}: {out}")
    print(f"  peaks: {gm.peak_g()[0]:.12g} g, {gm.peak_g()[1]:.12g} g; PGV = {np.abs(v).max(0)} m/s; "
          f"PGD = {np.abs(d).max(0)} m")
    print(f"  residual v_end = {v[-1]} m/s, d_end = {d[-1]} m; D5-95(x) = {t5x:.2f}-{t95x:.2f} s")
    i = int(np.argmax(sa_x))
    print(f"  max Sa_x = {sa_x[i]:.3f} g at T = {periods[i]:.3f} s")
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fast", action="store_true", help="the quick version (seconds)")
    ap.add_argument("--out", default=None, help="output folder (default verification/out)")
    a = ap.parse_args()
    main(fast=a.fast, outdir=a.out)
