"""The docs stay honest: every repository path they name exists, every relative link resolves,
every section a link names (``[run.md](run.md) §4``) is a numbered heading of that page, every
dotted module name (``ngs_driver.apps.dam.run``) is in the tree, every ``--flag`` given to a
verification script is defined by it, and no page carries the history that belongs in
CHANGELOG.md.

Reads README.md and docs/*.md (no imports of the project, no subprocess: well under a second).
A *path* is a token of a code span (`...`) or of a fenced code block that

* contains "/" and either starts with a top-level entry of the repository (``ngs_driver/post/``)
  or ends in .py/.md/.toml/.csv (``fe/model.py`` is caught: it is not a repository path), or
* has no "/" and ends in .py/.md/.toml/.csv (a file name: it must exist somewhere in the tree,
  or be one of the files a run or the user writes, ``WRITTEN`` below).

Not paths: URLs, absolute paths, flags, and paths under the folders a run or a study writes
(``IGNORED_PREFIXES``). ``<placeholder>`` and ``*`` are globs (at least one match); a
``file.py::test`` or ``file.py:name`` suffix names something inside the file.
"""
import fnmatch
import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md"] + sorted((ROOT / "docs").glob("*.md"))
EXTS = (".py", ".md", ".toml", ".csv")
SKIP_DIRS = {".git", ".venv", ".numba_cache", "__pycache__", ".benchmarks", ".pytest_cache",
             "results", "out"}
# folders written by runs, studies and verification (git-ignored or user-chosen): not repository
# paths. D/, DIR/, BASE/ are the user's folder in the study and run-paper examples.
IGNORED_PREFIXES = ("results/", "out/", "runs/", "vtk/", "verification/out/", ".venv/",
                    "D/", "DIR/", "BASE/", "koyna_studies_runs/")
# files a run, a study or the user writes (named in the docs as outputs or inputs, never
# shipped)
WRITTEN = {
    "timeseries.csv", "crest_displacement.csv", "damage_profiles.csv", "results.md",
    "REPORT.md", "reservoir_pressure.csv", "frequency_response.csv", "history.csv", "ida.csv",
    "dcb.md", "model_checks.md", "koyna_studies.md", "damage_rate_koyna.md", "scaling.md",
    "reservoir.md", "section.csv", "neck.toml", "damage_profiles_<joint>.csv",
}
TOKEN_STRIP = "()[]{},;'\"`.:!?"
FORBIDDEN = ("issue #", "docs/decisions.md")


def _tree():
    """(top-level entry names, every file name in the tree): one walk, pruned."""
    top = {p.name for p in ROOT.iterdir()}
    names = set()
    for dirpath, dirnames, filenames in os.walk(ROOT):
        dirnames[:] = [d for d in dirnames if d not in SKIP_DIRS and not d.endswith(".egg-info")]
        names.update(filenames)
    return top, names


TOP, NAMES = _tree()
SPAN = re.compile(r"(?<!`)`([^`\n]+)`(?!`)")
FENCE = re.compile(r"^```[^\n]*\n(.*?)^```", re.S | re.M)
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")


def _tokens(text):
    """Whitespace-separated tokens of the code spans and fenced blocks of a page."""
    fences = FENCE.findall(text)
    prose = FENCE.sub("", text)
    for chunk in SPAN.findall(prose) + fences:
        for tok in chunk.split():
            tok = tok.strip(TOKEN_STRIP)
            if "=" in tok:                       # --out=DIR, key=value
                tok = tok.split("=", 1)[1].strip(TOKEN_STRIP)
            yield tok


def _is_path(tok):
    if not tok or tok.startswith(("-", "/", "~", "$", "<")) or "://" in tok:
        return False
    if "/" in tok:
        return tok.split("/", 1)[0] in TOP or tok.endswith(EXTS)
    return tok.endswith(EXTS)


def _exists(tok):
    tok = re.sub(r"::.*$", "", tok)              # file.py::test_name
    tok = re.sub(r"(\.py):\w.*$", r"\1", tok)    # file.py:function
    if tok.startswith(IGNORED_PREFIXES) or tok in WRITTEN:
        return True
    pattern = re.sub(r"<[^>]*>", "*", tok)
    if "/" not in pattern:
        return (pattern in WRITTEN or (ROOT / pattern).exists()
                or any(fnmatch.fnmatch(n, pattern) for n in NAMES))
    if "*" in pattern:
        return any(ROOT.glob(pattern.rstrip("/")))
    return (ROOT / pattern).exists()


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_named_paths_exist(page):
    text = page.read_text(encoding="utf-8")
    missing = sorted({t for t in _tokens(text) if _is_path(t) and not _exists(t)})
    assert not missing, f"{page.name} names paths that do not exist: {missing}"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_relative_links_resolve(page):
    text = FENCE.sub("", page.read_text(encoding="utf-8"))
    bad = []
    for target in LINK.findall(text):
        if target.startswith(("http://", "https://", "mailto:", "#")):
            continue
        path = target.split("#", 1)[0]
        if not (page.parent / path).exists():
            bad.append(target)
    assert not bad, f"{page.name} has links that do not resolve: {bad}"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_no_history_markers(page):
    """Which issue asked for what is git's and CHANGELOG.md's business, not a reference page's."""
    text = page.read_text(encoding="utf-8")
    found = [s for s in FORBIDDEN if s in text]
    assert not found, f"{page.name} contains {found}"


SECTION_REF = re.compile(r"\[[^\]]*\]\(([^)\s#]+\.md)\)\s*§\s*(\d+(?:\.\d+)*)")
HEADING_NUMBER = re.compile(r"^#+\s+(\d+(?:\.\d+)*)[.\s]", re.M)


def _section_numbers(path):
    """The numbers of a page's numbered headings ("## 4. The collapse rule" -> "4")."""
    return set(HEADING_NUMBER.findall(path.read_text(encoding="utf-8")))


def _bad_section_refs(page, text):
    bad = []
    for target, number in SECTION_REF.findall(FENCE.sub("", text)):
        path = page.parent / target
        if path.exists() and number not in _section_numbers(path):
            bad.append(f"{target} §{number}")
    return bad


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_section_references_resolve(page):
    """``[run.md](run.md) §4``: the linked page has a heading numbered 4 (a renumbered page
    shows here)."""
    bad = _bad_section_refs(page, page.read_text(encoding="utf-8"))
    assert not bad, f"{page.name} refers to sections that do not exist: {bad}"


DOTTED = re.compile(r"\b((?:ngs_driver|interfacelaw)(?:\.[A-Za-z_]\w*)+)")


def _dotted_exists(name):
    """``ngs_driver.post.outputs.RunOutputs``: the longest prefix that is a folder or a module
    of the tree, then the next name defined (or re-exported) in that module or in the package's
    __init__.py (a word match: read as text, nothing imported)."""
    parts, path = name.split("."), ROOT
    for i, part in enumerate(parts):
        if (path / part).is_dir():
            path = path / part
            continue
        if (path / f"{part}.py").is_file():
            path, rest = path / f"{part}.py", parts[i + 1:]
        else:
            path, rest = path / "__init__.py", parts[i:]
        break
    else:
        return True
    if not rest:
        return True
    src = path.read_text(encoding="utf-8") if path.is_file() else ""
    return re.search(rf"(^|\W){re.escape(rest[0])}\b", src) is not None


# a stage-relative name in a code span (`fe.coupling.build_joint_operator`): checked when its
# first two parts are a module of ngs_driver (`run.u_static`, a checkpoint key, is not one)
STAGE_DOTTED = re.compile(r"`((?:setup|fe|solve|run|post|apps|studies)\.\w+\.[A-Za-z_]\w*)")


def _dotted_names(text):
    names = set(DOTTED.findall(text))
    for name in STAGE_DOTTED.findall(text):
        stage, module = name.split(".")[:2]
        if (ROOT / "ngs_driver" / stage / f"{module}.py").is_file():
            names.add("ngs_driver." + name)
    return names


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_dotted_names_resolve(page):
    """A module or object a page names by its dotted path (``ngs_driver.apps.dam.run``, or
    stage-relative ``fe.coupling.build_joint_operator``) is in the tree: a module moved or a
    function renamed by a refactor shows here."""
    names = _dotted_names(page.read_text(encoding="utf-8"))
    bad = sorted(n for n in names if not _dotted_exists(n))
    assert not bad, f"{page.name} names modules or objects that do not exist: {bad}"


SCRIPT_CALL = re.compile(r"python (?:verification/(\w+)\.py|-m verification\.(\w+))"
                         r"((?:\s+\[?--[a-z][\w-]*\]?(?:\s+(?!--)[^\s`\[\]]+)?)*)")


def _unknown_flags(text):
    """(script, flag) pairs of ``python verification/x.py --flag`` where the script's source does
    not define the flag (read as text: its argparse strings)."""
    bad = []
    for a, b, flags in SCRIPT_CALL.findall(text):
        script = ROOT / "verification" / f"{a or b}.py"
        if not script.is_file():
            continue                              # test_named_paths_exist reports it
        src = script.read_text(encoding="utf-8")
        for flag in re.findall(r"--[a-z][\w-]*", flags):
            if f'"{flag}"' not in src and f"'{flag}'" not in src:
                bad.append((script.name, flag))
    return bad


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_script_flags_exist(page):
    """Every ``--flag`` a page passes to a verification script is one that script defines."""
    bad = _unknown_flags(page.read_text(encoding="utf-8"))
    assert not bad, f"{page.name} passes flags the scripts do not define: {bad}"


def test_readme_lists_the_shipped_scenes():
    """README's "Shipped scenes:" paragraph names every scene file of ngs_driver/scenes/ and
    nothing else (a scene added, renamed or removed shows here)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    para = text[text.index("Shipped scenes:"):].split("\n\n", 1)[0]
    named = set(re.findall(r"`([A-Za-z0-9_]+)`", para))
    shipped = {p.stem for p in (ROOT / "ngs_driver" / "scenes").glob("*.toml")}
    assert len(shipped) >= 10, shipped
    assert named == shipped, (sorted(shipped - named), sorted(named - shipped))


def test_the_checker_catches_what_it_should():
    """The checker itself: a wrong path, a partial path, a bad link are found; outputs and
    placeholders are not paths."""
    assert _is_path("ngs_driver/fe/model.py") and _exists("ngs_driver/fe/model.py")
    assert _is_path("fe/model.py") and not _exists("fe/model.py")
    assert _is_path("ngs_driver/nothing/") and not _exists("ngs_driver/nothing/")
    assert _exists("tests/test_docs.py::test_relative_links_resolve")
    assert _exists("interfacelaw/_kernels.py:_law")
    assert _exists("ngs_driver/scenes/<name>.toml") and _exists("tests/test_reservoir*.py")
    assert _exists("timeseries.csv") and not _exists("no_such_file.py")
    for tok in ("m/s2", "2/3-same", "tcp://HOST:8786", "/tmp/x.py", "--out", "g_T/|g_T|"):
        assert not _is_path(tok), tok
    assert _exists("results/koyna_alpha2/") and _exists("verification/out/REPORT.md")
    page = ROOT / "docs" / "any.md"                   # a page in docs/: its links are relative
    assert _bad_section_refs(page, "[run.md](run.md) §4 and [law.md](law.md) §6.5") == []
    assert _bad_section_refs(page, "[run.md](run.md) §42") == ["run.md §42"]
    assert _dotted_exists("ngs_driver.post.outputs.RunOutputs")
    assert _dotted_exists("ngs_driver.setup.ground_motion.generate_koyna_like")
    assert _dotted_exists("interfacelaw.cabi") and _dotted_exists("ngs_driver.apps")
    assert not _dotted_exists("ngs_driver.post.RunOutputs")       # not re-exported by post/
    assert not _dotted_exists("ngs_driver.ground_motion")         # it is setup/ground_motion.py
    assert not _dotted_exists("ngs_driver.setup.ground_motion.no_such_function")
    assert _dotted_names("`fe.coupling.build_interface` and `run.u_static`") == {
        "ngs_driver.fe.coupling.build_interface"}                  # a checkpoint key is skipped
    assert not _dotted_exists("ngs_driver.fe.coupling.build_interface")
    assert _unknown_flags("`python verification/step_cost.py --floor --repeat 2`") == []
    assert _unknown_flags("python verification/koyna_studies.py [--fast] [--jobs 2]") == []
    assert _unknown_flags("`python verification/step_cost.py --flor`") == [("step_cost.py",
                                                                            "--flor")]


def test_architecture_table_names_files_of_their_stage():
    """docs/architecture.md's table of concepts: every file a cell names is in that column's
    stage folder (``joints.py`` under run/ must be ngs_driver/run/joints.py), so that the table
    follows a rename. Self-check: the table has rows and names at least one file per stage."""
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    table = text[text.index("| concept | scene keys |"):]
    rows = [r for r in table.split("\n\n")[0].splitlines()[2:] if r.startswith("|")]
    stages = ("setup", "fe", "solve", "run", "post")
    seen, missing = {s: 0 for s in stages}, []
    for row in rows:
        cells = [c.strip() for c in row.strip("|").split("|")]
        for stage, cell in zip(stages, cells[2:7]):
            for name in re.findall(r"`(\w+\.py)`", cell):
                seen[stage] += 1
                if not (ROOT / "ngs_driver" / stage / name).is_file():
                    missing.append((cells[0], stage, name))
    assert len(rows) >= 10 and all(seen.values()), (len(rows), seen)
    assert not missing, missing


def test_architecture_solve_stage_lists_the_solve_folder():
    """docs/architecture.md "The solve stage": every file its table names is in
    ngs_driver/solve/, and every module of that folder is named in the section (a file added
    or renamed by a split shows here). Self-check: the table has at least ten rows."""
    text = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    sec = text[text.index("## The solve stage"):]
    sec = sec[:sec.index("\n## ", 1)]
    rows = [r for r in sec.splitlines() if r.startswith("| `")]
    named = {n for r in rows for n in re.findall(r"`(\w+\.py)`", r.split("|")[1])}
    missing = sorted(n for n in named if not (ROOT / "ngs_driver" / "solve" / n).is_file())
    folder = sorted(p.name for p in (ROOT / "ngs_driver" / "solve").glob("*.py")
                    if p.name != "__init__.py")
    unnamed = [n for n in folder if f"`{n}`" not in sec and f"solve/{n}`" not in sec]
    assert len(rows) >= 10, rows
    assert not missing, missing
    assert not unnamed, unnamed


def test_verification_page_lists_every_study():
    """Every study `make verify` runs (verification/run_all.py ``STUDIES``, read as text) has
    its row in docs/verification.md's table. Self-check: at least ten studies are read."""
    src = (ROOT / "verification" / "run_all.py").read_text(encoding="utf-8")
    block = re.search(r"^STUDIES = \[(.*?)\]", src, re.S | re.M).group(1)
    studies = re.findall(r'"(\w+)"', block)
    page = (ROOT / "docs" / "verification.md").read_text(encoding="utf-8")
    missing = [s for s in studies if f"| `verification/{s}.py` |" not in page]
    assert len(studies) >= 10, studies
    assert not missing, missing
