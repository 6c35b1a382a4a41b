"""Shared test helpers: the one way tests load a verification study (its ``main(fast, outdir)``
in the fast version)."""
import importlib
import os
import pathlib
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.fixture
def study():
    """``study("energy_balance")`` -> the module ``verification.energy_balance``."""
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))

    def load(name):
        return importlib.import_module(f"verification.{name}")
    return load


@pytest.fixture
def cli_env():
    """The environment for a subprocess running the command from this checkout."""
    env = dict(os.environ)
    env.setdefault("NUMBA_CACHE_DIR", str(ROOT / ".numba_cache"))
    env.setdefault("MPLBACKEND", "Agg")
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env
