"""The declared interface of a field coupled to the joint solver inside every step (the
compressible water of solve/fluid.py; the incompressible water's ground-driven load). The
field is given to the solver's constructor (``JointSolver(..., coupled=field)``); the solver
calls these methods and nothing else."""
from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["CoupledField"]


@runtime_checkable
class CoupledField(Protocol):
    """A field eliminated inside the structure's step equation.

    bind(solver)  : called once by the solver's constructor; the field reads the solver's
                    committed fields (time, u, v, a), ``coefficients(h)``, ``integrator`` and
                    ``ndof`` through it, at the calls below
    matrix(h)     : (ndof, ndof) sparse block added to the effective matrix of step size h
    rhs(h)        : (ndof,) its share of the step's right-hand side (the committed state to
                    the end of a step of size h)
    commit(h)     : the step of size h was accepted (the solver's fields are already the new
                    ones): advance the field's own state
    checkpoint()  : a dict of copies of the field's state (numpy arrays; None where the field
                    is at rest), from which ``restore`` puts it back bit for bit
    restore(d)    : set the state from ``checkpoint()``'s dict (copies are taken)"""

    def bind(self, solver) -> None: ...

    def matrix(self, h: float): ...

    def rhs(self, h: float) -> np.ndarray: ...

    def commit(self, h: float) -> None: ...

    def checkpoint(self) -> dict: ...

    def restore(self, d: dict) -> None: ...
