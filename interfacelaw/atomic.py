"""Atomic file writes: a temporary file in the same directory, fsync, then os.replace, so a
killed process never leaves a half-written file under the final name."""
from __future__ import annotations

import os
import pathlib
import tempfile

# the process's umask, read once at import (os.umask can only be read by setting it, which is
# not safe once threads write files): a written file gets mode 0o666 & ~umask, as open() would
# give it, not the 0o600 of the temporary file
_UMASK = os.umask(0o022)
os.umask(_UMASK)


def atomic_write_bytes(path, data: bytes) -> pathlib.Path:
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fchmod(fh.fileno(), 0o666 & ~_UMASK)
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


def atomic_write_text(path, text: str) -> pathlib.Path:
    return atomic_write_bytes(path, text.encode("utf-8"))
