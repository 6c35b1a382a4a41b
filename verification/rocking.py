"""Rocking beyond small rotations: a slender block on a rigid base against Housner's rigid
block (1963, Bull. Seismol. Soc. Am. 53(2):403; the exact equation of Makris &
Konstantinidis 2003, EESD 32:265, integrated by ``solve_ivp`` in verification/housner.py):
``python verification/rocking.py [--fast]`` -> verification/out/rocking.md.

The block: 2 m wide, 10 m tall (alpha = atan(1/5) = 0.197 rad), E = 1e13 Pa (its modes above
1 kHz), contact stiffness 1e13 Pa/m, friction 2 (it never slides), no viscous damping, on the
``sliding_block`` scene's rigid base (``solver.kinematics`` and ``time.max_rotation`` set
per case). Its contact acts at the Gauss points of the joint (3 per segment of
``mesh.h_interface`` = 0.25 m): the block pivots on the outermost one, 0.028 m inside the
corner, and the reference is the rigid block pivoting there (``inset``; Housner's own block,
inset 0, is shown beside it). Compared before the first impact only: the restitution at
impact belongs to the contact law, not to Housner's model.

* **Free rocking** from rest at a tilt theta0 (0.5 and 0.9 alpha of the pivot's alpha): the
  time to the first impact, with the finite-rotation kinematics and with the small-rotation
  ones (run past their own range here, time.max_rotation lifted by hand, to show their error);
  a dt study of the finite-rotation case (its corrections are formed once per step from the
  predicted rotation).
* **Toppling** from the flat position with an initial angular velocity omega0 = 1.05 and 0.95
  times the critical omega_c (1/2 I_o omega_c^2 = m g R (1 - cos alpha)): the first topples
  (verdict collapse, mode toppling, its time against the exact equation's time to reach
  alpha), the second rocks and recovers (its largest rotation, its impact).
* **Ground pulses** (half-sine, 1 s): the forced response (largest rotation, its time, the
  impact) at 0.4 g, and toppling at 1.1 times the exact equation's critical amplitude.
* **The reduced bulk** (``solver.bulk = "reduced"``, 40 fixed-interface modes; fe/reduction.py):
  the free-rocking and toppling cases of the finite-rotation kinematics again, against the full
  bulk's (the rigid rotation lies in the basis; the lever-arm sums are the full bulk's,
  run/rotation.py).
"""
from __future__ import annotations

import math
import pathlib
import sys
import tempfile
import time

import numpy as np
from scipy.integrate import solve_ivp

HERE = pathlib.Path(__file__).resolve().parent
if str(HERE.parent) not in sys.path:
    sys.path.insert(0, str(HERE.parent))

from ngs_driver.fe.blocks import linear_fields  # noqa: E402
from ngs_driver.run.analysis import prepare  # noqa: E402
from ngs_driver.scene import load_scene  # noqa: E402
from verification.housner import free_rocking_quarter, rocking_response  # noqa: E402
from verification.study_cli import run_from_command_line, study_dir, write_report  # noqa: E402

G = 9.81
B_HALF, H_HALF = 1.0, 5.0          # m: the block's half-width and half-height
H_IFACE = 0.25                     # m: the joint's segments
INSET = H_IFACE * 0.5 * (1.0 - math.sqrt(0.6))   # outermost 3-point Gauss point: 0.0282 m
ALPHA = math.atan2(B_HALF - INSET, H_HALF)       # the pivot's slenderness, 0.1922 rad
PULSE_T = 1.0                      # s: the half-sine pulses' duration

FULL = dict(free=(0.5, 0.9), dts=(0.004, 0.002, 0.001), dt=0.002, topple=(1.05, 0.95),
            pulses=True)
FAST = dict(free=(0.9,), dts=(), dt=0.004, topple=(1.05, 0.95), pulses=False)
REDUCED = ("solver.bulk=reduced",)                # the reduced bulk's cases (its 40 modes)


def block_scene(kinematics="finite_rotation", dt=0.002, duration=3.0, record=None,
                extra=()):
    duration = round(math.ceil(duration / dt - 1e-9) * dt, 10)   # whole steps
    rec = record or "pulse:half-sine:1e-9:0.1"       # no ground motion (a negligible pulse)
    sets = [f"geometry.profile=[[0,0],[{2 * B_HALF!r},0],[{2 * B_HALF!r},{2 * H_HALF!r}],"
            f"[0,{2 * H_HALF!r}]]", "reservoir.level=0.0", "interface.friction=2.0",
            f'ground_motion.record="{rec}"', f"time.duration={duration!r}",
            "materials.dam.E=1e13", "interface.contact_stiffness=1e13",
            f"mesh.h_interface={H_IFACE!r}", f"mesh.h_heel={H_IFACE!r}", "mesh.h_coarse=1.0",
            f"time.dt={dt!r}", f"solver.kinematics={kinematics}",
            "time.max_rotation=" + ("0.1" if kinematics == "small" else "0.6"),
            "damping.ratio=0", "output.checkpoint_every=0"]
    return load_scene("sliding_block", sets + list(extra))


def rotation_field(model, pivot):
    """The unit rigid rotation (1 rad, linearised) of the blocks above the rock about
    ``pivot`` = (x, y), in the model's coordinates."""
    F = linear_fields(model, [r for r in model.regions if r != "rock"])
    cx, cy = pivot
    # a rigid field: in the model's coordinates (a reduced bulk's basis holds it exactly)
    return model.field_rows(-(F["Yx"] - cy * F["Tx"]) + (F["Xy"] - cx * F["Ty"]))


def release(sc, theta0=0.0, omega0=0.0, outdir=None):
    """Run ``sc`` from its static state with the block turned by theta0 about its upstream
    pivot and spinning at omega0 (rad, rad/s; counter-clockwise). Returns (t, theta, stop):
    the history of the base joint's rotation and the stop entry (None: the record's end).
    With the small-rotation kinematics the range check is lifted (to show their error)."""
    out = outdir or tempfile.mkdtemp(prefix="rocking_")
    a = prepare(sc, out, progress=False, overwrite=True)
    a.static()
    s = a.solver
    x = np.asarray(a.model.interface.x)
    pivot = (float(x.min()), float(np.mean(a.model.interface.y)))
    phi = rotation_field(a.model, pivot)
    s.set_initial(u=s.u + theta0 * phi, v=omega0 * phi)
    f0 = a.f_static.copy()
    if a.rotation is not None:
        f0 = f0 + a.rotation.step_load(s, 0.0, a.ax[0], a.ay[0])
    else:
        a.stop_rule.max_rotation = 10.0          # past the small kinematics' range, by hand
    s.set_initial(u=s.u)                         # the gap with the offset
    s.initial_acceleration(f0 - a.Mrx * a.ax[0] - a.Mry * a.ay[0])
    a.energy.start(s.u, s.v, s.f, s.t, s.g, s.state)
    a.guard.start()
    while a.step():
        pass
    a.close()
    a.release()
    H = a.history.arrays()
    stop = a.collapse or a.undetermined
    return np.asarray(H["t"]), np.asarray(H["base_rotation"]), stop


def run_pulse(sc, outdir=None):
    """A plain run (the ground pulse of ``sc``); (t, theta, stop)."""
    a = prepare(sc, outdir or tempfile.mkdtemp(prefix="rocking_"), progress=False,
                overwrite=True)
    a.static()
    while a.step():
        pass
    a.close()
    a.release()
    H = a.history.arrays()
    return np.asarray(H["t"]), np.asarray(H["base_rotation"]), a.collapse or a.undetermined


def first_crossing(t, th, after=0.0):
    """The first time after ``after`` where theta changes sign (linear between samples)."""
    for j in range(1, t.size):
        if t[j] > after and th[j - 1] * th[j] <= 0.0 and th[j - 1] != 0.0:
            return float(t[j - 1] + (t[j] - t[j - 1]) * th[j - 1] / (th[j - 1] - th[j]))
    return None


def free_cases(cfg, dt=None, kinematics=("finite_rotation", "small"), extra=()):
    rows = []
    for frac in cfg["free"]:
        th0 = frac * ALPHA
        ref = free_rocking_quarter(B_HALF, H_HALF, th0, g=G, inset=INSET)
        ref0 = free_rocking_quarter(B_HALF, H_HALF, th0, g=G)
        for kin in kinematics:
            t0 = time.perf_counter()
            sc = block_scene(kin, dt=dt or cfg["dt"], duration=round(1.3 * ref, 2),
                             extra=extra)
            t, th, stop = release(sc, theta0=th0)
            imp = first_crossing(t, th)
            rows.append({"theta0_over_alpha": frac, "kinematics": kin, "dt": sc.time.dt,
                         "fe_impact": imp, "ref_impact": ref, "housner_inset0": ref0,
                         "error": None if imp is None else imp / ref - 1.0,
                         "wall": time.perf_counter() - t0})
    return rows


def dt_study(cfg):
    rows = []
    th0 = 0.9 * ALPHA
    ref = free_rocking_quarter(B_HALF, H_HALF, th0, g=G, inset=INSET)
    for dt in cfg["dts"]:
        t, th, _ = release(block_scene("finite_rotation", dt=dt, duration=round(1.3 * ref, 2)),
                           theta0=th0)
        imp = first_crossing(t, th)
        rows.append({"dt": dt, "fe_impact": imp, "ref_impact": ref, "error": imp / ref - 1.0})
    return rows


def critical_omega():
    R = math.hypot(B_HALF - INSET, H_HALF)
    p2 = G * R / ((B_HALF ** 2 + H_HALF ** 2) / 3.0 + R * R)
    return math.sqrt(2.0 * p2 * (1.0 - math.cos(ALPHA))), p2


def topple_time_exact(omega0):
    """(t at |theta| = alpha or None, largest theta, impact time or None) of the exact
    equation from theta = 0 at omega0."""
    _, p2 = critical_omega()

    def rhs(t, y):
        return [y[1], -p2 * math.sin(ALPHA - y[0])]

    def top(t, y):
        return y[0] - ALPHA
    top.terminal, top.direction = True, 1.0

    def imp(t, y):
        return y[0] if t > 1e-6 else 1.0
    imp.terminal, imp.direction = True, -1.0
    sol = solve_ivp(rhs, (0.0, 30.0), [0.0, omega0], events=(top, imp), rtol=1e-11,
                    atol=1e-13, dense_output=True)
    tt = np.linspace(0.0, sol.t[-1], 20001)
    return ((float(sol.t_events[0][0]) if sol.t_events[0].size else None),
            float(np.max(sol.sol(tt)[0])),
            (float(sol.t_events[1][0]) if sol.t_events[1].size else None))


def toppling_cases(cfg, extra=()):
    wc, _ = critical_omega()
    rows = []
    for f in cfg["topple"]:
        t_top, th_max, t_imp = topple_time_exact(f * wc)
        dur = round(1.3 * (t_top if t_top is not None else t_imp), 2)
        t0 = time.perf_counter()
        t, th, stop = release(block_scene("finite_rotation", dt=cfg["dt"], duration=dur,
                                          extra=extra), omega0=f * wc)
        rows.append({"omega0_over_crit": f, "omega0": f * wc,
                     "verdict": None if stop is None else
                     ("collapse" if "mode" in stop else "undetermined"),
                     "mode": None if stop is None else stop.get("mode"),
                     "fe_topple_time": None if stop is None else stop["time"],
                     "ref_topple_time": t_top,
                     "toppling_angle": None if stop is None else stop.get("toppling_angle"),
                     "fe_theta_max": float(np.max(th)), "ref_theta_max": th_max,
                     "fe_impact": first_crossing(t, th, after=0.05), "ref_impact": t_imp,
                     "wall": time.perf_counter() - t0})
    return rows


def reduced_cases(cfg, free, topple):
    """The finite-rotation free-rocking and toppling cases on the reduced bulk, each beside the
    full bulk's row (``free``, ``topple``: the full bulk's rows): rows of (case, quantity,
    full, reduced, difference)."""
    rows = []
    full = {r["theta0_over_alpha"]: r for r in free if r["kinematics"] == "finite_rotation"}
    for r in free_cases(cfg, kinematics=("finite_rotation",), extra=REDUCED):
        f = full[r["theta0_over_alpha"]]
        rows.append({"case": f"free rocking, theta0 = {r['theta0_over_alpha']:g} alpha",
                     "quantity": "time to impact [s]", "full": f["fe_impact"],
                     "reduced": r["fe_impact"], "wall": r["wall"]})
    full = {r["omega0_over_crit"]: r for r in topple}
    for r in toppling_cases(cfg, extra=REDUCED):
        f = full[r["omega0_over_crit"]]
        case = f"omega0 = {r['omega0_over_crit']:g} omega_c"
        if f["mode"] == "toppling" or r["mode"] == "toppling":
            rows.append({"case": case, "quantity": "toppling time [s]",
                         "full": f["fe_topple_time"], "reduced": r["fe_topple_time"],
                         "mode_full": f["mode"], "mode_reduced": r["mode"], "wall": r["wall"]})
        else:
            rows.append({"case": case, "quantity": "largest rotation [rad]",
                         "full": f["fe_theta_max"], "reduced": r["fe_theta_max"],
                         "mode_full": f["mode"], "mode_reduced": r["mode"], "wall": r["wall"]})
            rows.append({"case": case, "quantity": "time to impact [s]",
                         "full": f["fe_impact"], "reduced": r["fe_impact"],
                         "mode_full": f["mode"], "mode_reduced": r["mode"], "wall": r["wall"]})
    for r in rows:
        r["difference"] = (None if r["full"] is None or r["reduced"] is None
                           else r["reduced"] / r["full"] - 1.0)
    return rows


def pulse_cases(cfg):
    if not cfg["pulses"]:
        return []

    def acc(A):
        return lambda t: A * G * math.sin(math.pi * t / PULSE_T) if t <= PULSE_T else 0.0
    lo, hi = 0.3, 0.6                             # the exact equation's critical amplitude
    for _ in range(40):
        m = 0.5 * (lo + hi)
        r = rocking_response(B_HALF, H_HALF, acc(m), 8.0, g=G, inset=INSET)
        lo, hi = (m, hi) if r["t_topple"] is None else (lo, m)
    A_c = hi
    rows = []
    for A, kin in ((0.4, "finite_rotation"), (0.4, "small"), (1.1 * A_c, "finite_rotation")):
        ref = rocking_response(B_HALF, H_HALF, acc(A), 4.0, g=G, inset=INSET)
        sc = block_scene(kin, dt=cfg["dt"], duration=4.0 if ref["t_topple"] is None
                         else round(ref["t_topple"] + 0.5, 2),
                         record=f"pulse:half-sine:{A!r}:{PULSE_T!r}")
        if kin == "small":
            sc = block_scene(kin, dt=cfg["dt"], duration=4.0,
                             record=f"pulse:half-sine:{A!r}:{PULSE_T!r}")
        t, th, stop = run_pulse(sc)
        k = int(np.argmax(np.abs(th)))
        rows.append({"A_over_g": A, "A_c_over_g": A_c, "kinematics": kin,
                     "fe_theta_max": float(th[k]), "ref_theta_max": ref["theta_max"],
                     "fe_t_max": float(t[k]), "ref_t_max": ref["t_max"],
                     "fe_impact": first_crossing(t, th, after=float(t[k])),
                     "ref_impact": ref["t_impact"],
                     "mode": None if stop is None else stop.get("mode"),
                     "fe_topple_time": None if stop is None else stop["time"],
                     "ref_topple_time": ref["t_topple"]})
    return rows


def _f(x, fmt="{:.4g}"):
    return "—" if x is None else fmt.format(x)


def report(res) -> str:
    L = ["# Rocking beyond small rotations: the block against Housner's (1963)", "",
         f"Block 2 m x 10 m on a rigid base, pivot {INSET:.4f} m inside the corner (the "
         f"outermost Gauss point), alpha = {ALPHA:.4f} rad; reference: the exact equation "
         "(verification/housner.py, solve_ivp). Compared before the first impact.", "",
         "## Free rocking from rest at theta0: time to the first impact", "",
         "| theta0/alpha | kinematics | dt [s] | FE [s] | exact [s] | difference | Housner, "
         "pivot at the corner [s] |", "|---|---|---|---|---|---|---|"]
    for r in res["free"]:
        L.append(f"| {r['theta0_over_alpha']:g} | {r['kinematics']} | {r['dt']:g} | "
                 f"{_f(r['fe_impact'], '{:.5g}')} | {r['ref_impact']:.5g} | "
                 f"{_f(r['error'], '{:+.3%}')} | {r['housner_inset0']:.4g} |")
    if res["dt"]:
        L += ["", "## dt study (finite rotation, theta0 = 0.9 alpha)", "",
              "| dt [s] | FE [s] | exact [s] | difference |", "|---|---|---|---|"]
        for r in res["dt"]:
            L.append(f"| {r['dt']:g} | {r['fe_impact']:.5g} | {r['ref_impact']:.5g} | "
                     f"{r['error']:+.3%} |")
    L += ["", "## Toppling from the flat position at omega0", "",
          "| omega0/omega_c | verdict | mode | FE toppling time [s] | exact time to alpha [s] "
          "| FE max theta | exact max theta | FE impact [s] | exact impact [s] |",
          "|---|---|---|---|---|---|---|---|---|"]
    for r in res["topple"]:
        L.append(f"| {r['omega0_over_crit']:g} | {r['verdict'] or 'no_collapse'} | "
                 f"{r['mode'] or '—'} | {_f(r['fe_topple_time'])} | "
                 f"{_f(r['ref_topple_time'])} | {r['fe_theta_max']:.4g} | "
                 f"{r['ref_theta_max']:.4g} | {_f(r['fe_impact'])} | {_f(r['ref_impact'])} |")
    if res["pulses"]:
        L += ["", f"## Half-sine ground pulses ({PULSE_T:g} s)", "",
              f"Critical amplitude of the exact equation: "
              f"{res['pulses'][0]['A_c_over_g']:.5g} g.", "",
              "| A [g] | kinematics | FE max theta | exact | FE t_max [s] | exact | FE impact "
              "[s] | exact | mode | FE toppling [s] | exact to alpha [s] |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in res["pulses"]:
            L.append(f"| {r['A_over_g']:.4g} | {r['kinematics']} | {r['fe_theta_max']:.4g} | "
                     f"{r['ref_theta_max']:.4g} | {r['fe_t_max']:.4g} | {r['ref_t_max']:.4g} | "
                     f"{_f(r['fe_impact'])} | {_f(r['ref_impact'])} | {r['mode'] or '—'} | "
                     f"{_f(r['fe_topple_time'])} | {_f(r['ref_topple_time'])} |")
    if res.get("reduced"):
        L += ["", "## The reduced bulk (solver.bulk = \"reduced\", 40 modes) against the full",
              "", "| case | quantity | full bulk | reduced bulk | difference |",
              "|---|---|---|---|---|"]
        for r in res["reduced"]:
            L.append(f"| {r['case']} | {r['quantity']} | {_f(r['full'], '{:.6g}')} | "
                     f"{_f(r['reduced'], '{:.6g}')} | {_f(r['difference'], '{:+.3%}')} |")
    return "\n".join(L) + "\n"


def main(fast: bool = False, outdir=None) -> dict:
    cfg = FAST if fast else FULL
    out = study_dir(outdir, HERE)
    res = {"fast": fast, "alpha": ALPHA, "inset": INSET, "free": free_cases(cfg),
           "dt": dt_study(cfg), "topple": toppling_cases(cfg), "pulses": pulse_cases(cfg)}
    res["reduced"] = reduced_cases(cfg, res["free"], res["topple"])
    write_report(out, "rocking", report(res), res)
    return res


if __name__ == "__main__":
    run_from_command_line(main, __doc__, "rocking", HERE)
