"""Command line: ``dam-seismic`` / ``python -m ngs_driver``.

    run SCENE [--set key=value ...] [--resume | --overwrite] [--dry-run] [--out DIR] [--quiet]
    run-paper [SCENE] [--set ...] [--out DIR] [--resume | --overwrite] [--dry-run] [--quiet]
                                                           alpha = 2 and alpha = 1 + comparison
    compare DIR_A DIR_B [--out DIR]                        comparison of two finished runs
    modal SCENE [--set ...] [--out DIR] [-n N]             natural frequencies -> modal.json
    verify [--fast]                                        verification/run_all.py
    bench                                                  pytest benchmarks (tests/bench)

Exit codes: 0 success, 1 run failure (solver, I/O), 2 bad input (scene, --set, arguments; a
results folder in use by another run, not writable, or holding a finished run or a checkpoint
without --overwrite/--resume; a damaged checkpoint), 3 interrupted.  Input errors are reported
before any results directory is created; the folder is then created and probed for writing
(--dry-run too, which removes what it created).
NGSolve is imported only when a model is built (never by --dry-run).
"""
from __future__ import annotations

import os

# One BLAS/OpenMP thread unless the user chose otherwise: the run's dense work is small (dot
# products of 1e4 entries, 224 x 224 systems) and threaded BLAS on a busy 2-core machine spent
# 86 s where one thread spent 9 s on the same 1 500 steps of the 0.2x Koyna run
# (BENCHMARKS.md). Set before numpy is first imported (the env is read then).
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import gc
import json
import pathlib
import subprocess
import sys

from .apps.heap import fix_heap_thresholds  # noqa: E402  (ctypes only: no NGSolve, no numpy)

ROOT = pathlib.Path(__file__).resolve().parent.parent


class _Parser(argparse.ArgumentParser):
    def error(self, message):          # exit code 2 with the usage (argparse default)
        self.print_usage(sys.stderr)
        self.exit(2, f"{self.prog}: error: {message}\n")


def _add_scene_args(p, scene_default=None):
    if scene_default is None:
        p.add_argument("scene", help="shipped scene name (e.g. koyna) or path to a .toml file")
    else:
        p.add_argument("scene", nargs="?", default=scene_default,
                       help=f"shipped scene name or .toml path (default {scene_default})")
    p.add_argument("--set", action="append", default=[], dest="overrides", metavar="KEY=VALUE",
                   help="override a scene key, e.g. --set interface.alpha=1 (repeatable)")
    p.add_argument("--out", default=None, help="results directory (default: output.dir)")


def build_parser() -> argparse.ArgumentParser:
    ap = _Parser(prog="dam-seismic", description=__doc__,
                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True, parser_class=_Parser)
    p = sub.add_parser("run", help="static + seismic run of a scene")
    _add_scene_args(p)
    p.add_argument("--resume", action="store_true", help="continue from the last checkpoint")
    p.add_argument("--overwrite", action="store_true",
                   help="the results folder may hold a finished run or a checkpoint: replace "
                        "them (else refused, exit 2)")
    p.add_argument("--dry-run", action="store_true",
                   help="print the resolved scene and what would be built; build nothing")
    p.add_argument("--quiet", action="store_true", help="no progress bar or messages")
    p = sub.add_parser("run-paper", help="run alpha = 2 and alpha = 1 and compare (make run)")
    _add_scene_args(p, "koyna")
    p.add_argument("--quiet", action="store_true")
    p.add_argument("--resume", action="store_true", help="resume unfinished runs")
    p.add_argument("--overwrite", action="store_true",
                   help="replace finished runs and checkpoints in the results folders")
    p.add_argument("--dry-run", action="store_true")
    p = sub.add_parser("compare", help="compare finished runs (Fig. 10/11 overlays, table)")
    p.add_argument("dirs", nargs="+", help="results directories (alpha = 2 first)")
    p.add_argument("--out", default="results/koyna_compare")
    p = sub.add_parser("modal", help="natural frequencies -> modal.json")
    _add_scene_args(p)
    p.add_argument("-n", type=int, default=6, help="number of modes")
    p = sub.add_parser("verify", help="verification studies (verification/run_all.py)")
    p.add_argument("--fast", action="store_true")
    p.add_argument("--out", default=None)
    sub.add_parser("bench", help="benchmarks (pytest tests/bench)")
    from .studies.cli import add_ida_parser   # IDA / fragility on Dask (docs/studies.md)
    add_ida_parser(sub)
    return ap


def _err(msg: str, code: int = 2) -> int:
    print(f"dam-seismic: error: {msg}", file=sys.stderr)
    return code


def _load(scene, overrides):
    # deferred: a command imports only what it runs (fast --help; --dry-run without NGSolve)
    from .scene import load_scene
    return load_scene(scene, overrides)


def _outdir(out, sc=None) -> pathlib.Path:
    """The results folder: --out, else the scene's output.dir; ValueError naming the key when
    it exists as a file (checked before anything is built or written)."""
    key, p = ("--out", out) if out else ("output.dir", sc.output.dir)
    p = pathlib.Path(p)
    if p.exists() and not p.is_dir():
        raise ValueError(f"{key} = {str(p)!r}: is an existing file; allowed: a folder (new or "
                         "existing)")
    return p


def _dry_run(sc, outdir) -> int:
    if sc.kind == "material_point":
        # deferred: a command imports only what it runs (fast --help; --dry-run without NGSolve)
        from .apps.point import describe_point as describe
    elif sc.kind == "dcb":
        # deferred: a command imports only what it runs (fast --help; --dry-run without NGSolve)
        from .apps.dcb import describe_dcb as describe
    else:
        # deferred: a command imports only what it runs (fast --help; --dry-run without NGSolve)
        from .setup import describe
    try:
        d = describe(sc)
    except ValueError as e:
        return _err(str(e))
    d["will_build"]["output_dir"] = str(outdir)
    print(json.dumps(d, indent=2))
    return 0


def _out_key(out) -> str:
    return "--out" if out else "output.dir"


def _folder_check(outdir, key, resume, overwrite, dry_run):
    """The results folder before anything is built: created and writable (a probe file; a dry
    run removes what it created), not in use by another run, and not holding a run that would
    be lost (run.folder). Returns the folder's lock, held (released at once by a dry run)."""
    # deferred: a command imports only what it runs (fast --help; --dry-run without NGSolve)
    from .run.folder import FolderLock, dry_run_probe, probe_writable, reuse_error
    if dry_run:
        if not outdir.is_dir():
            dry_run_probe(outdir, key)
            return None
        probe_writable(outdir, key)
    else:
        probe_writable(outdir, key)
    lock = FolderLock(outdir, key).acquire()
    try:
        why = reuse_error(outdir, resume=resume, overwrite=overwrite, key=key)
        if why is not None:
            raise ValueError(why)
    except BaseException:
        lock.release()
        raise
    if dry_run:
        lock.release()
        return None
    return lock


def cmd_run(a) -> int:
    if a.resume and a.overwrite:
        return _err("--resume and --overwrite: allowed: one of them (continue the checkpoint, "
                    "or replace what the folder holds)")
    try:
        sc = _load(a.scene, a.overrides)
        outdir = _outdir(a.out, sc)
        if sc.kind == "koyna":
            # deferred: a command imports only what it runs (fast --help; --dry-run without NGSolve)
            from .setup import validate
            validate(sc)              # input errors first: nothing created for a bad scene
            lock = _folder_check(outdir, _out_key(a.out), a.resume, a.overwrite, a.dry_run)
            if a.resume:
                try:
                    _resume_check(sc, outdir)
                except BaseException:
                    if lock is not None:
                        lock.release()
                    raise
    except ValueError as e:
        return _err(str(e))
    if a.dry_run:
        return _dry_run(sc, outdir)
    if sc.kind != "koyna":
        if a.resume:
            return _err(f"--resume: scenes of kind {sc.kind!r} are short and not checkpointed; "
                        "allowed: --resume with kind 'koyna'")
        return _run_other(sc, outdir, not a.quiet)
    try:                              # the folder's lock held from the checks to the end
        return _run_one(sc, outdir, a.resume, not a.quiet, a.overwrite, _out_key(a.out),
                        warm=(a.scene, a.overrides))
    finally:
        lock.release()


def _resume_check(sc, outdir):
    """--resume (also with --dry-run): a readable checkpoint in outdir written for this scene
    (the output keys may differ); the ValueError names the first key that differs, or the
    damaged checkpoint."""
    if not any((outdir / f).exists() for f in ("checkpoint.json", "checkpoint.prev.json")):
        done = " (it holds a finished run: summary.json)" if (outdir / "summary.json").exists() \
            else ""
        raise ValueError(f"--resume: no checkpoint in {outdir}{done}; allowed: the results "
                         "directory of an interrupted run with output.checkpoint_every > 0")
    # deferred: a command imports only what it runs (fast --help; --dry-run without NGSolve)
    from .run.checkpoint import checkpoint_scene_difference
    diff = checkpoint_scene_difference(sc.to_dict(), outdir)
    if diff is not None:
        raise ValueError(f"--resume: the checkpoint in {outdir} was written for a different "
                         f"scene: {diff}; allowed: the same scene and overrides as the "
                         "interrupted run")


def _run_other(sc, outdir, progress) -> int:
    """material_point (never imports NGSolve) and dcb scenes."""
    if sc.kind == "material_point":
        # deferred: a command imports only what it runs (fast --help; --dry-run without NGSolve)
        from .apps.point import run_point as fn
    else:
        # deferred: a command imports only what it runs (fast --help; --dry-run without NGSolve)
        from .apps.dcb import run_dcb_scene as fn
    try:
        s = fn(sc, outdir)
    except (ValueError, FileNotFoundError) as e:
        return _err(str(e))
    if progress:
        print(json.dumps(s["results"], indent=2))
        print(f"results in {outdir}")
    return 0


def _run_one(sc, outdir, resume, progress, overwrite=False, out_key="--out",
             warm=None) -> int:
    """One run of a koyna-kind scene. warm: (scene name or path, overrides) of ``sc``: its
    interface-law loops are compiled in a child process while this one builds the model
    (``apps.warm``: a cold numba cache's compile is not kept in the run's memory)."""
    # deferred: a command imports only what it runs (fast --help; --dry-run without NGSolve)
    from .apps import warm as warmup
    child = warmup.start(*warm) if warm is not None else None
    rc = None
    try:
        rc = _run_dam(sc, outdir, resume, progress, overwrite, out_key)
        return rc
    finally:
        warmup.finish(child, wait=rc == 0)


def _run_dam(sc, outdir, resume, progress, overwrite, out_key) -> int:
    # deferred: a command imports only what it runs (fast --help; --dry-run without NGSolve)
    from .apps.dam import run
    try:
        run(sc, outdir, resume=resume, progress=progress, overwrite=overwrite, out_key=out_key)
    except KeyboardInterrupt:
        print(f"\ninterrupted; continue with --resume (results dir {outdir})", file=sys.stderr)
        return 3
    except (ValueError, FileNotFoundError) as e:
        return _err(str(e))
    except OSError as e:               # the disk (full, removed) during the run
        return _err(f"run failed: {e}", 1)
    except RuntimeError as e:          # SolverError and friends
        return _err(f"run failed: {e}", 1)
    return 0


def paper_dirs(base: pathlib.Path) -> dict:
    return {"alpha = 2": base / "koyna_alpha2", "alpha = 1": base / "koyna_alpha1"}


def cmd_run_paper(a) -> int:
    if a.resume and a.overwrite:
        return _err("--resume and --overwrite: allowed: one of them")
    for item in a.overrides:        # the user's alpha would be replaced without a word
        if item.split("=", 1)[0].strip() == "interface.alpha":
            return _err(f"--set {item!r}: run-paper sets interface.alpha itself (2.0, then "
                        "1.0); allowed: any other key (one alpha: dam-seismic run)")
    scenes = {}
    try:
        base = _outdir(a.out or "results")
        for (lab, d), alpha in zip(paper_dirs(base).items(), (2.0, 1.0)):
            sets = list(a.overrides) + [f"interface.alpha={alpha}"]
            scenes[lab] = (_load(a.scene, sets), d, sets)
    except ValueError as e:
        return _err(str(e))
    kind = next(iter(scenes.values()))[0].kind
    if kind != "koyna":
        return _err(f"run-paper: scene {a.scene!r} is of kind {kind!r}; allowed: a koyna scene")
    try:
        for lab, (sc, d, _) in scenes.items():
            resume = a.resume and (d / "checkpoint.json").exists() \
                and not (d / "summary.json").exists()
            if not (a.resume and (d / "summary.json").exists()):
                lock = _folder_check(d, "--out", resume, a.overwrite, a.dry_run)
                if lock is not None:       # each run takes its own when it starts
                    lock.release()
    except ValueError as e:
        return _err(str(e))
    if a.dry_run:
        for lab, (sc, d, _) in scenes.items():
            print(f"# {lab}")
            _dry_run(sc, d)
        print(f"# comparison -> {base / 'koyna_compare'}")
        return 0
    for lab, (sc, d, sets) in scenes.items():
        resume = a.resume and (d / "checkpoint.json").exists() \
            and not (d / "summary.json").exists()
        if a.resume and (d / "summary.json").exists():
            print(f"{lab}: {d} is complete, not rerun")
            continue
        rc = _run_one(sc, d, resume, not a.quiet, a.overwrite, warm=(a.scene, sets))
        if rc:
            return rc
        gc.collect()        # the first run's model and factors are freed before the second
    return _compare({lab: d for lab, (sc, d, _) in scenes.items()}, base / "koyna_compare")


def _compare(runs: dict, out) -> int:
    # deferred: a command imports only what it runs (fast --help; --dry-run without NGSolve)
    from .post.report import compare_runs
    for d in runs.values():
        if not (pathlib.Path(d) / "summary.json").exists():
            return _err(f"compare: {d} has no summary.json (run not finished)")
    files = compare_runs({k: str(v) for k, v in runs.items()}, out)
    print(f"comparison written to {out}: {', '.join(files)}")
    print((pathlib.Path(out) / "results.md").read_text())
    return 0


def cmd_compare(a) -> int:
    try:
        _outdir(a.out)
    except ValueError as e:
        return _err(str(e))
    runs = {}
    for d in a.dirs:
        p = pathlib.Path(d)
        try:
            s = json.loads((p / "summary.json").read_text())
            runs[f"alpha = {s['scene']['interface']['alpha']:g}"] = p
        except (OSError, ValueError, KeyError):
            return _err(f"compare: {d} has no readable summary.json (run not finished)")
    return _compare(runs, a.out)


def cmd_modal(a) -> int:
    try:
        sc = _load(a.scene, a.overrides)
        out = _outdir(a.out, sc)
    except ValueError as e:
        return _err(str(e))
    # deferred: a command imports only what it runs (fast --help; --dry-run without NGSolve)
    from .apps.modal import run_modal
    md, res, damp = run_modal(sc, out, a.n)
    print(f"scene {sc.name}: nfree {md.nfree}, interface points {md.interface.npts}, "
          f"plane {sc.materials.plane}")
    print(f"f1 = {res.frequencies_hz[0]:.4f} Hz")
    print("frequencies [Hz]:", " ".join(f"{f:.4f}" for f in res.frequencies_hz))
    print(f"Rayleigh a0 = {damp['a0']:.6g} 1/s, a1 = {damp['a1']:.6g} s "
          f"({damp.get('model', 'rayleigh')}, {damp['source']}: {damp['f_a']:.3f}"
          + (f", {damp['f_b']:.3f}" if damp.get("f_b") is not None else "") + " Hz)")
    print(f"wrote {out / 'modal.json'}")
    rinfo = json.loads((out / "modal.json").read_text()).get("reservoir")
    if rinfo:                                  # docs/reservoir.md §5
        print(f"reservoir {rinfo['kind']}, level {rinfo['level']:g} m: {rinfo.get('note', '')}")
        fr = rinfo.get("frequency_response")
        if fr:
            print("fundamental resonance (first peak of the crest response): " + ", ".join(
                f"{k} {v['f_hz']:.3f} Hz (x{v['amplitude']:.2f})" if v else f"{k} none"
                for k, v in fr["fundamental_resonance"].items()))
            print("global maximum: " + ", ".join(
                f"{k} {v['f_hz']:.3f} Hz (x{v['amplitude']:.2f})"
                for k, v in fr["global_max"].items())
                + f"; wrote {', '.join(str(out / f) for f in fr['files'])}")
        for m in rinfo.get("measured", []):          # docs/real_dams.md (Pine Flat)
            ours = m["ours"].get("compressible") or m["ours"].get("incompressible")
            print(f"measured fundamental period {m['period_s']:.3f} s ({m['f_hz']:.3f} Hz; "
                  f"{m['source']}); ours "
                  + (f"{ours['period_s']:.3f} s ({ours['f_hz']:.3f} Hz, "
                     f"{100 * (ours['period_over_measured'] - 1):+.0f} %)" if ours else "none")
                  + " -- docs/real_dams.md explains the difference")
    return 0


def cmd_verify(a) -> int:
    """The studies of a source checkout, in their own process (as ``make verify``): the
    installed command does not put the checkout's ``verification/`` on its own import path."""
    script = ROOT / "verification" / "run_all.py"
    if not script.exists():
        return _err("verify: verification/run_all.py not found (run from a source checkout)", 1)
    argv = (["--fast"] if a.fast else []) + (["--out", a.out] if a.out else [])
    return subprocess.call([sys.executable, str(script), *argv], cwd=str(ROOT))


def cmd_bench(a) -> int:
    bench = ROOT / "tests" / "bench"
    if not bench.exists():
        return _err("bench: tests/bench not found (run from a source checkout)", 1)
    return subprocess.call([sys.executable, "-m", "pytest", "-q", str(bench), "--benchmark-only",
                            f"--benchmark-json={ROOT / '.benchmarks.json'}"], cwd=ROOT)


def main(argv=None) -> int:
    a = build_parser().parse_args(argv)
    if argv is None:
        # the command's process: fixed heap thresholds keep the freed factors of re-pairings
        # and sub-step sizes from staying resident (apps/heap.py; make run's peak)
        fix_heap_thresholds()
    rc = {"run": cmd_run, "run-paper": cmd_run_paper, "compare": cmd_compare,
          "modal": cmd_modal, "verify": cmd_verify, "bench": cmd_bench,
          "ida": _cmd_ida}[a.cmd](a)
    if argv is None:
        # the command line (console script, python -m): the process ends here. Its last full
        # garbage collection would scan every object left (numba, NGSolve, matplotlib: 0.1-1 s
        # measured at the end of a Koyna run); frozen, they are left to the OS. Files are all
        # written and closed by now (atomic writes).
        import gc
        gc.freeze()
    return rc


def _cmd_ida(a) -> int:
    # deferred: a command imports only what it runs (fast --help; --dry-run without NGSolve)
    from .studies.cli import cmd_ida
    return cmd_ida(a)


if __name__ == "__main__":
    sys.exit(main())
