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


def test_step_cost_floor_groups_the_parts_and_forms_the_targets_ratios():
    """``step_cost.floor_table`` on hand-made ``--parts`` medians: the factor's halves are the
    four "factor:" parts, the water its solve and commit, "compiled" halves + products + water;
    target 1's ratios are over fb = 0.5 ms, target 2's budget is 0.1 x the full step (0.2 ms).
    Hand-computed: full compiled 0.4+0.3+0.1 = 0.8 ms = 1.6 fb, with Newton 0.3: 2.2 fb; the
    reduced bulk 0.12 + 0.1 = 0.22 ms = 1.1 x the 0.2 ms budget."""
    def m(halves, prod, water, newton, step, fb=0.5):
        p = {"  factor: forward (+ low-rank)": halves / 2, "  factor: backward": halves / 4,
             "  factor: backward at the interface": halves / 8,
             "  factor: forward from the interface": halves / 8,
             step_cost.PRODUCTS: prod, step_cost.WATER[0]: water / 2,
             step_cost.WATER[1]: water / 2, step_cost.NEWTON: newton,
             "run: energy budget": 0.05, "run: history row": 0.01, "run: stop rule": 0.02,
             "solver: condensed Newton attempt": 9.0}       # a containing part: not summed
        return {"parts_median_ms": p, "fwd_bwd_ms": fb, "run_step_median_ms": step}
    t = step_cost.floor_table(m(0.4, 0.3, 0.1, 0.3, 2.0), m(0.12, 0.1, 0.06, 0.2, 0.8))
    assert t["full"]["compiled"] == pytest.approx(0.8, rel=1e-12)
    assert t["full"]["run_parts"] == pytest.approx(0.03, rel=1e-12)
    assert t["full_compiled_over_fb"] == pytest.approx(1.6, rel=1e-12)
    assert t["full_compiled_newton_over_fb"] == pytest.approx(2.2, rel=1e-12)
    assert t["target2_step_budget_ms"] == pytest.approx(0.2, rel=1e-12)
    assert t["reduced_bulk_over_budget"] == pytest.approx(1.1, rel=1e-12)
    assert t["reduced_step_over_full_step"] == pytest.approx(0.4, rel=1e-12)
