"""Run every verification study (`make verify`; `--fast` for the quick versions used by tests).

Each study is a module in this folder with ``main(fast: bool, outdir: pathlib.Path)`` that writes
its PNGs and a markdown section into ``outdir`` and returns a short summary string.
"""
from __future__ import annotations

import argparse
import importlib
import inspect
import pathlib
import sys
import time

HERE = pathlib.Path(__file__).resolve().parent
STUDIES = ["material_point", "scaling_plots", "ground_motion_plot", "model_checks",
           "newmark_checks", "dcb_study", "koyna_studies"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--fast", action="store_true", help="quick versions (seconds)")
    ap.add_argument("--only", nargs="*", default=None, help="run only these studies")
    ap.add_argument("--out", default=str(HERE / "out"))
    a = ap.parse_args(argv)
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    sys.path.insert(0, str(HERE))
    failed = []
    for name in a.only or STUDIES:
        if not (HERE / f"{name}.py").exists():
            print(f"[verify] {name}: not present, skipped")
            continue
        t0 = time.perf_counter()
        try:
            mod = importlib.import_module(name)
            params = inspect.signature(mod.main).parameters
            if "outdir" in params:
                summary = mod.main(fast=a.fast, outdir=out)
            else:                                   # argparse-style main(argv)
                summary = mod.main((["--fast"] if a.fast else []) + ["--out", str(out)])
            if not isinstance(summary, str):
                summary = None
            print(f"[verify] {name}: done in {time.perf_counter() - t0:.1f} s")
            if summary:
                print(summary)
        except Exception as exc:  # report every study, then fail
            failed.append(name)
            print(f"[verify] {name}: FAILED: {exc!r}")
    print(f"[verify] report files in {out}")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
