"""Linear screening (USACE EM 1110-2-6053): the DCR map of the dam body and the
cumulative inelastic duration, on the coarse koyna_smoke mesh with a rigid foundation."""
import json

import numpy as np
import pytest

pytest.importorskip("ngsolve")

from ngs_driver.fe.model import build_from_scene  # noqa: E402
from ngs_driver.apps.dam import run  # noqa: E402
from ngs_driver.run.screening import Screening  # noqa: E402
from ngs_driver.scene import load_scene  # noqa: E402

SETS = ["geometry.foundation=rigid", "screening.enabled=true"]


@pytest.fixture(scope="module")
def model():
    return build_from_scene(load_scene("koyna_smoke", SETS))


def test_dcr_is_the_principal_stress_of_each_element(model):
    """For an arbitrary displacement, the element's DCR times the strength equals the max
    principal stress of NGSolve's own stress CoefficientFunction at the element centroid
    (P1: constant per element; 1e-12 of the largest: round-off of two assemblies)."""
    sc = load_scene("koyna_smoke", SETS + ["screening.tensile_strength=2e6"])
    scr = Screening(sc.screening.tensile_strength, model)
    assert scr.x.size == sum(1 for el in model.mesh.Elements() if el.mat != "rock")
    u = np.random.default_rng(1).normal(size=model.nfree) * 1e-3
    d = scr.dcr(u) * 2e6
    S = model.stress_cf(model.to_gridfunction(u))
    ref = []
    for x, y in zip(scr.x, scr.y):
        mip = model.mesh(x, y)
        sx, sy, sxy = S[0, 0](mip), S[1, 1](mip), S[0, 1](mip)
        ref.append(0.5 * (sx + sy) + np.sqrt(0.25 * (sx - sy) ** 2 + sxy ** 2))
    assert np.max(np.abs(d - np.array(ref))) <= 1e-12 * np.max(np.abs(ref))
    # centroids of the stored triangles are the elements' centroids (the map is drawn right)
    assert np.allclose(scr.triangles.mean(axis=1), np.c_[scr.x, scr.y], atol=1e-9)


def test_cumulative_inelastic_duration_counts_the_steps_above_one(model, tmp_path):
    """Three states: the duration of every element is dt times the number of states with
    DCR > 1, the maximum and its time are those of the largest state (exact arithmetic)."""
    scr = Screening(load_scene("koyna_smoke", SETS).screening.tensile_strength, model)
    rng = np.random.default_rng(2)
    us = [rng.normal(size=model.nfree) * 1e-4 * s for s in (1.0, 3.0, 0.5)]
    for k, u in enumerate(us):
        scr.update(u, 0.01 * (k + 1), 0.01)
    D = np.array([scr.dcr(u) for u in us])
    assert np.array_equal(scr.duration, 0.01 * np.count_nonzero(D > 1.0, axis=0))
    assert np.array_equal(scr.max_dcr, D.max(axis=0))
    assert np.array_equal(scr.t_max, 0.01 * (np.argmax(D, axis=0) + 1))
    assert 0 < np.count_nonzero(scr.duration) < scr.x.size      # the test separates cases
    from ngs_driver.post.safety_plots import plot_screening
    assert plot_screening(tmp_path / "map.png", scr, "test") == "map.png"
    assert (tmp_path / "map.png").stat().st_size > 10_000


def test_screening_in_a_linear_run(tmp_path, model):
    """A linear run (interface on its elastic branch) with screening: summary.json, results.md
    and the map; the worst element's duration is a whole number of steps within the run."""
    sc = load_scene("koyna_smoke", SETS + ["interface.damage=false", "interface.sigma_max=10e6",
                                           "interface.tau_max=10e6", "time.duration=0.02",
                                           "screening.tensile_strength=1.5e6"])
    s = run(sc, tmp_path, progress=False, model=model, plots=False)
    d = json.loads((tmp_path / "summary.json").read_text())["screening"]
    w = d["worst_element"]
    n = w["cumulative_inelastic_duration"] / 0.002
    assert abs(n - round(n)) < 1e-9 and 0 <= round(n) <= 10
    assert d["max_dcr"] >= d["static_max_dcr"] > 0
    assert d["elements"] == sum(1 for el in model.mesh.Elements() if el.mat != "rock")
    assert "Linear screening" in (tmp_path / "results.md").read_text()
    assert s["screening"]["tensile_strength"] == 1.5e6
