"""The bad-input catalogue: every mistake in an input gives one clear ValueError that
names the field (or file and line), the value and what is allowed. Each case asserts the words
of the message, so a vaguer message fails the test."""
import warnings

import numpy as np
import pytest

from interfacelaw import (CohesiveParams, ContactParams, DamageParams, FrictionParams,
                          InterfaceLaw)
from interfacelaw.scaling import SizeScaling, fit_power_law
from ngs_driver.setup import ground_motion as gm
from ngs_driver.scene import load_scene

COH = CohesiveParams.from_fracture_energy(3e6, 3e6, 250.0, 0.2, 1.0)
LAW = InterfaceLaw(COH, ContactParams(), FrictionParams(0.3), DamageParams(g_max=1e-3))


def _gap(**kw):
    g = np.zeros((4, 2))
    for k, v in kw.items():
        g[int(k[1:])] = v
    return g


PARAMS = [
    ("sigma_max negative", lambda: CohesiveParams(-3e6, 3e6, 1e-4, 1e-4, 0.2),
     r"sigma_max = -3000000.0 is out of range; allowed: \(0.0, \+inf\)"),
    ("lambda_max = 1", lambda: CohesiveParams(3e6, 3e6, 1e-4, 1e-4, 1.0),
     r"lambda_max = 1.0 is out of range; allowed: \(0.0, 1.0\)"),
    ("l_Nc NaN", lambda: CohesiveParams(3e6, 3e6, float("nan"), 1e-4, 0.2), r"l_Nc = nan"),
    ("G_I zero", lambda: CohesiveParams.from_fracture_energy(3e6, 3e6, 0.0, 0.2), r"G_I = 0.0"),
    ("friction negative", lambda: FrictionParams(-0.3), r"FrictionParams.f = -0.3"),
    ("g_max zero", lambda: DamageParams(g_max=0.0), r"DamageParams.g_max = 0.0"),
    ("alpha string", lambda: DamageParams(g_max=1e-3, alpha="two"),
     r"DamageParams.alpha = 'two' is not a real number"),
    ("contact kind", lambda: ContactParams("sticky"), r"kind = 'sticky' is not allowed"),
    ("rough exponent", lambda: ContactParams("rough", exponent=50), r"exponent = 50"),
    ("friction without contact", lambda: InterfaceLaw(COH, friction=FrictionParams()),
     r"friction only with a ContactParams"),
    ("scaling negative b", lambda: SizeScaling.paper().params_for(-1.0),
     r"b = -1.0 is not allowed; allowed: finite and >= 0"),
    ("fit one point", lambda: fit_power_law([1.0], [2.0]),
     r"1 point\(s\) given; allowed: at least 2 points"),
    ("fit non-positive", lambda: fit_power_law([1.0, 2.0], [1.0, -2.0]),
     r"values contains -2.0 \(index 1\); allowed: finite real numbers > 0"),
]

GAPS = [
    ("gap NaN", lambda: LAW.evaluate(_gap(p2=[np.nan, 0.0]), LAW.initial_state(4)),
     r"gap\[2\] = \[nan, 0.0\] is not finite"),
    ("gap inf", lambda: LAW.evaluate(_gap(p3=[0.0, np.inf]), LAW.initial_state(4)),
     r"gap\[3\] = \[0.0, inf\]"),
    ("gap 1e200", lambda: LAW.evaluate(_gap(p0=[1e200, 0.0]), LAW.initial_state(4)),
     r"exceeds 1e\+100 m"),
    ("gap int dtype", lambda: LAW.evaluate(np.zeros((4, 2), int), LAW.initial_state(4)),
     r"dtype int64 .*allowed: a float64 array"),
    ("gap 4 columns", lambda: LAW.evaluate(np.zeros((4, 4)), LAW.initial_state(4)),
     r"shape \(4, 4\)"),
    ("state of other size", lambda: LAW.evaluate(np.zeros((4, 2)), LAW.initial_state(5)),
     r"5 points in 2D do not match gap of shape \(4, 2\)"),
]


def _records(tmp):
    (tmp / "empty.txt").write_text("")
    (tmp / "nonnum.txt").write_text("0 0.1\n0.01 x\n")
    (tmp / "nonuni.txt").write_text("0 0.1\n0.01 0.2\n0.03 0.1\n")
    (tmp / "nan.txt").write_text("0 0.1\n0.01 nan\n0.02 0.1\n")
    (tmp / "ok.txt").write_text("0 0.1\n0.01 0.2\n0.02 0.1\n")
    (tmp / "short.AT2").write_text("h\nh\nh\nNPTS= 3, DT= .0050 SEC\n0.1 0.2\n")
    return [
        ("record missing", lambda: gm.read_two_column(tmp / "none.txt", "g"),
         r"does not exist \(missing file\)"),
        ("record empty", lambda: gm.read_two_column(tmp / "empty.txt", "g"), r"is empty"),
        ("record non-numeric line", lambda: gm.read_two_column(tmp / "nonnum.txt", "g"),
         r"line 2: field a = 'x' is not a number"),
        ("record non-uniform dt", lambda: gm.read_two_column(tmp / "nonuni.txt", "g"),
         r"non-uniform dt"),
        ("record NaN", lambda: gm.read_two_column(tmp / "nan.txt", "g"), r"line 2.*NaN"),
        ("record wrong units", lambda: gm.read_two_column(tmp / "ok.txt", "furlongs"),
         r"units='furlongs' is not allowed"),
        ("AT2 too few points", lambda: gm.read_at2(tmp / "short.AT2"),
         r"NPTS=3 but 2 values follow"),
        ("resample negative dt", lambda: gm.resample(gm.load_default(), -1.0), r"dt=-1.0"),
    ]


SCENES = [
    (["mesh.h_heel=-1"], r"mesh.h_heel = -1.0: out of range"),
    (["mesh.order=0"], r"mesh.order = 0: out of range"),
    (["mesh.gauss_points=0"], r"mesh.gauss_points = 0: out of range"),
    (["mesh.hheel=1"], r"unknown key 'mesh.hheel'"),
    (["nosuch.x=1"], r"unknown key 'nosuch'"),
    (["time.dt=0"], r"time.dt = 0.0: out of range"),
    (["geometry.foundation='soft'"], r"foundation = 'soft': not allowed"),
    (["interface.alpha='x'"], r"interface.alpha = 'x': wrong type"),
    (["materials.dam.nu=0.6"], r"materials.dam.nu = 0.6: out of range"),
    # law ranges come from interfacelaw (one validation truth), checked by setup.validate
    (["interface.lambda_max=1.0"], r"interface.lambda_max = 1.0: rejected by the interface "
                                   r"law: CohesiveParams.lambda_max"),
    (["interface.alpha=0"], r"interface.alpha = 0.0: rejected by the interface law: "
                            r"DamageParams.alpha"),
    (["interface.friction=12"], r"interface.friction = 12.0: rejected by the interface law"),
    (["interface.G_I=-1"], r"interface.G_I = -1.0: rejected by the interface law"),
    (["joints=[{name='neck', elevation=66.5, g_max=0}]"],
     r"joints\[0\].g_max = 0.0: rejected by the interface law"),
    (["joints=[{name='neck', elevation=110}]"], r"joints\[0\].elevation = 110.0 \(joint 'neck'\): "
                                                r"outside the section"),
    (["geometry.profile=[[0,0],[60,0],[0,60],[10,60]]"],
     r"geometry.profile: .*self-intersecting"),
    (["geometry.profile=[[0,0],[0,60],[10,60],[60,0]]"], r"geometry.profile: .*clockwise"),
    (["geometry.profile=[[0,0],[60,1],[0,60]]"], r"geometry.profile: .*base .* not on y = 0"),
    (["geometry.profile=[[0,0],[60,0]]"], r"geometry.profile: .*2 points; allowed: at least 3"),
    (["geometry.profile=[[1,0],[60,0],[0,60]]"], r"geometry.profile: .*heel.*allowed: \[0, 0\]"),
    (["geometry.profile=[[0,0],[60,0],[0,60]]", "loads.reservoir_level=70"],
     r"loads.reservoir_level = 70.0: above the crest; allowed: \[0, 60\]"),
    (["geometry.profile_file='/nonexistent/section.csv'"],
     r"geometry.profile_file = '/nonexistent/section.csv': no such file"),
    (["interface.contact='soft'"], r"interface.contact = 'soft': not allowed"),
    # plane stress / strain
    (["materials.plane=axisymmetric"],
     r"materials.plane = 'axisymmetric': not allowed, choose one of \['strain', 'stress'\]"),
    (["materials.plane=1"], r"materials.plane = 1: wrong type"),
    (["mesh.h_heel"], r"expected KEY.PATH=VALUE"),
    (["mesh.h_heel=[1,"], r"is not a TOML literal"),
    (["interface.friction=0,8"], r"--set 'interface.friction=0,8': value '0,8' is not a TOML "
                                 r"literal; allowed: e.g. 0.8 \(a decimal point, not a comma\)"),
    # [reservoir]
    (["reservoir.length=2e4"], r"reservoir.length = 20000.0: out of range, allowed \(0.0, 10000.0\]"),
    (["reservoir.model=acoustic", "reservoir.length=50"],
     r"reservoir.length = 50.0: shorter than the depth reservoir.level = 92.0"),
    (["reservoir.sound_speed=0"], r"reservoir.sound_speed = 0.0: out of range"),
    (["reservoir.sound_speed=-1440"], r"reservoir.sound_speed = -1440.0: out of range"),
    (["reservoir.bottom_reflection=1.5"],
     r"reservoir.bottom_reflection = 1.5: out of range, allowed \[-1.0, 1.0\]"),
    (["reservoir.level=120"], r"reservoir[._]level = 120.0: (above the crest|out of range, allowed \[0.0, 103.0\])"),
    (["reservoir.model=westergaard", "reservoir.level=0"],
     r"reservoir.level = 0.0 with reservoir.model = 'westergaard': no water"),
    (["reservoir.far_end=open"], r"reservoir.far_end = 'open': not allowed"),
    (["reservoir.model=potential"], r"reservoir.model = 'potential': not allowed"),
    # [uplift] and the foundation models
    (["uplift.model=drains", "uplift.drain_x=80"],
     r"uplift.drain_x = 80.0: the drain line is outside the base; allowed: \(0, 70\) m"),
    (["joints=[{name='neck', elevation=66.5, uplift={model='drains', drain_x=30.0}}]"],
     r"joints\[0\].uplift.drain_x = 30.0: the drain line is outside the joint 'neck'"),
    (["uplift.drain_efficiency=1.5"],
     r"uplift.drain_efficiency = 1.5: out of range, allowed \[0.0, 1.0\]"),
    (["uplift.drain_efficiency=-0.1"], r"uplift.drain_efficiency = -0.1: out of range"),
    (["uplift.tailwater=95"],
     r"uplift.tailwater = 95.0: above the headwater reservoir.level = 92 m; allowed: \[0, 92\]"),
    (["uplift.in_crack=half"], r"uplift.in_crack = 'half': not allowed"),
    (["geometry.foundation=elastic"], r"geometry.foundation = 'elastic': not allowed"),
    (["geometry.foundation=rigid", "geometry.rock_sides=absorbing"],
     r"geometry.rock_sides = 'absorbing' with geometry.foundation = 'rigid'.*allowed: "
     r"geometry.foundation = 'massed'"),
    (["geometry.foundation=massless", "geometry.rock_sides=absorbing"],
     r"geometry.rock_sides = 'absorbing' with geometry.foundation = 'massless'"),
    # the time grid: at least one step, and a whole number of them (no silent rounding)
    (["time.dt=0.5", "time.duration=0.1"],
     r"time.dt = 0.5 with time.duration = 0.1: no time step fits in the duration; allowed: "
     r"time.dt <= time.duration"),
    (["time.dt=1e-9"],                     # 1e10 steps: the resampled record would take 75 GB
     r"time.dt = 1e-09 with time.duration = 10.0: 1e\+10 time steps; allowed: at most 1e\+07 "
     r"steps, i.e. time.dt >= 1e-06 for this duration"),
    (["time.dt=0.004", "time.duration=0.01"],
     r"time.duration = 0.01 with time.dt = 0.004: 2.5 steps, not a whole number; allowed: a "
     r"whole number of steps, e.g. time.duration = 0.008 or 0.012"),
    # the record window: the analysis starts inside the record
    (["ground_motion.start=20"],
     r"ground_motion.start = 20.0: at or past the end of the record .*allowed: \[0, 10\) s"),
    # friction < 0: the law's range although the friction part is built only for f > 0
    (["interface.friction=-1"],
     r"interface.friction = -1.0: rejected by the interface law: FrictionParams.f = -1.0"),
    (["joints=[{name='neck', elevation=66.5, friction=-0.1}]"],
     r"joints\[0\].friction = -0.1: rejected by the interface law"),
    # the key the user wrote, not its alias
    (["reservoir.level=150"], r"^reservoir.level = 150.0: above the crest"),
    (["loads.reservoir_level=150"], r"^loads.reservoir_level = 150.0: above the crest"),
    (["loads.reservoir_level=2e4"], r"^loads.reservoir_level = 20000.0: out of range"),
    # sliding: contact, damping, integrator, collapse limits (docs/sliding.md)
    (["interface.contact_stiffness=0"],
     r"interface.contact_stiffness = 0.0: out of range, allowed \(0.0, 1e\+20\]"),
    (["interface.contact_stiffness=-1e11"], r"interface.contact_stiffness = -100000000000.0: out of range"),
    (["joints=[{name='neck', elevation=66.5, contact_stiffness=0}]"],
     r"joints\[0\].interface.contact_stiffness = 0.0: out of range"),
    (["damping.model=foo"], r"damping.model = 'foo': not allowed, choose one of \['rayleigh', "
                            r"'stiffness', 'rayleigh_deformation'\]"),
    (["damping.modes=[]"], r"damping.modes = \[\]: damping.model = 'rayleigh_deformation' needs "
                           r"two distinct mode numbers"),
    (["damping.model=stiffness", "damping.modes=[]"],
     r"damping.modes = \[\]: damping.model = 'stiffness' needs a mode number"),
    (["time.integrator=foo"], r"time.integrator = 'foo': not allowed, choose one of \['newmark', "
                              r"'hht', 'generalized-alpha'\]"),
    (["time.rho_inf=1.5"], r"time.rho_inf = 1.5: out of range, allowed \[0.0, 1.0\]"),
    (["time.rho_inf=-0.1"], r"time.rho_inf = -0.1: out of range"),
    (["time.integrator=hht", "time.rho_inf=0.3"],
     r"time.rho_inf = 0.3 with time.integrator = 'hht': out of range, allowed \[0.5, 1\]"),
    (["time.max_slip=0"], r"time.max_slip = 0.0: out of range, allowed \(0.0, 10000.0\]"),
    # the bound that depends on solver.kinematics is named with the schema's range
    (["time.max_rotation=0"], r"time.max_rotation = 0.0: out of range, allowed \(0.0, 1.0\] "
                              r"\(at most 0.1 with solver.kinematics = 'small', the default; 1 "
                              r"with 'finite_rotation'\)"),
    # past the small-rotation kinematics (scene.MAX_ROTATION_SUPPORTED)
    (["time.max_rotation=0.2"], r"time.max_rotation = 0.2: out of range with solver.kinematics "
                                r"= 'small', allowed \(0, 0.1\]"),
    # past the finite-rotation kinematics (scene.MAX_ROTATION_FINITE)
    (["solver.kinematics=finite_rotation", "time.max_rotation=1.5"],
     r"time.max_rotation = 1.5: out of range, allowed \(0.0, 1.0\]"),
    (["solver.kinematics=large"], r"solver.kinematics = 'large': not allowed, choose one of "
                                  r"\['small', 'finite_rotation'\]"),
    (["time.max_rotation=-0.1"], r"time.max_rotation = -0.1: out of range"),
    (["time.stop_slip=-1"], r"time.stop_slip = -1: out of range, allowed \[0, 10000\] m \(alias "
                            r"of time.max_slip"),
    (["solver.pairing_tolerance=0"], r"solver.pairing_tolerance = 0.0: out of range"),
    # a record's polarity: as stored or reversed (SLAMMER's normal / inverse)
    (["ground_motion.polarity=reversed"],
     r"ground_motion.polarity = 'reversed': not allowed, choose one of \['normal', 'inverse'\]"),
    (["ground_motion.record='pulse:square:0.5:0.4'"],
     r"ground_motion.record = 'pulse:square:0.5:0.4': not a pulse; allowed: 'pulse:<shape>"),
    # physical sanity at --dry-run (setup/sanity.py, docs/run.md §8)
    (["interface.contact_stiffness=1e5"],
     r"interface.contact_stiffness = 100000.0 Pa/m: under the dam's weight .*overlap by "
     r"12.57 m, more than 1 % of its smallest element \(0.1 m\).*allowed: >= 1.26e\+09 Pa/m \(the "
     r"bond's own stiffness"),
    (["interface.contact_stiffness=1"], r"interface.contact_stiffness = 1.0 Pa/m: .*overlap by "
                                        r"1.257e\+06 m"),
    (["joints=[{name='neck', elevation=66.5, contact_stiffness=1e6}]"],
     r"joints\[0\].contact_stiffness = 1000000.0 Pa/m: .* on the joint 'neck'"),
    (["joints=[{name='low', elevation=0.001}]"],
     r"joints\[0\].elevation = 0.001 \(joint 'low'\): 0.001 m above the base, closer than the "
     r"element size there \(0.1 m"),
    (["joints=[{name='a', elevation=40.0}, {name='b', elevation=40.05}]"],
     r"joints\[1\].elevation = 40.05 \(joint 'b'\): 0.05 m above joint 'a' \(joints\[0\]\)"),
    (["joints=[{name='top', elevation=102.95}]"],
     r"joints\[0\].elevation = 102.95 \(joint 'top'\): 0.05 m below the crest"),
    (["uplift.model=linear", "uplift.drain_x=7"],
     r"uplift.drain_x = 7.0 with uplift.model = 'linear': the drain line is read only by "
     r"model = 'drains'"),
    (["uplift.drain_x=7"], r"uplift.drain_x = 7.0 with uplift.model = 'none'"),
    (["ground_motion.scale=0"], r"ground_motion.scale = 0.0: the record scaled to nothing"),
    (["materials.dam.E=5e-324"], r"materials.dam.E = 5e-324: softer than any soil a dam stands "
                                 r"on; allowed: >= 1e\+06 Pa"),
    (["materials.rock.rho=1e-3"], r"materials.rock.rho = 0.001: lighter than air; allowed: >= 1 "),
    (["materials.dam.nu=0.4999999"], r"materials.dam.nu = 0.4999999: nearly incompressible: the "
                                     r"elements lock; allowed: <= 0.49"),
    (["ground_motion.record='pulse:sine:0.5:-1'"],
     r"ground_motion.record = 'pulse:sine:0.5:-1': out of range; allowed: \|peak\| <= 10 g, "
     r"period > 0 s"),
]


@pytest.mark.parametrize("name,make,pat", PARAMS + GAPS, ids=[c[0] for c in PARAMS + GAPS])
def test_parameters_and_gaps(name, make, pat):
    # the clear error alone: no floating-point RuntimeWarning before it (a gap of 1e200 m
    # overflowed numpy's dot product in the law's quick check and printed one)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.raises(ValueError, match=pat):
            make()


def test_bound_law_refuses_a_huge_gap_without_a_warning():
    """The solver's bound law (``InterfaceLaw.bind``) on a gap of 1e200 m: the same clear error
    as ``evaluate``, and no overflow warning from its quick check."""
    bound = LAW.bind(LAW.initial_state(4))
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.raises(ValueError, match=r"exceeds 1e\+100 m"):
            bound(_gap(p0=[1e200, 0.0]))


def test_record_files(tmp_path):
    cases = _records(tmp_path)
    assert len(cases) >= 8
    for name, make, pat in cases:
        with pytest.raises(ValueError, match=pat):
            make()


@pytest.mark.parametrize("sets,pat", SCENES, ids=[s[0][0] for s in SCENES])
def test_scene_values(sets, pat):
    """Everything --dry-run rejects: the schema (load_scene) and setup.validate (law ranges,
    the record)."""
    from ngs_driver.setup import validate
    with pytest.raises(ValueError, match=pat):
        validate(load_scene("koyna", sets))


def test_section_files(tmp_path):
    """A section file (the shipped Pine Flat one, spoiled) that runs clockwise, has its base off
    y = 0, or does not close at the heel (its last point back on the base, not at the heel) is
    rejected at --dry-run with the key and the file."""
    from ngs_driver.scene import SCENE_DIR
    from ngs_driver.section import read_profile_csv

    pts = read_profile_csv(SCENE_DIR / "sections" / "pine_flat.csv")
    cases = {"clockwise": ([pts[0]] + pts[1:][::-1], r"clockwise"),
             "base_off": ([[x, y + 1.0] for x, y in pts], r"heel.*allowed: \[0, 0\]"),
             "base_tilted": ([pts[0], [95.71, 0.5]] + pts[2:], r"base .* not on y = 0"),
             "open": (pts + [[2.0, 0.0]], r"does not close at the heel")}
    for name, (P, pat) in cases.items():
        f = tmp_path / f"{name}.csv"
        f.write_text("# spoiled Pine Flat section\nx,y\n" + "".join(f"{x},{y}\n" for x, y in P))
        with pytest.raises(ValueError, match=r"geometry.profile_file = '.*" + name + r"\.csv'.*"
                           + pat):
            load_scene("pine_flat", [f"geometry.profile_file='{f}'"])


def test_unknown_scene_lists_the_shipped_ones():
    with pytest.raises(ValueError, match=r"scene 'nosuchscene'.*shipped scenes: \[.*'koyna'"):
        load_scene("nosuchscene")


def test_catalogue_has_at_least_30_cases(tmp_path):
    assert len(PARAMS) + len(GAPS) + len(_records(tmp_path)) + len(SCENES) + 1 >= 30


# ------------------------------------------------------------------------------ the command line
def _dry(argv, capsys):
    from ngs_driver.cli import main
    rc = main(argv)
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def test_out_that_is_a_file(tmp_path, capsys):
    """--out naming an existing file: exit 2 at --dry-run naming --out, the file untouched
    (it was a FileExistsError traceback when the run created its folder)."""
    f = tmp_path / "results.txt"
    f.write_text("keep me")
    for argv in (["run", "koyna_smoke", "--dry-run", "--out", str(f)],
                 ["run", "koyna_smoke", "--out", str(f)],
                 ["modal", "koyna_smoke", "--out", str(f)],
                 ["run-paper", "koyna_smoke", "--dry-run", "--out", str(f)]):
        rc, out, err = _dry(argv, capsys)
        assert rc == 2 and f"--out = {str(f)!r}: is an existing file" in err, (argv, err)
    assert f.read_text() == "keep me"


def test_ida_out_that_is_a_file(tmp_path):
    """The IDA says so before any input of the study is read or a cluster started."""
    from ngs_driver.studies.ida import StudyInputError, run_ida
    f = tmp_path / "study"
    f.write_text("")
    with pytest.raises(StudyInputError, match=r"--out = .*: is an existing file; allowed: a "
                                              r"folder"):
        run_ida("koyna_smoke", suite="fema-p695-farfield", im="pga", levels=[0.1], out=f,
                workers=1)


def test_ida_lists_name_what_is_allowed(tmp_path, capsys):
    """A mistyped --levels or --records: exit 2, the option, the value and what is allowed, and
    the study folder not created."""
    out = tmp_path / "study"
    base = ["ida", "koyna_smoke", "--suite", "fema-p695-farfield", "--components", "a",
            "--im", "pga", "--out", str(out)]
    cases = [(["--records", "1", "--levels", "0.1,abc"],
              "--levels '0.1,abc': 'abc' is not a valid value; allowed: comma-separated "
              "numbers, e.g. 0.05,0.1,0.2"),
             (["--records", "1,x", "--levels", "0.1"],
              "--records '1,x': 'x' is not a valid value; allowed: comma-separated integers"),
             (["--records", "1", "--levels", ","],
              "--levels ',': empty list; allowed: comma-separated numbers")]
    for extra, msg in cases:
        rc, _, err = _dry(base + extra, capsys)
        assert rc == 2 and msg in err, (extra, err)
    assert not out.exists()


def test_run_paper_refuses_an_alpha_of_its_own(tmp_path, capsys):
    """run-paper sets interface.alpha to 2 and 1: a --set of it (even a bad value) would be
    replaced without a word; exit 2 naming the key, nothing created."""
    out = tmp_path / "paper"
    for value in ("1.5", "abc"):
        rc, _, err = _dry(["run-paper", "koyna_smoke", "--dry-run", "--set",
                           f"interface.alpha={value}", "--out", str(out)], capsys)
        assert rc == 2 and (f"--set 'interface.alpha={value}': run-paper sets interface.alpha "
                            "itself (2.0, then 1.0); allowed: any other key") in err, err
    assert not out.exists()


def test_resume_with_another_scene_names_the_key(tmp_path, capsys):
    """--resume (with --dry-run too) against a checkpoint of another scene: exit 2 naming the
    first key that differs, with both values."""
    from ngs_driver.run.checkpoint import Checkpointer
    d = tmp_path / "r"
    d.mkdir()
    scene = load_scene("koyna_smoke").to_dict()
    ck = Checkpointer(d, 10)
    ck.save(10, {"scene": scene}, u=np.zeros(3))
    ck.wait()
    rc, out, err = _dry(["run", "koyna_smoke", "--resume", "--dry-run", "--out", str(d),
                         "--set", "interface.alpha=1"], capsys)
    assert rc == 2 and "interface.alpha = 2.0 in the checkpoint, 1.0 now" in err, err
    rc, out, err = _dry(["run", "koyna_smoke", "--resume", "--dry-run", "--out", str(d)],
                        capsys)
    assert rc == 0, err


def test_window_past_the_record_end_is_said(capsys):
    """A window that runs past the record's end runs (the ground at rest after it) and says
    so: in the dry run (and in the run's log and summary.json, ``setup.window_note``)."""
    import json
    rc, out, err = _dry(["run", "koyna_smoke", "--dry-run", "--set", "ground_motion.start=9.95"],
                        capsys)
    assert rc == 0, err
    note = json.loads(out)["will_build"]["ground_motion"]["window_note"]
    assert "9.95-10.05 s runs past the end of the record (10 s)" in note
    rc, out, err = _dry(["run", "koyna_smoke", "--dry-run"], capsys)
    assert json.loads(out)["will_build"]["ground_motion"]["window_note"] is None


def test_record_path_in_a_scene_file_is_relative_to_that_file(tmp_path, monkeypatch):
    """ground_motion.record = "rec.txt" in a scene file is found beside the scene file
    (as geometry.profile_file), whatever the current folder; on the command line (--set) a
    relative path is taken from the current folder."""
    from ngs_driver.setup import validate
    sub = tmp_path / "project"
    sub.mkdir()
    rows = "\n".join(f"{0.01 * k:.2f} {0.1 * (k % 7) - 0.3:.2f}" for k in range(300))
    (sub / "rec.txt").write_text(rows + "\n")
    (sub / "dam.toml").write_text('[ground_motion]\nrecord = "rec.txt"\nunits = "g"\n'
                                  '[time]\nduration = 1.0\n')
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    sc = load_scene(str(sub / "dam.toml"))
    assert sc.ground_motion.record == str((sub / "rec.txt").resolve())
    assert validate(sc).label.endswith("rec.txt") or "rec.txt" in validate(sc).source
    with pytest.raises(ValueError, match=r"ground_motion.record = 'rec.txt': no such file"):
        validate(load_scene(str(sub / "dam.toml"), ["ground_motion.record=rec.txt"]))
    monkeypatch.chdir(sub)
    assert validate(load_scene("koyna_smoke", ["ground_motion.record=rec.txt",
                                               "ground_motion.units=g",
                                               "ground_motion.start=0"])) is not None
