"""The joints as the solver sees them: the gap operator B with its weights, the law's initial
elastic stiffness K0 that the factorised matrix holds, the interface DOFs and their relative-DOF
structure B_I = G Delta (docs/solver.md §2), and the gap offset of a re-paired sliding joint."""
from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from .joint_laws import initial_stiffness, reference_gap
from .kernels import mv, phi_mask_kernel

__all__ = ["JointOperator", "relative_dofs"]


def relative_dofs(BI):
    """B_I = G Delta with Delta the relative displacements of the interface DOFs.

    A matching interface has every DOF of a dam-side node paired with one of the coincident
    rock-side node whose column of B is exactly its negative (g = B (u_dam - u_rock)): then
    Delta = E_dam^T - E_rock^T (r = |I| / 2 rows) and G = B_I[:, dam], exactly (no round-off).
    Otherwise (non-matching interfaces) Delta = identity, G = B_I.  Returns (G csr, Delta^T csr).
    """
    C = sp.csc_matrix(BI)
    C.sort_indices()
    m = C.shape[1]
    groups = {}
    for j in range(m):
        sl = slice(C.indptr[j], C.indptr[j + 1])
        groups.setdefault(C.indices[sl].tobytes(), []).append(j)
    pos, neg = [], []
    for js in groups.values():
        if len(js) != 2:
            break
        a, b = js
        va = C.data[C.indptr[a]:C.indptr[a + 1]]
        vb = C.data[C.indptr[b]:C.indptr[b + 1]]
        if va.size == 0 or not np.array_equal(va, -vb):
            break
        pos.append(a)
        neg.append(b)
    else:
        if 2 * len(pos) == m:
            r = len(pos)
            Dt = sp.csr_matrix((np.r_[np.ones(r), -np.ones(r)], (np.r_[pos, neg],
                                np.r_[np.arange(r), np.arange(r)])), shape=(m, r))
            return C[:, pos].tocsr(), Dt
    return sp.csr_matrix(BI), sp.identity(m, format="csr")


def dof_index(pts):
    """The gap-vector entries (2 p, 2 p + 1) of the points ``pts``."""
    d = np.empty(2 * pts.size, np.int64)
    d[0::2] = 2 * pts
    d[1::2] = 2 * pts + 1
    return d


class JointOperator:
    """B (2 npts x ndof, CSR): gap of point p, g_p = (g_N, g_T) = B[2p:2p+2] @ u (+ g_offset);
    w (npts,) the integration weights; K0 the law's initial stiffness per point.

    Public fields (read by the Newton methods and by tests of the condensed algebra):
    B, BT, w, wd (W on the gap vector), npts, ndof, k0p (npts, 2), k0 (2,), k0v (2 npts),
    k0blk (npts, 2, 2), gref (the residual's smallest scale), BtWK0B (B^T W K0 B), g_offset,
    f_off (B^T W K0 g_offset), dofs (the interface DOFs I), BI = B[:, I], BIT, G, Dt (B_I =
    G Delta, Dt = Delta^T), GT."""

    def __init__(self, B, w, law, active_tol):
        self.B = sp.csr_matrix(B)
        self.BT = self.B.T.tocsr()
        self.w = np.asarray(w, dtype=np.float64)
        self.npts = self.w.shape[0]
        self.ndof = self.B.shape[1]
        self.active_tol = float(active_tol)
        self.wd = np.repeat(self.w, 2)                     # W on the (2 npts) gap vector
        # the gap is g = B u + g_offset: g_offset is zero until a sliding joint is re-paired
        # (``set_operator``), which keeps g continuous across the new pairing
        self.g_offset = None
        self.f_off = None
        self.set_k0(law)
        self.set_interface_dofs()

    def set_interface_dofs(self):
        """The interface DOFs I of B and the relative-DOF structure B_I = G Delta."""
        self.dofs = np.unique(self.B.indices)               # DOFs the interface touches
        self.BI = self.B[:, self.dofs].tocsr()              # (2 npts, |I|)
        self.BIT = self.BI.T.tocsr()
        # B_I = G Delta: Delta^T (|I| x r), G (2 npts x r) sparse; S = G (Delta X Delta^T) G^T
        self.G, self.Dt = relative_dofs(self.BI)
        self.GT = self.G.T.tocsr()

    def set_k0(self, law, debonded=None):
        """K0 of ``law`` per point (a cracked point: the contact and stick stiffness)."""
        self.k0p = initial_stiffness(law, self.npts, debonded)
        self.k0 = self.k0p.max(axis=0)
        self.k0v = self.k0p.ravel()
        self.k0blk = np.zeros((self.npts, 2, 2))
        self.k0blk[:, 0, 0] = self.k0p[:, 0]
        self.k0blk[:, 1, 1] = self.k0p[:, 1]
        self.gref = reference_gap(law) * 1e-3 * math.sqrt(self.npts)
        self.BtWK0B = (self.BT @ sp.diags(self.k0v * np.repeat(self.w, 2)) @ self.B).tocsr()
        if self.g_offset is not None:
            self.set_offset_force()

    def set_operator(self, B, g_offset):
        """Replace B (same shape) and the gap's offset (a re-paired sliding joint)."""
        self.B = B
        self.BT = B.T.tocsr()
        self.g_offset = np.asarray(g_offset, dtype=np.float64).copy()
        self.set_interface_dofs()
        self.BtWK0B = (self.BT @ sp.diags(self.k0v * np.repeat(self.w, 2)) @ self.B).tocsr()
        self.set_offset_force()

    def set_offset(self, g_offset):
        """Replace the gap's offset with B kept (no refactorisation)."""
        self.g_offset = np.asarray(g_offset, dtype=np.float64).copy()
        self.set_offset_force()

    def set_offset_force(self):
        """f_off = B^T W K0 g_offset: the part of the interface's elastic force K0 g that the
        factorised matrix (which holds B^T W K0 B, acting on B u only) does not produce once the
        gap has an offset. The condensed equations subtract c f_off from the right-hand side
        (``JointSolver.attempt``): A u = rhs - c B^T W (phi + K0 g_offset), phi = t - K0 g.
        Without it a re-paired joint carried a spurious traction K0 g_offset at every point:
        ~1e6 Pa for the 1e-5 m offsets of a continuous re-pairing, and 9e10 Pa at a point
        that slid off its face (its offset opens it by 1 m): the energy of koyna_1967's
        3.642 s jump (docs/solver.md §2.7)."""
        if self.g_offset is None:
            self.f_off = None
            return
        self.f_off = self.BT @ (self.wd * self.k0v * self.g_offset)

    def gap(self, u):
        """g = B u (+ g_offset) as a flat (2 npts) vector."""
        g = self.B @ u
        if self.g_offset is not None:
            g += self.g_offset
        return g

    def internal_force(self, t):
        """B^T W t: the free-DOF force of the interface tractions t (npts, 2)."""
        return mv(self.BT, self.wd * t.ravel())     # bitwise scipy's BT @ (.)

    def phi_mask(self, phi, g):
        """Points whose correction phi is not round-off of K0 g."""
        out = np.empty(self.npts, np.bool_)
        phi_mask_kernel(phi, g, self.k0v, self.active_tol, out)
        return out
