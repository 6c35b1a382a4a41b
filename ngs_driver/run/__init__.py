"""Stage 5 of the pipeline: a dam run. ``prepare(scene, outdir) -> Analysis`` builds it;
``Analysis.static()``, ``Analysis.step()``, ``Analysis.finish()`` run it; ``outputs`` (an
``Outputs``) is what it hands to the output stage. The whole run with the standard files is
``ngs_driver.apps.dam.run`` (the ``run`` command)."""
from .analysis import Analysis, prepare
from .outputs import Outputs

__all__ = ["prepare", "Analysis", "Outputs"]
