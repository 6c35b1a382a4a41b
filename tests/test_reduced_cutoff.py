"""The reduced bulk's mode count and cut-off against what the mesh can give (issue 32, "Bad
input"; fe/reduction.py ``available_modes``, ``MAX_CUTOFF_MODES``; docs/reduced_bulk.md §4).

Each number would be wrong if the code were wrong:
* ``solver.bulk_modes`` above the modes the interior has is refused (it was clamped silently),
  the count named being the interior DOFs with mass counted here from the model's mass
  matrix (koyna_smoke: 538 with the rock, 160 with the massless rock), checked before any
  eigensolve; the count itself is accepted and keeps that many modes;
* a cut-off at or above the mesh's MAX_CUTOFF_MODES-th mode is refused, one just below it
  keeps MAX_CUTOFF_MODES - 1 modes; the frequency the message names is that mode's (from the
  dense eigensolver), and eigsh is never asked for more than the ceiling (the shift-invert
  path, forced on koyna_smoke by lowering DENSE_EIG and the ceiling);
* through the command: exit 2 with the message and no results file.
"""
import re
import subprocess
import sys

import numpy as np
import pytest
import scipy.sparse.linalg as spl

pytest.importorskip("ngsolve")

import ngs_driver.fe.reduction as reduction  # noqa: E402
from ngs_driver.fe.model import build_from_scene  # noqa: E402
from ngs_driver.fe.reduction import (MAX_CUTOFF_MODES, available_modes,  # noqa: E402
                                     boundary_dofs, reduce_model)
from ngs_driver.scene import load_scene  # noqa: E402

SMOKE = "koyna_smoke"


@pytest.fixture(scope="module")
def smoke_model():
    return build_from_scene(load_scene(SMOKE))


def _interior_dofs_with_mass(model) -> int:
    """The interior DOFs (free DOFs that are not boundary DOFs) whose mass-matrix diagonal is
    positive: counted DOF by DOF, not part by part as fe/reduction.py does."""
    inner = np.ones(model.nfree, bool)
    inner[boundary_dofs(model)] = False
    return int(np.count_nonzero(model.M.diagonal()[inner] > 0.0))


def _boom(*a, **k):
    raise AssertionError("an eigensolver ran before the count was checked")


@pytest.mark.parametrize("sets,expected", [([], 538), (["geometry.foundation=massless"], 160)],
                         ids=["rock", "massless_rock"])
def test_bulk_modes_above_the_interiors_modes(monkeypatch, sets, expected):
    """koyna_smoke's interior: 160 dam + 378 rock DOFs, both under DENSE_EIG (every mode, dense);
    the massless rock has no mode. One mode more than that is refused before any eigensolve
    (the eigensolvers replaced by a failure); the count itself keeps exactly that many."""
    model = build_from_scene(load_scene(SMOKE, sets))
    n = _interior_dofs_with_mass(model)
    assert n == expected
    assert available_modes(model) == n
    with monkeypatch.context() as mp:
        mp.setattr(reduction.sla, "eigh", _boom)
        mp.setattr(reduction.spl, "eigsh", _boom)
        with pytest.raises(ValueError) as e:
            reduce_model(model, n_modes=n + 1)
    msg = str(e.value)
    assert f"solver.bulk_modes = {n + 1}:" in msg and f"the {n} fixed-interface modes" in msg
    assert f"allowed: 1 .. {n}," in msg
    assert reduce_model(model, n_modes=n).reduction.nm == n


def test_bulk_modes_count_of_an_eigsh_part(monkeypatch, smoke_model):
    """A part above DENSE_EIG gives at most n - 1 modes (eigsh needs k < n): with DENSE_EIG
    lowered to 200 the rock's 378 DOFs give 377, the dam's 160 all of theirs."""
    monkeypatch.setattr(reduction, "DENSE_EIG", 200)
    n = _interior_dofs_with_mass(smoke_model) - 1
    assert available_modes(smoke_model) == n == 537
    with pytest.raises(ValueError, match=rf"solver.bulk_modes = 538: .*allowed: 1 \.\. {n},"):
        reduce_model(smoke_model, n_modes=n + 1)


def test_cutoff_at_the_ceiling_dense(smoke_model):
    """koyna_smoke has 538 modes, more than MAX_CUTOFF_MODES (512): a cut-off between its
    511th and 512th modes keeps 511; one between the 512th and 513th is refused naming the
    key, the value and the 512th mode's frequency (printed to 6 digits: 1e-5 relative)."""
    assert available_modes(smoke_model) >= MAX_CUTOFF_MODES + 2   # the case exists on the mesh
    f = reduce_model(smoke_model, n_modes=MAX_CUTOFF_MODES + 2).reduction.freqs_hz
    c = MAX_CUTOFF_MODES
    assert f[c - 2] < f[c - 1] < f[c]                # separated: each cut-off is unambiguous
    ok = float(0.5 * (f[c - 2] + f[c - 1]))
    assert reduce_model(smoke_model, cutoff_hz=ok).reduction.nm == c - 1
    bad = float(0.5 * (f[c - 1] + f[c]))
    with pytest.raises(ValueError) as e:
        reduce_model(smoke_model, cutoff_hz=bad)
    msg = str(e.value)
    assert msg.startswith(f"solver.bulk_cutoff_hz = {bad!r}:")
    reach = float(re.search(rf"{c}th fixed-interface mode \(([0-9.e+]+) Hz\)", msg).group(1))
    assert abs(reach - f[c - 1]) <= 1e-5 * f[c - 1]
    assert "allowed: a cut-off below" in msg and "solver.bulk_modes" in msg


def test_cutoff_search_stops_at_the_ceiling(monkeypatch, smoke_model):
    """The shift-invert path (DENSE_EIG lowered to 100: both parts go through eigsh) with a
    ceiling of 40: eigsh is never asked for more than 40 modes, also for a cut-off far above
    the spectrum (both parts stop at the ceiling); the frequency named is the dense 40th mode's
    (1e-5: 6 printed digits; eigsh's own error is ~1e-12); a cut-off below it keeps 39."""
    f = reduce_model(smoke_model, n_modes=41).reduction.freqs_hz          # dense, reference
    monkeypatch.setattr(reduction, "DENSE_EIG", 100)
    monkeypatch.setattr(reduction, "MAX_CUTOFF_MODES", 40)
    asked = []
    eigsh = spl.eigsh

    def spy(*a, **k):
        asked.append(k["k"])
        return eigsh(*a, **k)
    monkeypatch.setattr(reduction.spl, "eigsh", spy)
    red = reduce_model(smoke_model, cutoff_hz=0.5 * (f[38] + f[39])).reduction
    assert red.nm == 39
    np.testing.assert_allclose(red.freqs_hz, f[:39], rtol=1e-8)   # eigsh against dense
    for cut in (0.5 * (f[39] + f[40]), 10.0 * f[40]):
        asked.clear()
        with pytest.raises(ValueError) as e:
            reduce_model(smoke_model, cutoff_hz=cut)
        assert asked and max(asked) <= 40, asked
        m = re.search(r"40th fixed-interface mode \(([0-9.e+]+) Hz\)", str(e.value))
        assert str(e.value).startswith("solver.bulk_cutoff_hz =")
        assert abs(float(m.group(1)) - f[39]) <= 1e-5 * f[39]


def test_command_exit_2_and_nothing_written(tmp_path, cli_env, smoke_model):
    """The count is known only once the mesh is built: the command refuses it after the
    build with exit 2 and the message; the results folder (created and locked before the
    build, run/analysis.py prepare) is left empty: no summary.json, no checkpoint, no lock."""
    n = available_modes(smoke_model)
    out = tmp_path / "out"
    p = subprocess.run([sys.executable, "-m", "ngs_driver", "run", SMOKE, "--out", str(out),
                        "--set", "solver.bulk=reduced", "--set", f"solver.bulk_modes={n + 1}",
                        "--set", "time.duration=0.01"],
                       env=cli_env, capture_output=True, text=True, timeout=120)
    assert p.returncode == 2, p.stderr
    assert f"solver.bulk_modes = {n + 1}:" in p.stderr and f"allowed: 1 .. {n}," in p.stderr
    assert not (out / "summary.json").exists()
    assert list(out.iterdir()) == []
