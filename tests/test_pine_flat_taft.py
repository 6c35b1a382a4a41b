"""Pine Flat through Taft: the shipped Taft 1952 S69E record and its header,
the bad record files, the measured periods beside `dam-seismic modal`, and the independent
linear check (scikit-fem) in its fast form. docs/real_dams.md "Pine Flat", docs/validation.md."""
import json
import re

import numpy as np
import pytest

from ngs_driver.scene import load_scene
from ngs_driver.setup import load_ground_motion
from ngs_driver.setup import ground_motion as gmod
from ngs_driver.setup.records import SHIPPED_RECORDS

TAFT = gmod.SHIPPED_DIR / SHIPPED_RECORDS["taft-1952-s69e"]["file"]


def _header(path):
    out = {}
    for ln in path.read_text().splitlines():
        m = re.match(r"#\s*(units|dt|npts|peak_g|peak_time):\s*(\S+)", ln)
        if m:
            out[m.group(1)] = m.group(2)
    return out


def test_taft_record_as_its_header_says():
    """The data file read by the scene key has the header's points, step and peak, and the
    figures that identify it (54.38 s long, 0.179 g at 3.70 s: the Taft S69E component)."""
    h = _header(TAFT)
    sc = load_scene("pine_flat", ['ground_motion.record="shipped:taft-1952-s69e"',
                                  "time.dt=0.02", "time.duration=54.38"])
    gm = load_ground_motion(sc)
    assert gm.n == int(h["npts"]) == 2720
    assert gm.dt == pytest.approx(float(h["dt"]), rel=1e-12)       # exact grid of 0.02 s
    assert gm.duration == pytest.approx(54.38, rel=1e-12)
    # peak in g exactly as printed (3 decimals; g = 9.80665 is divided out again)
    assert gm.peak_g()[0] == pytest.approx(float(h["peak_g"]), abs=1e-12)
    assert float(gm.t[np.argmax(np.abs(gm.ax))]) == pytest.approx(float(h["peak_time"]),
                                                                    abs=1e-9)
    assert gm.peak_g()[1] == 0.0                                     # horizontal only
    assert gm.meta["component"] == "S69E" and not gm.synthetic
    # the data lines are the source's 2,720 pairs: the last one is t = 54.38 s, 0.002 g
    assert gm.ax[-1] / gmod.G == pytest.approx(0.002, abs=1e-12)
    # licence notice beside the data (MIT requires it to travel with the copy)
    lic = TAFT.with_suffix(".LICENSE").read_text()
    assert "MIT License" in lic and "Copyright (c) 2025 NiliAbtahi" in lic


def _spoiled(tmp_path, name, edit):
    lines = TAFT.read_text().splitlines()
    f = tmp_path / f"{name}.txt"
    f.write_text("\n".join(edit(lines)) + "\n")
    return f


def test_record_whose_header_lies_is_refused(tmp_path, capsys):
    """A headed record with a point missing, an extra point, or a peak that is not the header's
    is refused, by the reader and by `run --dry-run` (exit 2), naming the file and both
    numbers."""
    data0 = next(i for i, ln in enumerate(TAFT.read_text().splitlines())
                 if not ln.startswith("#"))
    i_pk = data0 + 185                          # t = 3.70 s, the 0.179 g sample
    cases = {
        "short": (lambda L: L[:-1], r"npts = 2720 but the file has 2719 data points"),
        "long": (lambda L: L + ["54.40 0.001"], r"npts = 2720 but the file has 2721"),
        "peak": (lambda L: L[:i_pk] + ["3.70 0.190"] + L[i_pk + 1:],
                 r"peak_g = 0.179 but the largest \|a\| in the file is 0.19 g"),
        "dt": (lambda L: [ln.replace("# dt: 0.02", "# dt: 0.01") for ln in L],
               r"dt = 0.01 s but the times step by 0.02 s"),
    }
    assert TAFT.read_text().splitlines()[i_pk].split() == ["3.70", "0.179"]
    from ngs_driver.cli import main
    for name, (edit, pat) in cases.items():
        f = _spoiled(tmp_path, name, edit)
        with pytest.raises(ValueError, match=pat):
            gmod.read_headed(f)
        rc = main(["run", "pine_flat", "--dry-run", "--out", str(tmp_path / "o"),
                   "--set", f"ground_motion.record='{f}'", "--set", "ground_motion.units='g'"])
        err = capsys.readouterr().err
        assert rc == 2 and re.search(pat, err) and f"{name}.txt" in err, (name, err)
    # an unknown shipped name lists the shipped ones
    from ngs_driver.setup import validate
    with pytest.raises(ValueError, match=r"no shipped record 'taft'; allowed: "
                                         r"'shipped:taft-1952-s69e'"):
        validate(load_scene("pine_flat", ['ground_motion.record="shipped:taft"']))


def test_linear_taft_against_skfem_fast(tmp_path, study):
    """The independent linear check's fast form (h = 8 m, 6 s of Taft, dt 0.01 s): the crest
    displacement of our model and stepper equals scikit-fem's own assembly, eigenvalues and
    Newmark loop on the same triangles within 2 % of the peak (the acceptance set before the check; measured 8e-14: the
    same space and the same average-acceleration scheme, round-off only). A wrong mass, a
    wrong Rayleigh a0/a1, a wrong load vector or a wrong record would each move it by more."""
    res = study("pine_flat_linear").main(fast=True, outdir=tmp_path)
    assert res["ok"] and res["max_diff_over_peak"] <= 0.02
    assert res["a0_ours"] == pytest.approx(res["a0_skfem"], rel=1e-8)   # eigenvalue round-off
    # the response is the Taft response, not a quiet one: the peak comes after the record's
    # 0.179 g peak at 3.70 s and is of the size of Sd(f1) (a few cm on this coarse section)
    assert 3.7 <= res["t_peak_s"] <= 6.0 and 0.005 < res["peak_ours_m"] < 0.05
    assert "(tolerance 0.02: met)" in (tmp_path / "pine_flat_linear.md").read_text()


COARSE = ["mesh.h_heel=1.0", "mesh.heel_zone=0.0", "mesh.h_interface=6.0", "mesh.h_coarse=6.0",
          "mesh.growth=1.5", "reservoir.length=250.0", "reservoir.h_max=10.0"]


def test_modal_prints_the_measured_period(tmp_path, capsys):
    """`dam-seismic modal pine_flat --set reservoir.level=94.5` prints the measured 0.288 s
    (Rea, Liaw & Chopra 1972) beside our fundamental resonance with compressible water, and
    modal.json keeps both; the period printed is 1 / the resonance reported (coarse mesh, rigid
    base: the printing is under test, the full study is verification/pine_flat.py)."""
    from ngs_driver.cli import main

    argv = ["modal", "pine_flat", "--out", str(tmp_path), "--set", "reservoir.level=94.5",
            "--set", "geometry.foundation='rigid'"]
    for s in COARSE:
        argv += ["--set", s]
    assert main(argv) == 0
    out = capsys.readouterr().out
    d = json.loads((tmp_path / "modal.json").read_text())["reservoir"]
    (m,) = d["measured"]
    f = d["frequency_response"]["fundamental_resonance"]["compressible"]["f_hz"]
    assert m["period_s"] == 0.288 and m["level_m"] == 94.5
    assert m["ours"]["compressible"]["period_s"] == pytest.approx(1.0 / f, rel=1e-12)
    assert (f"measured fundamental period 0.288 s (3.472 Hz; Rea, Liaw & Chopra 1972"
            in out), out
    assert f"ours {1.0 / f:.3f} s ({f:.3f} Hz" in out
    # the model is softer than the dam (2D monolith, in-situ E: docs/real_dams.md), not stiffer
    assert 1.0 < m["ours"]["compressible"]["period_over_measured"] < 1.8


def test_modal_measured_only_at_a_test_level():
    """No measurement is claimed for another water level (100 m is 5.5 m from the nearest
    test) nor for another section."""
    from ngs_driver.apps.modal import measured_comparison

    fund = {"compressible": {"f_hz": 2.5}}
    assert measured_comparison(load_scene("pine_flat", ["reservoir.level=100.0"]), fund) == []
    assert measured_comparison(load_scene("koyna_1967"), fund) == []
    (r,) = measured_comparison(load_scene("pine_flat", ["reservoir.level=105.2"]), fund)
    assert r["period_s"] == 0.306 and r["ours"]["compressible"]["period_over_measured"] == \
        pytest.approx(0.4 / 0.306, rel=1e-12)
