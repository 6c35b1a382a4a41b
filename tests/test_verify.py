"""``make verify`` runs every study of verification/run_all.STUDIES as ``main(fast, outdir)``:
each study's fast form runs in the test suite through that same call (``run_all.run_study``),
so that a study cannot fall out of ``make verify`` unnoticed (reservoir.py and
safety_column.py once had main(argv) and made ``make verify`` exit 2)."""
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
    assert (tmp_path / HERE[name]).stat().st_size > 100
