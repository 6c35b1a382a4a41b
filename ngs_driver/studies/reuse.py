"""What a study's runs share, built once per worker process (docs/studies.md §3, "Reuse").

Between the runs of an IDA on one scene only the record and its scale change; the model --
mesh, matrices, the interface, the acoustic reservoir's matrices and, with
``solver.bulk = "reduced"``, the Craig-Bampton basis (``fe/reduction.py``) -- depends only on
the scene's ``setup.ModelInputs`` (``setup.model_inputs``: section, joints, materials, mesh and
bulk options), never on ``ground_motion`` or ``time``. ``model_for(scene)`` returns the model of
the last scene this process built when its ModelInputs are the same (equal ``model_key``), else
builds it and replaces the cached one.

Memory: at most ``MAX_SCENES`` = 1 model is kept per process (a Dask worker runs one task at a
time with ``threads_per_worker=1``; an IDA has one scene); a run needs its model anyway, so the
cache adds at most one model's memory between runs (koyna_engineering: tens of MB against a
run's peak of ~0.5 GB, BENCHMARKS.md). ``clear()`` empties it.

A run builds its own solver, damping, reservoir stepper and laws from the model and changes
one of its arrays in place: the interface's gap operator B (finite sliding re-pairs on it).
Each run therefore gets ``for_run(model)``: its own copy of B, the rest shared. With it a run
on a cached model gives the same ``summary.json`` numbers bit for bit as a run in a fresh
process (tests/test_studies_reuse.py; without the copy, a koyna_engineering run that re-paired
its base changed the next run's permanent slip by ~1e-6 of its value). The static state and the solver's factorisations are not
reused: the first depends on the joints' laws and the uplift the run starts from, the second is
built inside the joint solver with the run's damping and step (``solve/``); both cost a few
per cent of a whole-record run (docs/studies.md, BENCHMARKS.md)."""
from __future__ import annotations

import copy
import hashlib
import time

from ..fe.model import build_from_inputs
from ..setup import model_inputs

__all__ = ["MAX_SCENES", "model_key", "model_for", "for_run", "clear", "stats"]

MAX_SCENES = 1
_cache: dict = {}            # model_key -> model (at most MAX_SCENES entries)
_stats = {"hits": 0, "builds": 0, "build_s": 0.0}


def model_key(scene) -> str:
    """A hash of everything the model is built from (``setup.model_inputs``: the scene
    resolved for the finite-element model; the record, scale and time keys are not in it)."""
    mi = model_inputs(scene)
    # the section by its vertices (its repr names the object, not the polygon); every other
    # field is plain values whose repr round-trips (floats by repr)
    key = (mi.section.vertices.tolist(), mi.joints, mi.materials, mi.options, mi.bulk)
    return hashlib.sha256(repr(key).encode()).hexdigest()[:16]


def model_for(scene):
    """(model, reused): the cached model when ``model_key(scene)`` matches the last scene
    built in this process, else a new one (which replaces it)."""
    key = model_key(scene)
    if key in _cache:
        _stats["hits"] += 1
        return for_run(_cache[key]), True
    _cache.clear()                   # MAX_SCENES = 1: the previous scene's model goes first
    t = time.perf_counter()
    model = build_from_inputs(model_inputs(scene))
    _stats["builds"] += 1
    _stats["build_s"] += time.perf_counter() - t
    _cache[key] = model
    return for_run(model), False


def for_run(model):
    """The cached model as one run may use it: a shallow copy whose interface has its own gap
    operator B. A run changes B in place (finite sliding pairs a sliding joint's points anew
    on its ``model.interface.B``; measured on koyna_engineering: B is the only array of the
    model a run changes), so each run gets a copy of B (a few hundred kB) and the cached model
    stays as built; every other array is shared, read only."""
    run_model = copy.copy(model)
    run_model.interface = copy.copy(model.interface)
    run_model.interface.B = model.interface.B.copy()
    return run_model


def clear() -> None:
    """Forget the cached model (tests; a caller that needs the memory)."""
    _cache.clear()


def stats() -> dict:
    """This process's cache hits, builds and their build time [s] (a copy)."""
    return dict(_stats, cached=len(_cache))
