"""Shared test helpers: the one way tests load a verification study (its ``main(fast, outdir)``
in the fast version); and the compile time of the law's kernels on a cold numba cache (below)."""
import contextvars
import copy
import functools
import importlib
import os
import pathlib
import sys

import pytest

import compile_report

ROOT = pathlib.Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:       # verification/ importable by every test module
    sys.path.insert(0, str(ROOT))


def _share_scope_copy_in_numba_inlining():
    """Halve numba's compile time of the law's loops in the test processes, same machine code.

    Most of a cold-cache ``make test`` is numba compiling the loops of interfacelaw/_kernels.py
    (one per kind of law, dim, optional parts, serial/parallel), and half of each compile was
    ``copy.deepcopy`` in numba's IR inliner (``inline="always"``: ``_law`` into each loop):
    ``InlineWorker.inline_ir`` copies the callee block by block, each block with a fresh memo,
    so the callee's scope with all its variables is copied once per block (~1 M ``ir.Var``
    copies per loop; numba issue #8989). Here the block copies of one ``inline_ir`` call share
    one memo per scope: the scope is copied once. The same code out (numba 0.68.1): LLVM IR of
    13 loops compared identical, and the machine code (.text, .rodata) of all 122 functions a
    cold-cache make test compiles, read from the numba caches of a run with and one without
    this. 10-17 s -> 3-7 s per loop in a pytest process. Tests only (the library leaves numba
    alone); skipped if numba's internals are not the ones this was written for."""
    try:
        from numba.core import inline_closurecall as icc, ir
        inline_ir = icc.InlineWorker.inline_ir
    except (ImportError, AttributeError):
        return
    if icc.copy is not copy or getattr(inline_ir, "shared_scope_copy", False):
        return
    memos = contextvars.ContextVar("inline_ir_memos", default=None)

    class Copy:
        """The copy module as inline_closurecall sees it: inside inline_ir, a deepcopy of a
        block reuses the memo of the blocks of the same scope copied before it."""
        def __getattr__(self, name):
            return getattr(copy, name)

        @staticmethod
        def deepcopy(x, memo=None):
            active = memos.get()
            if memo is None and active is not None and type(x) is ir.Block:
                memo = active.setdefault(id(x.scope), {})
            return copy.deepcopy(x, memo)

    @functools.wraps(inline_ir)
    def shared(self, *args, **kwargs):
        token = memos.set({})   # the memos (and the originals they keep alive) live one call
        try:
            return inline_ir(self, *args, **kwargs)
        finally:
            memos.reset(token)

    shared.shared_scope_copy = True
    icc.InlineWorker.inline_ir = shared
    icc.copy = Copy()


_share_scope_copy_in_numba_inlining()

# opt-in: where a cold-cache run spends its compile time (tests/compile_report.py)
if os.environ.get("NUMBA_COMPILE_LOG"):
    compile_report.install(os.environ["NUMBA_COMPILE_LOG"])


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_protocol(item, nextitem):
    """The test file running in this process, for NUMBA_COMPILE_LOG (a no-op without it)."""
    compile_report.file_started(item.nodeid.split("::")[0])


def pytest_sessionfinish(session):
    compile_report.finish()


# The slowest files on a cold numba cache (a fresh clone, CI), the slowest first. Measured as
# CPU seconds per file on one worker (the worker's own CPU and its subprocesses', so not
# inflated by other jobs on the machine; BENCHMARKS.md "make test on a fresh clone"): reference
# 62, bench_speed_targets 45, law 44, studies 22, sliding 20, drivers 16, verify 13, cabi 9,
# damage_rate 9, safe_runs 9, pipeline 8, debonding_step_refinement 8, solver_stall 8,
# examples 7, real_dams 7, cli 6; every other file <= 5.
SLOWEST_FIRST = ("test_reference.py", "test_bench_speed_targets.py", "test_law.py",
                 "test_studies.py", "test_sliding.py", "test_drivers.py", "test_verify.py", "test_cabi.py",
                 "test_damage_rate.py", "test_safe_runs.py", "test_pipeline.py",
                 "test_debonding_step_refinement.py", "test_solver_stall.py", "test_examples.py",
                 "test_real_dams.py", "test_cli.py")


def pytest_collection_modifyitems(config, items):
    """The slowest files first, the rest in collection order (each file's tests stay together
    and in order). With make test's ``-n 2 --dist loadfile`` each idle worker takes the next
    file: longest first, the two workers end within seconds of each other. In xdist's order
    (by number of tests) the slowest file, test_reference.py, started last and ran alone for
    1.5-3 min while the other worker sat idle."""
    rank = {name: i for i, name in enumerate(SLOWEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))


def pytest_configure(config):
    """xdist's loadfile would sort the files by their number of tests (test_law.py with 84
    first, test_reference.py with 7 late) instead of the order above; keep the order unless
    --loadscope-reorder is asked for explicitly (the option exists from pytest-xdist 3.8)."""
    if getattr(config.option, "loadscopereorder", False) \
            and "--loadscope-reorder" not in config.invocation_params.args:
        config.option.loadscopereorder = False


def run_fast_study(name, outdir):
    """The fast form of verification study ``name`` through ``make verify``'s own call
    (``verification/run_all.run_study``): a study whose ``main`` drifts from the
    ``main(fast, outdir)`` convention fails its test, not only ``make verify``."""
    from verification import run_all
    return run_all.run_study(name, True, outdir)


class _Study:
    """A verification module whose ``main(fast=True, outdir=...)`` runs through
    ``run_fast_study`` (every other attribute is the module's)."""

    def __init__(self, name):
        self._name = name
        self._mod = importlib.import_module(f"verification.{name}")

    def main(self, fast=True, outdir=None):
        assert fast, "the tests run the fast forms"
        return run_fast_study(self._name, outdir)

    def __getattr__(self, attr):
        return getattr(self._mod, attr)


@pytest.fixture
def study():
    """``study("energy_balance")`` -> the module ``verification.energy_balance``, its ``main``
    called the way ``make verify`` calls it."""
    return _Study


@pytest.fixture
def cli_env():
    """The environment for a subprocess running the command from this checkout."""
    env = dict(os.environ)
    env.setdefault("NUMBA_CACHE_DIR", str(ROOT / ".numba_cache"))
    env.setdefault("MPLBACKEND", "Agg")
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env
