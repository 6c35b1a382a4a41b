"""Acoustic reservoir (docs/reservoir.md): hydrodynamic pressure p in an
NGSolve H1 space on a water mesh glued to the dam's upstream face.

Water: x < face, 0 <= y <= H (level), length L upstream of the heel.  p is the hydrodynamic
pressure (the hydrostatic part stays the static load).  Strong form, total accelerations:

    (1/c^2) p'' = Laplace p                       in the water
    p = 0                                         free surface (y = H)
    dp/dn = -rho_w a_tot . n                      dam face (n out of the water, into the dam)
    dp/dn = -rho_w a_g . n - q p'                 bottom, q = (1 - alpha) / (c (1 + alpha))
                                                  (Fenves & Chopra 1983; alpha = 1 rigid)
    far end: dp/dn = -p'/c (radiation, Sommerfeld) | -rho_w a_g . n (rigid) | p = 0 (free)

Galerkin (test psi):  G p'' + C_f p' + H p = -rho_w Q^T (u'' + r_x a_gx + r_y a_gy) - rho_w (b_x
a_gx + b_y a_gy) with H = int grad p . grad psi, G = 1/c^2 int p psi, C_f = q int_bottom p psi
+ 1/c int_far p psi, Q = int_face (N_u . n) psi (structure x pressure), b the ground terms of the
bottom and of a rigid far end.  The dam sees the pressure load Q p (traction -p n_dam = p n):

    M u'' + C u' + K u + B^T W t = f - M r a_g + Q p.

Coupled (z = (u, p)):  [[M, 0], [rho Q^T, G]] z'' + [[C, 0], [0, C_f]] z' + [[K, -Q], [0, H]] z
= [f - M r a_g, -rho (g_x a_gx + g_y a_gy)],  g = Q^T r + b: unsymmetric (the standard u-p form),
so the effective matrix of a Newmark step is factorised by LU with pivoting.
Incompressible (c -> infinity): G = 0, C_f = 0 and p is condensed exactly,
p = -rho H^-1 (Q^T u'' + g_x a_gx + g_y a_gy): the added mass M_a = rho Q H^-1 Q^T (dense on
the face DOFs only) joins M, and the seismic load becomes M_s r + rho Q H^-1 g.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl

from .face import dam_normal_trial_test, face_normal_cf
from .ngs_helpers import to_scipy, vec

WATER = "water"
FACE = "upstream"            # the dam's upstream boundary (shared by the water)
BOUNDARIES = ("free_surface", "reservoir_bottom", "far_end")


# ---------------------------------------------------------------------------------------------
# meshes
# ---------------------------------------------------------------------------------------------
def _water_geometry(face_pts, L, h_max, grading=0.5):
    """Netgen geometry of the water polygon; face_pts from the heel up to the water line, each
    face edge one segment (maxh = its length, so netgen keeps the dam's face vertices)."""
    # deferred: NGSolve is optional: the package imports without it
    from netgen.geom2d import SplineGeometry

    geo = SplineGeometry()
    fp = [(float(x), float(y)) for x, y in face_pts]
    H = fp[-1][1]
    seg = [math.dist(a, b) for a, b in zip(fp[:-1], fp[1:])]
    # sizes a bit above the edge lengths: netgen then keeps every face edge whole
    hp = [1.5 * h for h in [seg[0]] + [max(a, b) for a, b in zip(seg[:-1], seg[1:])] + [seg[-1]]]
    pf = [geo.AppendPoint(x, y, maxh=h) for (x, y), h in zip(fp, hp)]
    xs = -float(L)
    ps = geo.AppendPoint(xs, H)
    pb = geo.AppendPoint(xs, 0.0)
    water = 1
    # counter-clockwise with the water on the left: bottom, face, surface, far end
    geo.Append(["line", pb, pf[0]], leftdomain=water, rightdomain=0, bc="reservoir_bottom")
    for a, b, s in zip(pf[:-1], pf[1:], seg):
        geo.Append(["line", a, b], leftdomain=water, rightdomain=0, bc=FACE, maxh=1.5 * s)
    geo.Append(["line", pf[-1], ps], leftdomain=water, rightdomain=0, bc="free_surface")
    geo.Append(["line", ps, pb], leftdomain=water, rightdomain=0, bc="far_end")
    geo.SetMaterial(water, WATER)
    # the global size may not be below a face edge, or netgen would split it
    # segmentsperedge < 1: netgen otherwise splits some face edges (measured on the smoke mesh)
    return geo.GenerateMesh(maxh=max(h_max, 1.5 * max(seg)), grading=grading,
                            segmentsperedge=0.1)


def rectangle_water_mesh(H: float, L: float, h_face: float, h_max: float, grading=0.3):
    """Water only (verification): x in [-L, 0], y in [0, H]; the rigid wall x = 0 is the
    boundary "upstream", uniformly divided with h_face.  Returns an ngsolve.Mesh."""
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs

    n = max(2, int(math.ceil(H / h_face)))
    face = [(0.0, H * k / n) for k in range(n + 1)]
    return ngs.Mesh(_water_geometry(face, L, h_max, grading))


def face_chain(mesh, level: float, boundary: str = FACE):
    """Vertices of ``boundary`` with y <= level, ordered from the heel up: [(nr, x, y)].  The
    wetted face must be one chain from y = 0 to a vertex at y = level."""
    nrs = set()
    edges = []
    for el in mesh.Boundaries(boundary).Elements():
        vs = [v.nr for v in el.vertices]
        ys = [mesh.vertices[v].point[1] for v in vs]
        if max(ys) <= level + 1e-9:
            edges.append(vs)
            nrs.update(vs)
    pts = sorted(((n, *mesh.vertices[n].point) for n in nrs), key=lambda t: t[2])
    if not pts or abs(pts[0][2]) > 1e-9 or abs(pts[-1][2] - level) > 1e-6 * max(level, 1):
        raise ValueError(f"reservoir.level = {level!r}: the upstream face of the mesh has no "
                         "vertex chain from y = 0 to the level (the dam mesh needs a vertex at "
                         "the water line); allowed: a level at a face vertex")
    if len(edges) != len(pts) - 1:
        raise ValueError("reservoir.model = 'acoustic': the wetted upstream face is not a "
                         "single chain of edges; allowed: a face x(y) below the level")
    return pts


def add_water(mesh, res, h_max: float | None = None):
    """The dam mesh with the region "water" glued to its wetted upstream face: the water is
    meshed separately (netgen) with the dam's face vertices as its own, and merged with those
    vertices identified, so the two meshes match on the face and one NGSolve mesh holds dam,
    (rock,) water.  New boundaries: "free_surface", "reservoir_bottom", "far_end".  The water
    bottom (y = 0) is not connected to the rock: the bottom is a rigid/absorbing boundary that
    moves with the ground (Fenves & Chopra's reservoir-bottom model)."""
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs
    from netgen.csg import Pnt
    from netgen.meshing import Element1D, Element2D, FaceDescriptor, Mesh, MeshPoint

    H = float(res.level)
    chain = face_chain(mesh, H)
    face_pts = [(x, y) for _, x, y in chain]
    xs_min = min(x for x, _ in face_pts)
    L = float(res.length)
    wm = _water_geometry(face_pts, L - 0.0 + (0.0 if xs_min >= 0 else 0.0),
                         h_max or res.h_max)
    src = mesh.ngmesh
    out = Mesh(dim=2)
    pmap_d = {}
    for i, p in enumerate(src.Points()):
        pmap_d[i + 1] = out.Add(MeshPoint(Pnt(p[0], p[1], 0.0)))
    # identify the water's face vertices with the dam's (exact coordinates: they are the same
    # numbers passed to netgen as geometry points)
    key = {(round(x, 9), round(y, 9)): pmap_d[n + 1] for n, x, y in chain}
    pmap_w = {}
    n_ident = 0
    for i, p in enumerate(wm.Points()):
        k = (round(p[0], 9), round(p[1], 9))
        if k in key:
            pmap_w[i + 1] = key[k]
            n_ident += 1
        else:
            pmap_w[i + 1] = out.Add(MeshPoint(Pnt(p[0], p[1], 0.0)))
    if n_ident != len(chain):
        raise ValueError(f"reservoir: the water mesh does not match the dam's upstream face "
                         f"({n_ident} of {len(chain)} face vertices matched)")
    mats = {}
    for idx in sorted({el.index for el in src.Elements2D()}):
        fd = out.Add(FaceDescriptor(bc=len(mats) + 1))
        out.SetMaterial(fd, src.GetMaterial(idx))
        mats[idx] = fd
    fd_w = out.Add(FaceDescriptor(bc=len(mats) + 1))
    out.SetMaterial(fd_w, WATER)
    for el in src.Elements2D():
        out.Add(Element2D(mats[el.index], [pmap_d[v.nr] for v in el.vertices]))
    for el in wm.Elements2D():
        out.Add(Element2D(fd_w, [pmap_w[v.nr] for v in el.vertices]))
    # boundary segments with their edge descriptors: which regions lie on either side of each
    # segment (domin, domout). The dam's own descriptors are copied (their regions renumbered
    # as above; the wetted face gets the water on its other side); without them NGSolve could
    # not tell the blocks' boundaries apart, and a block's space (definedon) took the vertices
    # of every block's outer boundary: with a lift joint below the water line the stiffness
    # was singular (koyna_1967).
    from netgen.meshing import EdgeDescriptor

    eds = list(src.EdgeDescriptors())
    names = {}

    def add_ed(name, domin, domout):
        ed = EdgeDescriptor()
        ed.domin, ed.domout, ed.name = int(domin), int(domout), name
        k = out.Add(ed)
        k = int(k) + 1 if int(k) < len(names) + 1 else int(k)      # 1-based segment index
        names[k] = name
        out.SetBCName(k - 1, name)
        return k

    seg_index = {}
    for i, ed in enumerate(eds, start=1):
        name = src.GetBCName(i - 1)
        domin, domout = (mats.get(d, 0) if d > 0 else 0 for d in (ed.domin, ed.domout))
        if name == FACE:
            domout = domout or fd_w
        seg_index[i] = add_ed(name, domin, domout)
    for el in src.Elements1D():
        out.Add(Element1D([pmap_d[v.nr] for v in el.vertices], index=seg_index[el.index]))
    w_index = {}
    n_face = 0
    for el in wm.Elements1D():
        name = wm.GetBCName(el.index - 1)
        if name == FACE:                      # the dam's face edges are already there
            n_face += 1
            continue
        if name not in w_index:
            w_index[name] = add_ed(name, fd_w, 0)
        out.Add(Element1D([pmap_w[v.nr] for v in el.vertices], index=w_index[name]))
    if n_face != len(chain) - 1:
        raise ValueError(f"reservoir: netgen split the face edges ({n_face} water face edges "
                         f"for {len(chain) - 1} dam face edges)")
    return ngs.Mesh(out)


# ---------------------------------------------------------------------------------------------
# matrices
# ---------------------------------------------------------------------------------------------
def bottom_q(alpha: float, c: float) -> float:
    """Admittance q of the absorbing bottom from the wave reflection coefficient alpha
    (Fenves & Chopra 1983: alpha = (1 - q c) / (1 + q c)).  alpha = -1: q = inf (p = 0)."""
    if alpha <= -1.0:
        return math.inf
    return (1.0 - alpha) / (c * (1.0 + alpha))


@dataclass
class WaterMatrices:
    """Fluid matrices on the free pressure DOFs (scipy CSR)."""
    Vp: Any
    free: np.ndarray
    H: sp.csr_matrix               # int grad p . grad psi
    G: sp.csr_matrix               # 1/c^2 int p psi (zero if incompressible)
    Cf: sp.csr_matrix              # q int_bottom + 1/c int_far (radiation)
    b_x: np.ndarray                # int over rigid boundaries moving with the ground of n_x psi
    b_y: np.ndarray                # (bottom, rigid far end; not the face: that is Q^T r)
    face_x: np.ndarray             # int_face n_x psi  (= Q^T r_x for a rigid face)
    face_y: np.ndarray
    Cf_far: sp.csr_matrix | None = None   # the far end's part of Cf (radiation), for the
                                          # energy budget; Cf - Cf_far is the bottom's


def water_matrices(mesh, c: float, compressible: bool, alpha: float, far_end: str,
                   order: int = 1) -> WaterMatrices:
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs

    q = bottom_q(alpha, c) if compressible else 0.0
    dirichlet = ["free_surface"]
    if far_end == "free":
        dirichlet.append("far_end")
    if math.isinf(q):
        dirichlet.append("reservoir_bottom")
    Vp = ngs.Compress(ngs.H1(mesh, order=order, definedon=WATER, dirichlet="|".join(dirichlet)))
    p, s = Vp.TnT()
    # DOFs of the water: free and touched by a water element (a definedon H1 space also keeps
    # the vertices of dam boundaries that share the region's boundary name, e.g. the face
    # above the water line)
    a = ngs.BilinearForm(Vp)
    a += ngs.grad(p) * ngs.grad(s) * ngs.dx(WATER)
    a.Assemble()
    Hfull = to_scipy(a.mat)
    free = np.flatnonzero(np.array(list(Vp.FreeDofs()), bool)
                          & (np.abs(Hfull.diagonal()) > 0))

    def mat(form):
        a = ngs.BilinearForm(Vp)
        a += form
        a.Assemble()
        A = to_scipy(a.mat)[free][:, free]
        return ((A + A.T) * 0.5).tocsr()

    Hm = Hfull[free][:, free]
    Hm = ((Hm + Hm.T) * 0.5).tocsr()
    nf = free.size
    if compressible:
        G = mat(1.0 / c ** 2 * p * s * ngs.dx(WATER))
        cf = 0
        if 0.0 < q < math.inf:
            cf = cf + q * p * s * ngs.ds("reservoir_bottom")
        if far_end == "radiation":
            cf = cf + 1.0 / c * p * s * ngs.ds("far_end")
        Cf = mat(cf) if not isinstance(cf, int) else sp.csr_matrix((nf, nf))
        # the far end's part alone (energy budget: radiated vs absorbed at the bottom); Cf
        # itself stays the one assembled form, bit for bit as before
        Cf_far = (mat(1.0 / c * p * s * ngs.ds("far_end")) if far_end == "radiation"
                  else sp.csr_matrix((nf, nf)))
    else:
        G = sp.csr_matrix((nf, nf))
        Cf = sp.csr_matrix((nf, nf))
        Cf_far = sp.csr_matrix((nf, nf))

    def lin(form):
        f = ngs.LinearForm(Vp)
        f += form
        f.Assemble()
        return vec(f)[free]

    n = face_normal_cf()
    # out of the water: bottom n = (0, -1), far end n = (-1, 0)
    b_y = -lin(s * ngs.ds("reservoir_bottom")) if not math.isinf(q) else np.zeros(nf)
    b_x = -lin(s * ngs.ds("far_end")) if far_end == "rigid" else np.zeros(nf)
    face_x = lin(n[0] * s * ngs.ds(FACE))
    face_y = lin(n[1] * s * ngs.ds(FACE))
    return WaterMatrices(Vp, free, Hm, G, Cf, b_x, b_y, face_x, face_y, Cf_far)


def rigid_wall_response(W: WaterMatrices, rho: float, omega: float = 0.0,
                        direction: str = "x") -> np.ndarray:
    """Pressure (free DOFs, complex) on a rigid dam face under a unit harmonic ground
    acceleration e^{i omega t} (wall, bottom and a rigid far end move with the ground)."""
    g = (W.face_x + W.b_x) if direction == "x" else (W.face_y + W.b_y)
    A = (W.H - omega ** 2 * W.G + 1j * omega * W.Cf).tocsc()
    if omega == 0.0:
        return spl.spsolve(W.H.tocsc(), -rho * g)
    return spl.spsolve(A, (-rho * g).astype(complex))


def face_force(W: WaterMatrices, p: np.ndarray) -> complex:
    """Hydrodynamic force on the face in x [N/m]: int p n_x ds (n into the dam)."""
    return W.face_x @ p


def westergaard_series(y, H: float, rho: float = 1000.0, a: float = 1.0, omega: float = 0.0,
                       c: float = math.inf, n_terms: int = 2000):
    """Pressure on a rigid vertical wall, rigid bottom, infinitely long reservoir, unit
    harmonic ground acceleration a e^{i omega t} (Westergaard 1933; Chopra 1967 for c < inf):
    p(0, y) = -sum 2 rho a (-1)^(n+1) cos(l_n y) / (H l_n mu_n),  l_n = (2n-1) pi / (2H),
    mu_n = sqrt(l_n^2 - omega^2/c^2) (= i sqrt(omega^2/c^2 - l_n^2) above the n-th resonance).
    Returns (p(y), force F = int_0^H p dy)."""
    n = np.arange(1, n_terms + 1)
    lam = (2 * n - 1) * math.pi / (2 * H)
    k2 = (omega / c) ** 2 if math.isfinite(c) else 0.0
    mu = np.sqrt((lam ** 2 - k2).astype(complex))
    mu = np.where(lam ** 2 >= k2, mu, 1j * np.sqrt((k2 - lam ** 2).astype(complex)))
    A = -2 * rho * a * (-1.0) ** (n + 1) / (H * lam * mu)
    y = np.atleast_1d(np.asarray(y, float))
    p = (A[None, :] * np.cos(np.outer(y, lam))).sum(axis=1)
    F = (A * (-1.0) ** (n + 1) / lam).sum()
    return p, F


class PressureProbe:
    """p at fixed points of the water mesh, for many pressure vectors. p(x) is a linear
    functional of the element's dofs: the functional of each point is found once (the shape
    functions of its element evaluated at it, through a GridFunction and a unit vector per
    dof) and kept as a sparse matrix over the free dofs, so each call is one sparse product
    (``pressure_at`` searches the mesh at every call)."""

    def __init__(self, W: WaterMatrices, pts):
        # deferred: NGSolve is optional: the package imports without it
        import ngsolve as ngs

        self.W = W
        Vp = W.Vp
        gf = ngs.GridFunction(Vp)
        vec = gf.vec.FV().NumPy()
        mesh = Vp.mesh
        rows, cols, vals = [], [], []
        for i, (x, y) in enumerate(pts):
            mp = mesh(float(x), float(y))
            if mp.nr < 0:
                raise ValueError(f"pressure probe point ({x}, {y}) is outside the mesh")
            for d in Vp.GetDofNrs(ngs.ElementId(ngs.VOL, mp.nr)):
                if d < 0:
                    continue
                vec[:] = 0.0
                vec[d] = 1.0
                v = gf(mp)
                if v != 0.0:
                    rows.append(i)
                    cols.append(d)
                    vals.append(v)
        E = sp.csr_matrix((vals, (rows, cols)), shape=(len(pts), Vp.ndof))
        self.E = E[:, W.free].tocsr()

    def __call__(self, p_free) -> np.ndarray:
        return self.E @ np.real(p_free)


def pressure_at(W: WaterMatrices, p_free: np.ndarray, pts):
    """Evaluate a pressure vector at points [(x, y)] of the water mesh (real part)."""
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs

    gf = ngs.GridFunction(W.Vp)
    v = np.zeros(W.Vp.ndof)
    v[W.free] = np.real(p_free)
    gf.vec.FV().NumPy()[:] = v
    mesh = W.Vp.mesh
    return np.array([gf(mesh(float(x), float(y))) for x, y in pts])


# ---------------------------------------------------------------------------------------------
# the reservoir of a dam model
# ---------------------------------------------------------------------------------------------
@dataclass
class AcousticReservoir:
    """Water matrices and the face coupling on a model's free DOFs (see the module docstring)."""
    W: WaterMatrices
    Q: sp.csr_matrix                 # (nfree_u, nfree_p)
    rho: float
    c: float
    level: float
    length: float
    incompressible: bool
    g_x: np.ndarray                  # Q^T r_x + b_x  (fluid ground forcing, per unit a_g)
    g_y: np.ndarray
    added_mass: sp.csr_matrix | None = None
    info: dict = field(default_factory=dict)
    _Hfac: Any = None
    _QHinv_g: tuple | None = None
    _Ma_r: tuple = (0.0, 0.0)

    @property
    def n_p(self) -> int:
        return self.W.free.size

    @classmethod
    def build(cls, res, mesh, fes, free, rho, components=None, order=1, bands=None):
        # deferred: NGSolve is optional: the package imports without it
        import ngsolve as ngs


        W = water_matrices(mesh, res.sound_speed, res.compressible, res.bottom_reflection,
                           res.far_end, order=1)
        # Q: test = structure, trial = pressure: int_face p (v . n) ds
        _, vn = dam_normal_trial_test(fes, components, bands)
        p = W.Vp.TrialFunction()
        b = ngs.BilinearForm(trialspace=W.Vp, testspace=fes)
        b += p * vn * ngs.ds(FACE)
        b.Assemble()
        Q = to_scipy(b.mat)[free][:, W.free].tocsr()
        r_x, r_y = (cls._influence(fes, components, free, d) for d in ((1.0, 0.0), (0.0, 1.0)))
        g_x = Q.T @ r_x + W.b_x
        g_y = Q.T @ r_y + W.b_y
        ac = cls(W, Q, rho, res.sound_speed, res.level, res.length, not res.compressible,
                 g_x, g_y)
        ac._Hfac = spl.splu(W.H.tocsc())
        if ac.incompressible:
            ac.added_mass = ac._condensed_added_mass()
            ac._Ma_r = (ac.added_mass @ r_x, ac.added_mass @ r_y)
        ac.info = ac.summary()
        return ac

    @staticmethod
    def _influence(fes, components, free, d):
        # deferred: NGSolve is optional: the package imports without it
        import ngsolve as ngs

        gf = ngs.GridFunction(fes)
        if components is None:
            gf.Set(ngs.CF(d))
        else:
            for k in range(len(gf.components)):
                gf.components[k].Set(ngs.CF(d))
        return vec(gf)[free]

    def _condensed_added_mass(self) -> sp.csr_matrix:
        """M_a = rho Q H^-1 Q^T: dense on the face DOFs (rows of Q that are not zero)."""
        Q = self.Q
        rows = np.unique(Q.nonzero()[0])
        Qf = Q[rows].toarray()                                 # (nf, np)
        X = self._Hfac.solve(np.ascontiguousarray(Qf.T))       # H^-1 Q_f^T
        Maf = self.rho * (Qf @ X)
        Maf = 0.5 * (Maf + Maf.T)
        n = Q.shape[0]
        I, J = np.meshgrid(rows, rows, indexing="ij")
        return sp.csr_matrix((Maf.ravel(), (I.ravel(), J.ravel())), shape=(n, n))

    def solve_H(self, b):
        """H^-1 b with the water's Laplacian-like matrix H (factorised once, at ``build``)."""
        return self._Hfac.solve(b)

    # --- incompressible: condensed -------------------------------------------------------
    def seismic_vectors(self, M_rx, M_ry):
        """M r (with M_a) -> M_s r + rho Q H^-1 g (the ground-driven pressure of the face, the
        bottom and a rigid far end)."""
        if self._QHinv_g is None:
            self._QHinv_g = tuple(self.rho * (self.Q @ self._Hfac.solve(g))
                                  for g in (self.g_x, self.g_y))
        return (M_rx - self._Ma_r[0] + self._QHinv_g[0],
                M_ry - self._Ma_r[1] + self._QHinv_g[1])

    def pressure_incompressible(self, a_rel, agx, agy, g=None):
        """p = -rho H^-1 (Q^T u'' + g_x a_gx + g_y a_gy) (g: other forcing vectors, e.g. b
        alone when u'' is the total acceleration)."""
        gx, gy = (self.g_x, self.g_y) if g is None else g
        return -self.rho * self._Hfac.solve(self.Q.T @ a_rel + gx * agx + gy * agy)

    # --- compressible: coupled u-p system -------------------------------------------------
    def coupled(self, K, M, C):
        """(K_c, M_c, C_c) of z = (u, p) (unsymmetric, see the module docstring)."""
        W = self.W
        nu, npp = K.shape[0], self.n_p
        Z = sp.csr_matrix((nu, npp))
        Kc = sp.bmat([[K, -self.Q], [Z.T, W.H]], format="csr")
        Mc = sp.bmat([[M, Z], [self.rho * self.Q.T, W.G]], format="csr")
        Cc = sp.bmat([[C if C is not None else sp.csr_matrix((nu, nu)), Z],
                      [Z.T, W.Cf]], format="csr")
        return Kc, Mc, Cc

    def energy(self, u, v, p, pdot, pi, K, M):
        """Total energy of the undamped coupled system: 1/2 v M v + 1/2 u K u + 1/(2 rho)
        (p G p + pi H pi), pi = int p dt (the fluid's kinetic energy is 1/(2 rho) pi H pi)."""
        W = self.W
        return (0.5 * v @ (M @ v) + 0.5 * u @ (K @ u)
                + 0.5 / self.rho * (p @ (W.G @ p) + pi @ (W.H @ pi)))

    # --- outputs ------------------------------------------------------------------------
    def face_stations(self, fractions=(0.0, 0.25, 0.5, 0.75, 0.9)):
        """Points on the face at the given fractions of the depth (x of the face there)."""
        mesh = self.W.Vp.mesh
        chain = face_chain(mesh, self.level)
        ys = np.array([f * self.level for f in fractions])
        xs = np.interp(ys, [c[2] for c in chain], [c[1] for c in chain])
        return list(zip(xs, ys))

    def face_force(self, p, u_free_len=None) -> tuple[float, float]:
        """Hydrodynamic force on the dam (Fx, Fy) [N/m] = int p n ds (n into the dam)."""
        return float(self.W.face_x @ p), float(self.W.face_y @ p)

    def summary(self) -> dict:
        W = self.W
        return {"model": "acoustic", "level": self.level, "length": self.length,
                "sound_speed": self.c, "incompressible": self.incompressible,
                "n_pressure_dofs": int(W.free.size),
                "n_face_dofs": int(np.unique(self.Q.nonzero()[0]).size),
                "omega1_rigid_bottom": math.pi * self.c / (2 * self.level),
                "f1_reservoir_hz": self.c / (4 * self.level)}


def absorbing_bottom_series(H: float, omega: float, c: float, alpha: float, rho: float = 1000.0,
                            a: float = 1.0, n_terms: int = 60):
    """Force on a rigid vertical wall (infinitely long reservoir, unit harmonic horizontal
    ground acceleration) with an absorbing bottom of reflection coefficient alpha (Fenves &
    Chopra 1983): eigenfunctions Y_n = sin(k_n (H - y)) with the complex roots of
    k cos(kH) + i omega q sin(kH) = 0 (bottom dp/dy = i omega q p), complex-symmetric so
    int Y_m Y_n = 0 (m != n); p = sum A_n Y_n e^{mu_n x}, mu_n = sqrt(k_n^2 - omega^2/c^2)
    (Re mu_n > 0), A_n mu_n int Y_n^2 = -rho a int Y_n.  Returns F = int_0^H p(0, y) dy."""
    q = bottom_q(alpha, c)
    F = 0j
    for n in range(1, n_terms + 1):
        k = (2 * n - 1) * math.pi / (2 * H) + 0j
        for _ in range(100):                       # Newton on f(k) = k cos kH + i w q sin kH
            f = k * np.cos(k * H) + 1j * omega * q * np.sin(k * H)
            df = np.cos(k * H) - k * H * np.sin(k * H) + 1j * omega * q * H * np.cos(k * H)
            dk = f / df
            k = k - dk
            if abs(dk) < 1e-14 * abs(k):
                break
        mu = np.sqrt(k * k - (omega / c) ** 2 + 0j)
        if mu.real < 0:
            mu = -mu
        intY = (1 - np.cos(k * H)) / k                     # int_0^H sin(k (H - y)) dy
        intY2 = H / 2 - np.sin(2 * k * H) / (4 * k)
        A = -rho * a * intY / (mu * intY2)
        F += A * intY
    return F
