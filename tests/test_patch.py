"""Patch test of the interface coupling across NON-matching meshes: a uniform stress
state (normal and shear) in the dam block on the rock block must cross the interface uniformly,
i.e. every interface point carries exactly the applied traction, for several size ratios.

The uniform state: sigma_yy = -p, sigma_xy = tau, and sigma_xx = nu/(1-nu) sigma_yy so that
eps_xx = 0 (plane strain), compatible with the fixed rock bottom: u = (gamma, eps_yy)(y + h_bot)
in the rock and the same plus a uniform jump t/k in the dam. Tractions sigma.n are applied on
every free boundary (top, and both vertical faces of both blocks)."""
import numpy as np
import pytest
import scipy.sparse.linalg as spl

ngs = pytest.importorskip("ngsolve")

from interfacelaw import CohesiveParams, ContactParams, InterfaceLaw  # noqa: E402
from ngs_driver.fe import geometry as geom  # noqa: E402
from ngs_driver.fe.model import build_model
from ngs_driver.fe.ngs_helpers import vec  # noqa: E402


@pytest.mark.parametrize("n_top,n_bot", [(4, 3), (3, 7), (8, 5), (5, 5)])
def test_uniform_traction_is_transmitted_exactly(n_top, n_bot):
    m = geom.two_block_mesh(n_top=n_top, n_bot=n_bot)
    md = build_model(mesh=m, foundation="rock", rock_sides="free", reservoir_level=0.0,
                     gravity=0.0)
    tau, p = 1.3e6, 2.1e6                       # applied shear and compression on the dam top
    nu = md.materials["dam"].nu if isinstance(md.materials, dict) else 0.2
    sx = nu / (1 - nu) * (-p)
    vd, vr = md.fes.TestFunction()
    lf = ngs.LinearForm(md.fes)
    lf += (tau * vd[0] - p * vd[1]) * ngs.ds("crest")                  # n = +y
    lf += (-sx * vd[0] - tau * vd[1]) * ngs.ds("upstream")             # n = -x
    lf += (sx * vd[0] + tau * vd[1]) * ngs.ds("downstream")            # n = +x
    lf += (-sx * vr[0] - tau * vr[1]) * ngs.ds("rock_left")
    lf += (sx * vr[0] + tau * vr[1]) * ngs.ds("rock_right")
    lf.Assemble()
    f = vec(lf)[md.free]
    # a linear law (stays elastic: strength far above the applied tractions)
    law = InterfaceLaw(CohesiveParams(3e9, 3e9, 1e-2, 1e-2, 0.2), ContactParams())
    k = np.array([law.cohesive.k_normal, law.cohesive.k_tangential])
    A = (md.K + md.interface.stiffness(*k)).tocsc()
    u = spl.spsolve(A, f)
    g = md.interface.gap(u)
    t, _, st = law.evaluate(g, law.initial_state(md.interface.npts))
    assert np.all(st.kappa < law.cohesive.lambda_max)       # stayed linear
    # uniform stress in both blocks is in the discrete space of each (linear triangles), and
    # node-to-segment gaps of linear fields are exact: only round-off remains (1e-10 relative)
    np.testing.assert_allclose(t[:, 0], -p, rtol=1e-10)
    np.testing.assert_allclose(t[:, 1], tau, rtol=1e-10)
