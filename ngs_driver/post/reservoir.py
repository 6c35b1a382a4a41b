"""Reservoir outputs of a run: hydrodynamic pressure on the upstream face at a few elevations
over time and the force resultant (``reservoir_pressure.csv`` + ``reservoir_pressure.png``),
and VTK of p (``vtk/water_*.vtu``) when VTK output is on. The values are gathered during the
run by ``run.reservoir.ReservoirRun``."""
from __future__ import annotations

import csv
import io
import pathlib

import numpy as np

from .files import atomic_write_text
from .plots import save_png, subplots

__all__ = ["WaterVTK", "write_reservoir_outputs"]


class WaterVTK:
    """VTK files of the water pressure p, one per call of ``write``."""

    def __init__(self, out, acoustic):
        self.dir = pathlib.Path(out) / "vtk"
        self.dir.mkdir(parents=True, exist_ok=True)
        self.W = acoustic.W
        self.files = []

    def write(self, p, t):
        # deferred: NGSolve is optional: the package imports without it
        import ngsolve as ngs
        W = self.W
        gf = ngs.GridFunction(W.Vp)
        v = np.zeros(W.Vp.ndof)
        v[W.free] = p
        gf.vec.FV().NumPy()[:] = v
        name = self.dir / f"water_{len(self.files):05d}"
        ngs.VTKOutput(W.Vp.mesh, coefs=[gf], names=["p"], filename=str(name),
                      subdivision=0).Do()             # p = 0 outside the water
        self.files.append(name.name + ".vtu")


def write_reservoir_outputs(out, rr, plots=True) -> list[str]:
    """CSV (and figure) of ``rr`` (a ``run.reservoir.ReservoirRun``); returns the file names."""
    out = pathlib.Path(out)
    keys = list(rr.rows)
    fh = io.StringIO(newline="")
    w = csv.writer(fh)
    w.writerow([k if k in ("t",) else (k + "_Pa" if k.startswith("p_") else k + "_N_per_m")
                for k in keys])
    for i in range(len(rr.rows["t"])):
        w.writerow([f"{rr.rows[k][i]:.9g}" for k in keys])
    atomic_write_text(out / "reservoir_pressure.csv", fh.getvalue())
    files = ["reservoir_pressure.csv"]
    if plots and rr.rows["t"]:
        fig, (a1, a2) = subplots(2, 1, figsize=(8, 6), sharex=True)
        t = np.asarray(rr.rows["t"])
        for y in rr.ys:
            a1.plot(t, np.asarray(rr.rows[f"p_y{y:.2f}"]) / 1e3, label=f"y = {y:.1f} m")
        a1.set_ylabel("hydrodynamic p [kPa]")
        a1.legend(fontsize=8, ncol=3)
        a1.set_title(f"reservoir: {rr.res.kind}"
                     + (" (incompressible)" if rr.ac is not None and rr.ac.incompressible
                        else "") + f", level {rr.level:g} m")
        a2.plot(t, np.asarray(rr.rows["Fx"]) / 1e6)
        a2.set_ylabel("force on the face Fx [MN/m]")
        a2.set_xlabel("t [s]")
        fig.tight_layout()
        fig.set_layout_engine(None)      # laid out: savefig need not draw twice
        files.append(save_png(fig, out / "reservoir_pressure.png", dpi=120))   # atomic
    return files
