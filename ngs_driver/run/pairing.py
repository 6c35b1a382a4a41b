"""Finite sliding in a run: each sliding joint is paired anew with the face below it.

After every committed step, a joint whose points have slid, since their last pairing, by more
than ``solver.pairing_tolerance`` times the length of the lower-face segment below them is
paired anew (``fe.pairing``): its gap rows take the lower face's displacement at the point now
below each point of the upper face, and the gap offset keeps the committed gap continuous (no
traction jump from the pairing itself). The solver's effective matrices are factorised anew.
Joints that do not slide cost one comparison per step. A point with no face below it (it slid
past the end of a lift joint) opens: its normal gap is set 1 m open.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..fe.pairing import lower_faces, upper_columns
from .parts import Part

__all__ = ["JointPairing", "OPEN_GAP", "splice_rows"]


def splice_rows(B, a, b, rows):
    """B (CSR) with its rows a..b-1 replaced by ``rows`` ((b - a) x ncol), as a new canonical
    CSR matrix (sorted indices, no stored zeros): the matrix that LIL slice assignment gave,
    without its dense copy of ``rows`` (scipy's LIL ``__setitem__`` densifies a sparse value:
    2 npts x ndof, 46 MB on koyna_engineering's base at every re-pairing, measured as the
    peak of ``make run``)."""
    B = sp.csr_matrix(B)
    new = sp.vstack([B[:a], sp.csr_matrix(rows), B[b:]], format="csr")
    new.sum_duplicates()
    new.sort_indices()
    new.eliminate_zeros()
    return new


OPEN_GAP = 1.0        # m: the normal gap given to a point that has no face below it


class JointPairing(Part):
    """The current pairing of every joint that can slide on a deformable face; a run part
    (``run.parts``): after each step the joints that slid are paired anew and every function
    in ``on_repair`` is called with the solver (the uplift's operator, the energy budget's
    gap)."""

    name = "pairing"

    def __init__(self, model, slices, names, B, tolerance: float, solver=None):
        self.solver = solver                  # whose operator a restore rebuilds
        self.on_repair = []
        self.offset = None                    # the solver's gap offset of the last pairing
        self.tol = float(tolerance)
        faces = lower_faces(model)
        self.joints = []                      # (name, slice, LowerFace, B rows of the upper)
        B = sp.csr_matrix(B)
        self.x = np.array(model.interface.x if hasattr(model, "interface") else [])
        for name, sl in zip(names, slices):
            upper, face = faces.get(name, (None, None))
            if face is None:
                continue
            cols = upper_columns(model, upper)
            rows = B[2 * sl.start:2 * sl.stop]
            Bup = rows.multiply(cols[None, :]).tocsr()
            Bup.eliminate_zeros()
            self.joints.append((name, sl, face, Bup))
        self.shift = np.zeros(B.shape[0] // 2)          # s at the last pairing, per point
        self._limits = {}     # joint -> the slip that calls a pairing, per point (by shift)
        self.repairs = 0
        self.shape = B.shape

    @property
    def active(self) -> bool:
        return bool(self.joints)

    def update(self, solver) -> bool:
        """Pair anew the joints that slid beyond the tolerance; True if B changed."""
        if not self.joints:
            return False
        g = solver.g
        due = []
        for name, sl, face, Bup in self.joints:
            lim = self._limits.get(name)
            if lim is None:           # changes only with the shift: formed once per pairing
                lim = self._limits[name] = self.tol * face.size_at(self.x[sl] + self.shift[sl])
            if np.any(np.abs(g[sl, 1] - self.shift[sl]) > lim):
                due.append((name, sl, face, Bup))
        if not due:
            return False
        B = solver.B
        opened = np.zeros(g.shape[0], bool)
        for name, sl, face, Bup in due:
            s = g[sl, 1].copy()
            low, off_face = face.rows(self.x[sl] + s, 0, sl.stop - sl.start,
                                      (2 * (sl.stop - sl.start), self.shape[1]))
            B = splice_rows(B, 2 * sl.start, 2 * sl.stop, Bup + low)
            self.shift[sl] = s
            self._limits.pop(name, None)
            opened[sl] = off_face
        offset = solver.g.ravel() - B @ solver.u
        if opened.any():                          # no face below: the point opens
            iN = 2 * np.flatnonzero(opened)
            offset[iN] += np.maximum(-solver.g[opened, 0], 0.0) + OPEN_GAP
        solver.set_operator(B, offset)
        self.offset = offset
        self.repairs += 1
        return True

    def after_step(self, ctx):
        if self.joints and self.update(ctx.solver):
            for call in self.on_repair:
                call(ctx.solver)

    def checkpoint(self) -> dict:
        d = {"shift": self.shift.copy(), "repairs": int(self.repairs)}
        if self.offset is not None:
            d["offset"] = np.array(self.offset, copy=True)
        return d

    def restore(self, d):
        """The pairing of a checkpoint: the shifts it was built at, and the solver's operator
        rebuilt from them with the gap offset of the last pairing."""
        if not self.joints:
            return
        self.shift = np.array(d["shift"], dtype=np.float64)
        self._limits = {}
        self.repairs = int(d["repairs"])
        self.offset = d.get("offset")
        if self.offset is None:
            return
        solver = self.solver
        B = solver.B
        for name, sl, face, Bup in self.joints:
            if not np.any(self.shift[sl]):
                continue
            low, _ = face.rows(self.x[sl] + self.shift[sl], 0, sl.stop - sl.start,
                               (2 * (sl.stop - sl.start), self.shape[1]))
            B = splice_rows(B, 2 * sl.start, 2 * sl.stop, Bup + low)
        solver.set_operator(B, self.offset)
