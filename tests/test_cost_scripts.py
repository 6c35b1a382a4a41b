"""The fast forms of two speed measurements of issue 32 (their full forms: BENCHMARKS.md "FAST"):
``verification/reduced_cost.py`` (target 2) and ``verification/newton_cost.py``."""
import pathlib
import sys

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "verification"))

import newton_cost  # noqa: E402
import step_cost  # noqa: E402
import reduced_cost  # noqa: E402


def write_series(d, crest, crack):
    d.mkdir()
    rows = "\n".join(f"{k},{0.002 * k},{c},{a}" for k, (c, a) in enumerate(zip(crest, crack)))
    (d / "timeseries.csv").write_text("# a run's header\nstep,t,crest_ux,crack_length_heel\n"
                                      + rows + "\n")
    return {"dir": str(d), "h_heel": 0.1}


def test_reduced_cost_accuracy_is_the_largest_crest_error_over_the_full_peak(tmp_path):
    """Hand-computed: the full crest peaks at 0.02 m, the reduced one is off by 1.5e-4 m at its
    third step (0.75 % of the peak: within target 2's 1 %), the final heel cracks differ by
    0.08 m (within one 0.1 m element); a 0.3 mm error (1.5 %) and a 0.15 m crack fail."""
    full = write_series(tmp_path / "f", [0.0, 0.01, 0.02, -0.005], [0.0, 0.1, 0.5, 0.6])
    red = write_series(tmp_path / "r", [0.0, 0.0101, 0.02015, -0.005], [0.0, 0.1, 0.5, 0.68])
    a = reduced_cost.accuracy(red, full)
    assert a["crest_err_over_peak"] == pytest.approx(1.5e-4 / 0.02, rel=1e-9)
    assert a["crest_ok"] and a["heel_crack_ok"]
    assert a["heel_crack_diff_m"] == pytest.approx(0.08, rel=1e-9)
    bad = write_series(tmp_path / "b", [0.0, 0.0103, 0.0203, -0.005], [0.0, 0.1, 0.5, 0.75])
    b = reduced_cost.accuracy(bad, full)
    assert not b["crest_ok"] and not b["heel_crack_ok"]


def test_newton_cost_measures_a_short_reduced_run():
    """koyna_smoke, 0.1 s on the reduced bulk: every step is timed, the Newton loop's time is a
    part of the loop's, and the Newton counters are those of the solver."""
    r = newton_cost.measure("koyna_smoke", 0.1)
    assert r["steps"] == 50
    assert 0.0 < r["newton_total_s"] <= r["loop_wall_s"]
    assert np.isfinite(r["step_median_ms"]) and r["step_median_ms"] > 0
    assert set(r["stats"]) >= {"jacobian_solves", "jacobian_factorisations"}


def test_step_cost_times_every_step_and_its_parts():
    """``verification/step_cost.py`` on koyna_smoke, 0.1 s (50 steps of 2 ms): each step is timed,
    the solver's step is a part of the run's step, and one forward + backward solve is timed."""
    r = step_cost.measure(0.1, parts=True, scene="koyna_smoke")
    assert r["steps"] == 50
    assert 0.0 < r["solver_step_median_ms"] <= r["run_step_median_ms"]
    assert r["fwd_bwd_ms"] > 0 and r["ratio_median"] == pytest.approx(
        r["run_step_median_ms"] / r["fwd_bwd_ms"], rel=1e-12)
    assert r["parts_calls"]["run: energy budget"] == 50
