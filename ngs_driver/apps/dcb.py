"""Double cantilever beam (mode I), quasi-static under displacement control ("Error against
run time").

Two elastic arms of height ``h`` (regions "top", "bottom"; thickness ``b``), length ``L``,
an unbonded initial crack on ``0 <= x <= a0`` and the project's interface law on the bonded
part ``a0 <= x <= L`` (boundary "interface", ``g = u_top - u_bottom`` in the fixed frame
normal +y, tangent +x; operator from ``fe.coupling.build_joint_operator`` with ``n_gauss``
points per segment = the virtual node technique).  The load faces (x = 0) of the arms move rigidly
by ``u_y = +-delta/2`` (u_x free, so the end section rotates freely: a pure end shear, the
load case of beam theory); u_x = 0 at the neutral-axis point (0, +-h/2) removes the axial
rigid mode (its reaction is zero: no x loads).  A soft anchor spring (``anchor`` x E b,
default 1e-9 E b) on u_x at the top/bottom corners of the load faces removes the rigid
rotation that a completely separated arm would otherwise have; its force is ~1e-9 of P.

The mesh is symmetric (the bottom arm is the mirror image of the top one), so the
solution is exactly mode I (g_T = 0 to round-off) and the dissipated energy at full
separation is G_I x bonded length.

Plane strain (``model.Material``), so the beam-theory modulus is E' = E / (1 - nu^2).
Reference curves: ``beam_theory_curve`` (simple beam theory + LEFM, or with Kanninen's
root-rotation correction a -> a + chi h, chi = 0.64).

Solver: full Newton with the consistent tangent (interface tangent from
``InterfaceLaw.evaluate``), sparse LU (scipy splu) per iteration, convergence on the
residual AND the energy norm, step halving on non-convergence from the reverted state;
an unconverged step is never accepted (the run stops, ``result.complete = False``).
"""
from __future__ import annotations

import pathlib
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from interfacelaw import CohesiveParams, ContactParams, InterfaceLaw

from ..fe.coupling import block_diag, build_joint_operator
from ..fe.model import Material
from ..fe.ngs_helpers import find_vertex, to_scipy
from ..post.files import atomic_write_json, atomic_write_text, environment_info

CHI_KANNINEN = 0.64   # Kanninen (1973) beam on a Winkler foundation: 1/lambda = h / 6^(1/4)


@dataclass(frozen=True)
class DCBSpec:
    """Geometry, material and interface of the DCB (SI units)."""

    L: float = 1.0            # total length [m]
    h: float = 0.1            # height of each arm [m]
    a0: float = 0.4           # initial crack length from the load line [m]
    b: float = 1.0            # thickness [m]
    E: float = 30e9
    nu: float = 0.2
    sigma_max: float = 3e6
    G_I: float = 100.0
    lambda_max: float = 0.01
    contact: bool = True      # a bonded interface must carry compression ahead of the tip

    @property
    def E_prime(self) -> float:
        """Plane-strain modulus E/(1 - nu^2) (the bulk is plane strain)."""
        return self.E / (1.0 - self.nu ** 2)

    @property
    def I(self) -> float:
        return self.b * self.h ** 3 / 12.0

    @property
    def l_ch(self) -> float:
        """Hillerborg characteristic length E' G_I / sigma_max^2 [m]."""
        return self.E_prime * self.G_I / self.sigma_max ** 2

    @property
    def bonded_length(self) -> float:
        return self.L - self.a0

    def cohesive(self) -> CohesiveParams:
        return CohesiveParams.from_fracture_energy(self.sigma_max, self.sigma_max, self.G_I,
                                                   self.lambda_max, 1.0)

    def law(self) -> InterfaceLaw:
        return InterfaceLaw(self.cohesive(), contact=ContactParams("linear")
                            if self.contact else None)


# ------------------------------------------------------------------------------ analytic
# Beam theory of one arm = cantilever of effective length a_e = a + chi h under the end
# shear P:  deflection P a_e^3/(3 E'I) (+ P a_e/(k_s G b h) with Timoshenko shear, k_s = 5/6),
# the DCB opening is twice that.  chi = 0: simple (built-in) beam theory; chi = 0.64:
# Kanninen's root rotation (beam on a Winkler foundation of stiffness 2E'b/h).
# LEFM: G = P^2/(2b) dC/da = G_I.
K_SHEAR = 5.0 / 6.0


def _shear_compliance(spec: DCBSpec) -> float:
    """Opening per load and per length of the Timoshenko shear term, 2/(k_s G b h)."""
    G = spec.E / (2.0 * (1.0 + spec.nu))
    return 2.0 / (K_SHEAR * G * spec.b * spec.h)


def beam_theory_compliance(spec: DCBSpec, a, chi: float = CHI_KANNINEN,
                           shear: bool = True) -> np.ndarray:
    """delta / P = 2 a_e^3 / (3 E' I) [+ 2 a_e / (k_s G b h)],  a_e = a + chi h."""
    ae = np.asarray(a, float) + chi * spec.h
    C = 2.0 * ae ** 3 / (3.0 * spec.E_prime * spec.I)
    return C + (_shear_compliance(spec) * ae if shear else 0.0)


def beam_theory_envelope(spec: DCBSpec, a, chi: float = CHI_KANNINEN, shear: bool = True):
    """(delta, P) of LEFM propagation at crack length(s) a: G(P, a) = G_I."""
    ae = np.asarray(a, float) + chi * spec.h
    dCda = 2.0 * ae ** 2 / (spec.E_prime * spec.I) + (_shear_compliance(spec) if shear else 0.0)
    P = np.sqrt(2.0 * spec.b * spec.G_I / dCda)
    return P * beam_theory_compliance(spec, a, chi, shear), P


def beam_theory_peak(spec: DCBSpec, chi: float = CHI_KANNINEN,
                     shear: bool = True) -> tuple[float, float]:
    """(delta_c, P_c) at the onset of propagation from a0 (the peak load)."""
    d, P = beam_theory_envelope(spec, spec.a0, chi, shear)
    return float(d), float(P)


def beam_theory_curve(spec: DCBSpec, delta, chi: float = CHI_KANNINEN,
                      shear: bool = True) -> np.ndarray:
    """P(delta): linear with the compliance at a0 up to the peak, then the LEFM envelope
    (delta increases monotonically with a: stable under displacement control)."""
    d = np.asarray(delta, float)
    d_c, _ = beam_theory_peak(spec, chi, shear)
    a = spec.a0 + np.geomspace(1e-9, 100.0, 4000) * spec.h
    da, Pa = beam_theory_envelope(spec, a, chi, shear)
    P_lin = d / beam_theory_compliance(spec, spec.a0, chi, shear)
    return np.where(d <= d_c, P_lin, np.interp(d, da, Pa))


# ------------------------------------------------------------------------------ mesh
def dcb_mesh(spec: DCBSpec, h_int: float, h_bulk: float | None = None,
             grading: float = 0.3):
    """Symmetric netgen mesh: the top arm is meshed (interface edge maxh = h_int, bulk
    maxh = h_bulk, default h/4), the bottom arm is its mirror image, sharing the y = 0
    vertices (the displacement fields of the two regions are independent anyway)."""
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs
    from netgen.geom2d import SplineGeometry
    from netgen.meshing import Mesh, MeshPoint, Element2D, Element1D, FaceDescriptor
    from netgen.csg import Pnt

    L, h, a0 = spec.L, spec.h, spec.a0
    h_bulk = h / 4.0 if h_bulk is None else h_bulk
    geo = SplineGeometry()
    p0 = geo.AppendPoint(0.0, 0.0)
    pa = geo.AppendPoint(a0, 0.0, maxh=h_int)
    pL = geo.AppendPoint(L, 0.0)
    pLh = geo.AppendPoint(L, h)
    p0h = geo.AppendPoint(0.0, h)
    pm = geo.AppendPoint(0.0, h / 2)
    geo.Append(["line", p0, pa], bc="crack", leftdomain=1, rightdomain=0)
    geo.Append(["line", pa, pL], bc="interface", leftdomain=1, rightdomain=0, maxh=h_int)
    geo.Append(["line", pL, pLh], bc="end", leftdomain=1, rightdomain=0)
    geo.Append(["line", pLh, p0h], bc="top", leftdomain=1, rightdomain=0)
    geo.Append(["line", p0h, pm], bc="load", leftdomain=1, rightdomain=0)
    geo.Append(["line", pm, p0], bc="load", leftdomain=1, rightdomain=0)
    top = geo.GenerateMesh(maxh=max(h_bulk, h_int), grading=grading)

    out = Mesh(dim=2)
    names = ["interface", "crack_top", "end_top", "face_top", "load_top",
             "crack_bottom", "end_bottom", "face_bottom", "load_bottom"]
    for i, n in enumerate(names):
        out.SetBCName(i, n)
    bcid = {n: i + 1 for i, n in enumerate(names)}
    for k, name in enumerate(("top", "bottom")):
        out.Add(FaceDescriptor(bc=k + 1))
        out.SetMaterial(k + 1, name)
    pts = [(p[0], p[1]) for p in top.Points()]
    tol = 1e-12 * max(L, h)
    ptop = {i + 1: out.Add(MeshPoint(Pnt(x, y, 0.0))) for i, (x, y) in enumerate(pts)}
    pbot = {i + 1: (ptop[i + 1] if abs(y) < tol else out.Add(MeshPoint(Pnt(x, -y, 0.0))))
            for i, (x, y) in enumerate(pts)}
    for el in top.Elements2D():
        vs = [v.nr for v in el.vertices]
        out.Add(Element2D(1, [ptop[v] for v in vs]))
        out.Add(Element2D(2, [pbot[v] for v in vs[::-1]]))     # mirrored: reverse order
    for el in top.Elements1D():
        name = top.GetBCName(el.index - 1)
        vs = [v.nr for v in el.vertices]
        if name == "interface":
            out.Add(Element1D([ptop[v] for v in vs], index=bcid["interface"]))
            continue
        nt = {"crack": "crack_top", "end": "end_top", "top": "face_top",
              "load": "load_top"}[name]
        out.Add(Element1D([ptop[v] for v in vs], index=bcid[nt]))
        out.Add(Element1D([pbot[v] for v in vs[::-1]],
                          index=bcid[nt.replace("_top", "_bottom")]))
    return ngs.Mesh(out)


# ------------------------------------------------------------------------------ problem
@dataclass
class DCBProblem:
    """Assembled DCB: bulk stiffness on all DOFs, interface operator, constraints."""

    spec: DCBSpec
    mesh: object
    K: sp.csr_matrix             # (ndof, ndof) bulk stiffness (+ soft anchors)
    interface: object            # fe.coupling.JointOperator (B on all DOFs)
    free: np.ndarray             # free DOF indices
    fixed: np.ndarray            # constrained DOF indices
    pattern: np.ndarray          # (ndof,) prescribed displacement per unit delta
    load_top: np.ndarray         # top load-face vertex y-DOFs (P = sum of their reactions)
    load_bottom: np.ndarray
    n_gauss: int
    h_int: float
    order: int

    @property
    def ndof(self) -> int:
        return self.K.shape[0]


def build_dcb(spec: DCBSpec = DCBSpec(), h_int: float = 0.02, n_gauss: int = 5,
              order: int = 2, h_bulk: float | None = None, anchor: float = 1e-9,
              mesh=None) -> DCBProblem:
    """Mesh, bulk stiffness, joint operator (``fe.coupling.build_joint_operator``, matching mesh,
    ``n_gauss`` Gauss points per segment) and constraints of the DCB."""
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs

    if n_gauss < 1:
        raise ValueError(f"n_gauss={n_gauss}: must be >= 1")
    if mesh is None:
        mesh = dcb_mesh(spec, h_int, h_bulk)
    mat = Material(spec.E, spec.nu, 0.0)
    Vt = ngs.Compress(ngs.VectorH1(mesh, order=order, definedon="top"))
    Vb = ngs.Compress(ngs.VectorH1(mesh, order=order, definedon="bottom"))
    fes = Vt * Vb
    (ut, ub), (vt, vb) = fes.TnT()

    def sigma(u):
        e = ngs.Sym(ngs.Grad(u))
        return mat.lam * ngs.Trace(e) * ngs.Id(2) + 2 * mat.mu * e

    a = ngs.BilinearForm(fes)
    a += spec.b * ngs.InnerProduct(sigma(ut), ngs.Sym(ngs.Grad(vt))) * ngs.dx("top")
    a += spec.b * ngs.InnerProduct(sigma(ub), ngs.Sym(ngs.Grad(vb))) * ngs.dx("bottom")
    a.Assemble()
    ndof = fes.ndof
    K = to_scipy(a.mat, (ndof, ndof))
    K = ((K + K.T) * 0.5).tolil()

    off = {"top": 0, "bottom": Vt.ndof}
    spaces = {"top": Vt, "bottom": Vb}
    pattern = np.zeros(ndof)
    fixed = set()
    load = {}
    for side, sgn in (("top", 1.0), ("bottom", -1.0)):
        V, o = spaces[side], off[side]
        ny = V.ndof // 2
        vdofs, edofs = set(), set()
        for el in mesh.Boundaries(f"load_{side}").Elements():
            for v in el.vertices:
                d = sorted(i for i in V.GetDofNrs(ngs.NodeId(ngs.VERTEX, v.nr)) if i >= 0)
                vdofs.add(o + d[1])
            for e in el.edges:
                d = sorted(i for i in V.GetDofNrs(ngs.NodeId(ngs.EDGE, e.nr)) if i >= 0)
                if d:
                    edofs.add(o + d[len(d) // 2])   # y block is the second half
        for dof in vdofs:
            pattern[dof] = 0.5 * sgn
        fixed |= vdofs | edofs
        load[side] = np.array(sorted(vdofs))
        # u_x = 0 at the neutral-axis point; soft anchors at the load-face corners
        y_na = 0.5 * spec.h * sgn
        for (px, py), what in (((0.0, y_na), "fix"), ((0.0, spec.h * sgn), "anchor"),
                               ((0.0, 0.0), "anchor")):
            vnr = _vertex_at(mesh, px, py)
            d = sorted(i for i in V.GetDofNrs(ngs.NodeId(ngs.VERTEX, vnr)) if i >= 0)
            assert len(d) == 2 and d[1] - d[0] == ny
            if what == "fix":
                fixed.add(o + d[0])
            else:
                K[o + d[0], o + d[0]] += anchor * spec.E * spec.b
    K = K.tocsr()
    fixed = np.array(sorted(fixed))
    free = np.setdiff1d(np.arange(ndof), fixed)
    iface = build_joint_operator(mesh, fes, Vt, Vb, np.arange(ndof), n_gauss, "rock", True, order)
    return DCBProblem(spec, mesh, K, iface, free, fixed, pattern, load["top"],
                      load["bottom"], n_gauss, h_int, order)


def _vertex_at(mesh, x, y, tol=1e-9) -> int:
    return find_vertex(mesh, x, y, tol=tol ** 2 * 1e6)


# ------------------------------------------------------------------------------ solver
@dataclass
class DCBResult:
    delta: np.ndarray            # converged opening displacements [m]
    P: np.ndarray                # reaction (mean of the two arms) [N]
    dissipated: np.ndarray       # sum_p w_p dissipated_p [J]
    crack_tip: np.ndarray        # x of the furthest fully debonded point (a0 if none)
    complete: bool               # reached the last target
    wall: float                  # solver wall time [s] (assembly excluded)
    n_iter: int
    n_cuts: int
    n_solves: int
    u: np.ndarray = field(repr=False, default=None)
    state: object = field(repr=False, default=None)
    message: str = ""
    n_secant: int = 0


def reaction(prob: DCBProblem, u: np.ndarray, r_full: np.ndarray) -> float:
    """P = mean of the top (+y) and bottom (-y) load-face reactions (r_full: the full
    internal-force vector K u + B^T w t)."""
    return 0.5 * (r_full[prob.load_top].sum() - r_full[prob.load_bottom].sum())


class _Condensed:
    """Static condensation of the (linear) bulk onto the interface DOFs Gamma (the free DOFs
    that B touches): S = K_GG - K_GI K_II^-1 K_IG (dense), computed once with one sparse LU
    (splu) of K_II.  Each Newton iteration then solves a dense system of size n_Gamma
    instead of re-factorising the whole sparse matrix (exact, not an approximation)."""

    def __init__(self, prob: DCBProblem, chunk: int = 256):
        K = prob.K.tocsr()
        B = prob.interface.B.tocsc()
        f, c = prob.free, prob.fixed
        if abs(B[:, c]).sum() != 0.0:
            raise ValueError("the interface touches a constrained DOF (a0 must be > 0)")
        touched = np.unique(B.tocsr().indices)
        G = np.intersect1d(f, touched)
        I = np.setdiff1d(f, G)
        self.G, self.I, self.c = G, I, c
        pc = prob.pattern[c]
        ell = np.zeros(c.size)
        ell[np.searchsorted(c, prob.load_top)] = 0.5
        ell[np.searchsorted(c, prob.load_bottom)] = -0.5
        KII = K[I][:, I].tocsc()
        KIG = K[I][:, G].tocsc()
        KIc = K[I][:, c]
        lu = sla.splu(KII, permc_spec="MMD_ATA")
        S = K[G][:, G].toarray()
        for k in range(0, G.size, chunk):
            X = lu.solve(KIG[:, k:k + chunk].toarray())
            S[:, k:k + chunk] -= KIG.T @ X
        self.S = 0.5 * (S + S.T)
        yc = lu.solve(KIc @ pc)
        self.gc = K[G][:, c] @ pc - KIG.T @ yc                 # bulk force per unit delta
        m = lu.solve(KIc @ ell)
        self.P0 = float(ell @ (K[c][:, c] @ pc) - m @ (KIc @ pc))   # reaction per delta
        self.PG = np.asarray(ell @ K[c][:, G] - KIG.T @ m).ravel()  # reaction per u_G
        self.BG = B[:, G].tocsr()
        self.BGT = self.BG.T.tocsr()
        self.lu, self.KIG, self.KIc, self.pc = lu, KIG, KIc, pc

    def reaction(self, uG, delta):
        return self.P0 * delta + self.PG @ uG

    def full(self, prob, uG, delta):
        u = np.zeros(prob.ndof)
        u[self.G] = uG
        u[self.c] = delta * self.pc
        u[self.I] = -self.lu.solve(self.KIG @ uG + delta * (self.KIc @ self.pc))
        return u


def solve_dcb(prob: DCBProblem, deltas, law: InterfaceLaw | None = None, rtol: float = 1e-8,
              etol: float = 1e-14, max_iter: int = 25, max_cuts: int = 6,
              max_secant: int = 300, record_substeps: bool = True,
              condensed: _Condensed | None = None) -> DCBResult:
    """Displacement-controlled full-Newton run through the targets ``deltas`` (increasing).

    Convergence: ||r|| <= rtol * max(||delta g_c||, |P|) (the load scale) and
    |du . r| <= etol * |du_0 . r_0| (energy norm, relative to the first iteration).
    On non-convergence the increment is halved from the reverted state (the law state is
    committed only on convergence), up to ``max_cuts`` times; at the smallest increment a
    secant (fixed-point) iteration, robust across the local snap-backs of a coarse
    interface, is tried with the same convergence test; if that fails too the run stops
    (``complete=False``): an unconverged step is never accepted.
    The solve includes the (one-off) static condensation (``wall``).
    """
    t0 = time.perf_counter()
    law = prob.spec.law() if law is None else law
    cd = _Condensed(prob) if condensed is None else condensed
    w = prob.interface.w
    BG, BGT = cd.BG, cd.BGT
    S = cd.S
    npts = prob.interface.npts
    state = law.initial_state(npts, 2)
    uG = np.zeros(cd.G.size)
    out_d, out_P, out_D, out_a = [0.0], [0.0], [0.0], [prob.spec.a0]
    cnt = dict(it=0, cuts=0, solves=0, secant=0)
    d_cur = 0.0
    complete, msg = True, ""
    x_pts = prob.interface.x

    def assemble(Tw):
        # S + B^T blockdiag(w T) B  (sparse product, added to the dense Schur complement)
        return S + (BGT @ block_diag(Tw) @ BG).toarray()

    def solve(u0, d_new, secant=False):
        u = u0.copy()
        e0 = None
        for it in range(max_secant if secant else max_iter):
            gap = (BG @ u).reshape(-1, 2)
            t, T, trial = law.evaluate(gap, state)
            r = S @ u + d_new * cd.gc + BGT @ (w[:, None] * t).ravel()
            if not np.all(np.isfinite(r)):
                return None
            ref = max(np.linalg.norm(d_new * cd.gc), abs(cd.reaction(u, d_new)), 1e-300)
            if secant:   # diagonal secant of the law at the current gap (positive)
                Ts = np.zeros_like(T)
                for k in (0, 1):
                    g = gap[:, k]
                    big = np.abs(g) > 1e-14 * law.cohesive.l_Nc
                    Ts[:, k, k] = np.where(big, t[:, k] / np.where(big, g, 1.0), T[:, k, k])
                T = np.maximum(Ts, 0.0)
            A = assemble(w[:, None, None] * T)
            try:
                du = np.linalg.solve(A, -r)
            except np.linalg.LinAlgError:
                return None
            cnt["solves"] += 1
            cnt["it"] += 1
            en = abs(du @ r)
            if e0 is None:
                e0 = max(en, 1e-300)
            if it > 0 and np.linalg.norm(r) <= rtol * ref and en <= etol * e0:
                return u, trial
            u = u + du
        return None

    for d_target in np.asarray(deltas, float):
        if d_target <= d_cur:
            continue
        step = d_target - d_cur
        cuts = 0
        while d_cur < d_target - 1e-15 * abs(d_target):
            d_new = min(d_cur + step, d_target)
            res = solve(uG, d_new)
            if res is None and cuts == max_cuts:
                res = solve(uG, d_new, secant=True)
                if res is not None:   # polish with Newton (quadratic) from there
                    res = solve(res[0], d_new) or res
                    cnt["secant"] += 1
            if res is None:
                if cuts == max_cuts:
                    complete = False
                    msg = (f"no convergence at delta = {d_new:.6g} m after {max_cuts} cuts "
                           f"and a secant iteration (from {d_cur:.6g} m); stopped")
                    break
                cuts += 1
                cnt["cuts"] += 1
                step *= 0.5
                continue
            uG, state = res
            d_cur = d_new
            if record_substeps or d_cur >= d_target - 1e-15 * abs(d_target):
                out_d.append(d_cur)
                out_P.append(cd.reaction(uG, d_cur))
                out_D.append(float(w @ state.dissipated))
                deb = state.kappa >= 1.0
                out_a.append(float(x_pts[deb].max()) if deb.any() else prob.spec.a0)
        if not complete:
            break
    wall = time.perf_counter() - t0
    return DCBResult(np.array(out_d), np.array(out_P), np.array(out_D), np.array(out_a),
                     complete, wall, cnt["it"], cnt["cuts"], cnt["solves"],
                     cd.full(prob, uG, d_cur), state, msg, cnt["secant"])


def elastic_compliance(prob: DCBProblem, law: InterfaceLaw | None = None) -> float:
    """delta / P of the intact (linear) DCB: one linear solve with the initial interface
    stiffness (k_N = K0 in tension and compression, k_T = initial tangential)."""
    law = prob.spec.law() if law is None else law
    coh = law.cohesive
    A = (prob.K + prob.interface.stiffness(coh.k_normal, coh.k_tangential)).tocsr()
    f, c = prob.free, prob.fixed
    u = np.zeros(prob.ndof)
    u[c] = prob.pattern[c]
    u[f] = sla.spsolve(A[f][:, f].tocsc(), -(A[f][:, c] @ u[c]))
    return 1.0 / reaction(prob, u, A @ u)


def run_dcb(spec: DCBSpec = DCBSpec(), h_int: float = 0.02, n_gauss: int = 5,
            delta_max: float | None = None, n_steps: int = 60, order: int = 2,
            h_bulk: float | None = None, **solver_kw) -> tuple[DCBResult, DCBProblem]:
    """Build and run to ``delta_max`` (default 3 x the beam-theory critical opening)
    in ``n_steps`` equal increments (the first one to 0.6 x the critical opening:
    the response is linear up to there)."""
    prob = build_dcb(spec, h_int, n_gauss, order, h_bulk)
    d_c, _ = beam_theory_peak(spec)
    delta_max = 3.0 * d_c if delta_max is None else delta_max
    targets = np.concatenate([[0.6 * d_c], np.linspace(0.6 * d_c, delta_max, n_steps + 1)[1:]])
    return solve_dcb(prob, targets, **solver_kw), prob


def describe_dcb(scene) -> dict:
    return {"scene": scene.to_dict(), "will_build": {"kind": "dcb", "ngsolve": True}}



def run_dcb_scene(scene, outdir) -> dict:
    """The DCB of the scene, with its beam-theory/LEFM reference; P(delta) CSV + PNG."""
    d = scene.dcb
    spec = DCBSpec(L=d.L, h=d.h, a0=d.a0, E=d.E, nu=d.nu, sigma_max=d.sigma_max, G_I=d.G_I,
                   lambda_max=d.lambda_max)
    t0 = time.perf_counter()
    res, _ = run_dcb(spec, h_int=d.h_int, n_gauss=d.gauss_points, n_steps=d.n_steps,
                     order=d.order)
    wall = time.perf_counter() - t0
    out = pathlib.Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    rows = "\n".join(f"{a:.17g},{b:.17g}" for a, b in zip(res.delta, res.P))
    atomic_write_text(out / "load_displacement.csv", "delta_m,P_N_per_m\n" + rows + "\n")
    d_c, P_c = beam_theory_peak(spec)
    summary = {"scene": scene.to_dict(),
               "results": {"peak_load": float(np.max(res.P)), "beam_theory_peak": float(P_c),
                           "complete": bool(res.complete), "message": res.message},
               "timings": {"solve": wall}, "environment": environment_info()}
    atomic_write_json(out / "summary.json", summary)
    return summary
