"""Throughput of the interface law: points per second at n = 10^6 (2D and 3D,
full law, states spread over all branches). `make bench` runs it; `make test` only collects and
runs each benchmark body once (--benchmark-disable), with a small n so it cannot rot.

Same-process comparison (kernel / copy of the same bytes, medians of interleaved rounds, and
optionally a kernel of an earlier revision — the numbers of BENCHMARKS.md):

    git show REV:interfacelaw/_kernels.py > /tmp/kernels_before.py      # optional
    python tests/bench/test_bench_law.py [--rounds 15] [--before /tmp/kernels_before.py]
"""
import numpy as np
import pytest

from interfacelaw import (CohesiveParams, ContactParams, DamageParams, FrictionParams,
                          InterfaceLaw, InterfaceState)
from interfacelaw.testing import copy_roofline, evaluate_reference


def _n(request):
    return 10**6 if request.config.getoption("benchmark_disable") is False else 2000


def setup(n, parallel, layout="interleaved", dim=2):
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
                        rng.uniform(-1, 1, (n, dim - 1)) * coh.l_Tc, np.zeros(n))
    gap = rng.uniform(-1.3, 1.3, (n, dim)) * coh.l_Nc
    if layout == "blocked":
        _, _, s1 = law.evaluate(gap, st)
        key = (np.digitize(st.kappa, [lm, 1.0]) * 8 + (st.damage > 0) * 4 + (st.damage >= 1) * 2
               + (gap[:, 0] < 0)) * 2 + (s1.kappa > st.kappa)
        o = np.argsort(key, kind="stable")
        st = st.take(o)
        gap = np.ascontiguousarray(gap[o])
    out = (np.empty((n, dim)), np.empty((n, dim, dim)), law.initial_state(n, dim))
    return law, gap, st, out


def test_bench_numba_3d(benchmark, request):
    """3D (g_N, g_T1, g_T2), one thread, interleaved branches."""
    import numba
    n = _n(request)
    law, gap, st, out = setup(n, parallel=False, dim=3)
    nt = numba.config.NUMBA_NUM_THREADS
    numba.set_num_threads(1)
    try:
        law.evaluate(gap, st, out=out)
        benchmark.extra_info.update(points=n, threads=1, layout="interleaved", dim=3)
        benchmark(law.evaluate, gap, st, out=out, check=False)
    finally:
        numba.set_num_threads(nt)
    # the same numbers as the numpy reference (the tests' tolerance, test_reference.py)
    Fr = evaluate_reference(law, gap[:500], st.take(np.arange(500)))[0]
    np.testing.assert_allclose(out[0][:500], Fr, rtol=1e-12, atol=1e-12 * 3e6)


def test_bench_copy_roofline_3d(benchmark, request):
    n = _n(request)
    law, gap, st, (F, T, new) = setup(n, parallel=False, dim=3)
    args = (gap, st.kappa, st.damage, st.separation, st.slip, st.dissipated,
            F, T, new.kappa, new.damage, new.separation, new.slip, new.dissipated)
    import numba
    nt = numba.config.NUMBA_NUM_THREADS
    numba.set_num_threads(1)
    try:
        copy_roofline(*args)
        benchmark.extra_info.update(points=n, threads=1, dim=3)
        benchmark(copy_roofline, *args)
    finally:
        numba.set_num_threads(nt)
    assert np.array_equal(F, gap)


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
        copy_roofline(*args)
        benchmark.extra_info.update(points=n, threads=1 if threads == "1" else nt)
        benchmark(copy_roofline, *args)
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


# ------------------------------------------------------------------------------------------
def same_run_ratios(n=10**6, rounds=15, before=None):
    """Medians of ``rounds`` interleaved rounds, one thread: law kernel (serial) / copy kernel of
    the same bytes, 2D and 3D, interleaved and blocked states; with ``before`` (a path to an
    earlier interfacelaw/_kernels.py) its evaluate_serial too, in the same rounds. Returns
    {(dim, layout): {name: seconds}}."""
    import importlib.util
    import statistics
    import time

    import numba
    old = None
    if before is not None:
        spec = importlib.util.spec_from_file_location("kernels_before", before)
        old = importlib.util.module_from_spec(spec)
        import sys
        sys.modules["kernels_before"] = old      # importable by name: numba's cache needs it
        spec.loader.exec_module(old)
    numba.set_num_threads(1)
    cases = {}
    for dim in (2, 3):
        for layout in ("interleaved", "blocked"):
            law, gap, st, (F, T, new) = setup(n, parallel=False, layout=layout, dim=dim)
            sa = (st.kappa, st.damage, st.separation, st.slip, st.dissipated)
            na = (F, T, new.kappa, new.damage, new.separation, new.slip, new.dissipated)
            fs = {"law": lambda law=law, gap=gap, st=st, o=(F, T, new):
                  law.evaluate(gap, st, out=o, check=False),
                  "copy": lambda gap=gap, sa=sa, na=na: copy_roofline(gap, *sa, *na)}
            if old is not None:
                fs["before"] = (lambda law=law, gap=gap, sa=sa, na=na: old.evaluate_serial(
                    gap, *law.kernel_params, 1.0, *sa, *na))
            cases[(dim, layout)] = fs
    for fs in cases.values():
        for f in fs.values():
            f()                                               # compile
    t = {k: {m: [] for m in fs} for k, fs in cases.items()}
    for _ in range(rounds):
        for k, fs in cases.items():
            for m, f in fs.items():
                t0 = time.perf_counter()
                f()
                t[k][m].append(time.perf_counter() - t0)
    return {k: {m: statistics.median(v) for m, v in d.items()} for k, d in t.items()}


if __name__ == "__main__":
    import argparse
    ap = argparse.ArgumentParser(description="law kernel / copy kernel, same process")
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--n", type=int, default=10**6)
    ap.add_argument("--before", default=None, help="an earlier interfacelaw/_kernels.py")
    a = ap.parse_args()
    res = same_run_ratios(a.n, a.rounds, a.before)
    print(f"n = {a.n}, 1 thread, medians of {a.rounds} interleaved rounds [M points/s]")
    for (dim, layout), med in res.items():
        cols = "  ".join(f"{m} {a.n / v / 1e6:6.1f}" for m, v in med.items())
        rat = f"law/copy {med['law'] / med['copy']:.2f}"
        if "before" in med:
            rat += f"  before/copy {med['before'] / med['copy']:.2f}  " \
                   f"speed-up {med['before'] / med['law']:.2f}"
        print(f"{dim}D {layout:11s} {cols}  | {rat}")
