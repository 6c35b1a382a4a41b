"""Linear NGSolve model of the Koyna dam on its rock foundation.

Everything the nonlinear solver needs, as scipy sparse matrices restricted to the free DOFs:
stiffness ``K``, mass ``M``, loads ``f_gravity`` / ``f_water``, influence vectors ``r_x`` /
``r_y`` (relative formulation: the effective seismic load is ``-M (r_x a_gx + r_y a_gy)``)
and the joints' gap operator (``JointOperator``: gap at Gauss points ``g = B u``).

Displacement spaces: ``Compress(VectorH1(mesh, order, definedon="dam"))`` x
``Compress(VectorH1(mesh, order, definedon="rock", dirichlet=...))``; the two fields are
independent, so the displacement may jump across the interface, and they are coupled only
through the interface law (``B``).  foundation="rigid": dam space only; the rock side of the
interface is the (fixed) ground, so the gap is the dam displacement.

Plane strain (default) or plane stress (``Material.plane``), small strains, isotropic linear
elasticity; every quantity is per unit thickness (per metre of dam).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from ..scene import KOYNA_PROFILE
from ..section import Section
from ..setup import model_inputs
from . import geometry as geom
from .acoustic import add_water
from .coupling import JointOperator, build_joint_operator, stack_joint_operators
from .ngs_helpers import find_vertex, to_scipy, vec, vertex_xy_dofs
from .reservoir import build_reservoir
from .reduction import reduce_model

G_STANDARD = 9.81


PLANES = ("strain", "stress")


@dataclass(frozen=True)
class Material:
    """Isotropic linear elastic material of a 2D region.  ``plane``: "strain" (eps_zz = 0) or
    "stress" (sigma_zz = 0: a slice of unit thickness, e.g. a dam monolith between open
    contraction joints).  Both are written per unit thickness (per metre of dam)."""
    E: float
    nu: float
    rho: float
    plane: str = "strain"

    def __post_init__(self):
        if self.plane not in PLANES:
            raise ValueError(f"plane = {self.plane!r}: not allowed, choose one of {list(PLANES)}")

    @property
    def lam(self) -> float:
        """The in-plane Lame constant: lambda (plane strain) or lambda* = 2 lambda mu /
        (lambda + 2 mu) = E nu / (1 - nu^2) (plane stress, sigma_zz = 0 eliminated)."""
        if self.plane == "stress":
            return self.E * self.nu / (1 - self.nu ** 2)
        return self.E * self.nu / ((1 + self.nu) * (1 - 2 * self.nu))

    @property
    def szz_factor(self) -> float:
        """sigma_zz = szz_factor (sigma_xx + sigma_yy): nu in plane strain, 0 in plane stress."""
        return self.nu if self.plane == "strain" else 0.0

    @property
    def mu(self) -> float:
        return self.E / (2 * (1 + self.nu))


PAPER_DAM = Material(50e9, 0.2, 2500.0)       # paper §5
PAPER_ROCK = Material(50e9, 0.2, 2800.0)      # paper §5
CLASSIC_KOYNA = Material(31.027e9, 0.2, 2643.0)  # Chopra & Chakrabarti (1973)


@dataclass
class Model:
    """Assembled linear model.  Vectors and matrices live on the free DOFs."""

    mesh: Any
    info: geom.MeshInfo
    fes: Any                       # ngsolve FESpace: product (dam, rock) or dam space only
    foundation: str
    order: int
    free: np.ndarray               # free DOF indices into fes.ndof
    K: sp.csr_matrix
    M: sp.csr_matrix
    f_gravity: np.ndarray
    f_water: np.ndarray
    r_x: np.ndarray
    r_y: np.ndarray
    interface: JointOperator
    crest_dofs: tuple[int, int]    # free indices of (u_x, u_y) at ``crest_point``
    dam_dofs: np.ndarray           # bool (nfree,): DOF belongs to the dam
    materials: dict[str, Material]
    gravity: float
    reservoir_level: float
    water_density: float
    lumped_mass: bool
    rock_sides: str
    include_rock_weight: bool
    reservoir: Any = None          # fe.reservoir.ReservoirModel ([reservoir] model != "none")
    crest_point: tuple[float, float] = (0.0, 103.0)
    regions: tuple = ("dam", "rock")       # one displacement field per region, fes order
    joints: dict = field(default_factory=dict)   # name -> JointOperator (base first)
    section: Any = None

    @property
    def nfree(self) -> int:
        return self.free.size

    @property
    def ndof(self) -> int:
        return self.fes.ndof

    # --- the model's coordinates (fe/reduction.py: a reduced bulk overrides these) -------
    def dof_map(self) -> np.ndarray:
        """The index in the model's coordinates of each free DOF (-1: none)."""
        return np.arange(self.free.size)

    def field_rows(self, v):
        """A free-DOF field (or DOF mask) in the model's coordinates."""
        return v

    def load_rows(self, f):
        """A free-DOF load vector in the model's coordinates."""
        return f

    def expand(self, u):
        """The free-DOF displacement of a state of the model's coordinates."""
        return u

    def full_bulk(self):
        """The mass matrix, dead load and influence vectors on the free DOFs (attributes M,
        f_gravity, r_x, r_y): the model itself (a reduced bulk: those of the full model it was
        reduced from, fe/reduction.py ``FullBulk``)."""
        return self

    # --- NGSolve views -----------------------------------------------------------------
    def to_gridfunction(self, u_free: np.ndarray, gf=None):
        """Full NGSolve GridFunction (zeros on fixed DOFs) from a free-DOF vector."""
        # deferred: NGSolve is optional: the package imports without it
        import ngsolve as ngs

        if gf is None:
            gf = ngs.GridFunction(self.fes)
        v = np.zeros(self.fes.ndof)
        v[self.free] = u_free
        gf.vec.FV().NumPy()[:] = v
        return gf

    def displacement_cf(self, gf):
        """Displacement as one CoefficientFunction on the whole mesh (each region its own
        field; on the interface itself the value is side-dependent)."""
        # deferred: NGSolve is optional: the package imports without it
        import ngsolve as ngs

        if len(self.regions) == 1:
            return gf
        return self.mesh.MaterialCF(dict(zip(self.regions, gf.components)),
                                    default=ngs.CF((0, 0)))

    def strain_cf(self, gf):
        # deferred: NGSolve is optional: the package imports without it
        import ngsolve as ngs

        if len(self.regions) == 1:
            return ngs.Sym(ngs.Grad(gf))
        return self.mesh.MaterialCF({r: ngs.Sym(ngs.Grad(c))
                                     for r, c in zip(self.regions, gf.components)})

    def stress_cf(self, gf):
        """In-plane Cauchy stress (plane strain or stress, per region), 2x2 CoefficientFunction."""
        # deferred: NGSolve is optional: the package imports without it
        import ngsolve as ngs

        lam, mu = self._lame_cfs()
        e = self.strain_cf(gf)
        return lam * ngs.Trace(e) * ngs.Id(2) + 2 * mu * e

    def von_mises(self, gf):
        """Von Mises stress [Pa] (plane strain: sigma_zz = nu (sigma_xx + sigma_yy); plane
        stress: sigma_zz = 0)."""
        # deferred: NGSolve is optional: the package imports without it
        import ngsolve as ngs

        s = self.stress_cf(gf)
        nu = self.mesh.MaterialCF({k: m.szz_factor for k, m in self.materials.items()})
        sxx, syy, sxy = s[0, 0], s[1, 1], s[0, 1]
        szz = nu * (sxx + syy)
        return ngs.sqrt(0.5 * ((sxx - syy) ** 2 + (syy - szz) ** 2 + (szz - sxx) ** 2)
                        + 3 * sxy ** 2)

    def _lame_cfs(self):
        lam = self.mesh.MaterialCF({k: m.lam for k, m in self.materials.items()})
        mu = self.mesh.MaterialCF({k: m.mu for k, m in self.materials.items()})
        return lam, mu

    # --- convenience -----------------------------------------------------------------
    def static_solution(self, k_normal: float, k_tangential: float,
                        loads: str = "gravity+water") -> np.ndarray:
        """Static displacement with a linear elastic (bonded) interface."""

        f = np.zeros(self.nfree)
        if "gravity" in loads:
            f += self.f_gravity
        if "water" in loads:
            f += self.f_water
        A = (self.K + self.interface.stiffness(k_normal, k_tangential)).tocsc()
        return sla.spsolve(A, f)

    def summary(self) -> dict:
        return {
            "foundation": self.foundation, "order": self.order,
            "n_vertices": self.mesh.nv, "n_elements": self.mesh.ne,
            "ndof": self.fes.ndof, "nfree": self.nfree,
            "n_interface_segments": int(self.interface.segments.shape[0]),
            "n_interface_points": self.interface.npts,
            "interface_length": self.interface.length,
            "mesh": dataclasses.asdict(self.info),
            "materials": {k: dataclasses.asdict(m) for k, m in self.materials.items()},
            "lumped_mass": self.lumped_mass, "rock_sides": self.rock_sides,
            "include_rock_weight": self.include_rock_weight,
        }


# -------------------------------------------------------------------------------------
def build_model(foundation: str = "rock", order: int = 1, gauss_points: int = 3,
                dam: Material = PAPER_DAM, rock: Material = PAPER_ROCK,
                gravity: float = G_STANDARD, reservoir_level: float = 92.0,
                water_density: float = 1000.0, lumped_mass: bool = False,
                rock_sides: str = "fixed", include_rock_weight: bool = False,
                mesh=None, mesh_info: geom.MeshInfo | None = None,
                clamp_base: bool = False, crest_point: tuple[float, float] | None = None,
                section: Section | None = None, joints=(), joint_gauss=None,
                **mesh_kw) -> Model:
    """Assemble the linear model.

    section: the dam's ``Section`` (default: the Koyna profile); joints: lift joints
    (``geometry.JointCut``), each cutting the dam into blocks with their own displacement
    fields, coupled only through the joint's interface law.  mesh_kw go to
    ``geometry.dam_mesh`` (h_heel, h_coarse, h_interface, growth, heel_zone, grading,
    extent_up/down/depth, matching, ...).  A prepared mesh (e.g. ``geometry.two_block_mesh``)
    can be passed instead.

    rock_sides: "fixed" (default; both components), "roller" (u_x = 0, u_y free) or
    "free".  clamp_base (rigid foundation only): Dirichlet-fix the dam base instead of
    leaving it to the interface law (then B is zero; for linear checks only).
    include_rock_weight: add the rock self weight to f_gravity (default False: the
    in-situ state of the rock predates the dam).
    """
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs

    if rock_sides not in ("fixed", "roller", "free", "absorbing"):
        raise ValueError(f"rock_sides={rock_sides!r}: allowed 'fixed', 'roller', 'free'")
    if lumped_mass and order != 1:
        raise ValueError("lumped_mass=True needs order=1 (row-sum lumping of higher-order "
                         "triangles gives non-positive masses)")
    if gauss_points < 1:
        raise ValueError(f"gauss_points={gauss_points}: must be >= 1")
    # reservoir: a scene [reservoir] table (fe/reservoir.py; none -> nothing is built)
    reservoir = mesh_kw.pop("reservoir", None)
    # "massed" is the rock block ("rock" its alias); "massless" the same block
    # without mass (docs/safety.md)
    foundation_name = foundation
    massless = foundation == "massless"
    if foundation in ("massed", "massless"):
        foundation = "rock"
    joints = tuple(sorted(joints, key=lambda j: j.elevation))
    if mesh is None:
        if section is None:
            section = Section(KOYNA_PROFILE)
        mesh, mesh_info = geom.dam_mesh(section, joints, foundation=foundation,
                                        reservoir_level=reservoir_level, **mesh_kw)
    elif mesh_info is None:
        nseg = sum(1 for _ in mesh.Boundaries("interface").Elements())
        mesh_info = geom.MeshInfo(foundation, "interface_rock" not in mesh.GetBoundaries(),
                                  float("nan"), float("nan"), float("nan"), float("nan"),
                                  float("nan"), float("nan"), float("nan"), mesh.nv, mesh.ne,
                                  nseg)
    if reservoir is not None and reservoir.model == "acoustic":
        mesh = add_water(mesh, reservoir)
    bnds = set(mesh.GetBoundaries())
    matching = "interface_rock" not in bnds
    blocks = geom.dam_block_names(joints)
    regions = blocks + ([] if foundation == "rigid" else ["rock"])
    mats = {b: dam for b in blocks}
    if foundation != "rigid":
        mats["rock"] = rock

    # ---- spaces: one displacement field per dam block (and the rock) ----
    spaces = [ngs.Compress(ngs.VectorH1(mesh, order=order, definedon=b,
                                        dirichlet="interface" if clamp_base and k == 0
                                        else "")) for k, b in enumerate(blocks)]
    if foundation != "rigid":
        side_bc = "|rock_left|rock_right" if rock_sides == "fixed" else ""
        spaces.append(ngs.Compress(ngs.VectorH1(mesh, order=order, definedon="rock",
                                                dirichlet="" if rock_sides == "absorbing"
                                                else "rock_bottom" + side_bc)))
    if len(spaces) == 1:
        fes = spaces[0]
        trial, test = (fes.TrialFunction(),), (fes.TestFunction(),)
    else:
        fes = ngs.FESpace(spaces)
        trial, test = fes.TnT()
    offsets = np.concatenate([[0], np.cumsum([V.ndof for V in spaces])]).astype(np.int64)
    freemask = np.array(list(fes.FreeDofs()), dtype=bool)
    if foundation == "rock" and rock_sides == "roller":
        # Compress drops per-component Dirichlet flags; the compressed VectorH1 keeps the
        # component-block layout (x block, then y block), so remove the x-DOFs of the
        # side boundaries by hand.
        Vr = spaces[-1]
        Vr_s = ngs.Compress(ngs.VectorH1(mesh, order=order, definedon="rock",
                                         dirichlet="rock_bottom|rock_left|rock_right"))
        assert Vr_s.ndof == Vr.ndof
        side = np.array(list(Vr.FreeDofs()), bool) & ~np.array(list(Vr_s.FreeDofs()), bool)
        nx = Vr.ndof // 2
        side_x = np.where(side[:nx])[0]
        freemask[offsets[-2] + side_x] = False
    free = np.where(freemask)[0]
    nfull = fes.ndof

    def restrict(A):
        return A[free][:, free].tocsr()

    # ---- stiffness & mass ----
    def sigma(uu, m):
        e = ngs.Sym(ngs.Grad(uu))
        return m.lam * ngs.Trace(e) * ngs.Id(2) + 2 * m.mu * e

    a = ngs.BilinearForm(fes)
    m = ngs.BilinearForm(fes)
    for uu, vv, reg in zip(trial, test, regions):
        mat = mats[reg]
        a += ngs.InnerProduct(sigma(uu, mat), ngs.Sym(ngs.Grad(vv))) * ngs.dx(reg)
        m += (0.0 if massless and reg == "rock" else mat.rho) * uu * vv * ngs.dx(reg)
    a.Assemble()
    m.Assemble()
    K = restrict(to_scipy(a.mat))
    M = restrict(to_scipy(m.mat))
    K = ((K + K.T) * 0.5).tocsr()
    M = ((M + M.T) * 0.5).tocsr()
    if lumped_mass:
        M = sp.diags(np.asarray(M.sum(axis=1)).ravel()).tocsr()
    res_model = None
    if reservoir is not None and reservoir.model != "none":
        comps = [k for k, r in enumerate(mats) if r != "rock"]     # dam fields, fes order
        res_model = build_reservoir(reservoir, mesh, fes, free, water_density,
                                    None if len(mats) == 1 else comps,
                                    regions=[r for r in mats if r != "rock"])
        if res_model.added_mass is not None:                # westergaard, incompressible
            M = (M + res_model.added_mass).tocsr()

    # ---- loads ----
    fg = ngs.LinearForm(fes)
    for vv, reg in zip(test, regions):
        if reg != "rock":
            fg += -dam.rho * gravity * vv[1] * ngs.dx(reg)
        elif include_rock_weight:
            fg += -rock.rho * gravity * vv[1] * ngs.dx(reg)
    fg.Assemble()
    H = reservoir_level
    pw = water_density * gravity * ngs.IfPos(H - ngs.y, H - ngs.y, 0.0)
    fw = ngs.LinearForm(fes)
    # upstream face: the pressure acts against the outward normal, traction -p n. The mesh's
    # normal sign is not relied on: the dam's outward normal on its upstream face points
    # upstream (n_x < 0), which fixes the orientation.
    nrm = ngs.specialcf.normal(2)
    n_out = ngs.IfPos(nrm[0], -1.0, 1.0) * nrm
    for vv in test[:len(blocks)]:    # each block's field is zero on the others' edges
        fw += -pw * ngs.InnerProduct(n_out, vv) * ngs.ds("upstream", bonus_intorder=2)
    if foundation != "rigid" and "rock_top_up" in bnds:
        # rock top upstream of the heel (outward normal +y): traction (0, -p(y=0))
        fw += -water_density * gravity * H * test[-1][1] * ngs.ds("rock_top_up")
    fw.Assemble()
    f_gravity = vec(fg)[free]
    f_water = vec(fw)[free]

    # ---- influence vectors ----
    def influence(cf):
        gf = ngs.GridFunction(fes)
        if len(spaces) == 1:
            gf.Set(cf)
        else:
            for c in gf.components:
                c.Set(cf)
        return vec(gf)[free]

    r_x = influence(ngs.CF((1.0, 0.0)))
    r_y = influence(ngs.CF((0.0, 1.0)))

    # ---- masks, crest ----
    dam_full = np.zeros(nfull, bool)
    dam_full[:offsets[len(blocks)]] = True
    dam_dofs = dam_full[free]
    inv = -np.ones(nfull, dtype=np.int64)
    inv[free] = np.arange(free.size)
    if crest_point is None:
        crest_point = (section.crest_upstream if section is not None
                       else top_left(mesh, blocks[-1]))
    crest_v = find_vertex(mesh, *crest_point)
    kt = len(blocks) - 1                      # the top block holds the crest
    cd = spaces[kt].GetDofNrs(ngs.NodeId(ngs.VERTEX, crest_v))
    crest = vertex_xy_dofs(spaces[kt], cd)
    crest_dofs = (int(inv[offsets[kt] + crest[0]]), int(inv[offsets[kt] + crest[1]]))

    # ---- interface operators: the base, then the lift joints bottom up ----
    base = build_joint_operator(mesh, fes, spaces[0], None if foundation == "rigid" else spaces[-1],
                           free, gauss_points, foundation, matching, order,
                           upper=0, lower=None if foundation == "rigid" else len(spaces) - 1,
                           rock_offset=int(offsets[-2]), name="base")
    joint_ifaces = [base]
    for k, j in enumerate(joints):
        ng = gauss_points if joint_gauss is None else joint_gauss
        joint_ifaces.append(build_joint_operator(mesh, fes, spaces[k + 1], spaces[k], free, ng,
                                            "joint", True, order, upper=k + 1, lower=k,
                                            boundary=j.name, name=j.name))
    iface = base if len(joint_ifaces) == 1 else stack_joint_operators(joint_ifaces)

    return Model(mesh=mesh, info=mesh_info, fes=fes, foundation=foundation_name, order=order,
                 free=free, K=K, M=M, f_gravity=f_gravity, f_water=f_water, r_x=r_x,
                 r_y=r_y, interface=iface, crest_dofs=crest_dofs, dam_dofs=dam_dofs,
                 materials=mats, gravity=gravity, reservoir_level=reservoir_level,
                 water_density=water_density, lumped_mass=lumped_mass,
                 rock_sides=rock_sides, include_rock_weight=include_rock_weight,
                 reservoir=res_model,
                 crest_point=tuple(float(c) for c in crest_point),
                 regions=tuple(regions), joints={ji.name: ji for ji in joint_ifaces},
                 section=section)


def top_left(mesh, region: str) -> tuple[float, float]:
    """Upstream crest corner of a custom dam region: highest, then left-most vertex."""
    pts = {v.nr: mesh.vertices[v.nr].point for el in mesh.Materials(region).Elements()
           for v in el.vertices}
    p = min(pts.values(), key=lambda q: (-round(q[1], 9), q[0]))
    return (p[0], p[1])


def model_kwargs(inputs) -> dict:
    """Keyword arguments of ``build_model`` for the ``setup.ModelInputs`` of a scene."""
    kw = dict(inputs.options)
    kw.update(section=inputs.section,
              joints=tuple(geom.JointCut(*j) for j in inputs.joints),
              **{r: Material(*v) for r, v in inputs.materials.items()})
    return kw


def build_from_inputs(inputs, **overrides) -> Model:
    """``build_model`` of a scene's ``setup.ModelInputs`` (keyword arguments overridable)."""
    kw = model_kwargs(inputs)
    kw.update(overrides)
    model = build_model(**kw)
    bulk, modes, cutoff_hz = inputs.bulk
    if bulk == "reduced":                    # the Craig-Bampton basis (fe/reduction.py)
        model = reduce_model(model, modes, cutoff_hz)
    return model


def build_from_scene(scene, **overrides) -> Model:
    """``build_from_inputs`` of ``setup.model_inputs(scene)`` (the scene is resolved there)."""
    return build_from_inputs(model_inputs(scene), **overrides)
