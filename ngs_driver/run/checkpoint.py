"""Checkpoints of a run: arrays + meta written atomically, the meta last (the commit point);
and the copy of a solver's committed state that a checkpoint or a repeated solve needs."""
from __future__ import annotations

import json
import pathlib
import threading

import numpy as np

from .store import atomic_write_bytes, atomic_write_text, json_text, npz_bytes


def solver_snapshot(solver) -> dict:
    """A copy of everything the solver has committed: u, v, a, f, time, the interface state
    and the internals of ``checkpoint_state`` (a solve can be repeated from it bit for bit)."""
    return {"u": solver.u.copy(), "v": solver.v.copy(), "a": solver.a.copy(),
            "f": None if solver.f is None else solver.f.copy(), "time": solver.time,
            "internals": solver.checkpoint_state(), "state": solver.state.copy()}


def restore_solver(solver, snap) -> None:
    """Put the solver back to ``solver_snapshot``'s state (copies: the snapshot stays valid)."""
    solver.u, solver.v, solver.a = snap["u"].copy(), snap["v"].copy(), snap["a"].copy()
    solver.f = None if snap["f"] is None else snap["f"].copy()
    solver.time = snap["time"]
    solver.restore_state(snap["internals"])
    solver.state = snap["state"].copy()


def solver_arrays(solver) -> dict:
    """The solver's committed fields as checkpoint arrays (``restore_solver_arrays``)."""
    out = {"u": solver.u, "v": solver.v, "a": solver.a, "f": solver.f}
    out.update({f"solver_{k}": v for k, v in solver.checkpoint_state().items()})
    out.update({f"state_{k}": v for k, v in solver.state.as_dict().items()})
    return out


def scene_difference(have, want, path="") -> str | None:
    """'key = <have> in the checkpoint, <want> now' for the first key whose value differs
    (depth first, in ``want``'s order), or None when the two scene dicts are equal."""
    if have == want:
        return None
    if isinstance(have, dict) and isinstance(want, dict):
        for k in list(want) + [k for k in have if k not in want]:
            p = f"{path}.{k}" if path else k
            if k not in have:
                return f"{p} = {want[k]!r} is not in the checkpoint's scene"
            if k not in want:
                return f"{p} = {have[k]!r} in the checkpoint is not in the scene"
            if have[k] != want[k]:
                return scene_difference(have[k], want[k], p)
    return f"{path or 'scene'} = {have!r} in the checkpoint, {want!r} now"


def checkpoint_scene_difference(scene, directory) -> str | None:
    """The first key in which ``scene`` differs from the scene of the checkpoint in
    ``directory`` (``scene_difference``), or None."""
    meta = json.loads((pathlib.Path(directory) / "checkpoint.json").read_text())
    return scene_difference(meta.get("scene") or {}, json.loads(json.dumps(scene.to_dict())))


def interface_state(arrs):
    """The interface state saved by ``solver_arrays``."""
    from interfacelaw import InterfaceState
    return InterfaceState.from_dict({k[6:]: v for k, v in arrs.items()
                                     if k.startswith("state_")})


def restore_solver_arrays(solver, arrs, time: float) -> None:
    """The rest of ``solver_arrays`` once ``solver.state`` (``interface_state``) and the law
    are set: u, v, a, f (``set_initial`` evaluates the law on them), then the committed
    internals exactly as they were, and the time."""
    solver.set_initial(u=arrs["u"], v=arrs["v"], a=arrs["a"], f=arrs["f"])
    solver.restore_state({k[7:]: v for k, v in arrs.items() if k.startswith("solver_")})
    solver.time = float(time)


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
        self._writer = None                 # the thread writing the last checkpoint
        self._error = None

    @property
    def meta_path(self) -> pathlib.Path:
        return self.dir / "checkpoint.json"

    def due(self, step: int) -> bool:
        return self.every > 0 and step > 0 and step % self.every == 0

    def save(self, step: int, meta: dict, **arrays) -> None:
        """Serialise the checkpoint now; write it in the background: the npz, then
        the json that names it (the commit point), then the previous npz removed, in this
        order in one writer thread, so the time loop does not wait for the disk (write and
        fsync, ~10-15 ms per Koyna checkpoint). One write at a time: a save waits for the
        previous one; ``wait()`` before anything reads the directory or the run ends."""
        name = f"checkpoint_{step:07d}.npz"
        data = npz_bytes(**arrays)
        text = json_text(dict(meta, step=step, arrays=name))
        self.wait()
        old = self.load_meta()
        stale = old["arrays"] if old and old.get("arrays") and old["arrays"] != name else None
        self._writer = threading.Thread(target=self._write, args=(name, data, text, stale),
                                        name=f"checkpoint {step}")
        self._writer.start()

    def _write(self, name, data, text, stale):
        try:
            atomic_write_bytes(self.dir / name, data)
            atomic_write_text(self.meta_path, text)
            if stale is not None:
                try:
                    (self.dir / stale).unlink()
                except FileNotFoundError:
                    pass
        except BaseException as e:          # re-raised by wait() in the run's thread
            self._error = e

    def wait(self) -> None:
        """Wait for the checkpoint being written (if any); re-raise its error."""
        w, self._writer = self._writer, None
        if w is not None:
            w.join()
        e, self._error = self._error, None
        if e is not None:
            raise e

    def load_meta(self) -> dict | None:
        if not self.meta_path.exists():
            return None
        return json.loads(self.meta_path.read_text())

    def load(self):
        self.wait()
        meta = self.load_meta()
        if meta is None:
            raise FileNotFoundError(f"--resume: no checkpoint in {self.dir}; allowed: a results "
                                    "directory of a run started with output.checkpoint_every > 0")
        with np.load(self.dir / meta["arrays"]) as z:
            arrays = {k: z[k] for k in z.files}
        return meta, arrays
