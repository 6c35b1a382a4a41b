"""Shared test helpers: the one way tests load a verification study (its ``main(fast, outdir)``
in the fast version)."""
import importlib
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
