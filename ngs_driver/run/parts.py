"""The per-step parts of a run behind one protocol (docs/architecture.md, docs/run.md).

Before the solve of a step every part of the run may add to the step's load
(``before_step``: e.g. a load that depends on the committed state); after the solve
(``Analysis.step``: the uplift's fixed point, the energy guard's repeats) every part gets the
committed step in the same ``StepContext`` and does its job (``after_step``), in the order
``Analysis`` lists them; a checkpoint is every part's ``checkpoint()`` and a resume gives each
part back its own dict (``restore``), in the same order. Adding a part to the run means
writing one class with these methods and listing it once (``Analysis.parts``).

The checkpoint dict of a part holds numpy arrays (written to the checkpoint's npz as
``<part name>.<key>``) and JSON values (numbers, strings, None, lists and dicts of them:
written to the manifest under ``parts.<part name>``); ``restore`` receives both merged.
"""
from __future__ import annotations

import dataclasses
from typing import Any, Callable, Protocol, runtime_checkable

import numpy as np

__all__ = ["StepContext", "StepPart", "Part", "acting", "split_checkpoint", "join_checkpoint"]


@dataclasses.dataclass
class StepContext:
    """What a part sees of a step.

    k, t: the step's number and time [s]; dt: the record's step [s]; ground: the record's
    accelerations (a_x, a_y) at t [m/s^2]; solver: the solver (before the solve: the state
    of the step before; after it: the committed state, u, v, a, tractions ``t``, gaps ``g``,
    ``state``); load: the step's load vector (before the solve the parts may add to it; after
    it: the load the step used, uplift included); static_loads: a function giving the static
    loads now (the collapse rule's FS_static). Set by the solve: report, the solver's
    ``StepReport`` (iterations, cuts, sub-steps, wall); energy, the energy budget's row of
    the step; scan, the joints' per-point scan of the committed state
    (``run.joints.JointScan``). Set by the parts after the solve: row, the history row under
    construction (each part adds its columns); measures, the joints' measures of the step
    (``run.joints.Joints.measures``, set by the joints part); stop, None or the stop entry a
    part set (the collapse rule: the run ends at this step, no checkpoint)."""

    k: int
    t: float
    dt: float
    solver: Any
    load: np.ndarray
    static_loads: Callable[[], np.ndarray]
    ground: tuple = (0.0, 0.0)
    report: Any = None
    energy: dict | None = None
    scan: Any = None
    row: dict = dataclasses.field(default_factory=dict)
    measures: dict | None = None
    stop: dict | None = None

    @property
    def state(self):
        """The committed interface state (``InterfaceState``)."""
        return self.solver.state


@runtime_checkable
class StepPart(Protocol):
    """One part of a run's step: its share of the load before the solve, its job after each
    committed step, and its checkpoint."""

    name: str                 # its namespace in a checkpoint (unique in a run)

    def before_step(self, ctx: StepContext) -> None: ...

    def after_step(self, ctx: StepContext) -> None: ...

    def checkpoint(self) -> dict: ...

    def restore(self, d: dict) -> None: ...


class Part:
    """A part with nothing to do by default: subclasses override what they need."""

    name = "part"

    def before_step(self, ctx: StepContext) -> None:
        pass

    def after_step(self, ctx: StepContext) -> None:
        pass

    def checkpoint(self) -> dict:
        return {}

    def restore(self, d: dict) -> None:
        pass


def acting(parts, hook: str) -> list:
    """The parts whose ``hook`` ("before_step" or "after_step") is not ``Part``'s no-op (the
    step loop calls only those; the others' calls would do nothing), in their order."""
    noop = getattr(Part, hook)
    return [p for p in parts
            if hook in getattr(p, "__dict__", ()) or getattr(type(p), hook, None) is not noop]


def split_checkpoint(parts) -> tuple[dict, dict]:
    """(arrays, json): every part's ``checkpoint()``, arrays as ``<name>.<key>``, the rest
    as ``{name: {key: value}}``. ValueError when two parts share a name."""
    arrays, meta = {}, {}
    for p in parts:
        if p.name in meta:
            raise ValueError(f"run parts: two parts named {p.name!r}")
        meta[p.name] = {}
        for key, v in p.checkpoint().items():
            if isinstance(v, np.ndarray):
                arrays[f"{p.name}.{key}"] = v
            else:
                meta[p.name][key] = v
    return arrays, meta


def join_checkpoint(name: str, arrays, meta: dict) -> dict:
    """The dict part ``name`` gave (``split_checkpoint``'s inverse for one part)."""
    pre = f"{name}."
    d = {k[len(pre):]: v for k, v in arrays.items() if k.startswith(pre)}
    d.update(meta.get(name) or {})
    return d
