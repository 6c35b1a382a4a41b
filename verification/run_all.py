"""Run every verification study (`make verify`; `--fast` for the quick versions the tests run).

Each study is a module of the ``verification`` package with ``main(fast: bool = False,
outdir=None)`` that writes its tables and figures into ``outdir`` and returns its numbers.
"""
from __future__ import annotations

import argparse
import importlib
import pathlib
import sys
import time

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent
# in the order of the report; benchmarks (bench_koyna, write_benchmarks) run with `make bench`
STUDIES = ["material_point", "damage_rate", "scaling_plots", "ground_motion_plot",
           "model_checks", "time_integration_checks", "energy_balance", "dcb_study", "reservoir",
           "safety_column", "koyna_studies", "damage_rate_koyna", "pine_flat",
           "pine_flat_linear", "sliding", "koyna_records", "slammer", "rocking",
           "debonding_step_refinement", "fuzz_edges", "reduced_bulk"]


# studies renamed for what they check: the old name still works with --only for one round
RENAMED = {"newmark_checks": "time_integration_checks", "unzip": "debonding_step_refinement",
           "bench_speed2": "bench_speed_targets"}


def run_study(name: str, fast: bool, outdir):
    """One study the way ``make verify`` runs it: ``verification.<name>.main(fast=fast,
    outdir=outdir)`` (the tests run the fast forms through this call)."""
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    mod = importlib.import_module(f"verification.{name}")
    return mod.main(fast=fast, outdir=outdir)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--fast", action="store_true", help="quick versions (seconds)")
    ap.add_argument("--only", nargs="*", default=None, help="run only these studies")
    ap.add_argument("--out", default=str(HERE / "out"))
    a = ap.parse_args(argv)
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    failed = []
    for name in a.only or STUDIES:
        if name in RENAMED:
            print(f"[verify] {name} is now {RENAMED[name]} (the old name works for one round)")
            name = RENAMED[name]
        if not (HERE / f"{name}.py").exists():
            print(f"[verify] {name}: not present, skipped")
            continue
        t0 = time.perf_counter()
        try:
            summary = run_study(name, a.fast, out)
            print(f"[verify] {name}: done in {time.perf_counter() - t0:.1f} s")
            if isinstance(summary, str):
                print(summary)
        except Exception as exc:  # report every study, then fail
            failed.append(name)
            print(f"[verify] {name}: FAILED: {exc!r}")
    print(f"[verify] report files in {out}")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
