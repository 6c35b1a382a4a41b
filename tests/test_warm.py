"""The command's warm-up child (ngs_driver/apps/warm.py): the scene's interface-law loops are
compiled into numba's cache by a separate process while the run builds its model, so that a
cold cache's compile is not kept in the run's memory (docs/run.md §7)."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

from ngs_driver.apps import warm
from ngs_driver.cli import main
from ngs_driver.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent


def test_the_child_compiles_the_scenes_law_loops_into_an_empty_cache(tmp_path, cli_env):
    """koyna_smoke's law through the child, with numba's cache a new empty folder: the child
    exits 0 and leaves the law's compiled loops (interfacelaw/_kernels.py's ``_run2`` and the
    quick gap check ``sum_squares``) in that cache, where the run's own first call loads them."""
    cache = tmp_path / "cache"
    env = dict(cli_env, NUMBA_CACHE_DIR=str(cache))
    r = subprocess.run([sys.executable, "-m", "ngs_driver.apps.warm"],
                       input=json.dumps(["koyna_smoke", []]), text=True, env=env, cwd=ROOT,
                       capture_output=True, timeout=300)
    assert r.returncode == 0, r.stderr
    names = {f.name.split("-")[0] for f in cache.rglob("_kernels.*.nbc")}
    assert {"_kernels._run2", "_kernels.sum_squares"} <= names, names


def test_warm_laws_evaluates_every_joints_law():
    """koyna_1967 has the base and the neck joint: two laws evaluated (each on one point)."""
    assert warm.warm_laws(load_scene("koyna_1967", [])) == 2
    assert warm.warm_laws(load_scene("koyna_smoke", [])) == 1


def test_a_run_starts_the_child_and_leaves_none_behind(tmp_path, monkeypatch):
    """`dam-seismic run` starts the child with the command's scene and overrides and has
    waited for it (exit code 0) when it returns; `--dry-run` starts none."""
    pytest.importorskip("ngsolve")
    seen = []

    def start(scene, overrides):
        p = warm_start(scene, overrides)
        seen.append((scene, list(overrides), p))
        return p

    warm_start = warm.start
    monkeypatch.setattr(warm, "start", start)
    sets = ["time.duration=0.01"]
    assert main(["run", "koyna_smoke", "--set", sets[0], "--out", str(tmp_path / "d"),
                 "--dry-run"]) == 0
    assert seen == []
    assert main(["run", "koyna_smoke", "--set", sets[0], "--out", str(tmp_path / "r"),
                 "--quiet"]) == 0
    assert [(s, o) for s, o, _ in seen] == [("koyna_smoke", sets)]
    assert seen[0][2].returncode == 0


def test_a_failed_run_leaves_no_child(tmp_path, monkeypatch):
    """A run that fails when its model is built (koyna_smoke's interior has 538 modes: 539 are
    refused, exit 2) stops the child instead of waiting for it; either way none is left."""
    pytest.importorskip("ngsolve")
    seen = []
    warm_start = warm.start

    def start(scene, overrides):
        p = warm_start(scene, overrides)
        seen.append(p)
        return p

    monkeypatch.setattr(warm, "start", start)
    assert main(["run", "koyna_smoke", "--set", "solver.bulk=reduced", "--set",
                 "solver.bulk_modes=539", "--set", "time.duration=0.01", "--out",
                 str(tmp_path / "r"), "--quiet"]) == 2
    assert len(seen) == 1 and seen[0].poll() is not None
