"""Stage 5 of the pipeline: a dam run. ``prepare(scene, outdir) -> Analysis`` builds it;
``Analysis.static()``, ``Analysis.step()``, ``Analysis.finish()`` run it; ``outputs`` (an
``Outputs``) is what it hands to the output stage. The whole run with the standard files is
``ngs_driver.apps.dam.run`` (the ``run`` command)."""
from .analysis import Analysis, prepare
from .outputs import Outputs

__all__ = ["prepare", "Analysis", "Outputs"]

_MOVED = {"run": "ngs_driver.apps.dam", "RunInterrupted": "ngs_driver.apps.dam"}


def __getattr__(name):
    """Names that moved out of the run stage (it does not import the output stage): an
    ImportError that says where they are now."""
    if name in _MOVED:
        raise ImportError(f"ngs_driver.run.{name} moved to {_MOVED[name]}.{name} (the whole run "
                          f"with its standard outputs); use 'from {_MOVED[name]} import {name}'")
    raise AttributeError(f"module 'ngs_driver.run' has no attribute {name!r}")
