"""Stage 5 of the pipeline: a dam run. ``prepare(scene, outdir) -> Analysis`` builds it;
``Analysis.static()``, ``Analysis.step()``, ``Analysis.finish()`` run it; ``run`` does all of
that in one call (the ``run`` command)."""
from .analysis import Analysis, prepare
from .dam import RunInterrupted, run

__all__ = ["prepare", "Analysis", "run", "RunInterrupted"]
