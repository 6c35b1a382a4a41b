"""Benchmarks of ngs_driver.solve.joint_solver: time per implicit step with the nonlinear
interface, condensed vs full Newton, at three mesh sizes of the block-on-block toy model
(ngs_driver/solver_toymodel.py; ~0.9k, 3.3k, 12.5k DOFs) and at 128 vs 512 interface points.

`make bench` runs them (pytest-benchmark, medians in .benchmarks.json); `make test` runs each
body once with --benchmark-disable on the smallest mesh so it cannot rot.
Numbers and discussion: docs/solver.md, BENCHMARKS.md.
"""
import numpy as np
import pytest

from interfacelaw import (CohesiveParams, ContactParams, DamageParams, FrictionParams,
                          InterfaceLaw)
from ngs_driver.solve.joint_solver import JointSolver
from toymodel import block_on_block

DT = 2e-3
_MODELS = {}


def _enabled(request):
    return request.config.getoption("benchmark_disable") is False


def _model(h, ng):
    key = (h, ng)
    if key not in _MODELS:
        _MODELS[key] = block_on_block(h, n_gauss=ng)
    return _MODELS[key]


def _law():
    coh = CohesiveParams.from_fracture_energy(3e4, 3e4, 3.0, 0.2)
    return InterfaceLaw(coh, ContactParams("linear"), FrictionParams(0.3),
                        DamageParams(g_max=1e-3, alpha=2))


def _load(m, n):
    return m.gravity + 1.2e5 * np.sin(2 * np.pi * 10 * n * DT) * m.crest_x


def _solver(m, method, warm):
    s = JointSolver(m.K, m.M, 1e-4 * m.K, m.B, m.w, _law(), dt=DT, method=method)
    s.static(m.gravity)
    for n in range(1, warm + 1):                # factorisation, S columns, damage everywhere
        s.step(_load(m, n))
    return s


def _run(benchmark, s, m, rounds, warm):
    counter = [warm]

    def one():
        counter[0] += 1
        return s.step(_load(m, counter[0]))

    benchmark.pedantic(one, rounds=rounds, iterations=1, warmup_rounds=0)
    its = [r.iterations for r in s.history[-rounds:]]
    benchmark.extra_info.update(ndof=m.ndof, npts=m.npts, method=s.method,
                                mean_newton_iterations=float(np.mean(its)),
                                n_active=s.history[-1].n_active, stats=dict(s.stats))
    # the benchmarked steps converged (every accepted sub-step below the tolerance, the
    # sub-steps covering dt to round-off) to finite fields
    for r in s.history[-rounds:]:
        assert max(r.residuals) <= s.tol_residual, r
        assert sum(r.dts) == pytest.approx(s.dt, rel=1e-12), r
    assert np.all(np.isfinite(s.u)) and min(its) >= 1 and s.history[-1].n_active > 0


@pytest.mark.parametrize("h", [0.25, 0.125, 0.0625])
def test_bench_condensed_step(benchmark, request, h):
    """Per-step time of the condensed method against DOFs (128 / 64 / 32 points x 2 GP)."""
    if not _enabled(request) and h != 0.25:
        pytest.skip("large mesh only with make bench")
    m = _model(h, 2)
    s = _solver(m, "condensed", warm=10)
    _run(benchmark, s, m, rounds=60 if _enabled(request) else 1, warm=10)


@pytest.mark.parametrize("h", [0.25, 0.0625])
def test_bench_full_step(benchmark, request, h):
    """Per-step time of the re-factorising full Newton (reference)."""
    if not _enabled(request) and h != 0.25:
        pytest.skip("large mesh only with make bench")
    m = _model(h, 2)
    s = _solver(m, "full", warm=2)
    _run(benchmark, s, m, rounds=8 if _enabled(request) else 1, warm=2)


@pytest.mark.parametrize("ng", [2, 8])
def test_bench_condensed_points(benchmark, request, ng):
    """Per-step time against interface points at 12.5k DOFs: 128 and 512 points (2 and 8 Gauss
    points per segment: the Newton system is r x r, r = the relative interface DOFs, for both)."""
    if not _enabled(request):
        pytest.skip("large mesh only with make bench")
    m = _model(0.0625, ng)
    s = _solver(m, "condensed", warm=10)
    _run(benchmark, s, m, rounds=40, warm=10)
