"""The run's parts that hand each step out: to the output stage (``OutputsStep``: the
``outputs`` object's ``step``) and to the person watching (``Progress``: the progress bar)."""
from __future__ import annotations

import numpy as np
from tqdm import tqdm

from .parts import Part

__all__ = ["OutputsStep", "Progress"]


class OutputsStep(Part):
    """After each step: ``outputs.step(analysis, k, t)`` (``run.outputs.Outputs``)."""

    name = "outputs"

    def __init__(self, analysis):
        self.analysis = analysis

    def after_step(self, ctx):
        self.analysis.outputs.step(self.analysis, ctx.k, ctx.t)


class Progress(Part):
    """The progress bar (tqdm on stderr; off when ``show`` is False or stderr is not a
    terminal) with the time, the Newton iterations, the step cuts so far, the heel's crack
    and damage every 10 steps."""

    name = "progress"

    def __init__(self, show: bool, n_steps: int, label: str, history):
        self.show, self.n_steps, self.label = show, n_steps, label
        self.history = history                 # run.history.StepHistory
        self.bar = None
        self._n_cuts, self._n_cuts_at = 0, 0

    def open(self, k: int):
        # disable=None: tqdm turns itself off when stderr is not a terminal (logs stay readable)
        self.bar = tqdm(total=self.n_steps, initial=k, disable=None if self.show else True,
                        unit="step", desc=self.label, dynamic_ncols=True)

    def write(self, text: str):
        self.bar.write(text)

    def close(self):
        if self.bar is not None:
            self.bar.close()

    def after_step(self, ctx):
        self.bar.update(1)
        k = ctx.k
        if self.show and (k % 10 == 0 or k == self.n_steps):
            # the cuts so far: a running sum (summing the whole column is O(k) per call)
            h = self.history.history
            self._n_cuts += int(np.sum(h.cols["cuts"][self._n_cuts_at:]))
            self._n_cuts_at = len(h)
            self.bar.set_postfix_str(f"t={ctx.t:.3f}s it={ctx.report.iterations} "
                                     f"cuts={self._n_cuts} "
                                     f"crack={ctx.measures['base_crack_length_upstream']:.3f}m "
                                     f"Dheel={ctx.state.damage[0]:.3f}", refresh=False)
