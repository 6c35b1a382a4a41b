"""verification/koyna_studies.py in its --fast form (koyna_smoke scene, 0.1 s, 2 values per knob).

Assertions and why they are robust:
* the report has every row (sweep, Gauss points, dt, g_max for both alphas, repeatability) and the
  PNGs and the summary exist;
* repeatability: two runs with identical settings give the same crack length, peak crest
  displacement and max D to 1e-12 — the whole error-against-run-time study rests on differences
  between runs being caused by the knob, not by run-to-run noise (ARPACK's random start vector
  once made identical runs differ by 1e-11, docs/model.md §8);
* g_max: for each alpha the max damage falls when g_max grows tenfold (Eq. 7: every increment
  gives (dg/g_max)^alpha, so a tenfold g_max divides each increment by 10^alpha; a changed path
  cannot undo a factor 10-100);
* every number in the records is finite.
"""
import math
import time

import pytest

pytest.importorskip("ngsolve")


from conftest import run_fast_study  # noqa: E402
from verification import koyna_studies as ks  # noqa: E402  (the package, as conftest's study)


@pytest.fixture(scope="module")
def fast_study(tmp_path_factory):
    out = tmp_path_factory.mktemp("koyna_studies")
    t0 = time.perf_counter()
    msg = run_fast_study("koyna_studies", out)
    return out, msg, ks.LAST_STATE, time.perf_counter() - t0


def test_report_rows_and_files(fast_study):
    out, msg, state, wall = fast_study
    md = (out / "koyna_studies.md").read_text()
    cfg = ks.FAST
    for s in cfg["sweep"]:
        assert f"\n| {s:g} | " in md, f"sweep row {s}"
    for n in cfg["gauss"]:
        assert f"| n = {n}" in md, f"gauss row n={n}"
    for d in cfg["dts"]:
        assert f"| dt = {1e3 * d:g} ms" in md, f"dt row {d}"
    for a in cfg["alphas"]:
        for m in cfg["gmax"]:
            assert f"| {a:g} | {m:g} | " in md, f"g_max row alpha={a} g_max={m} l_Nc"
    assert "## Repeatability" in md
    for f in ("koyna_intensity_sweep.png", "koyna_work_precision.png", "koyna_dt_damage.png",
              "koyna_gmax.png", "koyna_studies_summary.txt"):
        assert (out / f).stat().st_size > 0, f
    assert "gauss_points" in msg


def test_repeatable(fast_study):
    _, _, state, _ = fast_study
    R = state["runner"].records
    a, b = (R[ks.tag_of(s)] for s in state["repeat"])
    for key in ("L_end", "L_tot", "ux_peak", "D_max", "D_heel"):
        assert abs(a[key] - b[key]) <= 1e-12 * max(1.0, abs(a[key])), key


def test_gmax_monotone_and_finite(fast_study):
    _, _, state, _ = fast_study
    R = state["runner"].records
    for rec in R.values():
        for key in ("wall", "L_end", "ux_peak", "D_max", "D_heel"):
            assert math.isfinite(rec[key]), (rec["tag"], key)
    for a in ks.FAST["alphas"]:
        rr = sorted((R[ks.tag_of(s)] for s in state["gmax_sets"] if s["interface.alpha"] == a),
                    key=lambda r: r["sets"]["interface.g_max"])
        D = [r["D_max"] for r in rr]
        assert all(x > y for x, y in zip(D, D[1:])), (a, D)
