"""Checkpoints of a run: arrays + manifest written atomically, the manifest last (the commit
point), the previous checkpoint kept until the next one is committed; the solver's
committed state as a run part (``SolverPart``: the copy a checkpoint or a repeated solve
needs)."""
from __future__ import annotations

import hashlib
import io
import json
import pathlib
import threading
import zipfile
import zlib

import numpy as np

from .parts import Part
from .store import atomic_write_bytes, atomic_write_text, json_text, npz_bytes

# the layout of a checkpoint: 2 = one namespace per run part (``run.parts``); a checkpoint of
# another format is refused on --resume with a message saying so
CHECKPOINT_FORMAT = 2


# The calls into the solver's own save and restore (and its coupled water's) are here and
# nowhere else in run/: the solve stage's names for them may change in one place.
def _solver_checkpoint(solver, copy: bool = True) -> dict:
    return solver.checkpoint(coupled=False, copy=copy)


def _restore_solver(solver, d) -> None:
    solver.restore(d)


def _water(solver):
    """The solver's coupled water (``solve.coupled.CoupledField``), or None; only the
    compressible acoustic water has a state of its own (the others' checkpoint is empty)."""
    return getattr(solver, "coupled", None)


def _water_state(water) -> dict:
    return water.checkpoint()


def _restore_water(water, d) -> None:
    water.restore(d)


class SolverPart(Part):
    """The solver's committed state as a run part: u, v, a, f, time, the interface state, the
    internals a bitwise continuation needs (traction, gap, phi, the active set, the gap
    offset of a re-paired joint) and the state of its coupled water (compressible acoustic
    water: p, p', p'' and its energy accumulators). ``checkpoint()`` copies it all: the same
    dict repeats a solve bit for bit (the energy guard, the uplift's fixed point, the
    post-earthquake check) and is the solver's share of a checkpoint. Without the water's, a
    repeated step (the uplift's fixed point) stepped the water twice: pine_flat's energy
    guard stopped the run at 2.97 s."""

    name = "solver"

    def __init__(self, solver):
        self.solver = solver

    def checkpoint(self, copy: bool = True) -> dict:
        """copy=False: the solver's committed arrays by reference (a step's snapshot for the
        energy guard, restored at once: a commit replaces them and ``restore`` copies); the
        water's are copied either way."""
        s = self.solver
        d = _solver_checkpoint(s, copy)     # u, v, a, f, time, the internals, state_*
        water = _water(s)
        if water is not None:
            d.update({f"water.{k}": None if v is None else np.array(v, copy=True)
                      for k, v in _water_state(water).items()})
        return d

    def restore(self, d: dict) -> None:
        """The solver as ``checkpoint()`` found it (copies: ``d`` stays valid). The gap
        offset is not set here: the pairing's and the rotation's parts restore it."""
        s = self.solver
        _restore_solver(s, {k: v for k, v in d.items() if not k.startswith("water.")})
        water = {k[6:]: v for k, v in d.items() if k.startswith("water.")}
        if water:
            _restore_water(_water(s), water)


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


# keys that may change on --resume: they change where and how often files are written, not a
# number of the results (output.snapshots does: the D(x) profiles' times; it must stay)
RESUME_FREE = ("output.dir", "output.checkpoint_every", "output.vtk_every")


def _resumable(d: dict) -> dict:
    """The scene dict without the keys ``RESUME_FREE``."""
    d = dict(d)
    for key in RESUME_FREE:
        sec, name = key.split(".")
        if isinstance(d.get(sec), dict):
            d[sec] = {k: v for k, v in d[sec].items() if k != name}
    return d


def resume_difference(have: dict, want: dict) -> str | None:
    """``scene_difference`` of two scene dicts on the keys that change results (all but
    ``RESUME_FREE``)."""
    return scene_difference(_resumable(have), _resumable(json.loads(json.dumps(want))))


def checkpoint_scene_difference(scene_dict: dict, directory) -> str | None:
    """The first key in which ``scene_dict`` (a scene's ``to_dict()``) differs from the scene
    of the checkpoint in ``directory`` that a resume would use (``resume_difference``), or
    None. CheckpointDamaged when no checkpoint there can be read, ValueError when it has
    another format."""
    meta, _ = Checkpointer(directory, 0).load()
    why = format_error(meta, directory)
    if why is not None:
        raise ValueError(why)
    return resume_difference(meta.get("scene") or {}, scene_dict)


def format_error(meta: dict, directory) -> str | None:
    """Why a checkpoint's manifest cannot be resumed by this version (its format), or None."""
    have = meta.get("format", 1)
    if have == CHECKPOINT_FORMAT:
        return None
    return (f"--resume: the checkpoint (step {meta.get('step')}) in {directory} has checkpoint "
            f"format {have!r}, written by another version; this version reads format "
            f"{CHECKPOINT_FORMAT}; allowed: rerun without --resume (--overwrite replaces it)")


class CheckpointDamaged(ValueError):
    """No checkpoint in the folder can be read: the message names the damaged one(s)."""


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


class Checkpointer:
    """Checkpoints of a run, each a set committed at once (docs/run.md §6):

    * ``checkpoint_<step>.npz``: every array of the run's state at the step (solver, uplift,
      water, history), written first;
    * ``checkpoint.prev.json``: a copy of the manifest of the previous checkpoint, second;
    * ``checkpoint.json``: the manifest (meta, the npz's name, size and SHA-256), written last:
      the commit point; then the npz files that neither manifest names are removed.

    A kill at any point leaves ``checkpoint.json`` naming a complete npz (the one before, until
    the new manifest is on disk), and ``checkpoint.prev.json`` the one before that. ``load``
    checks the npz against its manifest and, when the newest set is damaged (truncated,
    emptied, altered), names it and takes the previous one (``notes``).
    """

    PREV = "checkpoint.prev.json"

    def __init__(self, directory, every: int):
        if isinstance(every, bool) or not isinstance(every, int) or every < 0:
            raise ValueError(f"output.checkpoint_every = {every!r} is not allowed; allowed: an "
                             "integer >= 0 (0 disables checkpoints)")
        self.dir = pathlib.Path(directory)
        self.every = every
        self._writer = None                 # the thread writing the last checkpoint
        self._error = None
        self.notes = []                     # what load() found damaged and passed over

    @property
    def meta_path(self) -> pathlib.Path:
        return self.dir / "checkpoint.json"

    @property
    def prev_path(self) -> pathlib.Path:
        return self.dir / self.PREV

    def files(self) -> list[pathlib.Path]:
        """Every checkpoint file in the folder (manifests and arrays, committed or not)."""
        return [p for p in (self.meta_path, self.prev_path) if p.exists()] + sorted(
            self.dir.glob("checkpoint_*.npz"))

    def remove_all(self) -> None:
        """No checkpoint left (the run is complete, or the user asked to overwrite)."""
        self.wait()
        for p in self.files():
            p.unlink(missing_ok=True)

    def due(self, step: int) -> bool:
        return self.every > 0 and step > 0 and step % self.every == 0

    def save(self, step: int, meta: dict, **arrays) -> None:
        """Serialise the checkpoint now; write it in the background (the class docstring's
        order, in one writer thread, so the time loop does not wait for the disk: write and
        fsync, ~10-15 ms per Koyna checkpoint). One write at a time: a save waits for the
        previous one; ``wait()`` before anything reads the directory or the run ends."""
        name = f"checkpoint_{step:07d}.npz"
        data = npz_bytes(**arrays)
        text = json_text(dict(meta, step=step, format=CHECKPOINT_FORMAT, arrays=name,
                              arrays_bytes=len(data),
                              arrays_sha256=_sha256(data)))
        self.wait()
        self._writer = threading.Thread(target=self._write, args=(name, data, text),
                                        name=f"checkpoint {step}")
        self._writer.start()

    def _write(self, name, data, text):
        try:
            atomic_write_bytes(self.dir / name, data)
            if self.meta_path.exists():
                atomic_write_bytes(self.prev_path, self.meta_path.read_bytes())
            atomic_write_text(self.meta_path, text)          # the commit point
            keep = {name}
            try:
                keep.add(json.loads(self.prev_path.read_text())["arrays"])
            except (OSError, ValueError, KeyError, TypeError):
                pass
            for p in self.dir.glob("checkpoint_*.npz"):
                if p.name not in keep:
                    p.unlink(missing_ok=True)
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

    def _read(self, path):
        """(meta, arrays) of the manifest ``path``; CheckpointDamaged naming what is wrong."""
        def damaged(step, why):
            return CheckpointDamaged(f"checkpoint step {step} in {self.dir} is damaged: {why}")
        try:
            meta = json.loads(path.read_text())
            if not isinstance(meta, dict) or "arrays" not in meta or "step" not in meta:
                raise ValueError("it names no arrays or step")
        except (ValueError, UnicodeDecodeError) as e:
            raise CheckpointDamaged(f"checkpoint manifest {path.name} in {self.dir} is damaged:"
                                    f" not a complete manifest ({e})") from None
        step = meta["step"]
        npz = self.dir / str(meta["arrays"])
        try:
            data = npz.read_bytes()
        except OSError as e:
            raise damaged(step, f"{npz.name} cannot be read ({e.strerror or e})") from None
        if "arrays_bytes" in meta and len(data) != meta["arrays_bytes"]:
            raise damaged(step, f"{npz.name} has {len(data)} bytes, its manifest "
                                f"{meta['arrays_bytes']} (truncated or emptied)")
        if "arrays_sha256" in meta and _sha256(data) != meta["arrays_sha256"]:
            raise damaged(step, f"{npz.name} differs from the SHA-256 in its manifest (altered "
                                "on disk)")
        try:
            with np.load(io.BytesIO(data)) as z:
                arrays = {k: z[k] for k in z.files}
        except (ValueError, OSError, EOFError, KeyError, zipfile.BadZipFile, zlib.error) as e:
            raise damaged(step, f"{npz.name} is not a readable npz ({type(e).__name__}: {e})") \
                from None
        return meta, arrays

    def load(self):
        """(meta, arrays) of the newest complete checkpoint; FileNotFoundError when there is
        none, CheckpointDamaged when none can be read. A damaged newest checkpoint passed over
        for the previous one is said in ``notes``."""
        self.wait()
        self.notes = []
        found = [p for p in (self.meta_path, self.prev_path) if p.exists()]
        if not found:
            raise FileNotFoundError(f"--resume: no checkpoint in {self.dir}; allowed: a results "
                                    "directory of a run started with output.checkpoint_every > 0")
        errors = []
        for p in found:
            try:
                meta, arrays = self._read(p)
            except CheckpointDamaged as e:
                errors.append(str(e))
                continue
            self.notes = [f"{e}; resuming from the previous one (step {meta['step']})"
                          for e in errors]
            return meta, arrays
        prev = ("the previous one is damaged too: " + "; ".join(errors[1:]) + "; "
                if len(errors) > 1 else "no previous one is left; ")
        raise CheckpointDamaged(f"{errors[0]}; resume from the previous one or rerun without "
                                f"--resume ({prev}a rerun needs --overwrite to replace it)")


class CheckpointStep(Part):
    """Writing the checkpoint when due (``output.checkpoint_every``), a run part
    (``run.parts``), listed last: ``save(k)`` writes every part's checkpoint. A run resumed
    there starts with a fresh solver, so the uninterrupted run drops what the solver carries
    besides its committed state (a reused Jacobian) at the same step."""

    name = "checkpoints"

    def __init__(self, checkpointer, save, solver):
        self.checkpointer, self.save, self.solver = checkpointer, save, solver

    def after_step(self, ctx):
        if ctx.stop is None and self.checkpointer.due(ctx.k):
            self.save(ctx.k)
            self.solver.forget_jacobian()
