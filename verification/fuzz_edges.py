"""Every scene that passes ``--dry-run`` runs: the smallest and the largest value each
key of the koyna schema allows, one key at a time on ``koyna_smoke``, checked by the dry run's
validation and, when accepted, run for a few steps. A run may end in a solver failure (a
``SolverError``: exit 1 with its message, a physical outcome of an extreme value); any other
exception (an IndexError, 'meshing failed', a traceback) is a failure of this study.

Not run, with the reason in the table: edges that set more than ``MAX_STEPS`` steps (time.dt's
smallest, time.duration's largest) and edges that refine a mesh without bound (the smallest
element sizes: the schema's open lower bound 0 allows any size; their mesh would not fit in
memory), and keys without a numeric range in the schema (strings, booleans, the law's own
parameters, which interfacelaw's ranges check and ``test_bad_inputs`` covers).

``make verify`` runs every key: the 98 edges take 10-22 s (two steps each on the smallest
scene; 9.3 s on an idle core, 22 s on the shared 2-core machine). The tests
(``tests/test_safe_runs.py``) run the fast form: the ``FAST_KEYS`` (the keys of the faults
once found, the materials whose edges crashed, one key of a few other sections; 18 edges, ~3 s).
"""
from __future__ import annotations

import dataclasses
import math
import pathlib
import sys
import tempfile
import time
from typing import get_type_hints

HERE = pathlib.Path(__file__).resolve().parent
if str(HERE.parent) not in sys.path:
    sys.path.insert(0, str(HERE.parent))

BASE = ["time.duration=0.004", "output.checkpoint_every=0"]     # 2 steps of dt = 0.002
MAX_STEPS = 10
# the keys of the issue's faults and a few of each section (the tests' fast form)
FAST_KEYS = ("interface.contact_stiffness", "damping.modes", "ground_motion.scale",
             "time.rho_inf", "uplift.drain_efficiency", "solver.pairing_tolerance",
             "materials.dam.E", "materials.dam.nu", "materials.dam.rho")
UNBOUNDED_MESH = ("mesh.h_heel", "mesh.h_coarse", "mesh.h_interface", "reservoir.h_max",
                  "mesh.grading", "mesh.growth")


def _edges_of(md, typ):
    lo, hi = md.get("lo"), md.get("hi")
    if lo is None or hi is None:
        return []
    if typ is int:
        return [lo + (1 if md.get("lo_open") else 0), hi - (1 if md.get("hi_open") else 0)]
    a = math.nextafter(lo, math.inf) if md.get("lo_open") else float(lo)
    b = math.nextafter(hi, -math.inf) if md.get("hi_open") else float(hi)
    return [a, b]


def edges():
    """[(key, value as a --set literal)] of the koyna schema's numeric keys."""
    from ngs_driver.scene import Scene
    out = []

    def walk(cls, prefix):
        hints = get_type_hints(cls)
        for f in dataclasses.fields(cls):
            t = hints[f.name]
            key = f"{prefix}{f.name}"
            if dataclasses.is_dataclass(t):
                if key != "joints":
                    walk(t, key + ".")
                continue
            if key == "damping.modes":
                out.extend([(key, "[1, 2]"), (key, "[49, 50]")])
                continue
            if t in (int, float):
                for v in _edges_of(f.metadata, t):
                    out.append((key, repr(v)))
    walk(Scene, "")
    return out


def skip_reason(key, value) -> str | None:
    v = float(value) if not value.startswith("[") else None
    if key in UNBOUNDED_MESH and v is not None and v < 0.05:
        return "mesh refined without bound (memory)"
    if key == "time.dt" and v is not None and 0.004 / v > MAX_STEPS:
        return f"more than {MAX_STEPS} steps"
    if key == "time.duration" and v is not None and v / 0.002 > MAX_STEPS:
        return f"more than {MAX_STEPS} steps"
    return None


def run_edge(key, value, outdir) -> dict:
    """Dry-run validation, then a few steps; {'key', 'value', 'outcome', 'message'}."""
    from ngs_driver.apps.dam import run
    from ngs_driver.scene import load_scene
    from ngs_driver.setup import validate
    from ngs_driver.solve.joint_solver import SolverError
    row = {"key": key, "value": value}
    why = skip_reason(key, value)
    if why:
        return dict(row, outcome="not run", message=why)
    try:
        sc = load_scene("koyna_smoke", BASE + [f"{key}={value}"])
        validate(sc)
    except ValueError as e:
        return dict(row, outcome="refused at --dry-run", message=str(e)[:160])
    try:
        run(sc, outdir, progress=False, plots=False, log=lambda *a, **k: None,
            overwrite=True)
        return dict(row, outcome="ran", message="")
    except SolverError as e:
        return dict(row, outcome="solver failure", message=str(e)[:160])
    except Exception as e:            # the failure this study looks for
        return dict(row, outcome="CRASH", message=f"{type(e).__name__}: {str(e)[:160]}")


def main(fast: bool = False, outdir=None, keys=None) -> str:
    out = pathlib.Path(outdir or tempfile.mkdtemp(prefix="fuzz_edges_")) / "fuzz_edges"
    out.mkdir(parents=True, exist_ok=True)
    keys = keys if keys is not None else (FAST_KEYS if fast else None)
    cases = [(k, v) for k, v in edges() if keys is None or k in keys]
    rows = []
    t0 = time.perf_counter()
    for i, (k, v) in enumerate(cases):
        rows.append(run_edge(k, v, out / f"run{i:03d}"))
    lines = ["| key | value | outcome | message |", "|---|---|---|---|"]
    lines += [f"| {r['key']} | {r['value']} | {r['outcome']} | {r['message']} |" for r in rows]
    text = (f"# Allowed edges of the koyna schema on koyna_smoke ({len(rows)} cases, "
            f"{time.perf_counter() - t0:.0f} s)\n\n" + "\n".join(lines) + "\n")
    (out / "fuzz_edges.md").write_text(text)
    crashed = [r for r in rows if r["outcome"] == "CRASH"]
    if crashed:
        raise RuntimeError(f"{len(crashed)} accepted edges crashed: " + "; ".join(
            f"{r['key']}={r['value']}: {r['message']}" for r in crashed))
    return text


if __name__ == "__main__":
    print(main(fast="--fast" in sys.argv))
