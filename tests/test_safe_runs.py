"""Safe runs: a results folder owned by one run, nothing deleted unasked, writable
before any work, checkpoints committed as one set and a damaged one named (docs/run.md
§6-8). Each test fails on the code before these checks (860c990)."""
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
import time
import types

import numpy as np
import pytest

from ngs_driver.scene import load_scene

pytest.importorskip("ngsolve")

from ngs_driver.apps.dam import RunInterrupted, run  # noqa: E402
from ngs_driver.cli import main  # noqa: E402
from ngs_driver.fe.model import build_from_scene  # noqa: E402
from ngs_driver.run import checkpoint as ckmod  # noqa: E402
from ngs_driver.run.checkpoint import CheckpointDamaged, Checkpointer  # noqa: E402
from ngs_driver.run.folder import FolderError  # noqa: E402
from ngs_driver.setup import describe  # noqa: E402
from ngs_driver.setup.uplift import drain_line  # noqa: E402
from conftest import run_fast_study  # noqa: E402
import verification.fuzz_edges as fz  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]
QUIET = dict(progress=False, plots=False, log=lambda *a, **k: None)


def _cli(argv, capsys):
    rc = main(argv)
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


# ------------------------------------------------------------------------ one run per folder
def test_second_process_into_one_folder_is_refused(tmp_path, capsys):
    """A run in a subprocess holds the folder; a second run into it exits 2 naming the folder
    and the first run's process id; the first finishes with its files (before: both exit 0 and
    each deletes the other's files)."""
    d = tmp_path / "D"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    first = subprocess.Popen([sys.executable, "-m", "ngs_driver", "run", "koyna_smoke", "--out",
                              str(d), "--quiet", "--set", "time.duration=0.04"], env=env,
                             cwd=ROOT, stderr=subprocess.PIPE, text=True)
    lock = d / ".dam-seismic.lock"
    t0 = time.time()
    while not (lock.exists() and lock.read_text().strip()) and time.time() - t0 < 60:
        time.sleep(0.02)
    assert first.poll() is None, first.stderr.read()      # still running: the lock is its own
    rc, out, err = _cli(["run", "koyna_smoke", "--out", str(d), "--quiet"], capsys)
    assert rc == 2, err
    assert f"--out = {str(d)!r} is in use by another run (process {first.pid})" in err
    assert first.wait(timeout=120) == 0, first.stderr.read()
    s = json.loads((d / "summary.json").read_text())
    assert s["n_steps"] == 20 and (d / "final_state.npz").exists()
    assert not lock.exists()                              # released with the run


# ------------------------------------------------------------------- nothing deleted unasked
@pytest.fixture(scope="module")
def smoke():
    sc = load_scene("koyna_smoke", ["time.duration=0.01", "output.checkpoint_every=2"])
    return sc, build_from_scene(sc)


def test_rerun_into_a_finished_folder(tmp_path, smoke, capsys):
    """A finished folder: a plain rerun exits 2 (dry run too) naming it; --overwrite replaces
    it; an --overwrite run that fails (here: interrupted) leaves the finished run as it was
    (before: the rerun deleted summary.json at its start)."""
    sc, md = smoke
    d = tmp_path / "D"
    s1 = run(sc, d, model=md, **QUIET)
    before = {p.name: p.read_bytes() for p in d.iterdir()}
    with pytest.raises(FolderError, match=r"holds a finished run \(summary.json\).*--overwrite"):
        run(sc, d, model=md, **QUIET)
    for argv in (["run", "koyna_smoke", "--out", str(d)],
                 ["run", "koyna_smoke", "--out", str(d), "--dry-run"]):
        rc, out, err = _cli(argv, capsys)
        assert rc == 2 and f"--out = {str(d)!r} holds a finished run" in err, err
    with pytest.raises(RunInterrupted):
        run(sc, d, model=md, overwrite=True, max_steps=3, **QUIET)
    after = {p.name: p.read_bytes() for p in d.iterdir() if not p.name.startswith("checkpoint")}
    assert after == before                     # every file of the finished run, byte for byte
    s2 = run(sc, d, model=md, overwrite=True, **QUIET)
    assert s2["results"] == s1["results"]
    assert not list(d.glob("checkpoint*"))


def test_plain_run_into_a_killed_runs_folder(tmp_path, smoke):
    """A folder with an interrupted run's checkpoint: a plain run is refused naming the step
    (before: the checkpoint was deleted without a word); --resume continues it."""
    sc, md = smoke
    d = tmp_path / "D"
    with pytest.raises(RunInterrupted):
        run(sc, d, model=md, max_steps=3, **QUIET)
    with pytest.raises(FolderError, match=r"holds the checkpoint of an interrupted run \(step "
                                          r"2\).*allowed: --resume"):
        run(sc, d, model=md, **QUIET)
    assert json.loads((d / "checkpoint.json").read_text())["step"] == 2
    s = run(sc, d, model=md, resume=True, **QUIET)
    assert s["resumed_from_step"] == 2


def _read_only(d):
    """Make ``d`` unwritable even for root (chattr +i), else by its mode; False: cannot."""
    d.chmod(0o555)
    if os.access(d, os.W_OK) and shutil.which("chattr"):
        subprocess.run(["chattr", "+i", str(d)], capture_output=True)
    try:
        (d / "x").write_text("x")
    except OSError:
        return True
    (d / "x").unlink()
    return False


def _writable(d):
    if shutil.which("chattr"):
        subprocess.run(["chattr", "-i", str(d)], capture_output=True)
    d.chmod(0o755)


def test_read_only_and_impossible_folders_at_dry_run(tmp_path, capsys):
    """A read-only --out, a folder under it, a folder under a regular file: exit 2 at
    --dry-run and before the build, naming the folder (before: a traceback after the whole
    analysis, nothing saved). A dry run into a new folder leaves nothing behind."""
    ro = tmp_path / "ro"
    ro.mkdir()
    f = tmp_path / "file"
    f.write_text("keep")
    try:
        if not _read_only(ro):
            pytest.skip("no way to make a folder read-only here")
        for out, what in ((ro, "is not writable"), (ro / "sub", "cannot be created"),
                          (f / "sub", "cannot be created")):
            for extra in (["--dry-run"], []):
                rc, o, err = _cli(["run", "koyna_smoke", "--out", str(out), "--quiet"] + extra,
                                  capsys)
                assert rc == 2 and f"--out = {str(out)!r}: the folder {what}" in err, err
    finally:
        _writable(ro)
    new = tmp_path / "a" / "b"
    rc, o, err = _cli(["run", "koyna_smoke", "--out", str(new), "--dry-run"], capsys)
    assert rc == 0 and not (tmp_path / "a").exists()


# -------------------------------------------------------------- a kill at every write point
class _LateThread:
    """A checkpoint writer thread that runs when it is joined: the latest schedule the run
    allows (the next step's work all done before the previous checkpoint is on disk)."""

    def __init__(self, target, args=(), name=None, **kw):
        self._run = lambda: target(*args)

    def start(self):
        pass

    def join(self):
        self._run()


def test_kill_at_every_checkpoint_write_resumes_bitwise(tmp_path, monkeypatch):
    """Compressible water, a checkpoint every step: the folder as a kill would leave it before
    and after every rename and every removal of a checkpoint file (a kill in the middle of a
    write: its temporary file half written), each resumed, gives the uninterrupted run's final
    state and pressure history bit for bit, and the temporary files are gone. The writer runs
    as late as the run allows (``_LateThread``). Before: the water state of step k-2 was
    removed before checkpoint.json committed step k-1 ('reservoir_state_... missing')."""
    sc = load_scene("koyna_smoke", ["reservoir.model=acoustic", "time.duration=0.006",
                                    "output.checkpoint_every=1"])
    ref = tmp_path / "ref"
    run(sc, ref, **QUIET)
    live = (tmp_path / "live").resolve()
    states = []
    real_replace, real_unlink = os.replace, os.unlink

    def ours(path):
        p = pathlib.Path(path).resolve()
        return p.parent == live and any(w in p.name for w in ("checkpoint", "reservoir_state"))

    def snap(op, path, when):
        d = tmp_path / f"kill{len(states):03d}"
        shutil.copytree(live, d)
        for t in d.glob(".*.tmp"):         # killed while writing it: half of it on disk
            t.write_bytes(t.read_bytes()[: t.stat().st_size // 2])
        states.append((f"{when} {op} {pathlib.Path(path).name}", d))

    def replace(src, dst, **kw):
        if not ours(dst):
            return real_replace(src, dst, **kw)
        snap("replace", dst, "before")
        real_replace(src, dst, **kw)
        snap("replace", dst, "after")

    def unlink(path, **kw):
        if not ours(path):
            return real_unlink(path, **kw)
        snap("unlink", path, "before")
        real_unlink(path, **kw)

    monkeypatch.setattr(ckmod, "threading", types.SimpleNamespace(Thread=_LateThread))
    monkeypatch.setattr(os, "replace", replace)
    monkeypatch.setattr(os, "unlink", unlink)
    run(sc, tmp_path / "live", **QUIET)
    monkeypatch.undo()
    assert len(states) >= 3 * 3           # 3 checkpoints, each with >= 3 file operations
    za = np.load(ref / "final_state.npz")
    pa = (ref / "reservoir_pressure.csv").read_text()
    resumed = 0
    for what, d in states:
        if (d / "summary.json").exists():       # killed after the run finished: nothing to do
            continue
        if not (d / "checkpoint.json").exists():
            with pytest.raises(FileNotFoundError, match="no checkpoint"):
                run(sc, d, resume=True, **QUIET)
            continue
        s = run(sc, d, resume=True, **QUIET)
        resumed += 1
        zb = np.load(d / "final_state.npz")
        for k in za.files:
            assert np.array_equal(za[k], zb[k]), (what, d.name, k)
        assert (d / "reservoir_pressure.csv").read_text() == pa, (what, d.name)
        assert s["resumed_from_step"] >= 1
        assert not list(d.glob(".*.tmp")) and not list(d.glob("checkpoint*")), (what, d.name)
    assert resumed >= 8


def test_resume_with_another_checkpoint_interval(tmp_path, smoke, capsys):
    """output.checkpoint_every (and output.dir) may change on --resume (they change no
    result); another output.snapshots or any other key is refused naming it."""
    sc, md = smoke
    d = tmp_path / "D"
    with pytest.raises(RunInterrupted):
        run(sc, d, model=md, max_steps=3, **QUIET)
    rc, out, err = _cli(["run", "koyna_smoke", "--resume", "--dry-run", "--out", str(d), "--set",
                         "time.duration=0.01", "--set", "output.snapshots=3"], capsys)
    assert rc == 2 and "output.snapshots = 5 in the checkpoint, 3 now" in err, err
    sc3 = load_scene("koyna_smoke", ["time.duration=0.01", "output.checkpoint_every=3"])
    s = run(sc3, d, model=md, resume=True, **QUIET)
    ref = run(sc, tmp_path / "ref", model=md, **QUIET)
    assert s["results"] == ref["results"]


def test_checkpoint_of_another_format_is_refused(tmp_path, smoke, capsys):
    """A checkpoint of the layout before the run's parts (format 1: no "format" in its
    manifest) is refused on --resume, at --dry-run too, naming its format and the remedy;
    nothing of the folder is changed."""
    sc, md = smoke
    d = tmp_path / "D"
    with pytest.raises(RunInterrupted):
        run(sc, d, model=md, max_steps=3, **QUIET)
    meta = json.loads((d / "checkpoint.json").read_text())
    assert meta["format"] == ckmod.CHECKPOINT_FORMAT
    del meta["format"]
    (d / "checkpoint.json").write_text(json.dumps(meta))
    rc, out, err = _cli(["run", "koyna_smoke", "--resume", "--dry-run", "--out", str(d), "--set",
                         "time.duration=0.01", "--set", "output.checkpoint_every=2"], capsys)
    assert rc == 2 and "checkpoint format 1" in err and "--overwrite" in err, err
    with pytest.raises(ValueError, match=r"has checkpoint format 1, written by another "
                                         r"version; this version reads format 2"):
        run(sc, d, model=md, resume=True, **QUIET)
    assert json.loads((d / "checkpoint.json").read_text()) == meta


# ----------------------------------------------------------------------- damaged checkpoints
def _two_checkpoints(d):
    ck = Checkpointer(d, 1)
    ck.save(1, {"scene": {}, "time": 0.1}, u=np.arange(3.0))
    ck.save(2, {"scene": {}, "time": 0.2}, u=np.arange(3.0) + 10)
    ck.wait()
    return ck


def _truncate(p):
    p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])


def _empty(p):
    p.write_bytes(b"")


def _flip(p):
    b = bytearray(p.read_bytes())
    b[len(b) // 2] ^= 0x01          # one bit inside the array data
    p.write_bytes(bytes(b))


@pytest.mark.parametrize("spoil", [_truncate, _empty, _flip], ids=["truncated", "emptied",
                                                                   "bit-flipped"])
def test_damaged_npz_is_named_and_the_previous_used(tmp_path, spoil):
    """The newest npz damaged: named (step, folder, what), the previous checkpoint used; both
    damaged: CheckpointDamaged with the issue's words (before: a BadZipFile/EOFError
    traceback, or a flipped bit read as data)."""
    ck = _two_checkpoints(tmp_path)
    spoil(tmp_path / "checkpoint_0000002.npz")
    meta, arrs = ck.load()
    assert meta["step"] == 1 and arrs["u"].tolist() == [0.0, 1.0, 2.0]
    assert len(ck.notes) == 1 and ck.notes[0].startswith(
        f"checkpoint step 2 in {tmp_path} is damaged: checkpoint_0000002.npz")
    assert "resuming from the previous one (step 1)" in ck.notes[0]
    spoil(tmp_path / "checkpoint_0000001.npz")
    with pytest.raises(CheckpointDamaged, match=rf"^checkpoint step 2 in {tmp_path} is damaged: "
                       r".*; resume from the previous one or rerun without --resume \(the "
                       r"previous one is damaged too: checkpoint step 1"):
        ck.load()


def test_truncated_manifest_is_named(tmp_path, capsys):
    """A truncated checkpoint.json: named as damaged, the previous manifest used; with no
    previous one, exit 2 at --resume --dry-run with the message (before: a bare JSON decoder
    message)."""
    ck = _two_checkpoints(tmp_path)
    _truncate(tmp_path / "checkpoint.json")
    meta, arrs = ck.load()
    assert meta["step"] == 1 and "checkpoint manifest checkpoint.json" in ck.notes[0]
    (tmp_path / "checkpoint.prev.json").unlink()
    with pytest.raises(CheckpointDamaged, match=r"checkpoint manifest checkpoint.json in .* is "
                       r"damaged: not a complete manifest .*; resume from the previous one or "
                       r"rerun without --resume \(no previous one is left"):
        ck.load()
    rc, out, err = _cli(["run", "koyna_smoke", "--resume", "--dry-run", "--out", str(tmp_path)],
                        capsys)
    assert rc == 2 and "is damaged" in err and "Traceback" not in err, err


# ------------------------------------------------------------------------ physical sanity
@pytest.mark.parametrize("sets,pat", [
    (["interface.contact_stiffness=1e5"],
     r"interface.contact_stiffness = 100000.0 Pa/m: under the dam's weight .* overlap by 12.57 "
     r"m, more than 1 % of its smallest element \(1 m\).*allowed: >= 1.26e\+08 Pa/m"),
    (["joints=[{name='j', elevation=0.001}]"],
     r"joints\[0\].elevation = 0.001 \(joint 'j'\): 0.001 m above the base, closer than the "
     r"element size there \(1 m.*allowed: at least 1 m apart"),
    (["uplift.model=linear", "uplift.drain_x=5"],
     r"uplift.drain_x = 5.0 with uplift.model = 'linear': the drain line is read only by "
     r"model = 'drains'"),
    (["ground_motion.scale=0"], r"ground_motion.scale = 0.0: the record scaled to nothing"),
])
def test_sanity_refused_at_dry_run(sets, pat, capsys):
    """Values each key's range allows that make a run absurd or unmeshable: exit 2 at
    --dry-run naming the key, the value and the bound (before: exit 0 and a dam sunk 12 m,
    or 'meshing failed' after the dry run passed)."""
    argv = ["run", "koyna_smoke", "--dry-run"]
    for s in sets:
        argv += ["--set", s]
    rc, out, err = _cli(argv, capsys)
    assert rc == 2 and re.search(pat, err), err


def test_drains_alone_and_high_damping_modes_run(tmp_path):
    """uplift.model = 'drains' with no drain_x runs (drain line at 10 % of the joint: 7 m on
    Koyna's 70 m base), and damping at mode 50 is computed, not an IndexError."""
    sc = load_scene("koyna_smoke", ["uplift.model=drains"])
    d = describe(sc)["will_build"]["uplift"]["base"]
    assert drain_line(sc.uplift, 70.0) == 0.1 * 70.0
    # the USACE drawing by hand: head p_h at the heel, p_d = (1 - E) p_h (L - x_d)/L = 0.45 p_h
    # at x_d = 7 m (E = 0.5, no tailwater), 0 at the toe: F = (p_h + p_d) 7/2 + p_d 63/2
    ph = sc.loads.water_density * sc.loads.gravity * sc.reservoir.level
    # 1e-12: the two sums of three terms round differently
    assert d["uplift_force_uncracked"] == pytest.approx(19.25 * ph, rel=1e-12)
    sc = load_scene("koyna_smoke", ["time.duration=0.004", "damping.modes=[1, 50]"])
    s = run(sc, tmp_path / "m50", **QUIET)
    assert len(s["frequencies_hz"]) == 50
    assert s["rayleigh"]["f_b"] == s["frequencies_hz"][49]      # the 50th mode, as asked


def test_fuzz_over_the_allowed_edges(tmp_path):
    """The smallest and largest allowed value of the fast form's keys (verification/
    fuzz_edges.py through make verify's call; make verify runs all 98 edges of the koyna
    schema, 10-22 s), each run for two steps on koyna_smoke: refused at --dry-run, ran, or a
    solver failure -- never a crash (before: damping.modes = [49, 50] an IndexError, E or rho
    = 5e-324 'Factor is exactly singular', nu = 0.5 - 1e-16 a ValueError after the build)."""
    text = run_fast_study("fuzz_edges", tmp_path)      # raises on any crash
    rows = [r for r in text.splitlines() if r.startswith("| ") and not r.startswith("| key")]
    assert len(rows) == 2 * len(fz.FAST_KEYS)
    out = {tuple(c.strip() for c in r.split("|")[1:4]) for r in rows}
    assert ("damping.modes", "[49, 50]", "ran") in out
    assert ("interface.contact_stiffness", "1e+20", "ran") in out
    assert ("materials.dam.E", "5e-324", "refused at --dry-run") in out
    assert ("materials.dam.nu", "0.49999999999999994", "refused at --dry-run") in out
    assert sum(r[2] == "ran" for r in out) >= 12
    assert len(fz.edges()) >= 90                       # the whole sweep's size (make verify)
