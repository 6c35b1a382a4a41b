"""Ground-motion input for the seismic dam analysis (numpy only; no ngsolve, no scipy).

Readers for two-column (t, a) text files (``read_headed``: one whose header states its points,
step and peak, checked against them), PEER NGA ``.AT2`` files, a uniform-step
:class:`GroundMotion` container (m/s^2), resampling to the analysis step, polynomial
baseline correction, trapezoid integration, a Newmark 5 %-damped response spectrum and the
reproducible SYNTHETIC Koyna-like default record.

No digitised 1967 Koyna accelerogram is in public sources, so the default record
(``ngs_driver/data/koyna_synthetic.txt``) is SYNTHETIC: Clough-Penzien filtered Gaussian white
noise under a Jennings-type envelope, baseline corrected and scaled to the peaks usually quoted
for Koyna 1967 (0.49 g horizontal / stream, 0.34 g vertical). It is *not* the recorded motion.
See docs/model.md §9 for every choice with its reason and source.

Sign/axis convention: ``ax`` is the horizontal (stream, x) ground acceleration and ``ay`` the
vertical (y, up) ground acceleration, both in m/s^2. Motion starts at rest (v = d = 0 at t[0]).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Sequence

import numpy as np

__all__ = [
    "G",
    "UNITS",
    "GroundMotion",
    "KoynaSyntheticParams",
    "read_two_column",
    "read_three_column",
    "read_at2",
    "read_headed",
    "SHIPPED_DIR",
    "write_three_column",
    "combine",
    "resample",
    "baseline_correct",
    "integrate",
    "response_spectrum",
    "significant_duration",
    "generate_koyna_like",
    "load_default",
    "write_default",
    "DEFAULT_FILE",
]

G = 9.80665  # standard gravity, m/s^2 (CGPM 1901; exact by definition)

#: accepted unit strings -> factor to m/s^2. No guessing: the caller must say which.
UNITS: dict[str, float] = {"g": G, "m/s2": 1.0, "cm/s2": 0.01}

MIN_POINTS = 3  # two intervals are needed to define dt and check that it is uniform
DT_RTOL = 1e-4  # default tolerance on dt uniformity, relative to dt (see read_two_column)

DEFAULT_FILE = Path(__file__).resolve().parent.parent / "data" / "koyna_synthetic.txt"
SHIPPED_DIR = DEFAULT_FILE.parent   # recorded motions shipped with their source (read_headed)


# --------------------------------------------------------------------------------------------
# container
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class GroundMotion:
    """Uniformly sampled two-component ground acceleration, SI units (m/s^2).

    t      : times, uniform step ``dt`` starting at ``t[0]`` (usually 0)
    ax, ay : horizontal / vertical ground acceleration, m/s^2 (a component may be all zero)
    units  : note on the original units and conversion applied
    label  : short name (file name or "synthetic ...")
    synthetic : True for generated (not recorded) motions
    source : free-text provenance
    meta   : record metadata (event, station, magnitude, PGA, citation ...) for summary.json
    """

    t: np.ndarray
    ax: np.ndarray
    ay: np.ndarray
    dt: float
    units: str = "m/s2"
    label: str = ""
    synthetic: bool = False
    source: str = ""
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        t = np.ascontiguousarray(self.t, dtype=float)
        ax = np.ascontiguousarray(self.ax, dtype=float)
        ay = np.ascontiguousarray(self.ay, dtype=float)
        dt = float(self.dt)
        if not (math.isfinite(dt) and dt > 0.0):
            raise ValueError(f"GroundMotion {self.label!r}: dt={dt!r} is not allowed; dt must be a finite number > 0")
        if not (t.ndim == ax.ndim == ay.ndim == 1 and t.size == ax.size == ay.size):
            raise ValueError(
                f"GroundMotion {self.label!r}: t, ax, ay must be 1-D of equal length, got {t.shape}, {ax.shape}, {ay.shape}")
        if t.size < MIN_POINTS:
            raise ValueError(f"GroundMotion {self.label!r}: too few points ({t.size}); at least {MIN_POINTS} are needed")
        for name, arr in (("t", t), ("ax", ax), ("ay", ay)):
            if not np.all(np.isfinite(arr)):
                i = int(np.flatnonzero(~np.isfinite(arr))[0])
                raise ValueError(f"GroundMotion {self.label!r}: {name}[{i}]={float(arr[i])!r} is not finite (NaN/inf not allowed)")
        # t must be uniform with step dt (it is constructed so by all readers)
        ideal = t[0] + dt * np.arange(t.size)
        err = np.max(np.abs(t - ideal))
        if err > 1e-6 * dt:
            raise ValueError(f"GroundMotion {self.label!r}: t is not uniform with dt={dt} (max deviation {err:.3g} s)")
        for k, v in (("t", t), ("ax", ax), ("ay", ay), ("dt", dt)):
            object.__setattr__(self, k, v)
        for a in (t, ax, ay):
            a.setflags(write=False)

    # -- basic properties ------------------------------------------------------------------
    @property
    def n(self) -> int:
        return int(self.t.size)

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])

    def peak(self) -> tuple[float, float]:
        """(max|ax|, max|ay|) in m/s^2."""
        return float(np.max(np.abs(self.ax))), float(np.max(np.abs(self.ay)))

    def peak_g(self) -> tuple[float, float]:
        """(max|ax|, max|ay|) in g (9.80665 m/s^2)."""
        px, py = self.peak()
        return px / G, py / G

    def integrate(self) -> tuple[np.ndarray, np.ndarray]:
        """Velocity and displacement by the trapezoid rule, starting at rest.

        Returns ``v, d`` each of shape (n, 2): column 0 horizontal, column 1 vertical (m/s, m).
        """
        a = np.column_stack([self.ax, self.ay])
        v = integrate(a, self.dt)
        d = integrate(v, self.dt)
        return v, d

    def scaled(self, factor: float | Sequence[float]) -> "GroundMotion":
        """Copy with accelerations multiplied by ``factor`` (a number, or (fx, fy))."""
        fx, fy = (factor, factor) if np.ndim(factor) == 0 else tuple(factor)
        fx, fy = float(fx), float(fy)
        for f in (fx, fy):
            if not math.isfinite(f):
                raise ValueError(f"scaled: factor {f!r} is not finite")
        return replace(self, ax=self.ax * fx, ay=self.ay * fy,
                       source=self.source + f" | scaled by ({fx:g}, {fy:g})")

    def at(self, time: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Linear interpolation of (ax, ay) at ``time``; zero outside the record."""
        return (np.interp(time, self.t, self.ax, left=0.0, right=0.0),
                np.interp(time, self.t, self.ay, left=0.0, right=0.0))


# --------------------------------------------------------------------------------------------
# analytic pulses (the rigid-block studies of Newmark 1965 and their successors)
# --------------------------------------------------------------------------------------------
PULSE_SHAPES = ("sine", "half-sine")
PULSE_PREFIX = "pulse:"


def pulse_record(spec: str, duration: float, dt: float) -> GroundMotion:
    """``pulse:<shape>:<peak in g>:<period s>[:<cycles>]``: a horizontal acceleration pulse
    a(t) = A sin(2 pi t / T) for ``cycles`` full periods ("sine", default 1 cycle) or
    A sin(pi t / T) for 0 <= t <= T ("half-sine"), then zero, sampled at ``dt`` (the run's
    step: no resampling) up to ``duration``. Raises ValueError naming the part that is wrong."""
    parts = spec[len(PULSE_PREFIX):].split(":") if spec.startswith(PULSE_PREFIX) else []
    allowed = ("allowed: 'pulse:<shape>:<peak in g>:<period in s>[:<cycles>]' with shape "
               f"{' or '.join(map(repr, PULSE_SHAPES))}, e.g. 'pulse:sine:0.5:0.4:2'")
    if len(parts) not in (3, 4) or parts[0] not in PULSE_SHAPES:
        raise ValueError(f"ground_motion.record = {spec!r}: not a pulse; {allowed}")
    try:
        A, T = float(parts[1]), float(parts[2])
        n = int(parts[3]) if len(parts) == 4 else 1
    except ValueError:
        raise ValueError(f"ground_motion.record = {spec!r}: the peak, period and cycles must be "
                         f"numbers; {allowed}") from None
    if not (math.isfinite(A) and math.isfinite(T) and T > 0 and n >= 1 and abs(A) <= 10):
        raise ValueError(f"ground_motion.record = {spec!r}: out of range; allowed: |peak| <= "
                         "10 g, period > 0 s, cycles >= 1")
    if parts[0] == "half-sine" and n != 1:
        raise ValueError(f"ground_motion.record = {spec!r}: a half-sine has one half cycle; "
                         f"{allowed}")
    t = dt * np.arange(int(round(duration / dt)) + 1)
    length = T * n if parts[0] == "sine" else T
    w = (2.0 if parts[0] == "sine" else 1.0) * math.pi / T
    ax = np.where(t <= length + 1e-12 * T, A * G * np.sin(w * t), 0.0)
    if t.size < MIN_POINTS:
        t = dt * np.arange(MIN_POINTS)
        ax = np.zeros(MIN_POINTS)
    return GroundMotion(t, ax, np.zeros_like(ax), dt, units="g", label=spec, synthetic=True,
                        source=f"analytic {parts[0]} pulse: peak {A:g} g, period {T:g} s, "
                               f"{n} cycle(s)")


# --------------------------------------------------------------------------------------------
# readers / writer
# --------------------------------------------------------------------------------------------
def _units_factor(units: str, where: str) -> float:
    if not isinstance(units, str) or units not in UNITS:
        raise ValueError(f"{where}: units={units!r} is not allowed; allowed units are {sorted(UNITS)} "
                         "(no default: say which units the file is in)")
    return UNITS[units]


def _open_text(path, what: str) -> tuple[Path, list[str]]:
    p = Path(path)
    if not p.exists():
        raise ValueError(f"{what} file {str(p)!r} does not exist (missing file)")
    if not p.is_file():
        raise ValueError(f"{what} file {str(p)!r} is not a regular file")
    lines = p.read_text(encoding="utf-8-sig", errors="replace").splitlines()  # BOM: not data
    if not any(ln.split("#", 1)[0].strip() for ln in lines):
        raise ValueError(f"{what} file {str(p)!r} is empty (no data lines)")
    return p, lines


def _parse_float(tok: str, p: Path, lineno: int, field_name: str) -> float:
    try:
        x = float(tok.replace("D", "E").replace("d", "e"))  # Fortran D exponents
    except ValueError:
        raise ValueError(f"file {str(p)!r} line {lineno}: field {field_name} = {tok!r} is not a number "
                         "(non-numeric value; comments must start with '#')") from None
    if not math.isfinite(x):
        raise ValueError(f"file {str(p)!r} line {lineno}: field {field_name} = {tok!r} is NaN/inf; "
                         "only finite numbers are allowed")
    return x


def _read_columns(path, ncol: int, names: Sequence[str], what: str) -> tuple[Path, np.ndarray]:
    p, lines = _open_text(path, what)
    rows = []
    for lineno, raw in enumerate(lines, start=1):
        body = raw.split("#", 1)[0].strip()
        if not body:
            continue
        toks = body.replace(",", " ").split()
        if len(toks) != ncol:
            raise ValueError(f"file {str(p)!r} line {lineno}: expected {ncol} columns ({', '.join(names)}), "
                             f"got {len(toks)}: {body!r}")
        rows.append([_parse_float(tok, p, lineno, nm) for tok, nm in zip(toks, names)])
    data = np.asarray(rows, dtype=float)
    if data.shape[0] < MIN_POINTS:
        raise ValueError(f"file {str(p)!r}: too few points ({data.shape[0]}); at least {MIN_POINTS} are needed")
    return p, data


def _uniform_dt(t: np.ndarray, p: Path, dt_rtol: float) -> float:
    dts = np.diff(t)
    bad = np.flatnonzero(dts <= 0.0)
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"file {str(p)!r}: time step dt = t[{i + 1}] - t[{i}] = {float(dts[i])!r} s between data "
                         f"points {i + 1} and {i + 2} is negative or zero; times must increase (dt > 0)")
    ref = float(np.median(dts))  # robust reference: one odd step does not shift it
    tol = dt_rtol * ref
    dev = np.abs(dts - ref)
    if np.any(dev > tol):
        i = int(np.argmax(dev > tol))
        raise ValueError(f"file {str(p)!r}: non-uniform dt between data points {i + 1} and {i + 2} "
                         f"(t={float(t[i])!r} -> {float(t[i + 1])!r} s): step {float(dts[i])!r} s differs from the "
                         f"median step {ref!r} s by {float(dev[i]):.3g} s > tolerance {tol:.3g} s "
                         f"(dt_rtol={dt_rtol:g}); resample the record first")
    return float((t[-1] - t[0]) / (t.size - 1))


def read_two_column(path, units: str, component: str = "x", *, dt_rtol: float = DT_RTOL) -> GroundMotion:
    """Read a two-column text file ``t  a`` ('#' comments, blank lines, ',' or blanks as separators).

    ``units`` must be given ("g", "m/s2" or "cm/s2"); ``component`` "x" (horizontal) or "y"
    (vertical) says which component the column is; the other component is zero. Times must be
    uniform to ``dt_rtol * dt`` (default 1e-4: larger than printing round-off of any sensibly
    formatted time column, smaller than any real change of step). The stored times are the exact
    uniform grid ``t0 + i*dt`` with ``dt = (t_end - t0)/(n-1)``.
    """
    f = _units_factor(units, f"read_two_column({str(path)!r})")
    if component not in ("x", "y"):
        raise ValueError(f"read_two_column: component={component!r} is not allowed; use 'x' (horizontal) or 'y' (vertical)")
    p, data = _read_columns(path, 2, ("t", "a"), "two-column")
    dt = _uniform_dt(data[:, 0], p, dt_rtol)
    t = data[0, 0] + dt * np.arange(data.shape[0])
    a = data[:, 1] * f
    z = np.zeros_like(a)
    ax, ay = (a, z) if component == "x" else (z, a)
    return GroundMotion(t, ax, ay, dt, units=f"read in {units}, x{f:g} -> m/s2", label=p.name,
                        synthetic=False, source=f"two-column file {p}")


def read_three_column(path, units: str, *, dt_rtol: float = DT_RTOL) -> GroundMotion:
    """Read ``t  ax  ay`` text (the format of the shipped default record)."""
    f = _units_factor(units, f"read_three_column({str(path)!r})")
    p, data = _read_columns(path, 3, ("t", "ax", "ay"), "three-column")
    dt = _uniform_dt(data[:, 0], p, dt_rtol)
    t = data[0, 0] + dt * np.arange(data.shape[0])
    return GroundMotion(t, data[:, 1] * f, data[:, 2] * f, dt, units=f"read in {units}, x{f:g} -> m/s2",
                        label=p.name, synthetic=False, source=f"three-column file {p}")


_NPTS_RE = re.compile(r"NPTS\s*[=:]?\s*([0-9]+)", re.IGNORECASE)
_DT_RE = re.compile(r"\bDT\s*[=:]?\s*([-+]?[0-9]*\.?[0-9]+(?:[eEdD][-+]?[0-9]+)?)", re.IGNORECASE)
_NUM_RE = re.compile(r"[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eEdD][-+]?[0-9]+)?")


def read_at2(path, component: str = "x") -> GroundMotion:
    """Read a PEER NGA ``.AT2`` file (accelerations in g by convention).

    Lines 1-3 are free text; line 4 gives NPTS and DT either as ``NPTS=  4000, DT= .0050 SEC``
    or as two leading numbers ``4000 0.005``; the values follow row by row (any number per row).
    The number of values must equal NPTS. ``component`` 'x' (horizontal) or 'y' (vertical).
    """
    if component not in ("x", "y"):
        raise ValueError(f"read_at2: component={component!r} is not allowed; use 'x' (horizontal) or 'y' (vertical)")
    p, lines = _open_text(path, "AT2")
    if len(lines) < 5:
        raise ValueError(f"AT2 file {str(p)!r}: too few lines ({len(lines)}); expected 4 header lines "
                         "then values")
    hdr = lines[3]
    m_n, m_dt = _NPTS_RE.search(hdr), _DT_RE.search(hdr)
    if m_n and m_dt:
        npts_s, dt_s = m_n.group(1), m_dt.group(1)
    else:
        nums = _NUM_RE.findall(hdr)
        if len(nums) < 2:
            raise ValueError(f"AT2 file {str(p)!r} line 4: cannot find NPTS and DT in {hdr.strip()!r}; "
                             "allowed forms are 'NPTS= 4000, DT= .0050 SEC' or '4000 0.005'")
        npts_s, dt_s = nums[0], nums[1]
    try:
        npts_f = float(npts_s)
    except ValueError:
        npts_f = float("nan")
    if not (math.isfinite(npts_f) and npts_f == int(npts_f)):
        raise ValueError(f"AT2 file {str(p)!r} line 4: NPTS={npts_s!r} is not an integer")
    npts = int(npts_f)
    dt = _parse_float(dt_s, p, 4, "DT")
    if not dt > 0.0:
        raise ValueError(f"AT2 file {str(p)!r} line 4: DT={dt_s!r} is negative or zero; DT must be > 0")
    if npts < MIN_POINTS:
        raise ValueError(f"AT2 file {str(p)!r} line 4: NPTS={npts} is too few points; at least {MIN_POINTS} needed")
    vals: list[float] = []
    for lineno, raw in enumerate(lines[4:], start=5):
        for tok in raw.split():
            vals.append(_parse_float(tok, p, lineno, f"value #{len(vals) + 1}"))
    if len(vals) != npts:
        raise ValueError(f"AT2 file {str(p)!r}: header line 4 says NPTS={npts} but {len(vals)} values follow "
                         "(too few points)" if len(vals) < npts else
                         f"AT2 file {str(p)!r}: header line 4 says NPTS={npts} but {len(vals)} values follow")
    a = np.asarray(vals) * G
    z = np.zeros_like(a)
    ax, ay = (a, z) if component == "x" else (z, a)
    return GroundMotion(dt * np.arange(npts), ax, ay, dt, units=f"AT2 in g, x{G} -> m/s2", label=p.name,
                        synthetic=False, source=f"PEER AT2 file {p}; header: {' | '.join(s.strip() for s in lines[:3])}")


_CLAIM_RE = re.compile(r"^#\s*(units|dt|npts|peak_g|peak_time)\s*:\s*(\S+)\s*$")
#: a peak printed with k decimals is exact to half a unit of its last digit (the check allows
#: that rounding and, for the float conversion of the bound itself, a relative 1e-9 more)
PEAK_HEADER_RTOL = 1e-9


def _decimals(tok: str) -> int:
    return len(tok.split(".", 1)[1]) if "." in tok else 0


def read_headed(path) -> GroundMotion:
    """Read a two-column ``t  a`` record whose '#' header states what the data are
    (``# units: g``, ``# dt: 0.02``, ``# npts: 2720``, ``# peak_g: 0.179``, optional
    ``# peak_time: 3.70``) and refuse it when the values do not match: the number of points,
    the step (to the printed digits), and the peak |a| (to half a unit of the header's last
    printed digit) and its time. The shipped recorded motions (``ngs_driver/data``) are read
    so: a file truncated, padded or edited shows up as a clear error, not as another record.
    """
    p, lines = _open_text(path, "record")
    claims: dict[str, str] = {}
    for ln in lines:
        m = _CLAIM_RE.match(ln.strip())
        if m:
            claims[m.group(1)] = m.group(2)
    missing = [k for k in ("units", "dt", "npts", "peak_g") if k not in claims]
    if missing:
        raise ValueError(f"record file {str(p)!r}: header lacks {', '.join('# ' + k + ':' for k in missing)}; "
                         "a headed record states units, dt, npts and peak_g")
    gm = read_two_column(p, claims["units"], "x")
    where = f"record file {str(p)!r}"
    try:
        npts = int(claims["npts"])
        dt = float(claims["dt"])
        peak = float(claims["peak_g"])
    except ValueError:
        raise ValueError(f"{where}: header npts={claims['npts']!r}, dt={claims['dt']!r}, "
                         f"peak_g={claims['peak_g']!r}: not numbers") from None
    if gm.n != npts:
        raise ValueError(f"{where}: the header says npts = {npts} but the file has {gm.n} data points "
                         "(truncated or padded?); allowed: exactly the header's number")
    half = 0.5 * 10.0 ** (-_decimals(claims["dt"]))
    if abs(gm.dt - dt) > half:
        raise ValueError(f"{where}: the header says dt = {claims['dt']} s but the times step by {gm.dt:.6g} s")
    a_g = np.abs(gm.ax) / G        # m/s2 -> g, whatever the file's units
    got = float(a_g.max())
    half = 0.5 * 10.0 ** (-_decimals(claims["peak_g"]))
    if abs(got - peak) > half * (1.0 + PEAK_HEADER_RTOL):
        raise ValueError(f"{where}: the header says peak_g = {claims['peak_g']} but the largest |a| in the "
                         f"file is {got:.6g} g (allowed: within {half:g} g, the header's printed digits)")
    if "peak_time" in claims:
        tp = float(claims["peak_time"])
        tgot = float(gm.t[int(np.argmax(a_g))])
        if abs(tgot - tp) > 0.5 * gm.dt:
            raise ValueError(f"{where}: the header says the peak is at {claims['peak_time']} s but it is at "
                             f"{tgot:.6g} s")
    return replace(gm, label=p.stem, source=f"headed record {p.name} (npts {npts}, dt {dt:g} s, "
                                            f"peak {got:.4g} g, as its header states)")


def write_three_column(gm: GroundMotion, path, header: Sequence[str] = ()) -> Path:
    """Write ``t ax ay`` (m/s^2) with '%.17g' (exact float round trip) and '#' header lines."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    lines = [f"# {h}" if h else "#" for h in header]
    lines.append("# columns: t [s]  ax [m/s2] (horizontal)  ay [m/s2] (vertical)")
    lines.extend(f"{t:.17g} {x:.17g} {y:.17g}" for t, x, y in zip(gm.t, gm.ax, gm.ay))
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return p


# --------------------------------------------------------------------------------------------
# processing
# --------------------------------------------------------------------------------------------
def combine(h: GroundMotion, v: GroundMotion) -> GroundMotion:
    """Horizontal record ``h`` (ax only) + vertical record ``v`` (ay only) -> one motion.

    Both must have the same dt and t[0] (else resample first). The shorter record is padded with
    zeros (ground at rest after its end). Read the vertical file with ``component="y"``.
    """
    if np.any(h.ay != 0.0):
        raise ValueError(f"combine: horizontal record {h.label!r} has a nonzero vertical component ay; "
                         "pass a horizontal-only record (component='x')")
    if np.any(v.ax != 0.0):
        raise ValueError(f"combine: vertical record {v.label!r} has a nonzero horizontal component ax; "
                         "read it with component='y'")
    if abs(h.dt - v.dt) > 1e-9 * h.dt:
        raise ValueError(f"combine: dt differ ({h.label!r}: {h.dt!r} s, {v.label!r}: {v.dt!r} s); resample first")
    if abs(h.t[0] - v.t[0]) > 1e-9 * h.dt:
        raise ValueError(f"combine: start times differ ({h.t[0]!r} vs {v.t[0]!r} s)")
    n = max(h.n, v.n)
    ax = np.zeros(n)
    ay = np.zeros(n)
    ax[:h.n] = h.ax
    ay[:v.n] = v.ay
    return GroundMotion(h.t[0] + h.dt * np.arange(n), ax, ay, h.dt, units=f"x: {h.units}; y: {v.units}",
                        label=f"{h.label}+{v.label}", synthetic=h.synthetic or v.synthetic,
                        source=f"x: {h.source}; y: {v.source}")


def resample(gm: GroundMotion, dt: float, *, antialias: bool = True) -> GroundMotion:
    """Resample to step ``dt`` over the same time span (t0 .. <= t_end).

    * ``dt <= gm.dt`` (refining): linear interpolation, i.e. the record is taken piecewise
      linear between samples, the same assumption as the exact piecewise-linear (Nigam-Jennings)
      and trapezoid integrations. Sine error bound: A*(w*dt_old)^2/8.
    * ``dt > gm.dt`` (decimating): first a zero-phase low-pass with the magnitude of an
      8-pole Butterworth applied forward and backward (|H|^2, as ``filtfilt`` would) at 0.8 x the
      new Nyquist frequency removes content that would alias, then linear interpolation. Done by
      FFT on the zero-padded record (padding as in Boore 2005), numpy only. Zero phase -> no time
      shift. Pass ``antialias=False`` to skip.
    Peaks are not preserved exactly (samples move); call ``scaled`` afterwards if needed.
    """
    dt = float(dt)
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(f"resample: dt={dt!r} is not allowed; dt must be a finite number > 0")
    n_new = int(math.floor(gm.duration / dt * (1.0 + 1e-12) + 1e-9)) + 1
    if n_new < MIN_POINTS:
        raise ValueError(f"resample: dt={dt!r} s gives too few points ({n_new}) over {gm.duration} s")
    t_new = gm.t[0] + dt * np.arange(n_new)
    ax, ay = gm.ax, gm.ay
    if antialias and dt > gm.dt * (1.0 + 1e-12):
        fc = 0.8 * (0.5 / dt)  # Hz
        ax = _lowpass_zero_phase(ax, gm.dt, fc) if np.any(ax) else ax
        ay = _lowpass_zero_phase(ay, gm.dt, fc) if np.any(ay) else ay
    return replace(gm, t=t_new, ax=np.interp(t_new, gm.t, ax), ay=np.interp(t_new, gm.t, ay), dt=dt,
                   source=gm.source + f" | resampled {gm.dt:g}->{dt:g} s"
                   + (" (anti-aliased)" if antialias and dt > gm.dt else ""))


def _lowpass_zero_phase(x: np.ndarray, dt: float, fc: float, order: int = 8) -> np.ndarray:
    """Zero-phase low-pass: multiply the spectrum by |H_butterworth(f)|^2 = 1/(1+(f/fc)^(2 order)).

    The record is zero-padded to >= 2n (a power of two) so the FFT's circular convolution acts
    as a linear one with the ground at rest outside the record (Boore 2005 pads).
    """
    n = x.size
    nfft = 1 << int(math.ceil(math.log2(2 * n)))
    f = np.fft.rfftfreq(nfft, dt)
    H2 = 1.0 / (1.0 + (f / fc) ** (2 * order))
    return np.fft.irfft(np.fft.rfft(x, nfft) * H2, nfft)[:n]


def integrate(a: np.ndarray, dt: float) -> np.ndarray:
    """Cumulative trapezoid integral along axis 0, starting from 0."""
    a = np.asarray(a, dtype=float)
    out = np.zeros_like(a)
    out[1:] = np.cumsum(0.5 * dt * (a[1:] + a[:-1]), axis=0)
    return out


def _baseline_1d(a: np.ndarray, dt: float, t: np.ndarray, order: int) -> np.ndarray:
    """Remove p''(t), p = sum_{k=3..order} c_k tau^k, fitted to the displacement (see baseline_correct)."""
    tau = (t - t[0]) / (t[-1] - t[0])  # scaled time in [0,1] for conditioning
    T = t[-1] - t[0]
    ks = np.arange(3, order + 1)
    # acceleration basis: d^2/dt^2 tau^k = k(k-1) tau^(k-2) / T^2
    P = np.stack([k * (k - 1) * tau ** (k - 2) / T ** 2 for k in ks], axis=1)
    Pv = integrate(P, dt)
    Pd = integrate(Pv, dt)  # discrete displacements of the basis (same operator as the data)
    v = integrate(a, dt)
    d = integrate(v, dt)
    # least squares Pd c ~ d subject to (Pv c)_end = v_end and (Pd c)_end = d_end  (KKT system)
    C = np.stack([Pv[-1], Pd[-1]])
    rhs_c = np.array([v[-1], d[-1]])
    m = ks.size
    K = np.zeros((m + 2, m + 2))
    K[:m, :m] = Pd.T @ Pd
    K[:m, m:] = C.T
    K[m:, :m] = C
    rhs = np.concatenate([Pd.T @ d, rhs_c])
    sol = np.linalg.lstsq(K, rhs, rcond=None)[0]
    return a - P @ sol[:m]


def baseline_correct(gm: GroundMotion, order: int = 6) -> GroundMotion:
    """Polynomial baseline correction: fit to displacement, remove through acceleration.

    For each component, the displacement ``d`` (double trapezoid of a, from rest) is fitted by
    ``p(t) = sum_{k=3..order} c_k tau^k`` (tau = (t-t0)/T; no tau^0..tau^2 terms, so p(0) = p'(0)
    = p''(0) = 0: the start at rest and the initial acceleration a(t0) are kept unchanged -- no
    step load at t0) in least squares, *constrained* so that the corrected final velocity and
    displacement are zero; ``p''`` is subtracted from the acceleration. The fit uses the same
    discrete trapezoid operator as :meth:`GroundMotion.integrate`, so after correction the final
    v and d vanish to round-off. This is the displacement-polynomial baseline of Boore et al.
    (2002)/Boore (2005) with end constraints in the spirit of Converse & Brady (1992, BAP).
    ``order`` >= 4 (order 4 = the two constraints only, no least-squares freedom; the default 6
    leaves two least-squares degrees of freedom).
    """
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or order < 4:
        raise ValueError(f"baseline_correct: order={order!r} is not allowed; use an integer >= 4")
    if gm.n <= order + 2:
        raise ValueError(f"baseline_correct: too few points ({gm.n}) for order {order}")
    ax = _baseline_1d(gm.ax, gm.dt, gm.t, order) if np.any(gm.ax) else gm.ax
    ay = _baseline_1d(gm.ay, gm.dt, gm.t, order) if np.any(gm.ay) else gm.ay
    return replace(gm, ax=ax, ay=ay, source=gm.source + f" | baseline-corrected (poly order {order})")


def response_spectrum(a: np.ndarray, dt: float, periods: np.ndarray, zeta: float = 0.05,
                      substeps: int | None = None) -> np.ndarray:
    """Pseudo-acceleration spectrum ``Sa(T) = w^2 max|u|`` of a linear SDOF, m/s^2.

    ``u'' + 2 zeta w u' + w^2 u = -a(t)`` from rest, Newmark average acceleration (gamma=1/2,
    beta=1/4; unconditionally stable, no numerical damping, period elongation ~ (pi^2/3)(h/T)^2),
    vectorised over periods. By default the ground motion is linearly interpolated to
    ``substeps`` per input step so that h <= T/40 for the shortest period (period error < 0.21 %).
    """
    a = np.asarray(a, dtype=float)
    T = np.asarray(periods, dtype=float)
    if np.any(T <= 0):
        raise ValueError("response_spectrum: periods must be > 0")
    if substeps is None:
        substeps = max(1, int(math.ceil(40.0 * dt / T.min() - 1e-9)))
    h = dt / substeps
    if substeps > 1:
        tt = np.arange(a.size) * dt
        th = np.arange((a.size - 1) * substeps + 1) * h
        a = np.interp(th, tt, a)
    w = 2.0 * np.pi / T
    k = w ** 2
    c = 2.0 * zeta * w
    gam, beta = 0.5, 0.25
    keff = k + gam / (beta * h) * c + 1.0 / (beta * h * h)
    u = np.zeros_like(w)
    v = np.zeros_like(w)
    acc = -a[0] - c * v - k * u
    umax = np.abs(u)
    A1 = 1.0 / (beta * h * h)
    A2 = 1.0 / (beta * h)
    A3 = 1.0 / (2 * beta) - 1.0
    B1 = gam / (beta * h)
    B2 = gam / beta - 1.0
    B3 = h * (gam / (2 * beta) - 1.0)
    for i in range(1, a.size):
        p = -a[i] + A1 * u + A2 * v + A3 * acc + c * (B1 * u + B2 * v + B3 * acc)
        un = p / keff
        an = A1 * (un - u) - A2 * v - A3 * acc
        v = v + h * ((1 - gam) * acc + gam * an)
        u = un
        acc = an
        np.maximum(umax, np.abs(u), out=umax)
    return k * umax


def significant_duration(a: np.ndarray, dt: float, lo: float = 0.05, hi: float = 0.95) -> tuple[float, float]:
    """Times (from the record start) at which the Arias intensity reaches ``lo`` and ``hi``.

    Trifunac & Brady (1975) significant duration is the difference (5-95 % by default).
    """
    e = integrate(np.asarray(a, float) ** 2, dt)
    e = e / e[-1]
    t = np.arange(e.size) * dt
    return float(np.interp(lo, e, t)), float(np.interp(hi, e, t))


# --------------------------------------------------------------------------------------------
# synthetic Koyna-like record
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class KoynaSyntheticParams:
    """Documented parameters of the synthetic Koyna-like motion (see docs/model.md §9.1).

    Filter: Clough-Penzien = Kanai-Tajimi (fg, zg) x high-pass (ff, zf), plus a 4-pole
    Butterworth-magnitude f_max cut-off (Hanks 1982). Envelope: Jennings, Housner & Tsai (1968)
    type: (t/t1)^2 rise, flat to t2, exp(-c (t - t2)) decay with c = ln(1/end_level)/(T - t2).
    """

    fg_h: float = 5.0     # Hz, Kanai-Tajimi ground frequency, horizontal (centre of 2-10 Hz)
    zg_h: float = 0.6     # Kanai-Tajimi damping (firm ground/rock, Tajimi 1960 / Kanai 1957)
    fg_v: float = 8.0     # Hz, vertical: stiffer P-wave path, higher frequency than horizontal
    zg_v: float = 0.6
    ff_ratio: float = 0.1  # Clough-Penzien high-pass corner = 0.1 fg (Der Kiureghian & Neuenhofer 1992)
    zf: float = 0.6
    fmax: float = 25.0    # Hz, high-frequency cut-off (Hanks 1982 f_max)
    t1: float = 1.0       # s, end of the quadratic build-up
    t2: float = 4.5       # s, end of the strong phase
    end_level: float = 0.05  # envelope value at the end of the record
    pga_h_g: float = 0.49  # target peaks, g (usually quoted for Koyna 1967)
    pga_v_g: float = 0.34
    baseline_order: int = 6


def _cp_filter(f: np.ndarray, fg: float, zg: float, ff: float, zf: float, fmax: float) -> np.ndarray:
    """Complex Clough-Penzien transfer function times a real f_max cut-off, at frequencies f (Hz)."""
    w, wg, wf = 2 * np.pi * f, 2 * np.pi * fg, 2 * np.pi * ff
    kt = (wg ** 2 + 2j * zg * wg * w) / (wg ** 2 - w ** 2 + 2j * zg * wg * w)
    hp = -(w ** 2) / (wf ** 2 - w ** 2 + 2j * zf * wf * w)
    lp = 1.0 / np.sqrt(1.0 + (f / fmax) ** 8)
    return kt * hp * lp


def _envelope(t: np.ndarray, T: float, p: KoynaSyntheticParams) -> np.ndarray:
    c = math.log(1.0 / p.end_level) / (T - p.t2)
    return np.where(t < p.t1, (t / p.t1) ** 2, np.where(t <= p.t2, 1.0, np.exp(-c * (t - p.t2))))


def _scale_exact(a: np.ndarray, target: float) -> np.ndarray:
    """Scale so that max|a| == target exactly (the peak sample is set to +-target; <= 1 ulp change)."""
    i = int(np.argmax(np.abs(a)))
    out = a * (target / abs(a[i]))
    out[i] = math.copysign(target, a[i])
    over = np.abs(out) > target
    out[over] = np.copysign(target, out[over])  # ties that rounded up by 1 ulp
    return out


def generate_koyna_like(seed: int = 1967, dt: float = 0.002, duration: float = 10.0,
                        params: KoynaSyntheticParams = KoynaSyntheticParams()) -> GroundMotion:
    """SYNTHETIC Koyna-like two-component motion, reproducible for a given seed.

    1. ``numpy.random.default_rng(seed)`` (PCG64): two independent N(0,1) sequences of n samples
       (first horizontal, then vertical).
    2. Each is filtered in the frequency domain (rfft, circular: the noise is stationary so the
       circular filter output is too) by the Clough-Penzien filter (+ f_max cut-off).
    3. Multiplied by the Jennings-type envelope (build-up to t1, strong phase to t2, decay).
    4. Baseline-corrected (:func:`baseline_correct`, order ``params.baseline_order``): final v, d = 0.
    5. Scaled so that max|ax| = 0.49 g and max|ay| = 0.34 g exactly.
    """
    dt = float(dt)
    duration = float(duration)
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"generate_koyna_like: dt={dt!r} is not allowed; dt must be > 0")
    if not (math.isfinite(duration) and duration > params.t2 and duration / dt >= 16):
        raise ValueError(f"generate_koyna_like: duration={duration!r} is not allowed; "
                         f"need duration > t2={params.t2} s and at least 16 steps")
    n = int(round(duration / dt)) + 1
    t = dt * np.arange(n)
    T = t[-1]
    rng = np.random.default_rng(seed)
    wx = rng.standard_normal(n)
    wy = rng.standard_normal(n)
    f = np.fft.rfftfreq(n, dt)
    env = _envelope(t, T, params)
    comps = []
    for w, fg, zg in ((wx, params.fg_h, params.zg_h), (wy, params.fg_v, params.zg_v)):
        H = _cp_filter(f, fg, zg, params.ff_ratio * fg, params.zf, params.fmax)
        comps.append(np.fft.irfft(np.fft.rfft(w) * H, n) * env)
    src = (f"SYNTHETIC Koyna-like motion: generate_koyna_like(seed={seed}, dt={dt:g}, duration={duration:g}) "
           f"Clough-Penzien filtered white noise (fg_h={params.fg_h} Hz, fg_v={params.fg_v} Hz, "
           f"zg={params.zg_h}/{params.zg_v}, ff={params.ff_ratio}fg, fmax={params.fmax} Hz), Jennings envelope "
           f"(t1={params.t1}, t2={params.t2}, end={params.end_level}), baseline order {params.baseline_order}; "
           "NOT the recorded 1967 Koyna accelerogram")
    gm = GroundMotion(t, comps[0], comps[1], dt, units="m/s2", label=f"synthetic Koyna-like (seed={seed})",
                      synthetic=True, source=src)
    gm = baseline_correct(gm, order=params.baseline_order)
    return replace(gm, ax=_scale_exact(gm.ax, params.pga_h_g * G), ay=_scale_exact(gm.ay, params.pga_v_g * G),
                   source=src)


DEFAULT_SEED = 1967
DEFAULT_DT = 0.002
DEFAULT_DURATION = 10.0


def _default_header(gm: GroundMotion) -> list[str]:
    px, py = gm.peak_g()
    return [
        "SYNTHETIC ground motion -- NOT the recorded 1967 Koyna accelerogram (none is in public sources).",
        f"generator: ngs_driver.setup.ground_motion.generate_koyna_like(seed={DEFAULT_SEED}, dt={DEFAULT_DT}, "
        f"duration={DEFAULT_DURATION})",
        f"seed: {DEFAULT_SEED}",
        f"peaks: |ax|max = {px:.12g} g (horizontal), |ay|max = {py:.12g} g (vertical); g = {G} m/s2",
        f"procedure: {gm.source}",
        "regenerate: python -m ngs_driver.setup.ground_motion --write-default",
        "units: m/s2",
    ]


def write_default(path=DEFAULT_FILE) -> Path:
    gm = generate_koyna_like(DEFAULT_SEED, DEFAULT_DT, DEFAULT_DURATION)
    return write_three_column(gm, path, _default_header(gm))


def load_default() -> GroundMotion:
    """The shipped SYNTHETIC Koyna-like record (t, ax, ay in m/s^2, dt = 0.002 s, 10 s)."""
    p = DEFAULT_FILE
    with open(p, encoding="utf-8") as fh:
        first = fh.readline()
    if "SYNTHETIC" not in first:
        raise ValueError(f"default record {str(p)!r}: first line does not say SYNTHETIC; file was replaced?")
    gm = read_three_column(p, "m/s2")
    return replace(gm, label=f"synthetic Koyna-like (seed={DEFAULT_SEED})", synthetic=True,
                   units="m/s2",
                   source=f"{p.name}: SYNTHETIC, generate_koyna_like(seed={DEFAULT_SEED}, dt={DEFAULT_DT}, "
                          f"duration={DEFAULT_DURATION})")


if __name__ == "__main__":  # pragma: no cover
    import argparse

    ap = argparse.ArgumentParser(description="ground-motion utilities")
    ap.add_argument("--write-default", action="store_true", help=f"regenerate {DEFAULT_FILE}")
    args = ap.parse_args()
    if args.write_default:
        out = write_default()
        print(f"wrote {out}")
    gm = load_default()
    print(f"{gm.label}: n={gm.n} dt={gm.dt} peaks(g)={gm.peak_g()}")
