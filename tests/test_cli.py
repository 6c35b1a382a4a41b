"""Command line (ngs_driver.cli): dry run without NGSolve, bad input, modal, run, run-paper."""
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import pytest

from ngs_driver.cli import main

ROOT = Path(__file__).resolve().parent.parent


def test_dry_run_does_not_import_ngsolve(tmp_path, cli_env):
    code = ("import sys, json\n"
            "from ngs_driver.cli import main\n"
            f"rc = main(['run', 'koyna', '--dry-run', '--out', {str(tmp_path / 'x')!r}])\n"
            "print('RC', rc, 'NGSOLVE', 'ngsolve' in sys.modules, 'NETGEN', "
            "'netgen' in sys.modules)\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       env=cli_env, cwd=ROOT, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "RC 0 NGSOLVE False NETGEN False" in r.stdout
    d = json.loads(r.stdout[:r.stdout.rindex("}") + 1])
    assert d["scene"]["name"] == "koyna"
    law = d["will_build"]["law"]
    assert law["contact"] == "linear" and law["friction"] and law["damage"] and law["scaling"]
    assert not (tmp_path / "x").exists()


def test_bad_set_key_exit_2(tmp_path, cli_env):
    out = tmp_path / "res"
    r = subprocess.run([sys.executable, "-m", "ngs_driver", "run", "koyna_smoke", "--set",
                        "interface.alfa=1", "--out", str(out)], capture_output=True, text=True,
                       env=cli_env, cwd=ROOT, timeout=120)
    assert r.returncode == 2
    assert "interface.alfa" in r.stderr and "alpha" in r.stderr
    assert not out.exists()


@pytest.mark.parametrize("argv, words", [
    (["run", "koyna_smoke", "--set", "interface.alpha=-1"], ["interface.alpha", "out of range"]),
    (["run", "koyna_smoke", "--set", "output.checkpoint_every=1.5"],
     ["output.checkpoint_every", "integer"]),
    (["run", "no_such_scene"], ["no_such_scene", "shipped scenes"]),
    (["modal", "koyna_smoke", "--set", "mesh.order=0"], ["mesh.order"]),
])
def test_bad_input_messages(tmp_path, capsys, argv, words):
    rc = main(argv + ["--out", str(tmp_path / "r")])
    err = capsys.readouterr().err
    assert rc == 2
    for w in words:
        assert w in err
    assert not (tmp_path / "r" / "summary.json").exists()


def test_resume_without_checkpoint(tmp_path, capsys):
    rc = main(["run", "koyna_smoke", "--resume", "--out", str(tmp_path / "r")])
    assert rc == 2 and "no checkpoint" in capsys.readouterr().err


def test_unknown_subcommand():
    with pytest.raises(SystemExit) as e:
        main(["frobnicate"])
    assert e.value.code == 2


def test_modal_writes_json(tmp_path):
    pytest.importorskip("ngsolve")
    assert main(["modal", "koyna_smoke", "--out", str(tmp_path)]) == 0
    d = json.loads((tmp_path / "modal.json").read_text())
    f = d["frequencies_hz"]
    assert len(f) == 6 and all(b >= a > 0 for a, b in zip(f, f[1:]))


def test_run_paper_smoke(tmp_path, capsys):
    """run-paper on the smoke scene: both alphas, the comparison figures and the table."""
    pytest.importorskip("ngsolve")
    rc = main(["run-paper", "koyna_smoke", "--out", str(tmp_path), "--quiet"])
    assert rc == 0
    for d in ("koyna_alpha2", "koyna_alpha1"):
        s = json.loads((tmp_path / d / "summary.json").read_text())
        assert s["scene"]["interface"]["alpha"] == (2.0 if d.endswith("2") else 1.0)
    cmp = tmp_path / "koyna_compare"
    for f in ("fig10_crest_displacement.png", "fig11_damage_profiles.png", "crack_length.png",
              "results.md"):
        assert (cmp / f).exists(), f
    md = (cmp / "results.md").read_text()
    assert "SYNTHETIC" in md and "D(alpha=2) ≤ D(alpha=1)²" in md and "6.0 s" in md
    # the table's numbers are the runs' own (summary.json), formatted as the table does
    r2, r1 = (json.loads((tmp_path / d / "summary.json").read_text())["results"]
              for d in ("koyna_alpha2", "koyna_alpha1"))
    assert f"max D {r2['max_D']:.3g} (alpha 2) vs {r1['max_D']:.3g} (alpha 1)" in md
    assert f"max D = {r1['max_D']:.3g}" in md
    # compare alone on the finished runs
    assert main(["compare", str(tmp_path / "koyna_alpha2"), str(tmp_path / "koyna_alpha1"),
                 "--out", str(tmp_path / "c2")]) == 0
    assert (tmp_path / "c2" / "results.md").exists()


# ---- scene kinds: material point (no NGSolve) and DCB -------------------------------------
def test_material_point_scene_never_imports_ngsolve(tmp_path):
    import json
    import subprocess
    import sys
    code = ("import sys; from ngs_driver.cli import main; "
            f"rc = main(['run', 'point_mode_I', '--out', r'{tmp_path}', '--quiet']); "
            "assert rc == 0, rc; "
            "bad = [m for m in ('ngsolve', 'netgen') if m in sys.modules]; "
            "assert not bad, bad")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    s = json.loads((tmp_path / "summary.json").read_text())
    # mode I to 1.5 l_Nc: the law's dissipation is exactly G_I (no lag, docs §1.2)
    assert s["results"]["dissipated_final"] == pytest.approx(250.0, rel=1e-10)
    assert s["law"]["friction"] is False and s["law"]["damage"] is False
    assert (tmp_path / "history.csv").exists()


def test_shear_under_pressure_scene_plateau(tmp_path):
    import json
    from ngs_driver.cli import main
    assert main(["run", "point_shear_pressure", "--out", str(tmp_path), "--quiet"]) == 0
    s = json.loads((tmp_path / "summary.json").read_text())
    import numpy as np
    lines = (tmp_path / "history.csv").read_text().splitlines()
    head = lines[0].split(",")
    data = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
    FT = data[:, head.index("FT")]
    # after debonding the shear traction sits on the Coulomb plateau f |F_N| = 0.3 x 1 MPa
    assert np.abs(FT[-20:]).max() == pytest.approx(0.3e6, rel=1e-10)
    assert s["results"]["converged"]


def test_dcb_scene_dry_run_and_bad_kind(tmp_path, capsys):
    from ngs_driver.cli import main
    assert main(["run", "dcb", "--dry-run"]) == 0
    assert '"kind": "dcb"' in capsys.readouterr().out
    assert main(["run-paper", "point_mode_I", "--out", str(tmp_path)]) == 2
    assert "allowed: a koyna scene" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


HEAP_PROBE = """
import sys, numpy as np
from ngs_driver.apps.heap import fix_heap_thresholds
mode = sys.argv[1]
fixed = fix_heap_thresholds(respect_env=(mode != "force")) if mode != "default" else False
def rss():
    for line in open("/proc/self/status"):
        if line.startswith("VmRSS"):
            return int(line.split()[1]) / 1024
base = rss()
keep = []
for i in range(6):
    a = np.ones(3_000_000)           # 24 MB, as a factor a re-pairing drops
    keep.append(np.ones(1000))       # a small block after it: the heap's top stays busy
    del a
print(fixed, rss() - base)
"""


@pytest.mark.skipif(not Path("/proc/self/status").exists()
                    or platform.libc_ver()[0] != "glibc", reason="Linux's /proc and glibc")
def test_fixed_heap_thresholds_give_freed_large_blocks_back():
    """apps/heap.py: with glibc's dynamic threshold a freed 24 MB block is reused from the heap
    and stays resident (measured +23 MiB); with the fixed thresholds it is unmapped (+0). The
    bound of 8 MiB is a third of one block: the probe's own small allocations are ~0. A
    ``MALLOC_TRIM_THRESHOLD_`` in the environment (Dask's nanny sets 65536) is respected by the
    command and overridden in an IDA worker (``respect_env=False``)."""
    clean = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
    clean["PYTHONPATH"] = str(ROOT)
    dask_like = {**clean, "MALLOC_TRIM_THRESHOLD_": "65536"}
    out = {}
    for mode, env in (("fix", clean), ("default", clean), ("fix_dask", dask_like),
                      ("force", dask_like)):
        r = subprocess.run([sys.executable, "-c", HEAP_PROBE, mode.replace("fix_dask", "fix")],
                           capture_output=True, text=True, check=True, env=env)
        fixed, grown = r.stdout.split()
        out[mode] = (fixed == "True", float(grown))
    assert out["fix"][0] and out["fix"][1] < 8.0
    assert out["default"][1] > 16.0
    assert not out["fix_dask"][0]                 # the environment's choice left alone
    assert out["force"][0] and out["force"][1] < 8.0
