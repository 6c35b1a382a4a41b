"""The committed state of the joint solver: what an accepted step leaves behind and the next
step starts from, in one object with ``snapshot()`` / ``revert()`` (a relaxation at a static
limit load, a step repeated by the run's energy guard or uplift)."""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

__all__ = ["Committed"]


@dataclass
class Committed:
    """The fields a step commits.

    u, v, a : displacement, velocity, acceleration of the free DOFs
    f       : the load at ``time`` (None before the first load)
    time    : time of the committed state [s]
    state   : the interface law's state (interfacelaw.InterfaceState)
    t, g    : (npts, 2) traction and gap (the law's) of the committed state
    phi     : (2 npts,) nonlinear correction t - K0 g at the active points (zero elsewhere)
    active  : (npts,) points not in their initial elastic state
    slip_sign : (npts,) sign of each point's last plastic slip step (friction events), or None

    A commit replaces the arrays, it never modifies them in place."""

    u: np.ndarray
    v: np.ndarray
    a: np.ndarray
    f: np.ndarray | None
    time: float
    state: object
    t: np.ndarray
    g: np.ndarray
    phi: np.ndarray
    active: np.ndarray
    slip_sign: np.ndarray | None = None

    def snapshot(self) -> "Committed":
        """A copy of every field (arrays and the interface state copied)."""
        out = {}
        for fl in fields(self):
            x = getattr(self, fl.name)
            if isinstance(x, np.ndarray):
                x = x.copy()
            elif hasattr(x, "copy"):
                x = x.copy()
            out[fl.name] = x
        return Committed(**out)

    def revert(self, snap: "Committed", names=None) -> None:
        """Set the fields ``names`` (all when None) from ``snap`` (``snapshot()``'s result;
        copies are taken, so the snapshot stays valid)."""
        for name in (names if names is not None else [fl.name for fl in fields(self)]):
            x = getattr(snap, name)
            if isinstance(x, np.ndarray) or hasattr(x, "copy"):
                x = x.copy()
            setattr(self, name, x)
