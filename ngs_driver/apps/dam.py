"""``run(scene, outdir)``: a whole dam run -- ``prepare``, the static state, every step of the
record, the standard outputs (``post.RunOutputs``) -- the ``run`` command. ``run.analysis`` has
the life cycle and what each part does."""
from __future__ import annotations

import gc

from ..post.outputs import RunOutputs
from ..run.analysis import prepare

__all__ = ["run", "RunInterrupted"]


class RunInterrupted(RuntimeError):
    """Raised by ``run(..., max_steps=k)`` after k steps (test hook for stop/resume)."""


def run(scene, outdir=None, resume: bool = False, progress: bool = True,
        max_steps: int | None = None, model=None, plots: bool = True,
        log=print, overwrite: bool = False, out_key: str | None = None) -> dict:
    """Run the scene; returns the summary dict (also written to ``outdir/summary.json``).

    max_steps: stop (``RunInterrupted``) after this many dynamic steps of this call, with the
    checkpoint written if one is due (test hook for stop/resume).  model: a prebuilt model
    of this scene (tests).  plots: False skips PNG/VTK output (tests).  overwrite: the folder
    may hold a finished run or a checkpoint, replaced by this run (``run.analysis.prepare``);
    out_key: the name of ``outdir`` in messages. The folder's lock is released when the run
    ends, however it ends."""
    # Python's full garbage collections scan every object alive (numba, NGSolve, the model:
    # ~0.1-0.2 s each, a few per run while matplotlib imports and draws): the objects that
    # exist when the time loop starts are moved out of their reach (gc.freeze) and given back
    # when the run ends (gc.unfreeze), so nothing is kept longer than before.
    mine = gc.get_freeze_count() == 0
    try:
        a = prepare(scene, outdir, resume=resume, progress=progress,
                    outputs=RunOutputs(plots=plots), model=model, log=log,
                    overwrite=overwrite, out_key=out_key)
        try:
            return _run(a, mine, max_steps)
        finally:
            a.release()
    finally:
        if mine:
            gc.unfreeze()


def _run(a, mine, max_steps):
    """static, the steps, finish: the run after ``prepare``."""
    a.static()
    if mine:
        gc.freeze()
    try:
        n = 0
        while a.step():
            n += 1
            if max_steps is not None and n >= max_steps:
                raise RunInterrupted(f"stopped after {n} steps (step {a.k}) by max_steps")
    finally:
        a.close()
    return a.finish()
