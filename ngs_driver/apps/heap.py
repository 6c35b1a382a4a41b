"""The process's heap: fixed mmap and trim thresholds for glibc's malloc (the ``dam-seismic``
process).

glibc serves a request of at least M_MMAP_THRESHOLD bytes with its own mmap, returned to the
system when freed; but its *dynamic* threshold rises to the size of every mmapped block that is
freed (up to 32 MiB), after which blocks of that size come from the heap, where freed memory
stays with the process. A run frees and allocates factors of the effective matrix at every
re-pairing of a sliding joint and at every new sub-step size, so with the dynamic rule its
resident set grew at each of them.

Fixed thresholds (mallopt(3); setting one switches the dynamic rule off): blocks of 1 MiB and
more are mmapped (the factors, their temporaries, the interface columns), smaller ones (a
step's vectors: 12 198 DOFs x 8 B = 98 kB) come from the heap as before, and the heap's top is
trimmed only above 32 MiB free (with glibc's 128 KiB the step's vectors were handed back and
faulted in again every step). What it changed, measured: docs/run.md §7 "The command's memory".
A threshold the user set (``MALLOC_MMAP_THRESHOLD_`` or ``MALLOC_TRIM_THRESHOLD_`` in the
environment, read by glibc itself) is left alone by the command; off glibc this does nothing.

Dask's nanny starts its workers with ``MALLOC_TRIM_THRESHOLD_=65536`` (its config
``distributed.nanny.pre-spawn-environ``; it also leaves the variable in the parent's
environment), which switches glibc's dynamic rule off with a 64 KiB trim: measured on
koyna_engineering with the reduced bulk (4 s, ``verification/step_cost.py --scene
koyna_engineering --set solver.bulk=reduced``), the time loop 3.52-3.77 s against 3.33 s
without it. An IDA task therefore sets this module's thresholds in its worker
(``respect_env=False``, ``studies.ida.execute``)."""
from __future__ import annotations

import ctypes
import ctypes.util
import os

__all__ = ["fix_heap_thresholds", "MMAP_THRESHOLD", "TRIM_THRESHOLD"]

M_TRIM_THRESHOLD = -1            # mallopt(3) parameter numbers (malloc.h)
M_MMAP_THRESHOLD = -3
MMAP_THRESHOLD = 1 << 20         # [bytes] blocks this large are mmapped (and unmapped when freed)
TRIM_THRESHOLD = 32 << 20        # [bytes] free memory at the heap's top kept up to this


def fix_heap_thresholds(mmap_bytes: int = MMAP_THRESHOLD,
                        trim_bytes: int = TRIM_THRESHOLD, respect_env: bool = True) -> bool:
    """Fix glibc's mmap and trim thresholds; True if both were set. ``respect_env``: leave
    them as a ``MALLOC_*_THRESHOLD_`` variable of the environment set them."""
    if respect_env and ("MALLOC_MMAP_THRESHOLD_" in os.environ
                        or "MALLOC_TRIM_THRESHOLD_" in os.environ):
        return False
    name = ctypes.util.find_library("c")
    if not name:
        return False
    try:
        mallopt = ctypes.CDLL(name).mallopt
    except (OSError, AttributeError):  # not glibc (musl, macOS): nothing to fix
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return bool(mallopt(M_TRIM_THRESHOLD, int(trim_bytes))) \
        and bool(mallopt(M_MMAP_THRESHOLD, int(mmap_bytes)))
