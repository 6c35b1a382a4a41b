"""Outputs of the Koyna run: CSV, PNG (paper Figs. 8b, 10, 11, 12 style), VTK, comparison.

All files are written atomically (``ngs_driver.io``).  Plot titles carry the record label
(with "SYNTHETIC" for the shipped motion).  matplotlib is used with the Agg backend; NGSolve
is needed only for the mesh/stress plots and VTK (they take the model).
"""
from __future__ import annotations

import io as _io
import json
import pathlib

import numpy as np

from .io import atomic_write_bytes, atomic_write_text

__all__ = ["write_timeseries_csv", "write_damage_csv", "read_csv", "plot_crest",
           "plot_damage_profiles", "plot_crack_length", "plot_heel_von_mises", "plot_mesh",
           "VTKWriter", "write_run_outputs", "compare_runs"]


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _savefig(fig, path):
    buf = _io.BytesIO()
    fig.savefig(buf, format="png", dpi=130, bbox_inches="tight")
    _plt().close(fig)
    atomic_write_bytes(path, buf.getvalue())
    return pathlib.Path(path).name


def _csv_text(header: list[str], cols: list[np.ndarray], comments=()) -> str:
    lines = [f"# {c}" for c in comments]
    lines.append(",".join(header))
    data = np.column_stack([np.asarray(c, float) for c in cols]) if cols else np.zeros((0, 0))
    for row in data:
        lines.append(",".join(f"{v:.10g}" for v in row))
    return "\n".join(lines) + "\n"


def write_timeseries_csv(path, H: dict, keys, comments=()):
    return atomic_write_text(path, _csv_text(list(keys), [H[k] for k in keys], comments))


def write_damage_csv(path, x, w, snaps, comments=()):
    header = ["x", "w"] + [f"D_t={t:.4f}" for t in snaps["t"]] + \
        [f"kappa_t={t:.4f}" for t in snaps["t"]]
    cols = [x, w] + list(snaps["D"]) + list(snaps["kappa"])
    return atomic_write_text(path, _csv_text(header, cols, comments))


def read_csv(path) -> dict:
    """CSV written here -> {column: array} (comment lines skipped)."""
    lines = [ln for ln in pathlib.Path(path).read_text().splitlines() if not ln.startswith("#")]
    header = lines[0].split(",")
    data = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:] if ln.strip()])
    data = data.reshape(-1, len(header))
    return {h: data[:, i] for i, h in enumerate(header)}


# ---------------------------------------------------------------------------------------------
def plot_crest(path, series, title):
    """Fig. 10 style: crest u_x and u_y [mm] against t. series: [(label, t, ux, uy), ...]."""
    plt = _plt()
    fig, axs = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for lab, t, ux, uy in series:
        axs[0].plot(t, 1e3 * np.asarray(ux), lw=0.9, label=lab)
        axs[1].plot(t, 1e3 * np.asarray(uy), lw=0.9, label=lab)
    axs[0].set_ylabel("crest $u_x$ [mm]")
    axs[1].set_ylabel("crest $u_y$ [mm]")
    axs[1].set_xlabel("t [s]")
    for a in axs:
        a.grid(alpha=0.3)
        a.legend(loc="upper right", fontsize=8)
    axs[0].set_title(title, fontsize=9)
    return _savefig(fig, path)


def plot_damage_profiles(path, panels, title, xmax=None):
    """Fig. 11 style: D(x) along the interface at several times.
    panels: [(panel title, x, times, [D arrays]), ...] (one subplot each)."""
    plt = _plt()
    n = len(panels)
    fig, axs = plt.subplots(1, n, figsize=(6 * n, 4.2), squeeze=False)
    for a, (ptitle, x, times, Ds) in zip(axs[0], panels):
        cmap = plt.get_cmap("viridis")
        for i, (t, D) in enumerate(zip(times, Ds)):
            a.plot(x, D, lw=1.0, color=cmap(i / max(1, len(times) - 1)), label=f"t = {t:.2f} s")
        a.set_xlabel("x from the heel [m]")
        a.set_ylabel("damage D")
        a.set_title(ptitle, fontsize=9)
        if xmax is not None:
            a.set_xlim(0, xmax)
        a.grid(alpha=0.3)
        a.legend(fontsize=7, ncol=2)
    fig.suptitle(title, fontsize=9)
    return _savefig(fig, path)


def plot_crack_length(path, series, title):
    """Crack length against t. series: [(label, t, contiguous-from-heel, total debonded)]."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8, 3.8))
    for lab, t, heel, tot in series:
        l, = ax.plot(t, heel, lw=1.2, label=f"{lab}: contiguous from the heel")
        ax.plot(t, tot, lw=0.8, ls="--", color=l.get_color(),
                label=f"{lab}: sum of debonded w")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("crack length [m]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title, fontsize=9)
    return _savefig(fig, path)


def _triangles(model, box=None):
    """(P (ntri,3,2), region names, centroids) of the volume elements, optionally in box."""
    import ngsolve as ngs

    mesh = model.mesh
    V = np.array([v.point for v in mesh.vertices])
    tri, reg = [], []
    for el in mesh.Elements(ngs.VOL):
        tri.append([v.nr for v in el.vertices])
        reg.append(el.mat)
    tri = np.array(tri)
    P = V[tri][:, :, :2]
    C = P.mean(axis=1)
    reg = np.array(reg)
    if box is not None:
        x0, x1, y0, y1 = box
        m = (C[:, 0] >= x0) & (C[:, 0] <= x1) & (C[:, 1] >= y0) & (C[:, 1] <= y1)
        P, C, reg = P[m], C[m], reg[m]
    return P, reg, C


def _eval(model, cf, X, Y):
    mesh = model.mesh
    vals = cf(mesh(X, Y))
    return np.asarray(vals)


def plot_heel_von_mises(path, model, u, title, magnification=400.0,
                        box=(-3.0, 6.0, -3.0, 3.0)):
    """Fig. 12 style: deformed mesh near the heel (magnification 400) with the von Mises
    stress (tripcolor per triangle, both regions), zoom on the first metres."""
    plt = _plt()
    gf = model.to_gridfunction(u)
    P, reg, C = _triangles(model, box=(box[0] - 1, box[1] + 1, box[2] - 1, box[3] + 1))
    if P.shape[0] == 0:
        return None
    # vertex values evaluated inside each triangle (the displacement jumps at the interface)
    Q = P + 1e-7 * (C[:, None, :] - P)
    disp = _eval(model, model.displacement_cf(gf), Q[:, :, 0].ravel(), Q[:, :, 1].ravel())
    disp = disp.reshape(P.shape)
    vm = _eval(model, model.von_mises(gf), C[:, 0], C[:, 1]).ravel()
    Pd = P + magnification * disp
    xy = Pd.reshape(-1, 2)
    tris = np.arange(xy.shape[0]).reshape(-1, 3)
    fig, ax = plt.subplots(figsize=(8, 6))
    tpc = ax.tripcolor(xy[:, 0], xy[:, 1], tris, facecolors=vm / 1e6, cmap="jet",
                       edgecolors="k", linewidth=0.1)
    fig.colorbar(tpc, ax=ax, label="von Mises stress [MPa]")
    ax.set_xlim(box[0], box[1])
    ax.set_ylim(box[2], box[3])
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title + f"\ndeformed mesh x{magnification:g} near the heel", fontsize=9)
    return _savefig(fig, path)


def plot_mesh(path, model, title):
    """Fig. 8b style: the mesh (dam and rock) and a zoom on the heel."""
    plt = _plt()
    P, reg, C = _triangles(model)
    fig, axs = plt.subplots(1, 2, figsize=(13, 5.5), gridspec_kw={"width_ratios": [2, 1]})
    cols = {"dam": "tab:blue", "rock": "tab:brown"}
    for a in axs:
        for r in np.unique(reg):
            m = reg == r
            xy = P[m].reshape(-1, 2)
            tris = np.arange(xy.shape[0]).reshape(-1, 3)
            a.triplot(xy[:, 0], xy[:, 1], tris, lw=0.15, color=cols.get(r, "k"))
        a.set_aspect("equal")
        a.set_xlabel("x [m]")
        a.set_ylabel("y [m]")
    axs[1].set_xlim(-4, 8)
    axs[1].set_ylim(-4, 5)
    axs[0].set_title(title, fontsize=9)
    axs[1].set_title("zoom on the heel", fontsize=9)
    return _savefig(fig, path)


class VTKWriter:
    """NGSolve VTKOutput time series (displacement, von Mises)."""

    def __init__(self, model, filename):
        import ngsolve as ngs

        self.model = model
        self.gf = ngs.GridFunction(model.fes)
        pathlib.Path(filename).parent.mkdir(parents=True, exist_ok=True)
        self.vtk = ngs.VTKOutput(model.mesh,
                                 coefs=[model.displacement_cf(self.gf),
                                        model.von_mises(self.gf)],
                                 names=["displacement", "von_mises"],
                                 filename=str(filename), subdivision=0)
        self.path_hint = pathlib.Path(filename).parent.name + "/"

    def write(self, u, t):
        self.model.to_gridfunction(u, self.gf)
        self.vtk.Do(time=float(t))


# ---------------------------------------------------------------------------------------------
def write_run_outputs(out, model, scene, gm, H, snaps, solver, u_static, plots=True,
                      heel=None):
    """CSV + PNG of one run; returns the list of file names written."""
    from .koyna import FORMULATION

    out = pathlib.Path(out)
    lab = gm.label + (" [SYNTHETIC record]" if gm.synthetic else "")
    a = scene.interface.alpha
    com = [f"scene {scene.name}, alpha = {a:g}, record: {lab}", f"formulation: {FORMULATION}",
           "crest = upstream crest corner (0, 103); displacements relative to the ground, "
           "including the static state"]
    files = []
    keys = ["t", "crest_ux", "crest_uy"]
    write_timeseries_csv(out / "crest_displacement.csv", H, keys, com)
    files.append("crest_displacement.csv")
    from .koyna import HIST_KEYS
    write_timeseries_csv(out / "timeseries.csv", H, list(HIST_KEYS),
                         com + ["crack_length = sum of w over debonded points; "
                                "crack_length_heel = contiguous debonded length from x = 0"])
    files.append("timeseries.csv")
    iface = model.interface
    write_damage_csv(out / "damage_profiles.csv", iface.x, iface.w, snaps,
                     com + ["D(x) and kappa(x) at the interface Gauss points (heel first)"])
    files.append("damage_profiles.csv")
    if not plots:
        return files
    title = f"Koyna, {scene.name}, alpha = {a:g} -- {lab}"
    t = np.concatenate([[0.0], H["t"]])
    ux = np.concatenate([[u_static[model.crest_dofs[0]]], H["crest_ux"]])
    uy = np.concatenate([[u_static[model.crest_dofs[1]]], H["crest_uy"]])
    files.append(plot_crest(out / "fig10_crest_displacement.png",
                            [(f"alpha = {a:g}", t, ux, uy)], title))
    files.append(plot_damage_profiles(out / "fig11_damage_profiles.png",
                                      [(f"alpha = {a:g}", iface.x, snaps["t"], snaps["D"])],
                                      title, xmax=_xmax(snaps, iface.x)))
    files.append(plot_crack_length(out / "crack_length.png",
                                   [(f"alpha = {a:g}", H["t"], H["crack_length_heel"],
                                     H["crack_length"])], title))
    if heel is None:
        heel = {"u": solver.u, "t": H["t"][-1] if len(H["t"]) else 0.0, "open": None}
    f = plot_heel_von_mises(out / "fig12_heel_von_mises.png", model, heel["u"],
                            title + f"\nt = {heel['t']:.3f} s: largest heel opening "
                            + (f"({1e3 * heel['open']:.3g} mm) " if heel["open"] is not None
                               else "") + "while the base still holds")
    if f:
        files.append(f)
    files.append(plot_mesh(out / "fig8b_mesh.png", model,
                           f"mesh: {model.mesh.nv} vertices, {model.mesh.ne} triangles, "
                           f"{model.nfree} free DOFs"))
    return files


def _xmax(snaps, x):
    """x range of the D(x) plots: where damage lives, at least 5 m."""
    D = np.max(np.asarray(snaps["D"]), axis=0) if len(snaps["D"]) else np.zeros_like(x)
    nz = np.flatnonzero(D > 1e-6)
    xm = float(x[nz[-1]]) * 1.5 if nz.size else 5.0
    return float(min(max(5.0, xm), x.max()))


# ---------------------------------------------------------------------------------------------
PAPER = {"alpha2": {"t_D_heel_1": 6.0, "crack_length": 1.1, "t_crack": 6.3},
         "alpha1": {"max_D": 0.1}}


def _load_run(d):
    d = pathlib.Path(d)
    s = json.loads((d / "summary.json").read_text())
    H = read_csv(d / "timeseries.csv")
    Dp = read_csv(d / "damage_profiles.csv")
    return s, H, Dp


def compare_runs(runs: dict, out) -> list[str]:
    """Overlay runs {label: results dir} (Fig. 10 both, Fig. 11 one panel each, crack length)
    and write results.md comparing with the paper's statements.  Expects the alpha = 2 run
    first and the alpha = 1 run second when both are given."""
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    data = {k: _load_run(v) for k, v in runs.items()}
    s0 = next(iter(data.values()))[0]
    lab = s0["label"]
    title = f"Koyna -- {lab}"
    files = []
    ser = []
    for k, (s, H, Dp) in data.items():
        st = s["static"]
        ser.append((k, np.concatenate([[0.0], H["t"]]),
                    np.concatenate([[st["crest_ux"]], H["crest_ux"]]),
                    np.concatenate([[st["crest_uy"]], H["crest_uy"]])))
    files.append(plot_crest(out / "fig10_crest_displacement.png", ser, title))
    panels = []
    xm = 0.0
    for i, (k, (s, H, Dp)) in enumerate(data.items()):
        tk = [c for c in Dp if c.startswith("D_t=")]
        times = [float(c[4:]) for c in tk]
        snaps = {"D": [Dp[c] for c in tk]}
        xm = max(xm, _xmax(snaps, Dp["x"]))
        panels.append((f"({chr(97 + i)}) {k}", Dp["x"], times, snaps["D"]))
    files.append(plot_damage_profiles(out / "fig11_damage_profiles.png", panels, title, xmax=xm))
    files.append(plot_crack_length(out / "crack_length.png",
                                   [(k, H["t"], H["crack_length_heel"], H["crack_length"])
                                    for k, (s, H, Dp) in data.items()], title))
    atomic_write_text(out / "results.md", results_table(data, runs))
    files.append("results.md")
    return files


def _fmt(v, f="{:.3g}"):
    return "never" if v is None else f.format(v)


def _observed(template: str, data) -> str:
    """Fill the 'observed here' column from the runs' summaries (alpha -> results)."""
    by = {}
    for s, H, Dp in data.values():
        by[s["scene"]["interface"]["alpha"]] = (s, H)
    na = "n/a (run missing)"

    def res(a):
        return by[a][0]["results"] if a in by else None

    r2, r1 = res(2.0), res(1.0)
    obs = dict(obs_t2=na, obs_crack=na, obs_d1=na, obs_crest=na, obs_uy=na, obs_sens=na)
    if r2:
        obs["obs_t2"] = ("D_heel = 1 at " + _fmt(r2["t_D_heel_reaches_1"], "{:.3f} s")
                         if r2["t_D_heel_reaches_1"] is not None
                         else f"no: max D_heel = {r2['max_D_heel']:.3g}")
        obs["obs_crack"] = (f"{r2['crack_length_heel_final']:.3g} m from the heel "
                            f"(max debonded {r2['crack_length_total_max']:.3g} m)")
    if r1:
        obs["obs_d1"] = f"max D = {r1['max_D']:.3g}"
    if r1 and r2:
        rng = [1e3 * (r["crest_ux_max"] - r["crest_ux_min"]) for r in (r2, r1)]
        obs["obs_crest"] = f"u_x range {rng[0]:.1f} mm (alpha 2) vs {rng[1]:.1f} mm (alpha 1)"
        obs["obs_sens"] = f"max D {r2['max_D']:.3g} (alpha 2) vs {r1['max_D']:.3g} (alpha 1)"
    fr = []
    for a, (s, H) in sorted(by.items()):
        uy = np.asarray(H["crest_uy"])
        fr.append(f"{100 * np.mean(uy < 0):.0f} % of steps (alpha {a:g})")
    if fr:
        obs["obs_uy"] = "u_y < 0 in " + ", ".join(fr)
    stops = [f"- alpha = {a:g}: **stopped at t = {s['stopped']['t']:.3f} s** — "
             f"{s['stopped']['reason']}." for a, (s, H) in sorted(by.items())
             if s.get("stopped")]
    obs["stops"] = ("**Failure by sliding.**\n" + "\n".join(stops) + "\n" if stops else "")
    return template.format(**obs)


def results_table(data, runs) -> str:
    rows = []
    for k, (s, H, Dp) in data.items():
        r = s["results"]
        tm = s["timings"]
        rows.append(
            f"| {k} | {s['scene']['interface']['alpha']:g} | {r['max_D_heel']:.4g} | "
            f"{_fmt(r['t_D_heel_reaches_1'], '{:.3f} s')} | {r['max_D']:.4g} | "
            f"{r['crack_length_heel_final']:.3g} m | "
            f"{_fmt(r['t_crack_heel_reaches_final'], '{:.3f} s')} | "
            f"{r['crack_length_total_max']:.3g} m | "
            f"{1e3 * (r['crest_ux_max'] - r['crest_ux_min']):.2f} mm | "
            f"{s['solver_totals']['iterations']} / {s['solver_totals']['cuts']} | "
            f"{tm['dynamic']:.1f} s ({1e3 * tm['per_step_median']:.2f} ms) |")
    s0 = next(iter(data.values()))[0]
    gmax = s0["scene"]["interface"]["g_max"]
    lnc = s0["reference_parameters"]["l_Nc"]
    ch = s0["characteristic_times"]
    synth = s0["ground_motion"]["synthetic"]
    txt = f"""# Koyna seismic interface fracture: our runs against the paper (§5)

Record: **{s0['label']}**. {'This is a SYNTHETIC Koyna-like motion, not the 1967 accelerogram the paper used (Fig. 9): no digitised record is public.' if synth else ''}
Formulation: {s0['formulation']}.
Interface: sigma_max = tau_max = {s0['scene']['interface']['sigma_max']:.3g} Pa, G_I = {s0['scene']['interface']['G_I']:g} N/m, l_Nc = {lnc:.4g} m,
f = {s0['scene']['interface']['friction']:g}, beta = {s0['scene']['interface']['beta']:g}, g_max = {gmax:.4g} m = {gmax / lnc:.3g} l_Nc (not given by the paper),
size-scale laws {'on' if s0['scene']['interface']['scaling'] else 'off'}. dt = {s0['scene']['time']['dt']} s, {s0['n_steps']} steps.
Characteristic times (Eq. 11, dam concrete): t1 = {ch['t1']:.3e} s, t2 = {ch['t2']:.3e} s (c_L = {ch['c_L']:.0f} m/s, a0 = {ch['a0']:g} m).

| run | alpha | max D at heel | t(D_heel = 1) | max D anywhere | crack from heel, final | reached at | max debonded length (sum w) | crest u_x range | Newton its / cuts | dynamic wall (per-step median) |
|---|---|---|---|---|---|---|---|---|---|---|
""" + "\n".join(rows) + _observed("""

## The paper's statements, and what our runs show

| statement (paper §5) | paper | what can match with a synthetic record | observed here |
|---|---|---|---|
| alpha = 2: D reaches 1 at the heel | t ≈ 6.0 s | not the time (record-specific); whether it happens in the strong phase | {obs_t2} |
| alpha = 2: interface crack length | 1.1 m at t ≈ 6.3 s | the order of magnitude only, if the base does not fail as a whole | {obs_crack} |
| alpha = 1: D < 0.1 throughout | max D < 0.1 | qualitatively (but see below: Eq. 7 reverses the ordering) | {obs_d1} |
| crest displacements hardly depend on alpha (Fig. 10) | qualitative | yes: a global response | {obs_crest} |
| vertical crest displacement often negative (contact) | qualitative | yes | {obs_uy} |
| strong alpha-sensitivity of damage | qualitative | expected, in the direction Eq. 7 dictates (below) | {obs_sens} |

{stops}
""", data) + """## Why alpha = 2 cannot give more damage than alpha = 1 with Eq. 7 and one g_max

With beta = 0 the damage increment of a step (Eq. 7) is ΔD = x^alpha with x = Δg/g_max (only
for Δg > 0). For x ≤ 1 (every step's opening below g_max, which holds here: Δg per 2 ms step is
a small fraction of l_Nc) x² ≤ x, and summed over the same history
Σ x² ≤ (Σ x)², i.e. **D(alpha=2) ≤ D(alpha=1)²**, and D(alpha=2) ≤ D(alpha=1) whenever D(alpha=1) ≤ 1.
So along the same opening history alpha = 2 accumulates *less* damage than alpha = 1, the
opposite of the paper's ordering (alpha = 2 fails at the heel, alpha = 1 stays below 0.1). The
paper's ordering cannot come from Eq. 7 with a common g_max (it would need, e.g., a much smaller
g_max for alpha = 2, x > 1 steps, or a different normalisation). The histories of the two runs
differ (damage feeds back on the opening), but the inequality holds step by step for the
increments, and what we observe is reported in the table above.
"""
    a = {s['scene']['interface']['alpha']: s['results'] for s, H, Dp in data.values()}
    if 1.0 in a and 2.0 in a:
        d1, d2 = a[1.0]["max_D"], a[2.0]["max_D"]
        txt += (f"\n**Observed:** max D = {d2:.4g} (alpha = 2) vs {d1:.4g} (alpha = 1); "
                f"D(alpha=1)^2 = {d1 ** 2:.4g}. "
                + ("alpha = 2 gives less damage than alpha = 1, as the analysis predicts and "
                   "against the paper's ordering." if d2 <= d1 else
                   "alpha = 2 gives more damage than alpha = 1 here (the opening histories "
                   "differ between the runs; see timeseries.csv).") + "\n")
        t1 = a[2.0]["t_D_heel_reaches_1"]
        txt += (f"Debonding at the heel (kappa ≥ 1, cohesive failure, independent of D): first at "
                f"t = {_fmt(a[2.0]['t_first_debond'], '{:.3f} s')} (alpha = 2), "
                f"{_fmt(a[1.0]['t_first_debond'], '{:.3f} s')} (alpha = 1); D_heel = 1 at "
                f"{_fmt(t1, '{:.3f} s')} (alpha = 2), "
                f"{_fmt(a[1.0]['t_D_heel_reaches_1'], '{:.3f} s')} (alpha = 1).\n")
    txt += "\nRuns: " + ", ".join(f"{k}: `{v}`" for k, v in runs.items()) + "\n"
    return txt
