"""Tests of ngs_driver.setup.ground_motion (numpy/scipy only; whole file runs in a few seconds)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from ngs_driver.setup import ground_motion as gmm
from ngs_driver.setup.ground_motion import (
    G,
    GroundMotion,
    baseline_correct,
    combine,
    generate_koyna_like,
    load_default,
    read_at2,
    read_three_column,
    read_two_column,
    resample,
    response_spectrum,
    significant_duration,
)

ROOT = Path(__file__).resolve().parents[1]


# ---------------------------------------------------------------------------- helpers
def _write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


def _at2_text(vals, npts=None, dt_field="DT= .0050 SEC", per_row=5):
    npts = len(vals) if npts is None else npts
    rows = [" ".join(f"{v:.7E}" for v in vals[i:i + per_row]) for i in range(0, len(vals), per_row)]
    return ("PEER NGA STRONG MOTION DATABASE RECORD\n"
            "TEST EVENT 1/1/2000, STATION X, 90\n"
            "ACCELERATION TIME SERIES IN UNITS OF G\n"
            f"NPTS=  {npts}, {dt_field}\n" + "\n".join(rows) + "\n")


# ---------------------------------------------------------------------------- readers
def test_at2_round_trip_exact(tmp_path):
    rng = np.random.default_rng(0)
    vals = rng.normal(scale=0.1, size=23)
    p = _write(tmp_path, "REC.AT2", _at2_text(vals))
    gm = read_at2(p)
    # the file holds 8 significant digits; re-parse the same text to get the exact g values
    written = np.array([float(f"{v:.7E}") for v in vals])
    assert gm.n == 23 and gm.dt == 0.005
    assert np.array_equal(gm.ax, written * G)  # exact: same float product
    assert np.all(gm.ay == 0.0)
    assert np.allclose(gm.t, 0.005 * np.arange(23), rtol=0, atol=1e-15)
    assert gm.label == "REC.AT2" and not gm.synthetic


def test_at2_plain_numbers_header_and_vertical(tmp_path):
    text = "h1\nh2\nh3\n   4  0.01   NPTS, DT\n0.1 -0.2\n0.3 0.4\n"
    gm = read_at2(_write(tmp_path, "V.AT2", text), component="y")
    assert gm.dt == 0.01 and gm.n == 4
    assert np.array_equal(gm.ay, np.array([0.1, -0.2, 0.3, 0.4]) * G)
    assert np.all(gm.ax == 0.0)


def test_two_column_round_trip_and_units(tmp_path):
    rng = np.random.default_rng(1)
    a = rng.normal(size=50)
    t = 0.01 * np.arange(50)
    text = "# time [s]   accel\n\n" + "\n".join(f"{float(ti)!r} {float(ai)!r}  # c" for ti, ai in zip(t, a)) + "\n"
    p = _write(tmp_path, "rec.txt", text)
    gm = read_two_column(p, "m/s2")
    assert np.array_equal(gm.ax, a)  # repr() round-trips floats exactly
    assert gm.dt == pytest.approx(0.01, rel=1e-15)
    gm_g = read_two_column(p, "g", component="y")
    assert np.array_equal(gm_g.ay, a * 9.80665) and np.all(gm_g.ax == 0.0)
    one = read_two_column(_write(tmp_path, "one.txt", "0 1\n0.1 1\n0.2 1\n"), "g")
    assert np.array_equal(one.ax, [9.80665] * 3)  # 1 g = 9.80665 m/s^2 exactly (standard gravity)


def test_three_column_writer_round_trip(tmp_path):
    gm = generate_koyna_like(seed=3, dt=0.01, duration=6.0)
    p = gmm.write_three_column(gm, tmp_path / "x.txt", ["SYNTHETIC test"])
    back = read_three_column(p, "m/s2")
    assert np.array_equal(back.ax, gm.ax) and np.array_equal(back.ay, gm.ay)  # '%.17g' is exact


# ---------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "name,text,kwargs,pattern",
    [
        ("empty.txt", "# only a comment\n\n", {}, r"empty"),
        ("nonnum.txt", "0 1\n0.1 2\n0.2 abc\n0.3 4\n", {}, r"line 3.*'abc'.*not a number"),
        ("ncol.txt", "0 1\n0.1 2 3\n0.2 4\n", {}, r"line 2: expected 2 columns"),
        ("nonuni.txt", "0 1\n0.01 1\n0.02 1\n0.035 1\n0.045 1\n", {}, r"non-uniform dt between data points 3 and 4.*0\.015.*tolerance"),
        ("neg.txt", "0.2 1\n0.1 1\n0.0 1\n", {}, r"negative or zero.*dt > 0"),
        ("zero.txt", "0 1\n0 1\n0 1\n", {}, r"negative or zero"),
        ("nan.txt", "0 1\n0.1 nan\n0.2 1\n", {}, r"line 2.*'nan'.*NaN"),
        ("few.txt", "0 1\n0.1 2\n", {}, r"too few points \(2\)"),
    ],
)
def test_two_column_bad_input(tmp_path, name, text, kwargs, pattern):
    p = _write(tmp_path, name, text)
    with pytest.raises(ValueError, match=pattern) as ei:
        read_two_column(p, "g", **kwargs)
    assert name in str(ei.value)  # the message names the file


def test_missing_file_and_bad_units(tmp_path):
    with pytest.raises(ValueError, match=r"nope\.txt.*does not exist"):
        read_two_column(tmp_path / "nope.txt", "g")
    with pytest.raises(ValueError, match=r"nope\.AT2.*does not exist"):
        read_at2(tmp_path / "nope.AT2")
    p = _write(tmp_path, "ok.txt", "0 1\n0.1 1\n0.2 1\n")
    with pytest.raises(ValueError, match=r"units='gal' is not allowed.*\['cm/s2', 'g', 'm/s2'\]"):
        read_two_column(p, "gal")
    with pytest.raises(ValueError, match=r"units=None"):
        read_two_column(p, None)
    with pytest.raises(ValueError, match=r"component='z'"):
        read_two_column(p, "g", component="z")


@pytest.mark.parametrize(
    "text,pattern",
    [
        (_at2_text([0.1, 0.2, 0.3], dt_field="DT= .0000 SEC"), r"line 4: DT='.0000' is negative or zero"),
        (_at2_text([0.1, 0.2, 0.3], dt_field="DT= -.0100 SEC"), r"line 4: DT='-.0100' is negative or zero"),
        (_at2_text([0.1, 0.2, 0.3], npts=5), r"NPTS=5 but 3 values.*too few"),
        (_at2_text([0.1, 0.2, 0.3], npts=2), r"NPTS=2 is too few points"),
        ("a\nb\nc\nNPTS=3, DT=0.01\n0.1 NaN 0.3\n", r"line 5.*'NaN'.*NaN"),
        ("a\nb\nc\nNPTS=3, DT=0.01\n0.1 x 0.3\n", r"line 5: field value #2 = 'x' is not a number"),
        ("a\nb\nc\nno numbers here\n0.1 0.2 0.3\n", r"line 4: cannot find NPTS and DT"),
        ("", r"empty"),
    ],
)
def test_at2_bad_input(tmp_path, text, pattern):
    with pytest.raises(ValueError, match=pattern):
        read_at2(_write(tmp_path, "BAD.AT2", text))


def test_processing_bad_arguments():
    gm = generate_koyna_like(seed=5, dt=0.01, duration=6.0)
    with pytest.raises(ValueError, match=r"dt=0\.0 is not allowed"):
        resample(gm, 0.0)
    with pytest.raises(ValueError, match=r"dt=-0\.01 is not allowed"):
        resample(gm, -0.01)
    with pytest.raises(ValueError, match=r"order=2 is not allowed.*>= 4"):
        baseline_correct(gm, order=2)
    with pytest.raises(ValueError, match=r"ax\[1\]=nan is not finite"):
        GroundMotion(gm.t[:3], [0.0, np.nan, 0.0], [0.0] * 3, gm.dt)
    with pytest.raises(ValueError, match=r"dt=0\.0 is not allowed"):
        GroundMotion(gm.t[:3], [0.0] * 3, [0.0] * 3, 0.0)


# ---------------------------------------------------------------------------- default record
def test_default_record_peaks_exact():
    gm = load_default()
    px, py = gm.peak_g()
    # scaling sets the peak sample to 0.49*g exactly and '%.17g' round-trips it: 1e-12 is slack
    assert abs(px - 0.49) <= 1e-12 * 0.49
    assert abs(py - 0.34) <= 1e-12 * 0.34
    assert gm.synthetic and "synthetic" in gm.label.lower()
    assert gm.dt == pytest.approx(0.002, rel=1e-12) and gm.duration == pytest.approx(10.0, rel=1e-12)
    assert "SYNTHETIC" in gmm.DEFAULT_FILE.read_text().splitlines()[0]


def test_shipped_file_equals_generator():
    gen = generate_koyna_like(seed=1967, dt=0.002, duration=10.0)
    shipped = load_default()
    assert gen.n == shipped.n
    # relative to the component peak (elementwise relative error is meaningless near zero
    # crossings); the file stores 17 digits so any difference is FFT round-off across builds
    for a, b in ((gen.ax, shipped.ax), (gen.ay, shipped.ay)):
        assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(a))


def test_shipped_file_header_names_modules_that_exist():
    """The shipped record's header tells a reader how it was made and how to regenerate it:
    the modules it names exist (they named ngs_driver.ground_motion after the module moved to
    ngs_driver/setup/)."""
    import importlib
    import importlib.util
    head = [ln[2:] for ln in gmm.DEFAULT_FILE.read_text().splitlines() if ln.startswith("# ")]
    gen = next(ln for ln in head if ln.startswith("generator: "))
    regen = next(ln for ln in head if ln.startswith("regenerate: "))
    func = gen.split(": ", 1)[1].split("(", 1)[0]            # module.function
    module, name = func.rsplit(".", 1)
    assert importlib.util.find_spec(module) is not None, gen
    assert hasattr(importlib.import_module(module), name), gen
    assert regen == f"regenerate: python -m {module} --write-default", regen


def test_default_record_residual_velocity_displacement():
    gm = load_default()
    v, d = gm.integrate()
    # baseline_correct enforces v_end = d_end = 0 in the same discrete trapezoid algebra, so the
    # residual is round-off: ~ n * eps * max|v| ~ 5000 * 2.2e-16 * 0.4 m/s ~ 5e-13; bound 1e-9.
    assert np.all(np.abs(v[-1]) < 1e-9)
    assert np.all(np.abs(d[-1]) < 1e-9)
    # the record starts at rest with zero acceleration (no step load at t = 0)
    assert gm.ax[0] == 0.0 and gm.ay[0] == 0.0


def test_default_record_character():
    gm = load_default()
    # strong phase in the first ~5 s: 5-95 % Arias (Trifunac-Brady) window
    for a in (gm.ax, gm.ay):
        t5, t95 = significant_duration(a, gm.dt)
        assert 0.5 < t5 < 1.5 and 4.5 < t95 < 6.0, (t5, t95)
    # horizontal is rich in 2-10 Hz: most of the Fourier energy (measured ~0.7) in that band
    F = np.abs(np.fft.rfft(gm.ax)) ** 2
    f = np.fft.rfftfreq(gm.n, gm.dt)
    frac = F[(f >= 2) & (f <= 10)].sum() / F.sum()
    assert frac > 0.6, frac


def test_generator_deterministic_and_seed_dependent():
    a = generate_koyna_like(seed=42, dt=0.01, duration=10.0)
    b = generate_koyna_like(seed=42, dt=0.01, duration=10.0)
    c = generate_koyna_like(seed=43, dt=0.01, duration=10.0)
    assert np.array_equal(a.ax, b.ax) and np.array_equal(a.ay, b.ay)
    # another seed: same peaks but a different history (differences of the order of the peak)
    assert c.peak_g() == pytest.approx((0.49, 0.34), rel=1e-12)
    assert np.max(np.abs(a.ax - c.ax)) > 0.3 * a.peak()[0]
    assert np.max(np.abs(a.ay - c.ay)) > 0.3 * a.peak()[1]


# ---------------------------------------------------------------------------- processing
def test_baseline_correct_removes_drift_and_keeps_start():
    dt = 0.005
    t = dt * np.arange(2001)
    a = 0.05 + np.sin(2 * np.pi * 1.3 * t) * np.exp(-0.2 * t)  # offset -> big drift
    gm = GroundMotion(t, a, np.zeros_like(a), dt)
    v0, d0 = gm.integrate()
    assert abs(d0[-1, 0]) > 1.0  # uncorrected: metres of drift (0.05*10^2/2 = 2.5 m alone)
    bc = baseline_correct(gm)
    v, d = bc.integrate()
    assert abs(v[-1, 0]) < 1e-10 and abs(d[-1, 0]) < 1e-10  # exact constraints; round-off bound
    assert bc.ax[0] == pytest.approx(a[0], abs=1e-14)  # no tau^2 term: a(t0) unchanged
    assert np.all(bc.ay == 0.0)
    # the correction is a smooth polynomial of degree order-2 = 4 with no constant/linear term
    # (p'' of tau^3..tau^6): fitting such a polynomial leaves only round-off
    diff = bc.ax - a
    tau = t / t[-1]
    B = np.stack([tau ** j for j in range(1, 5)], axis=1)
    res = diff - B @ np.linalg.lstsq(B, diff, rcond=None)[0]
    assert np.max(np.abs(res)) < 1e-9 * np.max(np.abs(diff))


def test_integrate_trapezoid_exact_for_linear():
    dt = 0.1
    t = dt * np.arange(11)
    gm = GroundMotion(t, 2.0 * np.ones(11), 3.0 * t, dt)  # const and linear accelerations
    v, d = gm.integrate()
    assert np.allclose(v[:, 0], 2.0 * t, atol=1e-13)  # trapezoid exact for linear integrand
    assert np.allclose(v[:, 1], 1.5 * t ** 2, atol=1e-13)
    # d of a constant a: trapezoid of a linear v is exact -> t^2
    assert np.allclose(d[:, 0], t ** 2, atol=1e-13)


def test_resample_refine_sine_linear_error_bound():
    dt0, f0 = 0.01, 2.0
    t = dt0 * np.arange(501)
    gm = GroundMotion(t, np.sin(2 * np.pi * f0 * t), np.zeros_like(t), dt0)
    r = resample(gm, 0.002)
    assert r.n == 2501 and r.dt == 0.002
    err = np.max(np.abs(r.ax - np.sin(2 * np.pi * f0 * r.t)))
    bound = (2 * np.pi * f0 * dt0) ** 2 / 8  # linear-interpolation bound A*(w*h)^2/8 = 1.97e-3
    assert err <= bound
    assert err > 0.5 * bound  # and it is really linear interpolation (bound nearly attained)


def test_resample_decimate_preserves_sine_and_antialiases():
    dt0 = 0.001
    t = dt0 * np.arange(10001)
    low = np.sin(2 * np.pi * 2.0 * t)
    high = np.sin(2 * np.pi * 80.0 * t)  # above the new Nyquist (50 Hz): would alias to 20 Hz
    gm = GroundMotion(t, low, high, dt0)
    r = resample(gm, 0.01)
    inner = (r.t > 0.5) & (r.t < 9.5)  # away from edge ringing (record ends abruptly, ~0.1 s)
    # 2 Hz is far inside the 40 Hz pass band: Butterworth-8 loss (2/40)^16 ~ 1e-21 -> round-off only
    assert np.max(np.abs(r.ax - np.sin(2 * np.pi * 2.0 * r.t))[inner]) < 1e-6
    # 80 Hz: |H|^2 = 1/(1+(80/40)^16) = 1.5e-5 (zero-phase Butterworth-8 squared); bound 1e-3
    assert np.max(np.abs(r.ay[inner])) < 1e-3
    naive = resample(gm, 0.01, antialias=False)
    assert np.max(np.abs(naive.ay[inner])) > 0.5  # without the filter it aliases at full amplitude


def test_combine_and_scaled(tmp_path):
    t = 0.01 * np.arange(5)
    h = GroundMotion(t, [1, 2, 3, 4, 5.0], np.zeros(5), 0.01, label="h")
    v = GroundMotion(t[:3], np.zeros(3), [7, 8, 9.0], 0.01, label="v")
    c = combine(h, v)
    assert np.array_equal(c.ax, [1, 2, 3, 4, 5]) and np.array_equal(c.ay, [7, 8, 9, 0, 0])
    with pytest.raises(ValueError, match=r"vertical record 'h' has a nonzero horizontal.*component='y'"):
        combine(h, h)
    with pytest.raises(ValueError, match=r"dt differ"):
        combine(h, GroundMotion(0.02 * np.arange(3), np.zeros(3), [1, 2, 3.0], 0.02))
    s = c.scaled((2.0, 0.5))
    assert s.peak() == (10.0, 4.5)
    assert c.scaled(3.0).peak() == (15.0, 27.0)


# ---------------------------------------------------------------------------- spectrum
def test_response_spectrum_resonance_and_rigid_limit():
    f0, a0, zeta = 2.0, 1.0, 0.05
    # fine input (h = 2.5e-3 s, T = 0.5 s, 20 s: transient decays as exp(-zeta*w*t) = exp(-12.6))
    dt = 0.0025
    t = dt * np.arange(8001)
    Sa = response_spectrum(np.sin(2 * np.pi * f0 * t) * a0, dt, np.array([1 / f0]), zeta)[0]
    # steady state at resonance: |u| = a0/(2 zeta w^2) -> Sa = a0/(2 zeta) = 10 a0.
    # Newmark average acceleration = trapezoid (bilinear) rule: the oscillator is seen at
    # w(1 + d), d = (w h)^2/12 = 8e-5 (detuning and damping increase, amplitude loss ~ d = 1e-4)
    # plus peak sampling (800 samples/cycle, < 1e-5): tolerance 5e-4
    assert Sa == pytest.approx(a0 / (2 * zeta), rel=5e-4)
    # coarse step h/T = 0.02: d = 1.3e-3 -> loss ~1.6e-3 plus peak sampling (<= 4.9e-4)
    dt = 0.01
    t = dt * np.arange(2001)
    Sa1 = response_spectrum(np.sin(2 * np.pi * f0 * t) * a0, dt, np.array([1 / f0]), zeta)[0]
    assert 1e-3 < 1 - Sa1 / (a0 / (2 * zeta)) < 2.5e-3
    gm = load_default()
    S0 = response_spectrum(gm.ax, gm.dt, np.array([0.01]), substeps=2)[0]
    # rigid oscillator (100 Hz >> 25 Hz f_max of the record) follows the ground: Sa -> PGA
    # (measured 1.009 PGA: the residual is the record's content near 25-50 Hz)
    assert S0 == pytest.approx(gm.peak()[0], rel=0.03)


def test_plot_script_fast(tmp_path, capsys, study):
    # in-process (a subprocess would pay numpy/scipy/matplotlib imports again)
    out = study("ground_motion_plot").main(fast=True, outdir=tmp_path)
    assert out.stat().st_size > 10_000
    text = capsys.readouterr().out
    assert "SYNTHETIC" in text and "peaks: 0.49 g, 0.34 g" in text
