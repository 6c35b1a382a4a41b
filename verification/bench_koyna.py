"""Koyna benchmarks (docs/solver.md): writes verification/out/bench_koyna.json
and (through verification/write_benchmarks.py) the Koyna section of BENCHMARKS.md.

1. time per step and Newton iterations against DOFs (mesh.h_coarse = 4, 2, 1 at the default
   heel/interface mesh: ~4.6k, 12k, 43k DOFs, ~333-351 interface points) and against interface
   points (mesh.gauss_points = 1, 3, 5 on the default mesh), short runs of `time.duration` =
   0.3 s (150 steps) starting at `ground_motion.start` = 2.0 s of the shipped SYNTHETIC record
   (its strongest second, |a| up to 4.8 m/s^2), medians of repeats, log-log fits;
2. the full Koyna run (10 s, 5000 steps, default mesh, alpha = 2; alpha = 1 with --alpha1):
   `python -m ngs_driver run koyna --out DIR --quiet` under /usr/bin/time -v (wall, peak RSS);
3. condensed vs full (re-factorising) Newton on the default mesh, the same steps from the same
   state (strong part, after warm-up steps of the condensed solver);
4. OpenSeesPy (`pip install -e .[bench]`): the same mesh (tri31 plane strain, lumped mass,
   interface as coincident nodes joined by zeroLength springs of the bonded stiffness k0 with
   the tributary length), the same Rayleigh a0, a1 (not on the springs, as in our C), Newmark
   average acceleration, dt = 2 ms, UniformExcitation with the same record; fastest linear
   system of BandSPD / ProfileSPD / SparseSYM / UmfPack with `algorithm Linear -factorOnce`;
   crest displacement compared with our solver on a linear run (interface law that stays on
   its elastic branch: sigma = tau = 3 GPa, G_I scaled so that k0 is the scene's, no damage,
   no friction) on the lumped-mass model.

Parts 3, 4, 7 and 8 build their runs with ``run.prepare`` (the run's own set-up) on the
benchmark scene ``BASE_SETS`` (koyna without hydrodynamic water: the dam's solver) and step its
solver directly; parts 1, 2, 5, 6 run the command itself.

Usage (the environment of the Makefile: NUMBA_CACHE_DIR, OMP_NUM_THREADS=1, ...):
    python verification/bench_koyna.py                 # everything (~10 min on 2 shared cores)
    python verification/bench_koyna.py --parts 1,3,4   # skip the full 10 s run
    python verification/bench_koyna.py --full-dir DIR  # reuse a finished full run in DIR
                                                       # (DIR/summary.json, DIR.time from time -v)
The JSON is updated after every part (results are kept if a later part fails).
"""
from __future__ import annotations

import argparse
import ctypes
import glob
import json
import os
import pathlib
import platform
import re
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
OUT = ROOT / "verification" / "out"
JSON = OUT / "bench_koyna.json"
START = 2.0                     # s of the record: its strongest second
DT = 2e-3
CREST_TOL = 1e-2               # crest u_x vs OpenSees: max abs diff / peak dynamic amplitude
LINEAR_SIGMA = 3.0e9            # elastic-branch law for the linear comparison


# ---------------------------------------------------------------------------------------------
def env_info() -> dict:
    cpu = "unknown"
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(),
            "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
            "threads": {k: os.environ.get(k) for k in ("OMP_NUM_THREADS",
                                                       "OPENBLAS_NUM_THREADS")}}


def loadavg() -> list[float]:
    try:
        return [float(x) for x in os.getloadavg()]
    except OSError:
        return []


def save(res: dict):
    OUT.mkdir(parents=True, exist_ok=True)
    tmp = JSON.with_suffix(".tmp")
    tmp.write_text(json.dumps(res, indent=1, default=float))
    tmp.replace(JSON)


def loglog_fit(x, y) -> float:
    return float(np.polyfit(np.log(np.asarray(x, float)), np.log(np.asarray(y, float)), 1)[0])


# ---------------------------------------------------------------------------------------------
# our model and solvers
# ---------------------------------------------------------------------------------------------
# The benchmark scene: the Koyna dam without hydrodynamic water (hydrostatic load only; the
# solver benchmarks and the OpenSees comparison are about the dam), from START of the record.
BASE_SETS = ("reservoir.model=none", f"ground_motion.start={START}", f"time.dt={DT}")


def scene(overrides=(), n_steps=None, base=BASE_SETS):
    """The benchmark scene with ``--set`` overrides; n_steps: time.duration = n_steps dt;
    base=(): the shipped koyna scene itself (the run command's benchmarks)."""
    from ngs_driver.scene import load_scene
    dur = [f"time.duration={n_steps * DT!r}"] if n_steps is not None else []
    return load_scene("koyna", list(base) + dur + list(overrides))


def model_of(sc):
    from ngs_driver.fe.model import build_from_scene
    return build_from_scene(sc)


def linear_sets(sc) -> list[str]:
    """Overrides that keep the scene's joint on its initial elastic branch with the scene's
    k0 (no damage, no friction, linear contact, no size scaling): sigma = tau = 3 GPa, G_I
    scaled by (sigma / sigma_scene)^2 (k0 = sigma^2 / (2 lambda_max G_I) unchanged)."""
    i = sc.interface
    f = LINEAR_SIGMA / i.sigma_max
    k0 = i.sigma_max ** 2 / (2 * i.lambda_max * i.G_I)     # the same in compression
    return [f"interface.sigma_max={i.sigma_max * f!r}", f"interface.tau_max={i.tau_max * f!r}",
            f"interface.G_I={i.G_I * f * f!r}", "interface.contact=linear",
            f"interface.contact_stiffness={k0!r}",
            "interface.friction=0.0", "interface.damage=false", "interface.scaling=false"]


_SCRATCH = None


def analysis(sc, model=None):
    """The run's own set-up (``run.prepare``; its folder a scratch one, nothing written but
    the folder) with the static state solved. The benchmarks step ``a.solver`` directly with
    ``load(a)``: the solver alone, the joints' laws frozen at their start (b_ref)."""
    global _SCRATCH
    from ngs_driver.post.outputs import RunOutputs
    from ngs_driver.run import prepare
    if _SCRATCH is None:
        _SCRATCH = pathlib.Path(tempfile.mkdtemp(prefix="bench_koyna_"))
    out = pathlib.Path(tempfile.mkdtemp(dir=_SCRATCH))
    a = prepare(sc, out, model=model, outputs=RunOutputs(plots=False), progress=False,
                log=lambda *x, **k: None)
    a.static()
    return a


def load(a):
    """f(k): the run's load of step k (``run.analysis.seismic_load``)."""
    from ngs_driver.run.analysis import seismic_load
    return lambda k: seismic_load(a.f_static, a.Mrx, a.Mry, a.ax[k], a.ay[k])


def a0a1_of(a) -> tuple[float, float]:
    return a.damping["a0"], a.damping["a1"]


def variant(s, method="condensed"):
    """A solver on the same matrices, law and options as ``s`` with another Newton method,
    started from s's committed state (the full method has no low-rank damping part: compare it
    on scenes with ``damping.model`` rayleigh or stiffness)."""
    from ngs_driver.solve.joint_solver import JointSolver
    v = JointSolver(s.K, s.M, s.C, s.B, s.w, s.law, dt=s.dt, method=method,
                    integrator=s.integrator,
                    C_lowrank=s.C_lowrank if method == "condensed" else None,
                    tol_residual=s.tol_residual, max_iter=s.max_iter, min_dt=s.min_dt)
    v.state = s.state
    v.set_initial(u=s.u.copy(), v=s.v.copy(), a=s.a.copy(), f=s.f.copy())
    v.time = s.time
    return v


# ---------------------------------------------------------------------------------------------
# part 1: scaling with DOFs and with interface points (the run command's own run(), short runs)
# ---------------------------------------------------------------------------------------------
def short_run(model, sc, outdir) -> dict:
    from ngs_driver.post.files import read_csv
    from ngs_driver.apps.dam import run
    s = run(sc, outdir, model=model, plots=False, progress=False, overwrite=True)
    ts = read_csv(pathlib.Path(outdir) / "timeseries.csv")
    w = np.asarray(ts["wall"])
    return {"per_step_median": float(np.median(w)), "per_step_mean": float(np.mean(w)),
            "per_step_median_after_first": float(np.median(w[1:])),
            "first_step": float(w[0]),
            "newton_per_step": float(np.mean(ts["iterations"])),
            "cuts": int(np.sum(ts["cuts"])), "n_active_max": int(np.max(ts["n_active"])),
            "n_active_final": int(ts["n_active"][-1]),
            "crest_ux_max_abs": float(np.max(np.abs(ts["crest_ux"]))),
            "n_steps_done": int(len(w)), "n_debonded_final": int(ts["n_debonded"][-1]),
            "static_wall": s["timings"]["static"], "modal_wall": s["timings"]["modal"]}


def part1(res, repeats=3, duration=0.3, quick=False):
    base = ["time.duration=%g" % duration, "ground_motion.start=%g" % START,
            "time.stop_slip=0",
            "output.checkpoint_every=0", "output.snapshots=1"]
    series = {"dofs": [("h_coarse=4", ["mesh.h_coarse=4.0"]),
                       ("h_coarse=2 (default)", []),
                       ("h_coarse=1", ["mesh.h_coarse=1.0"])],
              "points": [("gauss_points=1", ["mesh.gauss_points=1"]),
                         ("gauss_points=3 (default)", []),
                         ("gauss_points=5", ["mesh.gauss_points=5"])]}
    if quick:
        series = {"dofs": [("h_coarse=8", ["mesh.h_coarse=8.0", "mesh.h_heel=0.4",
                                           "mesh.h_interface=4.0"])], "points": []}
    out = {"duration": duration, "start": START, "repeats": repeats,
           "record": "shipped SYNTHETIC Koyna-like record (seed 1967), from t = 2.0 s",
           "series": {}}
    res["part1"] = out
    cache = {}
    with tempfile.TemporaryDirectory() as td:
        for name, rows in series.items():
            out["series"][name] = []
            for label, ov in rows:
                sc = scene(base + ov, base=())
                key = tuple(ov)
                t0 = time.perf_counter()
                if key not in cache:
                    cache[key] = model_of(sc)
                m = cache[key]
                tb = time.perf_counter() - t0
                reps = []
                la0 = loadavg()
                for r in range(repeats):
                    reps.append(short_run(m, sc, pathlib.Path(td) / f"{name}{len(reps)}"))
                med = lambda k: float(np.median([x[k] for x in reps]))  # noqa: E731
                row = {"label": label, "overrides": ov, "nfree": int(m.nfree),
                       "npts": int(m.interface.npts), "build": tb,
                       "per_step_median": med("per_step_median"),
                       "per_step_mean": med("per_step_mean"),
                       "per_step_median_repeats": [x["per_step_median"] for x in reps],
                       "first_step": med("first_step"),
                       "newton_per_step": med("newton_per_step"),
                       "cuts": max(x["cuts"] for x in reps),
                       "n_active_max": max(x["n_active_max"] for x in reps),
                       "crest_ux_max_abs": reps[0]["crest_ux_max_abs"],
                       "n_debonded_final": reps[0]["n_debonded_final"],
                       "n_steps_done": reps[0]["n_steps_done"],
                       "loadavg": [la0, loadavg()]}
                out["series"][name].append(row)
                print(f"[1] {name} {label}: {row['nfree']} DOFs, {row['npts']} pts, "
                      f"{1e3 * row['per_step_median']:.2f} ms/step, "
                      f"{row['newton_per_step']:.2f} it/step", flush=True)
                save(res)
            rs = out["series"][name]
            if len(rs) >= 2:
                xk = "nfree" if name == "dofs" else "npts"
                out[f"exponent_{name}"] = loglog_fit([r[xk] for r in rs],
                                                    [r["per_step_median"] for r in rs])
                out[f"exponent_{name}_iterations"] = loglog_fit(
                    [r[xk] for r in rs], [max(r["newton_per_step"], 1e-9) for r in rs])
            save(res)
    for m in cache.values():
        del m


# ---------------------------------------------------------------------------------------------
# part 2: the full 10 s run (CLI under /usr/bin/time -v)
# ---------------------------------------------------------------------------------------------
def parse_time_v(text: str) -> dict:
    d = {}
    m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", text)
    if m:
        d["peak_rss_MB"] = int(m.group(1)) / 1024
    m = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): ([\d:.]+)", text)
    if m:
        parts = [float(p) for p in m.group(1).split(":")]
        sec = 0.0
        for p in parts:
            sec = sec * 60 + p
        d["wall_s"] = sec
    for key, pat in (("user_s", r"User time \(seconds\): ([\d.]+)"),
                     ("sys_s", r"System time \(seconds\): ([\d.]+)"),
                     ("cpu_percent", r"Percent of CPU this job got: (\d+)%")):
        m = re.search(pat, text)
        if m:
            d[key] = float(m.group(1))
    return d


def _steps_done(outdir) -> int:
    p = pathlib.Path(outdir) / "timeseries.csv"
    return sum(1 for ln in p.read_text().splitlines()[1:] if ln and not ln.startswith("#")) - 1 \
        if p.exists() else -1


def full_run_info(outdir: pathlib.Path, time_file: pathlib.Path, cmd: str, load) -> dict:
    s = json.loads((outdir / "summary.json").read_text())
    d = parse_time_v(time_file.read_text()) if time_file.exists() else {}
    tm = s["timings"]
    d.update({"command": cmd, "n_steps": s["n_steps"], "nfree": s["dofs"]["nfree"],
              "npts": s["dofs"]["interface_points"], "alpha": s["scene"]["interface"]["alpha"],
              "timings": tm, "solver_totals": s["solver_totals"],
              "newton_per_step": s["solver_totals"]["iterations"] / s["n_steps"],
              "results": {k: s["results"].get(k) for k in
                          ("max_D_heel", "crack_length_heel_final", "t_D_heel_reaches_1",
                           "t_crack_heel_reaches_final", "crest_ux_max")},
              "stopped": s.get("stopped"), "steps_done": _steps_done(outdir),
              "loadavg": load, "target_s": 60.0})
    return d


def part2(res, alphas=(2.0,), full_dir=None, extra_set=("time.stop_slip=0",)):
    """extra_set: `time.stop_slip=0` by default so that all 5000 steps run (the scene's
    default stops once the whole base is debonded and has slid 5 cm)."""
    out = res.setdefault("part2", {})
    for a in alphas:
        key = f"alpha{a:g}" + ("" if extra_set else "_default_stop_slip")
        if full_dir is not None and a == 2.0:
            od = pathlib.Path(full_dir)
            tf = pathlib.Path(str(od) + ".time")
            lf = pathlib.Path(str(od) + ".load")
            load = lf.read_text().strip().splitlines() if lf.exists() else None
            cmd = ("/usr/bin/time -v python -m ngs_driver run koyna --out " + str(od)
                   + " --quiet")
        else:
            od = pathlib.Path(tempfile.mkdtemp(prefix=f"bench_koyna_{key}_"))
            tf = od.parent / (od.name + ".time")
            args = ["-m", "ngs_driver", "run", "koyna", "--out", str(od), "--quiet"]
            if a != 2.0:
                args[4:4] = ["--set", f"interface.alpha={a:g}"]
            for ov in extra_set:
                args[4:4] = ["--set", ov]
            timev = pathlib.Path("/usr/bin/time")
            argv = ([str(timev), "-v"] if timev.exists() else []) + [sys.executable] + args
            cmd = " ".join(["/usr/bin/time -v" if timev.exists() else "", "python"] + args)
            l0 = os.getloadavg()
            with open(tf, "w") as fh:
                p = subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=fh, cwd=ROOT)
            load = [" ".join(f"{x:.2f}" for x in l0), " ".join(f"{x:.2f}" for x in
                                                              os.getloadavg())]
            if p.returncode != 0:
                out[key] = {"command": cmd, "error": f"exit code {p.returncode}",
                            "stderr_tail": tf.read_text()[-2000:]}
                save(res)
                continue
        out[key] = full_run_info(od, tf, cmd, load)
        r = out[key]
        print(f"[2] {key}: wall {r.get('wall_s')} s, dynamic {r['timings']['dynamic']:.1f} s, "
              f"peak RSS {r.get('peak_rss_MB')} MB", flush=True)
        save(res)


# ---------------------------------------------------------------------------------------------
# part 3: condensed vs full Newton on the default mesh
# ---------------------------------------------------------------------------------------------
def part3(res, warm=50, n_full=5, n_cond=50, model=None):
    # Rayleigh damping: the full (re-factorising) reference has no low-rank damping part
    sc = scene(["damping.model=rayleigh"], n_steps=warm + n_cond + 1)
    m = model if model is not None else model_of(sc)
    a = analysis(sc, m)
    fk = load(a)
    la0 = loadavg()
    sc_ = a.solver
    for k in range(1, warm + 1):
        sc_.step(fk(k))
    sf = variant(sc_, "full")
    tc, ic, tf_, if_ = [], [], [], []
    for k in range(warm + 1, warm + n_full + 1):
        r = sf.step(fk(k))
        tf_.append(r.wall)
        if_.append(r.iterations)
    uf = sf.u.copy()
    for k in range(warm + 1, warm + n_cond + 1):
        r = sc_.step(fk(k))
        tc.append(r.wall)
        ic.append(r.iterations)
        if k == warm + n_full:
            uc = sc_.u.copy()
            na = r.n_active
    out = {"nfree": int(m.nfree), "npts": int(m.interface.npts), "warm_steps": warm,
           "start": START, "law": "scene law (alpha = 2), size scaling frozen at b_ref",
           "condensed_ms_same_steps": 1e3 * float(np.median(tc[:n_full])),
           "condensed_ms_median_all": 1e3 * float(np.median(tc)), "n_condensed": n_cond,
           "condensed_newton_same_steps": float(np.mean(ic[:n_full])),
           "full_ms": 1e3 * float(np.median(tf_)), "n_full": n_full,
           "full_newton": float(np.mean(if_)),
           "n_active": int(na),
           "u_rel_diff": float(np.linalg.norm(uc - uf) / np.linalg.norm(uf)),
           "loadavg": [la0, loadavg()]}
    out["speedup"] = out["full_ms"] / out["condensed_ms_same_steps"]
    res["part3"] = out
    print(f"[3] condensed {out['condensed_ms_same_steps']:.1f} ms/step, full "
          f"{out['full_ms']:.0f} ms/step, speed-up {out['speedup']:.1f}x, "
          f"u rel diff {out['u_rel_diff']:.1e}", flush=True)
    save(res)


# ---------------------------------------------------------------------------------------------
# part 4: OpenSeesPy
# ---------------------------------------------------------------------------------------------
def import_opensees():
    """openseespy's Linux wheel fails at import unless its bundled BLAS/LAPACK/gfortran
    libraries are loaded globally first."""
    try:
        import openseespy.opensees as ops
        return ops
    except Exception:                            # noqa: BLE001 (RuntimeError in 3.7)
        pass
    for sp in sys.path:
        libdir = pathlib.Path(sp) / "openseespylinux" / "lib"
        if libdir.is_dir():
            for name in ("libquadmath.so*", "libgfortran.so*", "libgomp.so*", "libblas.so*",
                         "liblapack.so*"):
                for p in sorted(glob.glob(str(libdir / name))):
                    try:
                        ctypes.CDLL(p, mode=ctypes.RTLD_GLOBAL)
                    except OSError:
                        pass
            break
    for k in [k for k in sys.modules if k.startswith("openseespy")]:
        del sys.modules[k]
    import openseespy.opensees as ops
    return ops


def mesh_data(model):
    """Vertices, triangles per region, fixed rock vertices, interface segments and the map
    (region, vertex) -> free-DOF indices (x, y) of our model."""
    import ngsolve as ngs
    mesh = model.mesh
    xy = np.array([v.point for v in mesh.vertices])
    tris = {"dam": [], "rock": []}
    for el in mesh.Elements(ngs.VOL):
        tris[el.mat].append([v.nr for v in el.vertices])
    fixed = set()
    iface = []
    for el in mesh.Elements(ngs.BND):
        vs = [v.nr for v in el.vertices]
        if el.mat in ("rock_bottom", "rock_left", "rock_right"):
            fixed.update(vs)
        elif el.mat == "interface":
            iface.append(vs)
    nfull = model.fes.ndof
    inv = -np.ones(nfull, dtype=np.int64)
    inv[model.free] = np.arange(model.free.size)
    comps = model.fes.components
    off = {"dam": 0, "rock": comps[0].ndof}
    dofmap = {}
    for reg, k in (("dam", 0), ("rock", 1)):
        V = comps[k]
        for v in {v for t in tris[reg] for v in t}:
            d = sorted(int(i) for i in V.GetDofNrs(ngs.NodeId(ngs.VERTEX, v)))
            dofmap[(reg, v)] = (int(inv[d[0] + off[reg]]), int(inv[d[1] + off[reg]]))
    return xy, tris, fixed, iface, dofmap


def build_opensees(ops, model, sc, a0a1, k0n, k0t, fs, ax, ay, system="BandSPD"):
    """The same mesh in OpenSees; returns (crest node tag, ndof free)."""
    xy, tris, fixed, iface, dofmap = mesh_data(model)
    nv = xy.shape[0]
    ops.wipe()
    ops.model("basic", "-ndm", 2, "-ndf", 2)
    tag = {("dam", v): v + 1 for (r, v) in dofmap if r == "dam"}
    tag.update({("rock", v): nv + v + 1 for (r, v) in dofmap if r == "rock"})
    for (r, v), t in tag.items():
        ops.node(t, float(xy[v, 0]), float(xy[v, 1]))
        if r == "rock" and v in fixed:
            ops.fix(t, 1, 1)
    mats = sc.materials
    ops.nDMaterial("ElasticIsotropic", 1, mats.dam.E, mats.dam.nu, 0.0)
    ops.nDMaterial("ElasticIsotropic", 2, mats.rock.E, mats.rock.nu, 0.0)
    e = 0
    for reg, mt, rho in (("dam", 1, mats.dam.rho), ("rock", 2, mats.rock.rho)):
        for t in tris[reg]:
            p = xy[t]
            area2 = ((p[1, 0] - p[0, 0]) * (p[2, 1] - p[0, 1])
                     - (p[2, 0] - p[0, 0]) * (p[1, 1] - p[0, 1]))
            if area2 < 0:
                t = [t[0], t[2], t[1]]
            e += 1
            ops.element("tri31", e, *[tag[(reg, v)] for v in t], 1.0, "PlaneStrain", mt,
                        0.0, float(rho), 0.0, 0.0)
    # interface: coincident dam/rock nodes joined by springs k0 * tributary length (lumped)
    trib = {}
    for a, b in iface:
        L = float(np.hypot(*(xy[a] - xy[b])))
        trib[a] = trib.get(a, 0.0) + L / 2
        trib[b] = trib.get(b, 0.0) + L / 2
    mt = 10
    for v, L in sorted(trib.items()):
        mt += 1
        ops.uniaxialMaterial("Elastic", mt, k0t * L)
        mt += 1
        ops.uniaxialMaterial("Elastic", mt, k0n * L)
        e += 1
        ops.element("zeroLength", e, tag[("rock", v)], tag[("dam", v)], "-mat", mt - 1, mt,
                    "-dir", 1, 2)                 # no -doRayleigh: springs undamped, as ours
    nfree = sum(1 for (r, v) in tag if not (r == "rock" and v in fixed)) * 2
    # static: dead load + reservoir as nodal loads (our assembled vectors)
    ops.timeSeries("Constant", 1)
    ops.pattern("Plain", 1, 1)
    for (r, v), t in tag.items():
        ix, iy = dofmap[(r, v)]
        if ix >= 0:
            ops.load(t, float(fs[ix]), float(fs[iy]))
    crest = tag[("dam", int(np.argmin(np.hypot(xy[:, 0] - model.crest_point[0],
                                               xy[:, 1] - model.crest_point[1]))))]
    _analysis(ops, system, static=True)
    ops.analyze(1)
    ops.loadConst("-time", 0.0)
    ops.wipeAnalysis()
    ops.timeSeries("Path", 2, "-dt", DT, "-values", *[float(x) for x in ax])
    ops.timeSeries("Path", 3, "-dt", DT, "-values", *[float(x) for x in ay])
    ops.pattern("UniformExcitation", 2, 1, "-accel", 2)
    ops.pattern("UniformExcitation", 3, 2, "-accel", 3)
    ops.rayleigh(a0a1[0], a0a1[1], 0.0, 0.0)
    _analysis(ops, system, static=False)
    return crest, nfree, tag, dofmap


def _analysis(ops, system, static):
    ops.constraints("Plain")
    ops.numberer("RCM")
    ops.system(system)
    if static:
        ops.algorithm("Linear")
        ops.integrator("LoadControl", 1.0)
        ops.analysis("Static")
    else:
        ops.algorithm("Linear", "-factorOnce")
        ops.integrator("Newmark", 0.5, 0.25)
        ops.analysis("Transient")


def ours_linear(model, sets, n, zero_accel=True):
    """n steps of the linear run (``linear_sets``) of the benchmark scene with ``sets`` on
    ``model``; zero_accel: v = a = 0 after the static state, as OpenSees starts. Returns
    (crest u_x per step, step walls, max active points, solver, analysis)."""
    a = analysis(scene(list(sets) + linear_sets(scene(sets)), n_steps=n), model)
    s, fk = a.solver, load(a)
    if zero_accel:                    # as OpenSees: v = a = 0 after the static analysis
        s.set_initial(u=s.u.copy(), v=np.zeros_like(s.u), a=np.zeros_like(s.u), f=fk(0))
    cx = model.crest_dofs[0]
    ux, walls, act = [s.u[cx]], [], 0
    for k in range(1, n + 1):
        r = s.step(fk(k))
        walls.append(r.wall)
        ux.append(s.u[cx])
        act = max(act, r.n_active)
    return np.asarray(ux), np.asarray(walls), act, s, a


def part4(res, n=500, systems=("BandSPD", "ProfileSPD", "SparseSYM", "UmfPack"),
          model_c=None):
    out = res.setdefault("part4", {})
    t0 = time.perf_counter()
    try:
        ops = import_opensees()
        out["opensees_version"] = ops.version() if hasattr(ops, "version") else "?"
    except Exception as exc:                      # noqa: BLE001
        out["error"] = f"openseespy import failed: {exc!r}"
        save(res)
        return
    out["import_note"] = ("openseespy 3.7 (Linux wheel) raises 'Failed to import openseespy "
                          "on Linux' unless the BLAS/LAPACK/gfortran libraries bundled in "
                          "site-packages/openseespylinux/lib are loaded with "
                          "ctypes.CDLL(..., RTLD_GLOBAL) first")
    sc = scene(n_steps=n)
    mc = model_c if model_c is not None else model_of(sc)
    # the consistent-mass model's Rayleigh frequencies (hence a0, a1) and k0 for both models
    # and OpenSees
    ac = analysis(sc, mc)
    a0a1 = a0a1_of(ac)
    k0n, k0t = ac.reference["k_normal"], ac.reference["k_tangential"]
    fr = [f"damping.frequencies=[{ac.damping['f_a']!r}, {ac.damping['f_b']!r}]"]
    lumped = ["mesh.lumped_mass=true"] + fr
    ml = model_of(scene(lumped, n_steps=n))
    assert ml.nfree == mc.nfree and ml.interface.npts == mc.interface.npts
    # ours, linear (lumped mass: the same mass matrix as tri31's), and on the default model
    la0 = loadavg()
    ux_l, w_l, act_l, s_l, al = ours_linear(ml, lumped, n)
    assert a0a1_of(al) == a0a1
    _, w_c, act_c, _, _ = ours_linear(mc, fr, n, zero_accel=False)
    scl, fs, ax, ay = al.scene, al.f_static, al.ax[:n + 1], al.ay[:n + 1]
    out.update({"n_steps": n, "start": START, "nfree": int(ml.nfree),
                "npts": int(ml.interface.npts), "k0": [k0n, k0t], "a0a1": list(a0a1),
                "ours_linear_lumped_ms": 1e3 * float(np.median(w_l)),
                "ours_linear_default_ms": 1e3 * float(np.median(w_c)),
                "ours_linear_active_max": int(max(act_l, act_c))})
    save(res)
    rows = {}
    for system in systems:
        try:
            crest, nfree, tag, dofmap = build_opensees(ops, ml, scl, a0a1, k0n, k0t, fs, ax, ay,
                                                       system)
            uxs = [ops.nodeDisp(crest, 1)]
            walls = []
            for k in range(n):
                t = time.perf_counter()
                ok = ops.analyze(1, DT)
                walls.append(time.perf_counter() - t)
                if ok != 0:
                    raise RuntimeError(f"analyze returned {ok} at step {k + 1}")
                uxs.append(ops.nodeDisp(crest, 1))
            uxs = np.asarray(uxs)
            dyn = np.max(np.abs(ux_l - ux_l[0]))
            rows[system] = {"ms_median": 1e3 * float(np.median(walls)),
                            "first_step_ms": 1e3 * walls[0],
                            "ms_median_after_first": 1e3 * float(np.median(walls[1:])),
                            "nfree": nfree,
                            "crest_static_ours": float(ux_l[0]),
                            "crest_static_opensees": float(uxs[0]),
                            "crest_static_rel_diff": float(abs(uxs[0] - ux_l[0]) / abs(ux_l[0])),
                            "crest_dyn_peak_ours": float(dyn),
                            "crest_dyn_peak_opensees": float(np.max(np.abs(uxs - uxs[0]))),
                            "crest_max_diff_over_dyn_peak":
                                float(np.max(np.abs(uxs - ux_l)) / dyn),
                            "crest_dyn_max_diff_over_dyn_peak":
                                float(np.max(np.abs((uxs - uxs[0]) - (ux_l - ux_l[0]))) / dyn),
                            "crest_tolerance": CREST_TOL}
            rows[system]["crest_within_tolerance"] = bool(
                rows[system]["crest_max_diff_over_dyn_peak"] <= CREST_TOL)
            print(f"[4] OpenSees {system}: {rows[system]['ms_median']:.2f} ms/step, crest diff "
                  f"{rows[system]['crest_max_diff_over_dyn_peak']:.2e} of dyn peak", flush=True)
        except Exception as exc:                  # noqa: BLE001
            rows[system] = {"error": repr(exc)}
            print(f"[4] OpenSees {system}: {exc!r}", flush=True)
        out["systems"] = rows
        save(res)
    good = {k: v for k, v in rows.items() if "ms_median" in v}
    if good:
        best = min(good, key=lambda k: good[k]["ms_median"])
        out["fastest"] = best
        out["opensees_ms"] = good[best]["ms_median"]
        out["ratio_ours_linear_default"] = out["ours_linear_default_ms"] / out["opensees_ms"]
        out["ratio_ours_linear_lumped"] = out["ours_linear_lumped_ms"] / out["opensees_ms"]
    out["loadavg"] = [la0, loadavg()]
    out["wall"] = time.perf_counter() - t0
    ops.wipe()
    save(res)


def ratios(res):
    """Ours nonlinear (the full run and the strong-part default-mesh run) / OpenSees linear."""
    p4 = res.get("part4", {})
    if "opensees_ms" not in p4:
        return
    r = {}
    full = res.get("part2", {}).get("alpha2", {})
    if "timings" in full:
        r["full_run_median_over_opensees"] = (1e3 * full["timings"]["per_step_median"]
                                              / p4["opensees_ms"])
        r["full_run_mean_over_opensees"] = (1e3 * full["timings"]["dynamic"] / full["n_steps"]
                                            / p4["opensees_ms"])
    for row in res.get("part1", {}).get("series", {}).get("dofs", []):
        if row["overrides"] == []:
            r["strong_part_median_over_opensees"] = (1e3 * row["per_step_median"]
                                                     / p4["opensees_ms"])
    p3 = res.get("part3")
    if p3:
        r["condensed_strong_over_opensees"] = p3["condensed_ms_median_all"] / p4["opensees_ms"]
    res["ratios"] = r
    save(res)


# ---------------------------------------------------------------------------------------------
# speed targets 2-5 (parts 5-8)
# ---------------------------------------------------------------------------------------------
# the scene of the speed targets (set before the koyna scene's reservoir became "acoustic"): the dam
# without the water domain, so that before/after and the figures compare
NL_SET = ("ground_motion.scale=0.2", "reservoir.model=none")
LIN_SET = ("ground_motion.scale=0.001", "interface.damage=false", "reservoir.model=none")


def cli_run(sets, tag) -> dict:
    """`python -m ngs_driver run koyna --set ...` under /usr/bin/time -v: wall, CPU, peak RSS,
    the run's own timings and solver totals, per-step walls."""
    od = pathlib.Path(tempfile.mkdtemp(prefix=f"bench15_{tag}_"))
    tf = od.parent / (od.name + ".time")
    args = ["-m", "ngs_driver", "run", "koyna", "--out", str(od), "--quiet"]
    for ov in sets:
        args[4:4] = ["--set", ov]
    timev = pathlib.Path("/usr/bin/time")
    argv = ([str(timev), "-v"] if timev.exists() else []) + [sys.executable] + args
    cmd = " ".join(["/usr/bin/time -v" if timev.exists() else "", "python"] + args)
    l0 = loadavg()
    with open(tf, "w") as fh:
        p = subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=fh, cwd=ROOT)
    d = {"command": cmd.replace(str(od), "DIR"), "loadavg": [l0, loadavg()]}
    if p.returncode != 0:
        d["error"] = f"exit code {p.returncode}: {tf.read_text()[-1500:]}"
        return d
    d.update(parse_time_v(tf.read_text()))
    sm = json.loads((od / "summary.json").read_text())
    from ngs_driver.post.files import read_csv
    ts = read_csv(od / "timeseries.csv")
    d.update({"timings": sm["timings"], "solver_totals": sm["solver_totals"],
              "n_steps": sm["n_steps"], "steps_done": int(len(ts["wall"])),
              "stopped": sm.get("stopped"),
              "per_step_median_ms": 1e3 * float(np.median(ts["wall"])),
              "per_step_mean_ms": 1e3 * float(np.mean(ts["wall"])),
              "newton_per_step": float(np.mean(ts["iterations"])),
              "crest_ux": np.asarray(ts["crest_ux"]).tolist(),
              "crest_ux_max": float(np.max(np.abs(ts["crest_ux"]))),
              "n_active_max": int(np.max(ts["n_active"]))})
    return d


def part5(res, repeats=2):
    """Target 2 (+ memory, target 4): the 0.2x run and the same run with an elastic interface,
    interleaved, `repeats` times each; medians of the whole-run wall and of the dynamic wall."""
    out = {"nonlinear_set": list(NL_SET), "linear_set": list(LIN_SET), "runs": []}
    res["part5"] = out
    cli_run(("time.duration=0.01",), "warm_numba_cache")      # compile outside the timing
    for r in range(repeats):
        for tag, sets in (("nonlinear", NL_SET), ("linear", LIN_SET)):
            d = cli_run(sets, tag)
            d["kind"] = tag
            crest = d.pop("crest_ux", None)
            if tag == "nonlinear" and crest is not None:
                out.setdefault("crest_ux_first", crest)
                a = np.asarray(out["crest_ux_first"])
                b = np.asarray(crest)
                if a.shape == b.shape:
                    d["crest_rel_diff_vs_first"] = float(np.max(np.abs(a - b)) /
                                                         np.max(np.abs(a)))
            out["runs"].append(d)
            print(f"[5] {tag} #{r}: wall {d.get('wall_s')} s, dynamic "
                  f"{d.get('timings', {}).get('dynamic', float('nan')):.1f} s, "
                  f"user {d.get('user_s')} s, RSS {d.get('peak_rss_MB', 0):.0f} MB", flush=True)
            save(res)
    out.pop("crest_ux_first", None)
    summ = {}
    for tag in ("nonlinear", "linear"):
        rs = [x for x in out["runs"] if x["kind"] == tag and "wall_s" in x]
        if rs:
            summ[tag] = {k: float(np.median([f(x) for x in rs])) for k, f in (
                ("wall_s", lambda x: x["wall_s"]), ("user_s", lambda x: x["user_s"]),
                ("dynamic_s", lambda x: x["timings"]["dynamic"]),
                ("per_step_median_ms", lambda x: x["per_step_median_ms"]),
                ("peak_rss_MB", lambda x: x["peak_rss_MB"]))}
    if len(summ) == 2:
        summ["ratio_wall"] = summ["nonlinear"]["wall_s"] / summ["linear"]["wall_s"]
        summ["ratio_dynamic"] = summ["nonlinear"]["dynamic_s"] / summ["linear"]["dynamic_s"]
        summ["ratio_user"] = summ["nonlinear"]["user_s"] / summ["linear"]["user_s"]
        summ["ratio_step_median"] = (summ["nonlinear"]["per_step_median_ms"]
                                     / summ["linear"]["per_step_median_ms"])
    out["summary"] = summ
    save(res)


def part6(res):
    """Target 5: full intensity with the stop disabled (sliding over the whole base)."""
    d = cli_run(("time.stop_slip=0", "reservoir.model=none"), "full_intensity")
    d.pop("crest_ux", None)
    res["part6"] = d
    print(f"[6] full intensity: wall {d.get('wall_s')} s, per step median "
          f"{d.get('per_step_median_ms', float('nan')):.1f} ms, cuts "
          f"{d.get('solver_totals', {}).get('cuts')}", flush=True)
    save(res)


def step_pair(m, sets, n_warm=10, n_meas=30):
    """Nonlinear (scene law, the scene's record scale) and linear (elastic-branch law) steps of
    the same model, interleaved: per-step medians [s], Newton iterations, active points."""
    n = n_warm + n_meas + 1
    an = analysis(scene(sets, n_steps=n), m)
    al = analysis(scene(list(sets) + linear_sets(an.scene), n_steps=n), m)
    sn, sl, fk = an.solver, al.solver, load(an)
    for k in range(1, n_warm + 1):
        sn.step(fk(k))
        sl.step(fk(k))
    wn, wl, its, cn, cl = [], [], [], [], []
    for k in range(n_warm + 1, n_warm + n_meas + 1):
        c0 = time.process_time()
        r = sn.step(fk(k))
        cn.append(time.process_time() - c0)
        wn.append(r.wall)
        its.append(r.iterations)
        c0 = time.process_time()
        wl.append(sl.step(fk(k)).wall)
        cl.append(time.process_time() - c0)
    # CPU time of this process (time.process_time) beside the wall time: on a shared, loaded
    # machine the wall time of a step is mostly waiting for a core
    return {"nl_cpu_ms": 1e3 * float(np.median(cn)), "lin_cpu_ms": 1e3 * float(np.median(cl)),
            "ratio_cpu": float(np.median(cn) / np.median(cl)),
            "nl_ms": 1e3 * float(np.median(wn)), "lin_ms": 1e3 * float(np.median(wl)),
            "nl_mean_ms": 1e3 * float(np.mean(wn)), "newton_per_step": float(np.mean(its)),
            "n_active": int(sn.history[-1].n_active), "lin_active": int(sl.history[-1].n_active),
            "ratio": float(np.median(wn) / np.median(wl)), "stats": dict(sn.stats)}


def part7(res, quick=False, n_meas=20):
    """Target 3: time per step against interface points and DOFs, nonlinear and linear."""
    base = ["ground_motion.scale=0.2"]
    series = {"points": [[f"mesh.gauss_points={g}"] for g in (1, 3, 6, 10)]
              + [["mesh.gauss_points=10", "mesh.h_interface=0.5"]],
              "dofs": [[f"mesh.h_coarse={h}"] for h in (4.0, 2.0, 1.0, 0.6)]}
    if quick:
        series = {"points": [["mesh.gauss_points=1"], ["mesh.gauss_points=2"]], "dofs": []}
    out = res.setdefault("part7", {"series": {}})
    for name, rows in series.items():
        out["series"][name] = []
        for ov in rows:
            sets = base + ov + (["mesh.h_coarse=10.0", "mesh.h_interface=5.0",
                                 "mesh.h_heel=1.0", "mesh.heel_zone=2.0"] if quick else [])
            sc = scene(sets)
            t0 = time.perf_counter()
            m = model_of(sc)
            tb = time.perf_counter() - t0
            la0 = loadavg()
            row = step_pair(m, sets, n_meas=n_meas if not quick else 3,
                            n_warm=10 if not quick else 2)
            row.update({"overrides": ov, "nfree": int(m.nfree), "npts": int(m.interface.npts),
                        "build_s": tb, "loadavg": [la0, loadavg()]})
            out["series"][name].append(row)
            print(f"[7] {name} {ov}: {row['nfree']} DOFs, {row['npts']} pts: nonlinear "
                  f"{row['nl_ms']:.2f} ms ({row['nl_cpu_ms']:.2f} CPU), linear "
                  f"{row['lin_ms']:.2f} ms ({row['lin_cpu_ms']:.2f} CPU), ratio "
                  f"{row['ratio']:.2f} ({row['ratio_cpu']:.2f} CPU)", flush=True)
            save(res)
            del m
        rs = out["series"][name]
        if len(rs) >= 2:
            xk = "npts" if name == "points" else "nfree"
            for kind, key in (("nonlinear", "nl"), ("linear", "lin")):
                out[f"exponent_{name}_{kind}"] = loglog_fit([r[xk] for r in rs],
                                                            [r[f"{key}_ms"] for r in rs])
                out[f"exponent_{name}_{kind}_cpu"] = loglog_fit(
                    [r[xk] for r in rs], [r[f"{key}_cpu_ms"] for r in rs])
    save(res)
    plot7(res)


def part8(res, start=START, n=200):
    """Target 2 per step: the 0.2x step (scene law) against the step of the issue's elastic
    run (record x 0.001, interface.damage = false), same model, same record times, interleaved;
    medians of the CPU time of this process and of the wall time."""
    at = [f"ground_motion.start={start!r}"]
    scn = scene(list(NL_SET) + at, n_steps=n + 30)
    m = model_of(scn)
    an = analysis(scn, m)
    al = analysis(scene(list(LIN_SET) + at, n_steps=n + 30), m)
    sn, sl, fkn, fkl = an.solver, al.solver, load(an), load(al)
    for k in range(1, 11):
        sn.step(fkn(k))
        sl.step(fkl(k))
    cn, cl, wn, wl = [], [], [], []
    la0 = loadavg()
    for k in range(11, 11 + n):
        c0 = time.process_time()
        wn.append(sn.step(fkn(k)).wall)
        cn.append(time.process_time() - c0)
        c0 = time.process_time()
        wl.append(sl.step(fkl(k)).wall)
        cl.append(time.process_time() - c0)
    out = {"start": start, "n": n, "nfree": int(m.nfree), "npts": int(m.interface.npts),
           "nl_cpu_ms": 1e3 * float(np.median(cn)), "lin_cpu_ms": 1e3 * float(np.median(cl)),
           "ratio_cpu": float(np.median(cn) / np.median(cl)),
           "nl_wall_ms": 1e3 * float(np.median(wn)), "lin_wall_ms": 1e3 * float(np.median(wl)),
           "newton_nl": float(np.mean([r.iterations for r in sn.history[-n:]])),
           "newton_lin": float(np.mean([r.iterations for r in sl.history[-n:]])),
           "active_nl": int(sn.history[-1].n_active), "active_lin": int(sl.history[-1].n_active),
           "loadavg": [la0, loadavg()]}
    res["part8"] = out
    print(f"[8] per step CPU: nonlinear {out['nl_cpu_ms']:.2f} ms, elastic {out['lin_cpu_ms']:.2f}"
          f" ms, ratio {out['ratio_cpu']:.2f}", flush=True)
    save(res)


def plot7(res):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    p7 = res.get("part7", {})
    ser = p7.get("series", {})
    fig, axs = plt.subplots(1, 2, figsize=(10, 4))
    for ax, name, xk, xl in ((axs[0], "points", "npts", "interface points"),
                             (axs[1], "dofs", "nfree", "free DOFs")):
        rs = ser.get(name, [])
        if not rs:
            continue
        x = [r[xk] for r in rs]
        for key, lab in (("nl_cpu_ms", "nonlinear (0.2x, alpha = 2)"),
                         ("lin_cpu_ms", "linear")):
            kind = "nonlinear" if key == "nl_cpu_ms" else "linear"
            ex = p7.get(f"exponent_{name}_{kind}_cpu")
            ax.loglog(x, [r[key] for r in rs], "o-",
                      label=lab + (f": ∝ n^{ex:.2f}" if ex is not None else ""))
        ax.set_xlabel(xl)
        ax.set_ylabel("CPU ms per step (median)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    fig.suptitle("Koyna: time per implicit step (target 3)")
    fig.tight_layout()
    OUT.mkdir(parents=True, exist_ok=True)
    fig.savefig(OUT / "bench15_scaling.png", dpi=110)
    plt.close(fig)


# ---------------------------------------------------------------------------------------------
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--parts", default="1,2,3,4",
                    help="1-4: time per step, full run, condensed vs full Newton, OpenSees; 5: "
                         "speed target 2 + memory, 6: target 5 (full intensity), 7: target 3 "
                         "(scaling), 8: target 2 per step "
                         "(CPU time, interleaved)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--alpha1", action="store_true", help="also the full run with alpha = 1")
    ap.add_argument("--default-stop", action="store_true",
                    help="also alpha = 2 with the scene's time.stop_slip (stops at failure)")
    ap.add_argument("--full-dir", default=None, help="reuse a finished alpha=2 full run")
    ap.add_argument("--opensees-steps", type=int, default=500)
    ap.add_argument("--fresh", action="store_true", help="ignore an existing JSON")
    ap.add_argument("--no-md", action="store_true")
    a = ap.parse_args(argv)
    parts = {int(p) for p in a.parts.split(",") if p}
    res = {} if a.fresh or not JSON.exists() else json.loads(JSON.read_text())
    res["env"] = env_info()
    res["command"] = "python verification/bench_koyna.py " + " ".join(
        argv if argv is not None else sys.argv[1:])
    res.setdefault("commands", []).append(res["command"])
    res.setdefault("loadavg_start", loadavg())
    save(res)
    if 2 in parts:
        part2(res, (2.0, 1.0) if a.alpha1 else (2.0,), a.full_dir)
        if a.default_stop:
            part2(res, (2.0,), None, extra_set=())
    shared = {}
    if 3 in parts or 4 in parts:
        shared["model"] = model_of(scene())
    if 3 in parts:
        part3(res, model=shared["model"])
    if 4 in parts:
        part4(res, n=a.opensees_steps, model_c=shared["model"])
    if 1 in parts:
        part1(res, repeats=a.repeats)
    if 5 in parts:
        part5(res, repeats=a.repeats)
    if 6 in parts:
        part6(res)
    if 7 in parts:
        part7(res)
    if 8 in parts:
        part8(res)
    ratios(res)
    res["loadavg_end"] = loadavg()
    save(res)
    print(f"wrote {JSON}")
    if not a.no_md:
        sys.path.insert(0, str(ROOT / "verification"))
        import write_benchmarks
        write_benchmarks.main([])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
