"""The standard files of a dam run (``prepare(..., outputs=RunOutputs())``): VTK of the dam and
of the water every ``output.vtk_every`` steps, then timeseries.csv, the damage profiles, the
figures, the reservoir's CSV and figure, results.md with the safety table, and the summary's
text for the log. ``plots=False`` keeps the CSV files and results.md, without PNG and VTK."""
from __future__ import annotations

from ..run.outputs import Outputs
from .report import format_summary
from .reservoir import WaterVTK, write_reservoir_outputs
from .results import write_run_outputs
from .safety_plots import write_safety_outputs
from .vtk import VTKWriter

__all__ = ["RunOutputs"]


class RunOutputs(Outputs):
    def __init__(self, plots: bool = True):
        self.plots = bool(plots)
        self.vtk = None                  # post.vtk.VTKWriter of the dam
        self.water_vtk = None            # post.reservoir.WaterVTK

    def start(self, a) -> None:
        if not (self.plots and a.scene.output.vtk_every > 0):
            return
        self.vtk = VTKWriter(a.model, a.out / "vtk" / "dam", a.joints)
        ac = None if a.reservoir is None else a.reservoir.ac
        if ac is not None:
            self.water_vtk = WaterVTK(a.out, ac)

    def step(self, a, k: int, t: float) -> None:
        if self.vtk is None or k % a.scene.output.vtk_every != 0:
            return
        if self.water_vtk is not None:
            p = a.reservoir.pressure()
            if p is not None:
                self.water_vtk.write(p, t)
        self.vtk.write(a.solver.u, t, a.solver)

    def results(self, a, H: dict) -> list[str]:
        files = write_run_outputs(a.out, a.model, a.scene, a.gm, H, a.snapshots.data, a.solver,
                                  a.u_static, a.joints, plots=self.plots, heel=a.heel)
        if self.vtk is not None:
            files.extend(self.vtk.files())
        if self.water_vtk is not None:
            files.extend(f"vtk/{f}" for f in self.water_vtk.files)
        if a.reservoir is not None:
            files.extend(write_reservoir_outputs(a.out, a.reservoir, self.plots))
        return files

    def safety(self, a, H: dict, post: dict, safety_summary: dict) -> list[str]:
        return write_safety_outputs(a.out, a.scene, a.gm, H, a.static_info.get("joints"), post,
                                    safety_summary, plots=self.plots, screening=a.screening)

    def report(self, summary: dict) -> str:
        return format_summary(summary)
