"""Lift joints: a joint is an interface like the base, with its own fields on both
sides, its own law, in the one condensed solver."""
import json

import numpy as np
import pytest
import scipy.sparse.linalg as spl

ngs = pytest.importorskip("ngsolve")

from interfacelaw import CohesiveParams, ContactParams, InterfaceLaw  # noqa: E402
from ngs_driver.fe import geometry as geom  # noqa: E402
from ngs_driver.fe.model import build_model  # noqa: E402
from ngs_driver.fe.ngs_helpers import vec  # noqa: E402
from ngs_driver.apps.dam import run  # noqa: E402
from ngs_driver.scene import from_dict  # noqa: E402
from ngs_driver.section import Section  # noqa: E402

BLOCK = Section([[0, 0], [10, 0], [10, 20], [0, 20]])
MESH = dict(h_heel=1.0, h_coarse=2.5, h_interface=2.0, growth=1.3, heel_zone=0.0,
            extent_up=0.5, extent_down=0.5, extent_depth=0.5)


def _linear_law(strength=3e9):
    return InterfaceLaw(CohesiveParams(strength, strength, 1e-2, 1e-2, 0.2), ContactParams())


def test_joint_patch_test():
    """A uniform stress state (sigma_yy = -p, sigma_xy = tau, eps_xx = 0) in a block on its rock,
    cut by a lift joint: both the base and the joint points carry exactly the applied traction.
    Uniform stress is in the discrete space of linear triangles and the matching joint's gap is
    exact, so only round-off remains (1e-10 relative)."""
    joint = geom.JointCut("mid", 8.0, 0.5, 2.0)
    md = build_model(foundation="rock", rock_sides="free", reservoir_level=0.0, gravity=0.0,
                     section=BLOCK, joints=[joint], **MESH)
    assert md.regions == ("dam", "dam_mid", "rock")
    assert set(md.joints) == {"base", "mid"}
    tau, p = 1.3e6, 2.1e6
    nu = md.materials["dam"].nu
    sx = nu / (1 - nu) * (-p)
    v_lo, v_hi, v_r = md.fes.TestFunction()
    lf = ngs.LinearForm(md.fes)
    lf += (tau * v_hi[0] - p * v_hi[1]) * ngs.ds("crest")                     # n = +y
    for v in (v_lo, v_hi):                      # each block's field lives on its own edges
        lf += (-sx * v[0] - tau * v[1]) * ngs.ds("upstream")                   # n = -x
        lf += (sx * v[0] + tau * v[1]) * ngs.ds("downstream")                  # n = +x
    lf += (-sx * v_r[0] - tau * v_r[1]) * ngs.ds("rock_left")
    lf += (sx * v_r[0] + tau * v_r[1]) * ngs.ds("rock_right")
    lf += (tau * v_r[0] - p * v_r[1]) * ngs.ds("rock_top_up|rock_top_down")    # n = +y
    lf.Assemble()
    f = vec(lf)[md.free]
    law = _linear_law()
    k = np.array([law.cohesive.k_normal, law.cohesive.k_tangential])
    A = (md.K + md.interface.stiffness(*k)).tocsc()
    u = spl.spsolve(A, f)
    g = md.interface.gap(u)
    t, _, st = law.evaluate(g, law.initial_state(md.interface.npts))
    assert np.all(st.kappa < law.cohesive.lambda_max)          # stayed linear
    sl = md.interface.parts["mid"]
    assert sl.stop - sl.start > 10 and np.allclose(md.interface.y[sl], 8.0)
    np.testing.assert_allclose(t[sl, 0], -p, rtol=1e-10)
    np.testing.assert_allclose(t[sl, 1], tau, rtol=1e-10)
    sb = md.interface.parts["base"]
    np.testing.assert_allclose(t[sb, 0], -p, rtol=1e-10)
    np.testing.assert_allclose(t[sb, 1], tau, rtol=1e-10)


def test_joint_weights_and_frame():
    """The joint's Gauss weights add up to the section's width at its elevation (exact for a
    straight cut), and the points run from the upstream face to the downstream face."""
    sec = Section([[0, 0], [60, 0], [10, 60], [0, 60]])
    j = geom.JointCut("j", 30.0, 0.5, 2.0)
    md = build_model(foundation="rigid", reservoir_level=0.0, section=sec, joints=[j],
                     **MESH)
    it = md.joints["j"]
    xu, xd = sec.width_at(30.0)
    assert it.w.sum() == pytest.approx(xd - xu, rel=1e-12)
    assert np.all(np.diff(it.x) > 0) and xu < it.x[0] < it.x[-1] < xd


def _glued(mesh):
    """The same mesh with every dam block named "dam": one displacement field, no joint."""
    ngm = mesh.ngmesh.Copy()
    for i in range(1, 100):
        try:
            name = ngm.GetMaterial(i)
        except Exception:
            break
        if not name:
            break
        if name.startswith("dam_"):
            ngm.SetMaterial(i, "dam")
    return ngs.Mesh(ngm)


def _scene(joints, **over):
    raw = {"name": "joint_test", "mesh": {"h_heel": 1.0, "heel_zone": 0.0, "h_interface": 5.0,
                                          "h_coarse": 10.0, "growth": 1.5},
           "ground_motion": {"start": 3.0, "scale": 3.0},
           "time": {"duration": 0.06}, "output": {"checkpoint_every": 0, "snapshots": 3},
           "joints": joints}
    for k, v in over.items():
        raw.setdefault(k.split(".")[0], {})[k.split(".")[1]] = v
    return from_dict(raw)


def test_strong_joint_behaves_like_no_joint(tmp_path):
    """A neck joint far stronger and stiffer than the concrete (sigma_max = 100 MPa against
    ~1 MPa of stress; G_I = 1 J/m^2: initial stiffness 2.5e16 Pa/m in tension, the same in
    compression by its contact_stiffness, so its compliance over the
    neck is ~1e-6 of the concrete's above it) gives the crest response of the same mesh glued
    at the neck (both blocks one field). Measured 3.6e-8 of the crest amplitude; tolerance
    1e-6: the joint's compliance plus the round-off of a stiffness ratio 2.5e16 / 5e10 in the
    factorisation (5e-7 measured with 2.5e18 Pa/m: stiffer is not closer)."""
    joint = {"name": "neck", "elevation": 66.5, "sigma_max": 1e8, "tau_max": 1e8,
             "G_I": 1.0, "damage": False, "scaling": False, "contact_stiffness": 2.5e16}
    # a motion that keeps the base bonded: a nonlinear base would amplify any difference
    sc = _scene([joint], **{"ground_motion.scale": 0.3})
    s_j = run(sc, tmp_path / "joint", progress=False, plots=False)
    # the same mesh with the joint glued: one region name for both blocks
    from ngs_driver.fe.model import build_from_scene
    md = build_from_scene(sc)
    mesh_glued = _glued(md.mesh)
    sc0 = _scene([], **{"ground_motion.scale": 0.3})
    from ngs_driver.fe.model import model_kwargs
    from ngs_driver.setup import model_inputs
    kw = model_kwargs(model_inputs(sc0))
    md0 = build_model(mesh=mesh_glued, **{k: v for k, v in kw.items()
                                          if k in ("foundation", "order", "gauss_points",
                                                   "dam", "rock", "gravity",
                                                   "reservoir_level", "water_density",
                                                   "rock_sides", "include_rock_weight")},
                      crest_point=md.crest_point)
    assert md0.nfree < md.nfree                 # the neck's nodes are shared when glued
    s_0 = run(sc0, tmp_path / "glued", progress=False, plots=False, model=md0)
    from ngs_driver.post.files import read_csv
    a = read_csv(tmp_path / "joint" / "timeseries.csv")
    b = read_csv(tmp_path / "glued" / "timeseries.csv")
    amp = np.max(np.abs(b["crest_ux"]))
    assert np.max(np.abs(a["crest_ux"] - b["crest_ux"])) <= 1e-6 * amp
    assert s_j["joints"]["neck"]["max_D"] == 0.0
    assert s_0["results"]["max_D"] == pytest.approx(s_j["results"]["max_D"], rel=1e-4)


def test_neck_joint_cracks_from_the_faces(tmp_path):
    """The 1967 Koyna earthquake cracked the dam near the downstream slope break (66.5 m). A
    weak neck joint under a strong motion debonds from a face inward: the debonded points
    form runs that touch the upstream or the downstream face. The base has friction 0.8, so
    that it does not collapse (slide without bound) before the neck cracks."""
    joint = {"name": "neck", "elevation": 66.5, "sigma_max": 0.5e6, "tau_max": 0.5e6}
    sc = _scene([joint], **{"time.duration": 0.3, "ground_motion.start": 2.5,
                            "interface.friction": 0.8})
    s = run(sc, tmp_path, progress=False, plots=False)
    nk = s["joints"]["neck"]
    assert nk["debonded_length_max"] > 0.5
    fs = np.load(tmp_path / "final_state.npz")
    sl = slice(s["joints"]["base"]["points"], None)
    deb = (fs["state_kappa"][sl] >= 1.0) | (fs["state_damage"][sl] >= 1.0)
    assert deb.any()
    assert deb[0] or deb[-1], "the crack starts at a face"
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert set(summary["joints"]) == {"base", "neck"}
