"""Checkpoints of a run: arrays + meta written atomically, the meta last (the commit point)."""
from __future__ import annotations

import json
import pathlib

import numpy as np

from ..out.files import atomic_savez, atomic_write_json

class Checkpointer:
    """Writes ``checkpoint.npz`` (arrays) + ``checkpoint.json`` (meta) atomically.

    The npz is written first under a step-stamped name, then the json that names it: the json
    is the commit point, so a kill between the two leaves the previous checkpoint valid.
    """

    def __init__(self, directory, every: int):
        if isinstance(every, bool) or not isinstance(every, int) or every < 0:
            raise ValueError(f"output.checkpoint_every = {every!r} is not allowed; allowed: an "
                             "integer >= 0 (0 disables checkpoints)")
        self.dir = pathlib.Path(directory)
        self.every = every

    @property
    def meta_path(self) -> pathlib.Path:
        return self.dir / "checkpoint.json"

    def due(self, step: int) -> bool:
        return self.every > 0 and step > 0 and step % self.every == 0

    def save(self, step: int, meta: dict, **arrays) -> None:
        name = f"checkpoint_{step:07d}.npz"
        atomic_savez(self.dir / name, **arrays)
        old = self.load_meta()
        atomic_write_json(self.meta_path, dict(meta, step=step, arrays=name))
        if old and old.get("arrays") and old["arrays"] != name:
            try:
                (self.dir / old["arrays"]).unlink()
            except FileNotFoundError:
                pass

    def load_meta(self) -> dict | None:
        if not self.meta_path.exists():
            return None
        return json.loads(self.meta_path.read_text())

    def load(self):
        meta = self.load_meta()
        if meta is None:
            raise FileNotFoundError(f"--resume: no checkpoint in {self.dir}; allowed: a results "
                                    "directory of a run started with output.checkpoint_every > 0")
        with np.load(self.dir / meta["arrays"]) as z:
            arrays = {k: z[k] for k in z.files}
        return meta, arrays
