"""Joint operators: the gap at the Gauss points of a joint, g = B u (virtual nodes).

Matching meshes: NGSolve evaluates the basis functions at the Gauss points of an
``IntegrationRuleSpaceSurface``; non-matching: segment-to-segment (patch test to round-off)
or one-pass node-to-segment (kept for comparison).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from .ngs_helpers import to_scipy, vec, vertex_xy_dofs


@dataclass
class JointOperator:
    """The gap operator of one or several joints at ``n_gauss`` Gauss points per segment
    (virtual node technique).  Points are sorted by x (heel first).

    gap at point p: ``(g_N, g_T) = B[2p:2p+2] @ u``  (u: free-DOF vector), in the fixed
    frame ``normal`` (from rock into dam, +y for Koyna) and ``tangent`` (+x); gap =
    u_dam - u_rock.  Joint virtual work = sum_p w_p t_p . dg_p, so the interface
    internal force is ``B.T @ (w[:, None] * t).ravel()``.
    """

    B: sp.csr_matrix            # (2*npts, nfree): rows 2p -> g_N, 2p+1 -> g_T
    x: np.ndarray               # (npts,) x coordinate of the points
    y: np.ndarray               # (npts,)
    w: np.ndarray               # (npts,) segment length x Gauss weight
    segment: np.ndarray         # (npts,) segment id (index into ``segments``)
    segments: np.ndarray        # (nseg, 2, 2) dam-side segment end points, sorted by x
    n_gauss: int
    normal: np.ndarray = field(default_factory=lambda: np.array([0.0, 1.0]))
    tangent: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0]))
    matching: bool = True
    name: str = "base"
    parts: dict | None = None      # joint name -> slice of points (stacked operators)

    def __post_init__(self):
        if self.parts is None:
            self.parts = {self.name: slice(0, self.x.size)}

    @property
    def npts(self) -> int:
        return self.x.size

    @property
    def length(self) -> float:
        return float(self.w.sum())

    def gap(self, u: np.ndarray) -> np.ndarray:
        """(npts, 2) array of (g_N, g_T)."""
        return (self.B @ u).reshape(-1, 2)

    def force(self, t: np.ndarray) -> np.ndarray:
        """Joint internal force B^T (w t) for tractions t (npts, 2) = (t_N, t_T)."""
        t = np.asarray(t, dtype=float).reshape(-1, 2)
        return self.B.T @ (self.w[:, None] * t).ravel()

    def stiffness(self, k_normal, k_tangential) -> sp.csr_matrix:
        """B^T diag(w k) B for (per-point or scalar) spring stiffnesses [Pa/m];
        a general 2x2 tangent per point: use ``tangent_stiffness``."""
        kn = np.broadcast_to(np.asarray(k_normal, float), self.x.shape)
        kt = np.broadcast_to(np.asarray(k_tangential, float), self.x.shape)
        d = np.empty(2 * self.npts)
        d[0::2] = self.w * kn
        d[1::2] = self.w * kt
        return (self.B.T @ sp.diags(d) @ self.B).tocsr()

    def tangent_stiffness(self, D: np.ndarray) -> sp.csr_matrix:
        """B^T blockdiag(w_p D_p) B for per-point 2x2 tangents D (npts, 2, 2) ordered
        (N, T) x (N, T)."""
        D = np.asarray(D, float).reshape(-1, 2, 2) * self.w[:, None, None]
        blk = sp.block_diag(list(D), format="csr") if self.npts < 64 else block_diag(D)
        return (self.B.T @ blk @ self.B).tocsr()



def block_diag(D: np.ndarray) -> sp.csr_matrix:
    n = D.shape[0]
    rows = np.repeat(np.arange(2 * n).reshape(n, 2), 2, axis=1).ravel()
    cols = np.tile(np.arange(2 * n).reshape(n, 2), (1, 2)).ravel()
    return sp.csr_matrix((D.ravel(), (rows, cols)), shape=(2 * n, 2 * n))



def build_joint_operator(mesh, fes, Vd, Vr, free, n_gauss: int, foundation: str,
                    matching: bool, order: int,
                    coupling: str = "segment-to-segment", *, upper: int = 0,
                    lower: int | None = 1, boundary: str = "interface",
                    rock_offset: int | None = None, name: str = "base") -> JointOperator:
    """Joint operator B (see ``JointOperator``).

    Dam side (and rock side for matching meshes): NGSolve evaluates the basis functions
    at the Gauss points of an ``IntegrationRuleSpaceSurface`` on the "interface" segments:
    the mixed form  b(u, q) = sum_p w_p (u . e)(x_p) q_p  divided by the IR-space mass
    (diagonal = w_p) gives exactly the point values.  Rock side of a non-matching mesh:
    node-to-segment projection of each dam-side Gauss point onto the "interface_rock"
    segments, linear shape functions (order 1 only) — ``coupling="node-to-segment"``, kept for
    comparison; the default for non-matching meshes is ``segment_to_segment`` (passes the
    patch test).

    upper / lower: indices of the fields above and below the joint in the product space
    ``fes`` (lower None: the fixed ground); the gap is u_upper - u_lower at the points of the
    internal boundary ``boundary``. rock_offset: first DOF of the lower field (non-matching)."""
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs
    from ngsolve.comp import IntegrationRuleSpaceSurface

    normal = np.array([0.0, 1.0])
    tangent = np.array([1.0, 0.0])
    if foundation != "rigid" and not matching and coupling == "segment-to-segment":
        if order != 1:
            raise NotImplementedError("non-matching interface implemented for order=1 only")
        return segment_to_segment(mesh, fes, Vd, Vr, free, n_gauss, normal, tangent,
                                  Vd.ndof if rock_offset is None else rock_offset)
    nfull = fes.ndof
    irs = IntegrationRuleSpaceSurface(mesh, order=n_gauss - 1,
                                      definedon=mesh.Boundaries(boundary))
    rules = irs.GetIntegrationRules()
    # IntegrationRuleSpaceSurface(order=n-1) carries the n-point Gauss rule: check
    segrule = rules[ngs.ET.SEGM]
    if len(segrule.points) != n_gauss:
        raise RuntimeError(f"IntegrationRuleSpaceSurface gave {len(segrule.points)} points "
                           f"per segment, expected {n_gauss}")
    q = irs.TestFunction()
    p = irs.TrialFunction()
    dsI = ngs.ds(boundary, intrules=rules)
    mi = ngs.BilinearForm(irs)
    mi += p * q * dsI
    mi.Assemble()
    w = to_scipy(mi.mat).diagonal()
    lfx = ngs.LinearForm(irs)
    lfx += ngs.x * q * dsI
    lfx.Assemble()
    lfy = ngs.LinearForm(irs)
    lfy += ngs.y * q * dsI
    lfy.Assemble()
    xs = vec(lfx) / w
    ys = vec(lfy) / w

    tr = fes.TrialFunction()
    tr = tuple(tr) if isinstance(tr, (tuple, list)) else (tr,)
    ud = tr[upper]
    ur = None if (lower is None or foundation == "rigid") else tr[lower]
    rows = []
    for e in (normal, tangent):
        b = ngs.BilinearForm(trialspace=fes, testspace=irs)
        cf_e = ngs.CF(tuple(e))
        if ur is not None and matching:
            b += ngs.InnerProduct(ud - ur, cf_e) * q * dsI
        else:
            b += ngs.InnerProduct(ud, cf_e) * q * dsI
        b.Assemble()
        rows.append(sp.diags(1.0 / w) @ to_scipy(b.mat, (irs.ndof, nfull)))
    npts = irs.ndof
    # interleave (N, T) rows per point
    Bfull = sp.vstack(rows).tocsr()
    perm = np.empty(2 * npts, dtype=np.int64)
    perm[0::2] = np.arange(npts)
    perm[1::2] = npts + np.arange(npts)
    Bfull = Bfull[perm]

    # segments (dam side) and point -> segment map
    els = list(mesh.Boundaries(boundary).Elements())
    seg_of_dof = np.empty(npts, dtype=np.int64)
    segs = np.empty((len(els), 2, 2))
    for k, el in enumerate(els):
        for d in irs.GetDofNrs(el):
            seg_of_dof[d] = k
        pts = [mesh.vertices[v.nr].point for v in el.vertices]
        segs[k] = sorted([(pt[0], pt[1]) for pt in pts])

    if ur is not None and not matching:
        if order != 1:
            raise NotImplementedError("non-matching interface implemented for order=1 only")
        Bfull = Bfull + _rock_nts(mesh, fes, Vd, Vr, xs, ys, normal, tangent,
                                  Vd.ndof if rock_offset is None else rock_offset)

    # sort points by x (heel first), renumber segments by their left end
    seg_order = np.argsort(segs[:, 0, 0], kind="stable")
    seg_new = np.empty_like(seg_order)
    seg_new[seg_order] = np.arange(seg_order.size)
    pord = np.lexsort((xs, seg_new[seg_of_dof]))
    rp = np.empty(2 * npts, dtype=np.int64)
    rp[0::2] = 2 * pord
    rp[1::2] = 2 * pord + 1
    B = Bfull[rp][:, free].tocsr()
    B.eliminate_zeros()
    return JointOperator(B=B, x=xs[pord], y=ys[pord], w=w[pord], segment=seg_new[seg_of_dof][pord],
                     segments=segs[seg_order], n_gauss=n_gauss, normal=normal,
                     tangent=tangent, matching=matching or ur is None, name=name)



def _p1_segments(mesh, V, boundary):
    """[(vertex coordinates (2, 2), (x dof, y dof) per vertex)] of the boundary's segments."""
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs
    segs = []
    for el in mesh.Boundaries(boundary).Elements():
        vs = [v.nr for v in el.vertices]
        P = np.array([mesh.vertices[v].point[:2] for v in vs])
        dofs = [vertex_xy_dofs(V, V.GetDofNrs(ngs.NodeId(ngs.VERTEX, v))) for v in vs]
        segs.append((P, dofs))
    return segs



def _p1_rows(segs, off, X, sign, normal, tangent, rows, cols, vals, i):
    """Append sign * (displacement . e) at point X (rows 2i, 2i+1) by projection onto the
    nearest segment of ``segs`` (linear shape functions). Returns the segment index."""
    best = None
    for k, (P, dofs) in enumerate(segs):
        t = P[1] - P[0]
        s = np.clip((X - P[0]) @ t / (t @ t), 0.0, 1.0)
        dist = np.linalg.norm(P[0] + s * t - X)
        if best is None or dist < best[0] - 1e-14:
            best = (dist, s, k)
    _, s, k = best
    N = (1.0 - s, s)
    for a in range(2):
        for comp in range(2):
            for r, e in ((2 * i, normal), (2 * i + 1, tangent)):
                if e[comp] != 0.0:
                    rows.append(r)
                    cols.append(off + segs[k][1][a][comp])
                    vals.append(sign * N[a] * e[comp])
    return k



def segment_to_segment(mesh, fes, Vd, Vr, free, n_gauss, normal, tangent,
                       rock_offset) -> "JointOperator":
    """Non-matching straight interface, integrated segment-to-segment: the dam-side and
    rock-side segments are cut at every vertex of either side, and each piece carries n Gauss
    points, so both sides' linear shape functions are smooth on every piece and B^T W t is
    integrated exactly for a linear traction: the patch test (uniform stress across the
    interface) passes to round-off (tests/test_patch.py). One-pass node-to-segment with the
    points on the dam segments only does not (0.2-6 % error measured)."""
    dseg = _p1_segments(mesh, Vd, "interface")
    rseg = _p1_segments(mesh, Vr, "interface_rock")
    allp = np.vstack([P for P, _ in dseg] + [P for P, _ in rseg])
    a0 = allp[np.argmin(allp[:, 0] + 1e-9 * allp[:, 1])]
    d = allp[np.argmax(np.linalg.norm(allp - a0, axis=1))] - a0
    L = np.linalg.norm(d)
    d = d / L
    off_line = np.abs((allp - a0) @ np.array([-d[1], d[0]])).max()
    if off_line > 1e-9 * L:
        raise NotImplementedError("segment-to-segment coupling needs a straight interface "
                                  f"(vertices are up to {off_line:.3g} m off the line)")
    s_br = np.unique(np.round((allp - a0) @ d, 12))
    gx, gw = np.polynomial.legendre.leggauss(n_gauss)
    xs, ys, w = [], [], []
    for s0, s1 in zip(s_br[:-1], s_br[1:]):
        if s1 - s0 <= 1e-12 * L:
            continue
        for xi, wi in zip(gx, gw):
            X = a0 + (0.5 * (s0 + s1) + 0.5 * (s1 - s0) * xi) * d
            xs.append(X[0])
            ys.append(X[1])
            w.append(0.5 * (s1 - s0) * wi)
    xs, ys, w = np.array(xs), np.array(ys), np.array(w)
    rows, cols, vals = [], [], []
    seg = np.empty(xs.size, dtype=np.int64)
    for i in range(xs.size):
        X = np.array([xs[i], ys[i]])
        seg[i] = _p1_rows(dseg, 0, X, 1.0, normal, tangent, rows, cols, vals, i)
        _p1_rows(rseg, rock_offset, X, -1.0, normal, tangent, rows, cols, vals, i)
    B = sp.csr_matrix((vals, (rows, cols)), shape=(2 * xs.size, fes.ndof))[:, free].tocsr()
    B.eliminate_zeros()
    segs = np.array([sorted(map(tuple, P)) for P, _ in dseg])
    order = np.argsort(segs[:, 0, 0], kind="stable")
    renum = np.empty_like(order)
    renum[order] = np.arange(order.size)
    return JointOperator(B=B, x=xs, y=ys, w=w, segment=renum[seg], segments=segs[order],
                     n_gauss=n_gauss, normal=normal, tangent=tangent, matching=False, name="base")



def _rock_nts(mesh, fes, Vd, Vr, xs, ys, normal, tangent, rock_offset) -> sp.csr_matrix:
    """-(rock displacement) at the points, node-to-segment on "interface_rock" (order 1)."""
    rseg = _p1_segments(mesh, Vr, "interface_rock")
    rows, cols, vals = [], [], []
    for i in range(xs.size):
        _p1_rows(rseg, rock_offset, np.array([xs[i], ys[i]]), -1.0, normal, tangent, rows, cols,
                 vals, i)
    return sp.csr_matrix((vals, (rows, cols)), shape=(2 * xs.size, fes.ndof))


def stack_joint_operators(ifaces) -> JointOperator:
    """One operator over the concatenated points of several joints (the base first); the
    solver sees one gap vector, ``parts`` tells each joint's slice."""
    parts, segs, seg_ids, n0, s0 = {}, [], [], 0, 0
    for it in ifaces:
        parts[it.name] = slice(n0, n0 + it.npts)
        seg_ids.append(it.segment + s0)
        segs.append(it.segments)
        n0 += it.npts
        s0 += it.segments.shape[0]
    return JointOperator(B=sp.vstack([it.B for it in ifaces]).tocsr(),
                     x=np.concatenate([it.x for it in ifaces]),
                     y=np.concatenate([it.y for it in ifaces]),
                     w=np.concatenate([it.w for it in ifaces]),
                     segment=np.concatenate(seg_ids), segments=np.concatenate(segs),
                     n_gauss=ifaces[0].n_gauss, matching=all(it.matching for it in ifaces),
                     name="+".join(it.name for it in ifaces), parts=parts)
