"""Safety outputs of a run: the FS(t) figure and the run's results.md section."""
from __future__ import annotations

import pathlib

import numpy as np

from .files import atomic_write_text
from .plots import save_png, subplots

__all__ = ["write_safety_outputs", "safety_markdown", "plot_sliding_fs"]


def _fmt(v, f="{:.4g}"):
    return "n/a" if v is None else f.format(v)


def plot_sliding_fs(path, H, static_joints, post, title, criterion=1.3):
    """FS(t) per joint (static value at t = 0, post-earthquake value after the record) and the
    base's N', T, U."""

    names = [k[:-len("_sliding_fs")] for k in H if k.endswith("_sliding_fs")]
    t = H["t"]
    t_end = float(t[-1]) if t.size else 0.0
    fig, (a1, a2) = subplots(2, 1, figsize=(8, 7), sharex=True)
    for n in names:
        t0 = [0.0] + list(t)
        fs = [static_joints[n]["sliding_fs"] if static_joints else np.nan] + list(H[f"{n}_sliding_fs"])
        ln, = a1.plot(t0, fs, label=f"{n}")
        pe = post["joints"].get(n, {}).get("sliding_fs") if post else None
        if pe is not None:
            a1.plot([t_end * 1.02 + 1e-3], [pe], "o", color=ln.get_color(),
                    label=f"{n} post-earthquake: {pe:.3g}")
    a1.axhline(1.0, color="r", lw=1, ls="--", label="FS = 1")
    a1.axhline(criterion, color="orange", lw=1, ls=":", label=f"post-earthquake criterion "
                                                             f"{criterion:g}")
    a1.set_yscale("log")
    a1.set_ylabel("sliding FS")
    a1.legend(fontsize=7, loc="best")
    a1.set_title(title, fontsize=9)
    if "base_normal_force" in H:
        a2.plot(t, 1e-6 * H["base_normal_force"], label="N' (effective normal)")
        a2.plot(t, 1e-6 * H["base_shear_force"], label="|T| (shear)")
        a2.plot(t, 1e-6 * H["base_uplift_force"], label="U (uplift)")
    a2.set_xlabel("t [s]")
    a2.set_ylabel("base forces [MN/m]")
    a2.legend(fontsize=7)
    fig.tight_layout()
    fig.set_layout_engine(None)      # laid out: savefig need not draw twice
    return save_png(fig, path, dpi=110)           # atomic, like every result file


def safety_markdown(scene, static_joints, post, safety_sum) -> str:
    up = scene.uplift
    lines = ["## Safety (docs/safety.md)",
             "",
             f"Foundation: {scene.geometry.foundation}, rock sides {scene.geometry.rock_sides}. "
             f"Uplift: model {up.model}, in_crack {up.in_crack}, tailwater {up.tailwater:g} m"
             + (f", drains at {up.drain_x:g} m (efficiency {up.drain_efficiency:g})"
                if up.model == "drains" else "") + ".",
             "FS = (f·N' + c·L_bonded)/|T| (USACE EM 1110-2-2100 eq. 3-1; f and c the law's "
             "current friction and cohesive shear strength). Forces in N per metre of dam.",
             "",
             "| joint | N' static | T static | U static | FS static | min FS (t) | time FS < 1 "
             "| cumulative slip | residual slip | FS post-earthquake | ≥ 1.3 |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for n, s in (static_joints or {}).items():
        d = safety_sum.get(n, {})
        pe = post["joints"].get(n, {}) if post else {}
        lines.append(
            f"| {n} | {s['normal_force']:.6g} | {s['shear_force']:.6g} | "
            f"{s['uplift_force']:.6g} | {s['sliding_fs']:.4g} | "
            f"{_fmt(d.get('min_sliding_fs'))} ({_fmt(d.get('t_min_sliding_fs'), '{:.3f} s')}) | "
            f"{_fmt(d.get('time_fs_below_1'), '{:.3f} s')} | "
            f"{_fmt(d.get('cumulative_slip'), '{:.3g} m')} | "
            f"{_fmt(d.get('residual_slip'), '{:.3g} m')} | {_fmt(pe.get('sliding_fs'))} | "
            f"{'yes' if pe.get('meets_criterion') else 'NO'} |")
    if post:
        lines += ["", f"Post-earthquake: {post['note']}"
                  + ("" if post["converged"] else " **(no equilibrium)**") + "."]
    return "\n".join(lines) + "\n"


def plot_screening(path, scr, title):
    """Map of the maximum DCR over the record per dam element, the worst element marked."""
    # deferred: matplotlib loads only when a figure is drawn
    from matplotlib.collections import PolyCollection


    s = scr.summary()
    fig, ax = subplots(figsize=(6, 7))
    pc = PolyCollection(scr.triangles, array=scr.max_dcr, cmap="viridis", edgecolors="none")
    pc.set_clim(0.0, max(2.0, float(np.max(scr.max_dcr))))
    ax.add_collection(pc)
    ax.autoscale_view()
    ax.set_aspect("equal")
    w = s["worst_element"]
    ax.plot([w["x"]], [w["y"]], "k*", ms=12,
            label=f"worst: DCR {w['max_dcr']:.2f}, {w['cumulative_inelastic_duration']:.3f} s "
                  "above 1")
    ax.tricontour(scr.x, scr.y, scr.max_dcr, levels=[1.0], colors="k", linewidths=0.8)
    fig.colorbar(pc, ax=ax, label=f"max DCR = sigma_1 / {scr.ft:.3g} Pa")
    ax.legend(fontsize=7, loc="upper right")
    ax.set_title(title + "\nlinear screening (EM 1110-2-6053): max over the record", fontsize=8)
    fig.tight_layout()
    fig.set_layout_engine(None)      # laid out: savefig need not draw twice
    return save_png(fig, path, dpi=110)           # atomic, like every result file


def screening_markdown(s) -> str:
    w = s["worst_element"]
    return ("\n## Linear screening (USACE EM 1110-2-6053)\n\n"
            f"DCR = max principal stress / {s['tensile_strength']:.4g} Pa per dam element "
            f"({s['elements']}): static max {_fmt(s['static_max_dcr'])}, max over the record "
            f"{s['max_dcr']:.4g} at ({s['max_dcr_at'][0]:.3g}, {s['max_dcr_at'][1]:.3g}) m, "
            f"t = {s['t_max_dcr']:.3f} s; {s['elements_dcr_over_1']} elements above 1. Worst "
            f"element (longest time above 1) at ({w['x']:.3g}, {w['y']:.3g}) m: max DCR "
            f"{w['max_dcr']:.4g}, cumulative inelastic duration "
            f"{w['cumulative_inelastic_duration']:.4g} s.\n")


def write_safety_outputs(out, scene, gm, H, static_joints, post, safety_sum, plots=True,
                         screening=None):
    """results.md (the run's safety table) and, with plots, sliding_fs.png (and the screening
    map screening_dcr.png when [screening] is enabled)."""
    out = pathlib.Path(out)
    lab = gm.label + (" [SYNTHETIC record]" if gm.synthetic else "")
    txt = (f"# {scene.name}: run results\n\nRecord: {lab}.\n\n"
           + safety_markdown(scene, static_joints, post, safety_sum))
    if screening is not None:
        txt += screening_markdown(screening.summary())
    atomic_write_text(out / "results.md", txt)
    files = ["results.md"]
    if plots:
        files.append(plot_sliding_fs(out / "sliding_fs.png", H, static_joints, post,
                                     f"{scene.name} -- {lab}"))
        if screening is not None:
            files.append(plot_screening(out / "screening_dcr.png", screening,
                                        f"{scene.name} -- {lab}"))
    return files
