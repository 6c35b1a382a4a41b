"""What the studies share around their ``main(fast, outdir)``: the output folder, the report
pair (markdown + JSON) and the command line ``[--fast] [--out DIR]`` that runs ``main`` and
prints the report."""
from __future__ import annotations

import argparse
import json
import pathlib

__all__ = ["study_dir", "write_report", "run_from_command_line"]


def study_dir(outdir, here: pathlib.Path) -> pathlib.Path:
    """``outdir`` (default ``here / "out"``), created."""
    out = pathlib.Path(outdir if outdir is not None else here / "out")
    out.mkdir(parents=True, exist_ok=True)
    return out


def write_report(out: pathlib.Path, name: str, markdown: str, numbers: dict) -> None:
    """``out/name.md`` and ``out/name.json`` (floats of numpy types written as floats)."""
    (out / f"{name}.md").write_text(markdown)
    (out / f"{name}.json").write_text(json.dumps(numbers, indent=1, default=float))


def run_from_command_line(main, doc: str, name: str, here: pathlib.Path,
                          fast_help: str | None = None) -> None:
    """``python verification/<name>.py [--fast] [--out DIR]``: ``main(fast, out)``, then the
    report ``out/name.md`` printed."""
    ap = argparse.ArgumentParser(description=doc.split("\n")[0])
    ap.add_argument("--fast", action="store_true", help=fast_help)
    ap.add_argument("--out", default=str(here / "out"))
    a = ap.parse_args()
    main(a.fast, a.out)
    print((pathlib.Path(a.out) / f"{name}.md").read_text())
