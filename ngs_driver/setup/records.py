"""Scene -> ground motion in m/s^2 on the run's time grid (no NGSolve)."""
from __future__ import annotations

import pathlib
from dataclasses import replace

from . import ground_motion as gmod
from .fema_records import load_record

DEFAULT_RECORDS = ("synthetic", "default")
FEMA_PREFIX = "fema-p695:"   # FEMA P695 record sets (PEER NGA), setup/fema_records.py
SHIPPED_PREFIX = "shipped:"  # recorded motions in ngs_driver/data with a stating header
SHIPPED_RECORDS = {          # name -> file in ngs_driver/data and what it is (docs/real_dams.md,
    "taft-1952-s69e": {      # "Pine Flat record": identity checked against published figures)
        "file": "pine_flat_taft_s69e.txt",
        "meta": {"event": "Kern County, California, 21 July 1952",
                 "station": "Taft, Lincoln School Tunnel", "component": "S69E",
                 "pga_g": 0.179, "t_pga_s": 3.70, "npts": 2720, "dt_s": 0.02,
                 "duration_s": 54.38,
                 "source": "input/INPUT-PF4-DAMRes.TXT (function 5, 'EQ IN X-DIR') of "
                           "github.com/NiliAbtahi/Modern-Fortran-Finite-Element-Analysis-for-"
                           "Dam-Reservoir-Foundation-system- @65322095, MIT (c) 2025 NiliAbtahi"}},
}



def load_ground_motion(scene):
    """The scene's record in m/s^2, scaled, components selected, resampled to dt."""

    g = scene.ground_motion
    rec = g.record
    vertical = getattr(g, "vertical", "record")
    if rec.startswith(FEMA_PREFIX):
        # PEER-processed records (filtered, baseline corrected by PEER): no second baseline
        gm = load_record(rec, vertical)
    elif rec.startswith(SHIPPED_PREFIX):
        # as the source printed it, checked against its header (no second baseline)
        name = rec[len(SHIPPED_PREFIX):]
        if name not in SHIPPED_RECORDS:
            raise ValueError(f"ground_motion.record = {rec!r}: no shipped record {name!r}; "
                             "allowed: " + ", ".join(repr(SHIPPED_PREFIX + k)
                                                     for k in SHIPPED_RECORDS))
        entry = SHIPPED_RECORDS[name]
        gm = gmod.read_headed(gmod.SHIPPED_DIR / entry["file"])
        gm = replace(gm, label=rec, meta=dict(entry["meta"]))
    elif rec in DEFAULT_RECORDS:
        gm = gmod.load_default()
    elif rec.startswith(gmod.PULSE_PREFIX):      # an analytic pulse on the run's own grid
        gm = gmod.pulse_record(rec, g.start + scene.time.duration, scene.time.dt)
    else:
        p = pathlib.Path(rec)
        if not p.exists():
            raise ValueError(f"ground_motion.record = {rec!r}: no such file; allowed: "
                             f"{list(DEFAULT_RECORDS)} (the shipped SYNTHETIC record), "
                             f"'{FEMA_PREFIX}<set>:<record>:<a|b>' (FEMA P695 / PEER NGA, "
                             "e.g. 'fema-p695:farfield:7:a'), "
                             f"{', '.join(repr(SHIPPED_PREFIX + k) for k in SHIPPED_RECORDS)} "
                             "(shipped recorded motions) or a path "
                             "to a .AT2 / two-column (t a_x) / three-column (t a_x a_y) file")
        if p.suffix.lower() == ".at2":
            gm = gmod.read_at2(p, "x")
        else:
            ncol = None
            for ln in p.read_text(encoding="utf-8-sig", errors="replace").splitlines():
                body = ln.split("#", 1)[0].strip()
                if body:
                    ncol = len(body.replace(",", " ").split())
                    break
            if ncol == 3:
                gm = gmod.read_three_column(p, g.units)
            elif any(ln.replace(" ", "").startswith("#npts:") for ln in
                     p.read_text(encoding="utf-8", errors="replace").splitlines()):
                gm = gmod.read_headed(p)         # its header states npts/dt/peak: checked
            else:
                gm = gmod.read_two_column(p, g.units, "x")
        if g.baseline:
            gm = gmod.baseline_correct(gm)
    if not rec.startswith(FEMA_PREFIX):
        if vertical == "none":
            gm = gm.scaled((1.0, 0.0))
        elif vertical == "2/3-same":
            gm = replace(gm, ay=(2.0 / 3.0) * gm.ax,
                         source=gm.source + " | vertical = 2/3 of the horizontal (same history)")
        elif vertical == "2/3-other":
            raise ValueError(f"ground_motion.vertical = '2/3-other' with ground_motion.record = "
                             f"{rec!r}: the other horizontal component is known only for "
                             f"'{FEMA_PREFIX}...' records; allowed here: 'record', 'none', "
                             "'2/3-same'")
    if g.scale != 1.0:
        gm = gm.scaled(g.scale)
    if getattr(g, "polarity", "normal") == "inverse":      # SLAMMER's inverse polarity
        gm = gm.scaled(-1.0)
    fx = 1.0 if "x" in g.components else 0.0
    fy = 1.0 if "y" in g.components else 0.0
    if fx == 0.0 or fy == 0.0:
        gm = gm.scaled((fx, fy))
    dt = scene.time.dt
    if abs(gm.dt - dt) > 1e-12 * dt:
        gm = gmod.resample(gm, dt)
    return gm
