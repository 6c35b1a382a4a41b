"""Finite sliding on a joint: the face below each point of the upper face, found anew as the
joint slides (node-to-segment pairing; docs/sliding.md).

The gap operator B pairs each integration point X_p of a joint's upper face with the point of
the lower face below it. At the start that is the same point X_p (matching mesh: small
sliding). A joint that slides by s_p pairs X_p with the lower-face point Y_p = X_p + s_p t
(t the joint's tangent): its gap rows become

    g_p = (u_up(X_p) - u_low(Y_p)) . (n, t)     (+ the offset that keeps g continuous),

the lower face's displacement interpolated on the segment of the lower face that holds Y_p
(linear shape functions; P1 meshes). The lower face of the base is the rock's top: the joint
itself and the rock's free top upstream and downstream of the dam (so a base can slide past
its original toe or heel); of a lift joint, the top of the block below (a point that slides
beyond it has no support and opens). A rigid foundation is the fixed ground: nothing to pair
(the gap is the dam's own displacement).

Kinematics kept small (docs/sliding.md): strains in the blocks, rotations (the joint's normal
stays vertical), the reservoir's interface with the dam (the water mesh does not follow).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .ngs_helpers import vertex_xy_dofs

__all__ = ["LowerFace", "lower_faces", "upper_columns"]


@dataclass
class LowerFace:
    """The lower face of one joint: segments on the line y = y0, sorted by x.

    x0, x1 (ns,) the segments' ends (x0 < x1); dofs (ns, 2, 2) the free-DOF index of (u_x,
    u_y) at each end (-1 where the DOF is fixed); y0 the line's elevation."""

    x0: np.ndarray
    x1: np.ndarray
    dofs: np.ndarray
    y0: float

    def locate(self, xq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(segment index or -1 outside the face, local coordinate in [0, 1]) of each xq."""
        k = np.searchsorted(self.x0, xq, side="right") - 1
        k = np.clip(k, 0, self.x0.size - 1)
        inside = (xq >= self.x0[k] - 1e-12) & (xq <= self.x1[k] + 1e-12)
        s = np.clip((xq - self.x0[k]) / (self.x1[k] - self.x0[k]), 0.0, 1.0)
        return np.where(inside, k, -1), s

    def size_at(self, xq: np.ndarray) -> np.ndarray:
        """The length of the lower-face segment below each xq (inf outside the face)."""
        k, _ = self.locate(xq)
        L = self.x1 - self.x0
        return np.where(k >= 0, L[np.maximum(k, 0)], np.inf)

    def rows(self, xq: np.ndarray, first: int, n: int, shape):
        """Sparse rows -(u_low . n, u_low . t) at the positions xq for the points
        first..first+len(xq)-1 (rows 2p: normal (0, 1), 2p+1: tangent (1, 0)); and the mask
        of the points with no face below them."""
        k, s = self.locate(xq)
        rows, cols, vals = [], [], []
        for i in range(xq.size):
            if k[i] < 0:
                continue
            p = first + i
            for a, Na in ((0, 1.0 - s[i]), (1, s[i])):
                dx, dy = self.dofs[k[i], a]
                if dy >= 0 and Na != 0.0:
                    rows.append(2 * p)
                    cols.append(dy)
                    vals.append(-Na)
                if dx >= 0 and Na != 0.0:
                    rows.append(2 * p + 1)
                    cols.append(dx)
                    vals.append(-Na)
        M = sp.csr_matrix((vals, (rows, cols)), shape=shape)
        return M, k < 0


def _field_offsets(model):
    """First global DOF of each field of the model's (product) space, in ``model.regions``
    order."""
    comps = [model.fes] if len(model.regions) == 1 else list(model.fes.components)
    off = np.concatenate([[0], np.cumsum([V.ndof for V in comps])]).astype(np.int64)
    return comps, off


def upper_columns(model, region: str) -> np.ndarray:
    """Bool (nfree,): the free DOFs of the field of ``region`` (a dam block)."""
    comps, off = _field_offsets(model)
    k = list(model.regions).index(region)
    full = np.zeros(model.fes.ndof, bool)
    full[off[k]:off[k + 1]] = True
    return model.field_rows(full[model.free])


def lower_faces(model) -> dict:
    """{joint name: (upper region, LowerFace or None)} for every joint, the base first. None:
    nothing to pair (a rigid foundation under the base, or a mesh of order > 1, whose faces
    this module does not interpolate: such a joint keeps its initial pairing)."""
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs


    comps, off = _field_offsets(model)
    inv = -np.ones(model.fes.ndof, dtype=np.int64)
    inv[model.free] = model.dof_map()
    regions = list(model.regions)
    blocks = [r for r in regions if r != "rock"]
    bnds = set(model.mesh.GetBoundaries())
    out = {}
    for k, name in enumerate(model.joints):
        upper = blocks[k]
        if name == "base":
            if "rock" not in regions:
                out[name] = (upper, None)
                continue
            low = regions.index("rock")
            faces = ["interface" if "interface_rock" not in bnds else "interface_rock",
                     "rock_top_up", "rock_top_down"]
        else:
            low = regions.index(blocks[k - 1])
            faces = [name]
        if model.order != 1:
            out[name] = (upper, None)
            continue
        V = comps[low]
        y0 = float(np.mean(model.joints[name].y))
        x0, x1, dofs = [], [], []
        for b in faces:
            if b not in bnds:
                continue
            for el in model.mesh.Boundaries(b).Elements():
                vs = [v.nr for v in el.vertices]
                P = np.array([model.mesh.vertices[v].point[:2] for v in vs])
                if np.max(np.abs(P[:, 1] - y0)) > 1e-6 * max(1.0, abs(y0)):
                    continue                      # not on the joint's line
                d = [vertex_xy_dofs(V, V.GetDofNrs(ngs.NodeId(ngs.VERTEX, v))) for v in vs]
                order = np.argsort(P[:, 0])
                P, d = P[order], [d[i] for i in order]
                x0.append(P[0, 0])
                x1.append(P[1, 0])
                dofs.append([[inv[off[low] + dd] for dd in dv] for dv in d])
        x0, x1, dofs = np.array(x0), np.array(x1), np.array(dofs, dtype=np.int64)
        srt = np.argsort(x0)
        out[name] = (upper, LowerFace(x0[srt], x1[srt], dofs[srt], y0))
    return out
