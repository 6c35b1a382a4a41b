"""The results folder of a run: owned by one run at a time, writable before any work, and never
emptied of what the user did not ask to delete (docs/run.md §6).

* ``FolderLock``: an OS file lock (``fcntl.flock``) on ``.dam-seismic.lock`` in the folder, held
  while the run lives; the kernel releases it when the process ends, however it ends (a kill
  leaves no stale lock). The file holds the holder's process id, named by the refusal.
* ``probe_writable``: the folder created (parents too) and a probe file written and removed;
  ``dry_run_probe`` does the same and removes the folders it created (a dry run leaves nothing).
* ``reuse_error``: a plain run into a folder holding a finished run (summary.json) or an
  interrupted run's checkpoint is refused unless ``--overwrite`` (or ``--resume``) is given.
* ``clean_temporaries``: the ``.*.tmp`` files a killed run's atomic writes left behind (only
  while the lock is held: no other run is writing them).

Every refusal is a ``FolderError`` (a ValueError: exit 2 on the command line) naming the folder.
"""
from __future__ import annotations

import errno
import json
import os
import pathlib

try:
    import fcntl
except ImportError:                      # pragma: no cover - not POSIX: no lock (documented)
    fcntl = None

__all__ = ["FolderError", "FolderLock", "LOCK_NAME", "probe_writable", "dry_run_probe",
           "reuse_error", "clean_temporaries", "finished_files"]

LOCK_NAME = ".dam-seismic.lock"
PROBE_NAME = ".dam-seismic-probe"


class FolderError(ValueError):
    """The results folder cannot be used (in use, not writable, holds a run not to be lost)."""


def _make(path: pathlib.Path, key: str) -> list[pathlib.Path]:
    """Create ``path`` and its missing parents; the folders created (outermost first)."""
    missing = []
    p = path
    while not p.exists() and p != p.parent:
        missing.append(p)
        p = p.parent
    if path.exists() and not path.is_dir():
        raise FolderError(f"{key} = {str(path)!r}: is an existing file; allowed: a folder (new "
                          "or existing)")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise FolderError(f"{key} = {str(path)!r}: the folder cannot be created ({e.strerror or e}"
                          f"{': ' + str(e.filename) if e.filename else ''}); allowed: a folder "
                          "this user can create and write") from None
    return missing[::-1]


def probe_writable(path, key: str = "--out") -> list[pathlib.Path]:
    """Create the folder and write + remove a probe file in it; FolderError naming ``key`` and
    the folder when either fails. Returns the folders created."""
    path = pathlib.Path(path)
    created = _make(path, key)
    probe = path / f"{PROBE_NAME}-{os.getpid()}"
    try:
        with open(probe, "wb") as fh:
            fh.write(b"probe\n")
        probe.unlink()
    except OSError as e:
        raise FolderError(f"{key} = {str(path)!r}: the folder is not writable ({e.strerror or e})"
                          "; allowed: a folder this user can write") from None
    return created


def dry_run_probe(path, key: str = "--out") -> None:
    """``probe_writable`` for ``--dry-run``: the folders it had to create are removed again."""
    created = probe_writable(path, key)
    for p in reversed(created):
        try:
            p.rmdir()
        except OSError:
            pass


def finished_files(out) -> list[str] | None:
    """The files a finished run in ``out`` listed in its summary.json (None: no finished run)."""
    p = pathlib.Path(out) / "summary.json"
    if not p.exists():
        return None
    try:
        return [str(f) for f in json.loads(p.read_text()).get("files", [])] + ["summary.json"]
    except (OSError, ValueError, AttributeError):
        return ["summary.json"]


def _checkpoint_step(out: pathlib.Path):
    try:
        return json.loads((out / "checkpoint.json").read_text()).get("step")
    except (OSError, ValueError, AttributeError):
        return "unreadable"


def reuse_error(out, *, resume: bool, overwrite: bool, key: str = "--out") -> str | None:
    """Why a run may not start in ``out`` as asked (None: it may). A plain run is refused in a
    folder holding a finished run or a checkpoint (``overwrite`` allows both: the user asks for
    them to go); ``resume`` needs a checkpoint (checked where it is read)."""
    out = pathlib.Path(out)
    if resume or overwrite or not out.is_dir():
        return None
    ckp = (out / "checkpoint.json").exists() or any(out.glob("checkpoint_*.npz"))
    if ckp:
        step = _checkpoint_step(out) if (out / "checkpoint.json").exists() else "uncommitted"
        return (f"{key} = {str(out)!r} holds the checkpoint of an interrupted run (step {step}); "
                "a new run would delete it; allowed: --resume to continue it, --overwrite to "
                "replace it, or another folder")
    if (out / "summary.json").exists():
        return (f"{key} = {str(out)!r} holds a finished run (summary.json); a new run would "
                "replace its results; allowed: --overwrite to replace them, or another folder")
    return None


def clean_temporaries(out) -> list[str]:
    """Remove the ``.<name>.*.tmp`` files of atomic writes a killed run left (``interfacelaw.
    atomic``); call only with the folder's lock held. Returns their names."""
    gone = []
    for p in pathlib.Path(out).glob(".*.tmp"):
        try:
            p.unlink()
            gone.append(p.name)
        except OSError:
            pass
    return gone


class FolderLock:
    """The folder's run lock (module docstring). ``acquire()`` raises FolderError naming the
    folder and the holder's process id when another process holds it. Held per process: a
    second ``acquire`` of a folder this process already holds is counted, not refused (a study
    worker takes its folder's lock, then ``prepare`` takes it again)."""

    _held: dict = {}                     # resolved folder -> [fd, count] (this process)

    def __init__(self, folder, key: str = "--out"):
        self.dir = pathlib.Path(folder)
        self.key = key
        self.path = self.dir / LOCK_NAME
        self._mine = False

    def _id(self):
        return str(self.dir.resolve())

    def acquire(self) -> "FolderLock":
        if self._mine:
            return self
        k = self._id()
        if k in FolderLock._held:
            FolderLock._held[k][1] += 1
            self._mine = True
            return self
        if fcntl is None:                # pragma: no cover
            FolderLock._held[k] = [None, 1]
            self._mine = True
            return self
        for _ in range(20):              # the lock file replaced under us: take the new one
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError as e:
                raise FolderError(f"{self.key} = {str(self.dir)!r}: the folder is not writable "
                                  f"({e.strerror or e}); allowed: a folder this user can write")\
                    from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as e:
                os.close(fd)
                if e.errno not in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                    raise
                raise FolderError(f"{self.key} = {str(self.dir)!r} is in use by another run "
                                  f"({self.holder()}); allowed: one run per folder: wait for "
                                  "it to end, or choose another folder") from None
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(self.path))
            except FileNotFoundError:
                same = False
            if not same:                 # released and removed by its holder meanwhile
                os.close(fd)
                continue
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode())
            FolderLock._held[k] = [fd, 1]
            self._mine = True
            return self
        raise FolderError(f"{self.key} = {str(self.dir)!r}: its lock file keeps changing; "
                          "allowed: one run per folder")

    def holder(self) -> str:
        try:
            pid = self.path.read_text().strip()
        except OSError:
            pid = ""
        return f"process {pid}" if pid else "a process that is starting"

    def release(self) -> None:
        if not self._mine:
            return
        self._mine = False
        k = self._id()
        ent = FolderLock._held.get(k)
        if ent is None:
            return
        ent[1] -= 1
        if ent[1] > 0:
            return
        del FolderLock._held[k]
        if ent[0] is not None:
            try:
                self.path.unlink()       # before the unlock: a waiting run takes a new file
            except OSError:
                pass
            os.close(ent[0])

    def __enter__(self):
        return self.acquire()

    def __exit__(self, *exc):
        self.release()
