"""Koyna benchmarks (per implicit step on the Koyna dam-foundation mesh): the
condensed solver with the scene's nonlinear interface law (strong part of the record), the
re-factorising full Newton, our solver on a linear (elastic-branch) interface, and OpenSeesPy
linear on the same mesh (skipped without openseespy: `pip install -e .[bench]`).

`make bench` runs them on the default Koyna mesh (12.2k DOFs, 333 interface points; each < 1
min including model build); `make test` (--benchmark-disable) runs every body once on a tiny
mesh so they cannot rot. The full study (DOF/point scaling, the 10 s run, ratios) is
verification/bench_koyna.py; numbers in BENCHMARKS.md.
"""
import pathlib
import sys

import numpy as np
import pytest

pytest.importorskip("ngsolve")
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "verification"))
import bench_koyna as bk  # noqa: E402

TINY = ["mesh.h_coarse=10.0", "mesh.h_interface=5.0", "mesh.h_heel=1.0", "mesh.heel_zone=2.0"]
_CACHE = {}


def _enabled(request):
    return request.config.getoption("benchmark_disable") is False


def _setup(request):
    """(--set overrides, model): default Koyna mesh with make bench, tiny mesh otherwise; the
    benchmark scene has no hydrodynamic water (OpenSees models dam and rock only)."""
    key = _enabled(request)
    if key not in _CACHE:
        sets = [] if key else list(TINY)
        _CACHE[key] = (sets, bk.model_of(bk.scene(sets)))
    return _CACHE[key]


def _analysis(sets, m, linear=False):
    """The run's set-up (run.prepare, static state solved) of the benchmark scene, 400 steps;
    linear: the elastic-branch law of bench_koyna.linear_sets."""
    if linear:
        sets = list(sets) + bk.linear_sets(bk.scene(sets))
    return bk.analysis(bk.scene(sets, n_steps=400), m)


def _warm_solver(sets, m, method, warm, linear=False):
    a = _analysis(sets, m, linear)
    s = a.solver if method == "condensed" else bk.variant(a.solver, method)
    fk = bk.load(a)
    for k in range(1, warm + 1):
        s.step(fk(k))
    return s, fk


def _bench_steps(benchmark, s, fk, warm, rounds, m):
    counter = [warm]

    def one():
        counter[0] += 1
        return s.step(fk(counter[0]))

    benchmark.pedantic(one, rounds=rounds, iterations=1, warmup_rounds=0)
    its = [r.iterations for r in s.history[-rounds:]] if getattr(s, "history", None) else []
    benchmark.extra_info.update(ndof=int(m.nfree), npts=int(m.interface.npts),
                                method=s.method,
                                mean_newton_iterations=float(np.mean(its)) if its else None,
                                n_active=int(s.history[-1].n_active) if its else None)
    return its


def test_bench_koyna_condensed_step(benchmark, request):
    """Condensed solver, scene law (alpha = 2), strong part of the record (t = 2 s on)."""
    sets, m = _setup(request)
    warm = 20 if _enabled(request) else 1
    s, fk = _warm_solver(sets, m, "condensed", warm)
    its = _bench_steps(benchmark, s, fk, warm, 100 if _enabled(request) else 1, m)
    assert np.isfinite(s.u[m.crest_dofs[0]]) and min(its) >= 1


def test_bench_koyna_full_step(benchmark, request):
    """Full re-factorising Newton (reference), same law and record; few rounds (~1 s/step)."""
    sets, m = _setup(request)
    warm = 2 if _enabled(request) else 1
    s, fk = _warm_solver(sets, m, "full", warm)
    its = _bench_steps(benchmark, s, fk, warm, 5 if _enabled(request) else 1, m)
    assert min(its) >= 1


def test_bench_koyna_linear_step(benchmark, request):
    """Our condensed solver with an interface that stays on its elastic branch (k0 of the
    scene): the same work as a linear Newmark step (one solve)."""
    sets, m = _setup(request)
    s, fk = _warm_solver(sets, m, "condensed", 1, linear=True)
    _bench_steps(benchmark, s, fk, 1, 200 if _enabled(request) else 1, m)
    assert s.history[-1].n_active == 0


def test_bench_koyna_opensees_linear_step(benchmark, request):
    """OpenSeesPy, same mesh, linear (tri31 plane strain, zeroLength springs k0), BandSPD,
    algorithm Linear -factorOnce, Newmark average acceleration, dt = 2 ms."""
    try:
        ops = bk.import_opensees()
    except Exception as exc:  # noqa: BLE001
        pytest.skip(f"openseespy not usable: {exc!r}")
    sets, m = _setup(request)
    a = _analysis(sets, m)
    crest, nfree, _, _ = bk.build_opensees(ops, m, a.scene, bk.a0a1_of(a),
                                           a.reference["k_normal"], a.reference["k_tangential"],
                                           a.f_static, a.ax[:401], a.ay[:401], "BandSPD")
    assert nfree == m.nfree
    ops.analyze(1, bk.DT)                         # factorisation outside the timing

    def one():
        return ops.analyze(1, bk.DT)

    benchmark.pedantic(one, rounds=200 if _enabled(request) else 1, iterations=1,
                       warmup_rounds=0)
    benchmark.extra_info.update(ndof=int(nfree), system="BandSPD")
    ux = ops.nodeDisp(crest, 1)
    ops.wipe()
    assert np.isfinite(ux)


@pytest.mark.parametrize("kind", ["nonlinear", "linear"])
def test_bench_koyna_02_step(benchmark, request, kind):
    """Speed target 2 per step: the record at 0.2x from its strong part (t = 2 s),
    nonlinear (scene law, alpha = 2: every point slightly damaged, all active) against the same
    steps with an elastic-branch interface; the ratio of the two medians is the per-step cost
    of the interface nonlinearity (verification/bench_koyna.py --parts 5 times whole runs)."""
    sets, m = _setup(request)
    warm = 20 if _enabled(request) else 1
    s, fk = _warm_solver(sets + ["ground_motion.scale=0.2"], m, "condensed", warm,
                         linear=kind == "linear")
    its = _bench_steps(benchmark, s, fk, warm, 100 if _enabled(request) else 1, m)
    benchmark.extra_info.update(kind=kind, stats=dict(s.stats))
    if kind == "nonlinear":
        assert s.history[-1].n_active > 0 and min(its) >= 1
    else:
        assert s.history[-1].n_active == 0 and max(its) == 0
    for r in s.history[-len(its):]:   # the benchmarked steps: converged sub-steps covering
        # dt (to round-off)
        assert max(r.residuals, default=0.0) <= s.tol_residual, r
        assert sum(r.dts) == pytest.approx(s.dt, rel=1e-12), r
