"""What a run hands to the output stage, and when. ``prepare(..., outputs=...)`` takes an object
with these five methods; this base class writes nothing (the run's own files -- checkpoints,
``final_state.npz``, ``summary.json`` -- are written by the run either way).
``ngs_driver.post.outputs.RunOutputs`` writes the standard results: the CSV files, the figures and the
VTK files. The run stage never imports the output stage: the arrow goes one way."""
from __future__ import annotations

__all__ = ["Outputs"]


class Outputs:
    """No output files. Subclass and override what a run should write."""

    def start(self, analysis) -> None:
        """Once, when ``prepare`` has built the run (writers of per-step files open here)."""

    def step(self, analysis, k: int, t: float) -> None:
        """After the committed step k (time t): per-step files (VTK) when due."""

    def results(self, analysis, H: dict) -> list[str]:
        """Once the time loop is over, before the post-earthquake solve changes the solver's
        state: the files of the run's results (H: the history's arrays); their names."""
        return []

    def safety(self, analysis, H: dict, post: dict, safety_summary: dict) -> list[str]:
        """After the post-earthquake check: the safety files; their names."""
        return []

    def report(self, summary: dict) -> str | None:
        """The text the run logs at its end (progress on), or None."""
        return None
