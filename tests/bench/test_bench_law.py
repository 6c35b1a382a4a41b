"""Throughput of the interface law (issue #2): points per second at n = 10^6 (2D, full law,
states spread over all branches). `make bench` runs it; `make test` only collects and runs each
benchmark body once (--benchmark-disable), with a small n so it cannot rot."""
import numpy as np
import pytest

from interfacelaw import (CohesiveParams, ContactParams, DamageParams, FrictionParams,
                          InterfaceLaw, InterfaceState, _kernels)
from interfacelaw.reference import evaluate_reference


def _n(request):
    return 10**6 if request.config.getoption("benchmark_disable") is False else 2000


def setup(n, parallel, layout="interleaved"):
    """Random states over every branch. layout "interleaved": the branch changes from point to
    point (worst case for branch prediction); "blocked": the same states sorted by branch, as
    along a real interface where neighbouring points share a branch."""
    coh = CohesiveParams.from_fracture_energy(3e6, 3e6, 250.0, 0.2, 1.0)
    law = InterfaceLaw(coh, ContactParams("rough"), FrictionParams(0.3),
                       DamageParams(g_max=20 * coh.l_Nc, alpha=2.0), parallel=parallel)
    rng = np.random.default_rng(0)
    lm = coh.lambda_max
    kappa = np.choose(rng.integers(0, 4, n), [np.zeros(n), rng.uniform(0, lm, n),
                                              rng.uniform(lm, 1, n), rng.uniform(1, 1.5, n)])
    dmg = np.choose(rng.integers(0, 3, n), [np.zeros(n), rng.uniform(0, 1, n), np.ones(n)])
    st = InterfaceState(kappa, dmg, rng.uniform(0, 1.5, n) * coh.l_Nc,
                        rng.uniform(-1, 1, (n, 1)) * coh.l_Tc, np.zeros(n))
    gap = rng.uniform(-1.3, 1.3, (n, 2)) * coh.l_Nc
    if layout == "blocked":
        _, _, s1 = law.evaluate(gap, st)
        key = (np.digitize(st.kappa, [lm, 1.0]) * 8 + (st.damage > 0) * 4 + (st.damage >= 1) * 2
               + (gap[:, 0] < 0)) * 2 + (s1.kappa > st.kappa)
        o = np.argsort(key, kind="stable")
        st = st.take(o)
        gap = np.ascontiguousarray(gap[o])
    out = (np.empty((n, 2)), np.empty((n, 2, 2)), law.initial_state(n))
    return law, gap, st, out


@pytest.mark.parametrize("layout", ["interleaved", "blocked"])
@pytest.mark.parametrize("threads", ["1", "all"])
def test_bench_numba(benchmark, request, threads, layout):
    import numba
    n = _n(request)
    law, gap, st, out = setup(n, parallel=True, layout=layout)
    nt = numba.config.NUMBA_NUM_THREADS
    numba.set_num_threads(1 if threads == "1" else nt)
    try:
        law.evaluate(gap, st, out=out)
        benchmark.extra_info.update(points=n, threads=1 if threads == "1" else nt, layout=layout)
        benchmark(law.evaluate, gap, st, out=out, check=False)
    finally:
        numba.set_num_threads(nt)
    F = out[0]
    assert np.all(np.isfinite(F))


@pytest.mark.parametrize("threads", ["1", "all"])
def test_bench_copy_roofline(benchmark, request, threads):
    import numba
    n = _n(request)
    law, gap, st, (F, T, new) = setup(n, parallel=True)
    nt = numba.config.NUMBA_NUM_THREADS
    numba.set_num_threads(1 if threads == "1" else nt)
    args = (gap, st.kappa, st.damage, st.separation, st.slip, st.dissipated,
            F, T, new.kappa, new.damage, new.separation, new.slip, new.dissipated)
    try:
        _kernels.copy_roofline(*args)
        benchmark.extra_info.update(points=n, threads=1 if threads == "1" else nt)
        benchmark(_kernels.copy_roofline, *args)
    finally:
        numba.set_num_threads(nt)
    assert np.array_equal(F, gap)


def test_bench_numpy_reference(benchmark, request):
    n = _n(request)
    law, gap, st, _ = setup(n, parallel=False)
    benchmark.extra_info.update(points=n, threads=1)
    F, T, _ = benchmark.pedantic(evaluate_reference, args=(law, gap, st), rounds=3,
                                 iterations=1)
    assert np.all(np.isfinite(F))
