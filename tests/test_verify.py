"""``make verify`` runs every study of verification/run_all.STUDIES as ``main(fast, outdir)``:
each study's fast form runs in the test suite through that same call (``run_all.run_study``),
so that a study cannot fall out of ``make verify`` unnoticed (reservoir.py and
safety_column.py once had main(argv) and made ``make verify`` exit 2). The two studies run
only here have their reports' numbers checked against their references."""
import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]

from verification import run_all  # noqa: E402

# studies whose fast form only this file runs (the others have their own tests, which call
# them through ``conftest.run_fast_study`` / the ``study`` fixture: both are run_all's call)
HERE = {"reservoir": "reservoir.md", "safety_column": "safety_column.md"}


def _called_elsewhere(name) -> list[str]:
    """Test files that run study ``name``'s fast form through run_all's call."""
    pat = re.compile(rf"""(run_fast_study|study)\(\s*["']{name}["']""")
    return [f.name for f in sorted((ROOT / "tests").glob("test_*.py"))
            if f.name != pathlib.Path(__file__).name and pat.search(f.read_text())]


def test_every_study_is_run_through_run_all_by_some_test():
    missing = [n for n in run_all.STUDIES if n not in HERE and not _called_elsewhere(n)]
    assert not missing, f"no test runs these studies through run_all.run_study: {missing}"
    assert set(HERE) <= set(run_all.STUDIES)


@pytest.mark.parametrize("name", sorted(HERE))
@pytest.mark.slow
def test_study_fast_form_through_make_verify(name, tmp_path, capsys):
    """``verification/run_all.py --fast --only NAME``: exit 0 and the study's report."""
    pytest.importorskip("ngsolve")
    rc = run_all.main(["--fast", "--only", name, "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert rc == 0, out
    assert f"[verify] {name}: done" in out
    md = (tmp_path / HERE[name]).read_text()
    CHECKS[name](md)


def _rows(md: str, heading: str) -> list[list[str]]:
    """The body rows of the first table after the line starting with ``heading``."""
    lines = md.splitlines()
    i = next(k for k, ln in enumerate(lines) if ln.startswith(heading))
    rows, seen = [], False
    for ln in lines[i + 1:]:
        if ln.startswith("|"):
            seen = True
            cells = [c.strip() for c in ln.strip("|").split("|")]
            if not set(cells[0]) <= set("-") and not cells[0].startswith(("r_x", "h wall",
                                                                           "wave")):
                rows.append(cells)
        elif seen:
            break
    return rows


def _check_reservoir(md):
    """Westergaard's added mass against 7/12 rho H^2 within 1e-5 (measured 8.1e-7: the
    quadrature of the sqrt profile on the face's elements); the rigid wall's force against the
    exact 0.54275 rho a H^2 within 5e-3 (measured -2.3e-3 on the fast 2 m mesh, -9.6e-4 on
    the 1 m mesh of the full study: the P1 water's O(h^2)) and its pressure profile within
    1e-2 of p_max (measured 4.9e-3)."""
    (wm,) = _rows(md, "## 1.")
    assert abs(float(wm[2])) < 1e-5, wm
    assert float(wm[0]) == pytest.approx(float(wm[1]), rel=1e-5)
    rw = _rows(md, "## 2.")
    assert rw
    for r in rw:
        assert abs(float(r[4])) < 5e-3 and float(r[5]) < 1e-2, r
        assert float(r[2]) == pytest.approx(0.54275, abs=5e-3)


def _check_safety_column(md):
    """The Lysmer-Kuhlemeyer bottom leaves < 1e-3 of the pulse's energy in the column (measured
    1.3e-5 S, 6.7e-5 P), where the same column with a free bottom keeps all of it (1.000)."""
    rows = _rows(md, "| wave")
    assert {(r[0], r[3]) for r in rows} >= {("S", "dashpots"), ("P", "dashpots"),
                                           ("S", "free"), ("P", "free")}
    for r in rows:
        e = float(r[4])
        assert (e < 1e-3) if r[3] == "dashpots" else (e > 0.99), r


CHECKS = {"reservoir": _check_reservoir, "safety_column": _check_safety_column}


def test_renamed_studies_keep_their_old_name_for_one_round(tmp_path, monkeypatch, capsys):
    """``--only OLDNAME`` of a study renamed for what it checks runs the renamed study and says
    its new name; every new name is a study file (a rename cannot point nowhere)."""
    ran = []
    monkeypatch.setattr(run_all, "run_study", lambda name, fast, out: ran.append(name) or "")
    old = sorted(run_all.RENAMED)
    assert run_all.main(["--fast", "--only", *old, "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert ran == [run_all.RENAMED[n] for n in old]
    assert all(f"{n} is now {run_all.RENAMED[n]}" in out for n in old), out
    assert all((ROOT / "verification" / f"{n}.py").is_file() for n in run_all.RENAMED.values())
    assert not any((ROOT / "verification" / f"{n}.py").exists() for n in old)
