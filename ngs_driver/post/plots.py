"""Figures of a run (paper Figs. 8b, 10, 11, 12 style) and VTK, fed arrays and the model.

All files are written atomically (``post.files``).  Plot titles carry the record label
(with "SYNTHETIC" for the shipped motion).  matplotlib is used with the Agg backend; NGSolve
is needed only for the mesh/stress plots and VTK (they take the model).
"""
from __future__ import annotations

import io as _io
import pathlib

import numpy as np

from .files import atomic_write_bytes

__all__ = ["plot_crest", "plot_damage_profiles", "plot_crack_length", "plot_heel_von_mises",
           "plot_mesh", "plot_energy", "damage_xmax"]


def subplots(*args, figsize=None, **kw):
    """``matplotlib.pyplot.subplots`` without pyplot: a bare ``Figure`` (rendered by Agg when
    saved to PNG; nothing to close) and its axes. pyplot's import and figure manager cost a
    run ~0.3 s and are not needed to write files."""
    # deferred: matplotlib loads only when a figure is drawn
    from matplotlib.figure import Figure
    fig = Figure(figsize=figsize)
    return fig, fig.subplots(*args, **kw)


# zlib level of the PNGs: 3 encodes the run's figures in ~55 % of the time of PIL's default 6
# (0.17 s against 0.31 s for a Koyna run), files 0-8 % larger; the pixels are the same
PNG_COMPRESS_LEVEL = 3


def save_png(fig, path, dpi, bbox_inches=None):
    """``fig.savefig(path, dpi=dpi, bbox_inches=...)`` as a PNG written atomically
    (``post.files``), zlib level ``PNG_COMPRESS_LEVEL``. Returns the file name."""
    buf = _io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches=bbox_inches,
                pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})
    atomic_write_bytes(path, buf.getvalue())
    return pathlib.Path(path).name


def _savefig(fig, path, dpi=130):
    """The PNG of ``savefig(bbox_inches="tight")``, drawn once: "tight" draws the figure
    twice, the first time only to measure it; here the box is measured on the Agg renderer at
    the output dpi without that draw (same box and padding: the PNGs of a Koyna run are
    pixel-identical, 0.4 s less over a run's figures)."""
    # deferred: matplotlib loads only when a figure is drawn
    from matplotlib import rcParams
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    dpi0 = fig.dpi
    fig.dpi = dpi
    try:
        bbox = fig.get_tightbbox(canvas.get_renderer()).padded(rcParams["savefig.pad_inches"])
    finally:
        fig.dpi = dpi0
    return save_png(fig, path, dpi, bbox_inches=bbox)


# ---------------------------------------------------------------------------------------------
def plot_crest(path, series, title):
    """Fig. 10 style: crest u_x and u_y [mm] against t. series: [(label, t, ux, uy), ...]."""
    fig, axs = subplots(2, 1, figsize=(8, 6), sharex=True)
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
    # deferred: matplotlib loads only when a figure is drawn
    from matplotlib import colormaps
    n = len(panels)
    fig, axs = subplots(1, n, figsize=(6 * n, 4.2), squeeze=False)
    for a, (ptitle, x, times, Ds) in zip(axs[0], panels):
        cmap = colormaps["viridis"]
        for i, (t, D) in enumerate(zip(times, Ds)):
            a.plot(x, D, lw=1.0, color=cmap(i / max(1, len(times) - 1)), label=f"t = {t:.2f} s")
        a.set_xlabel("x [m] (the heel at 0)")
        a.set_ylabel("damage D")
        a.set_title(ptitle, fontsize=9)
        if xmax is not None:
            a.set_xlim(min(0.0, float(np.min(x))), xmax)
        a.grid(alpha=0.3)
        a.legend(fontsize=7, ncol=2)
    fig.suptitle(title, fontsize=9)
    return _savefig(fig, path)


def plot_energy(path, H, joints, title):
    """The energy budget over time (run.energy): input work, kinetic, bulk, damping, each
    joint's stored and dissipated energy, and the balance residual."""
    fig, (ax, ar) = subplots(2, 1, figsize=(8, 6), sharex=True,
                                 gridspec_kw={"height_ratios": [3, 1]})
    t = H["t"]
    for k, lab in (("W_ext", "external work"), ("E_kin", "kinetic"), ("E_bulk", "bulk elastic"),
                   ("E_damp", "viscous damping"), ("E_alg", "time integrator")):
        if k in H:
            ax.plot(t, H[k], lw=1.0, label=lab)
    for j in joints:
        ax.plot(t, H[f"{j}_E_stored"], lw=0.8, ls="--", label=f"{j}: stored")
        ax.plot(t, H[f"{j}_E_diss"], lw=0.8, ls=":", label=f"{j}: dissipated")
    for k, lab in (("W_water", "water: work of the ground"), ("E_water_kin", "water: kinetic"),
                   ("E_water_pot", "water: compression"),
                   ("E_water_radiated", "water: radiated (far end)"),
                   ("E_water_absorbed", "water: absorbed (bottom)"),
                   ("E_water_alg", "water: integrator's exchange"),
                   ("E_kin_added_mass", "added mass: kinetic (in 'kinetic')")):
        if k in H and (k != "E_water_absorbed" or np.any(H[k] != 0)):
            ax.plot(t, H[k], lw=0.9, ls="-." if k.startswith("E_") else "-", label=lab)
    ax.set_ylabel("energy [J/m]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    ax.set_title(title, fontsize=9)
    ar.plot(t, H["residual"], lw=0.8, color="k")
    ar.set_ylabel("residual [J/m]")
    ar.set_xlabel("t [s]")
    ar.grid(alpha=0.3)
    return _savefig(fig, path)


def plot_block_motion(path, H, joints, title):
    """Each joint's slip and the rotation of the block above it against t, from the static
    state (run/joints.py; docs/sliding.md §7)."""
    fig, (a1, a2) = subplots(2, 1, figsize=(8, 5.5), sharex=True)
    t = H["t"]
    for j in joints:
        a1.plot(t, 1e3 * H[f"{j}_slip"], lw=1.0, label=j)
        a2.plot(t, 1e3 * H[f"{j}_rotation"], lw=1.0, label=j)
    a1.set_ylabel("slip [mm]")
    a2.set_ylabel("rotation [mrad]\n(counter-clockwise +)")
    a2.set_xlabel("t [s]")
    for a in (a1, a2):
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
    a1.set_title(title, fontsize=9)
    return _savefig(fig, path)


def plot_crack_length(path, series, title):
    """Crack length against t. series: [(label, t, contiguous-from-heel, total debonded)]."""
    fig, ax = subplots(figsize=(8, 3.8))
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


def mesh_cells(model, box=None, triangles=None):
    """(P (ntri,3,2), region names, centroids) of the volume elements, optionally in box.
    triangles: the result of ``mesh_cells(model)`` if the caller has it."""
    if triangles is not None:
        P, reg, C = triangles
    else:
        P, reg = mesh_triangles(model.mesh)
        C = P.mean(axis=1)
    if box is not None:
        x0, x1, y0, y1 = box
        m = (C[:, 0] >= x0) & (C[:, 0] <= x1) & (C[:, 1] >= y0) & (C[:, 1] <= y1)
        P, C, reg = P[m], C[m], reg[m]
    return P, reg, C


def mesh_triangles(mesh):
    """(vertex coordinates (ntri, 3, 2), region names) of the volume elements, in NGSolve's
    element order. From netgen's arrays (~1 ms) when every element is a triangle whose
    first three nodes are NGSolve vertices (netgen point i = vertex i - 1 ... checked);
    otherwise by NGSolve's element loop (~0.07 s on the default Koyna mesh)."""
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs

    try:
        ng = mesh.ngmesh
        els = ng.Elements2D().NumPy()
        X = np.asarray(ng.Coordinates(), dtype=float)
        nodes = np.asarray(els["nodes"], dtype=np.int64)
        tri = nodes[:, :3] - 1
        names = {int(i): ng.GetMaterial(int(i)) for i in np.unique(els["index"])}
        ok = bool(mesh.dim == 2 and tri.shape[0] == mesh.ne and tri.size and tri.min() >= 0
                  and tri.max() < mesh.nv and not np.any(nodes[:, 3:])     # triangles only
                  and X.shape[0] >= mesh.nv)
    except (AttributeError, TypeError, ValueError, IndexError, KeyError):
        ok = False
    if ok:
        els_first = next(iter(mesh.Elements(ngs.VOL)))     # spot check: the numbering
        ok = ([v.nr for v in els_first.vertices] == tri[0].tolist()
              and els_first.mat == names[int(els["index"][0])])
    if ok:
        reg = np.array([names[int(i)] for i in els["index"]])
        return X[:, :2][tri], reg
    V = np.array([v.point for v in mesh.vertices])
    tri, reg = [], []
    for el in mesh.Elements(ngs.VOL):
        tri.append([v.nr for v in el.vertices])
        reg.append(el.mat)
    return V[np.array(tri)][:, :, :2], np.array(reg)


def _eval(model, cf, X, Y):
    mesh = model.mesh
    vals = cf(mesh(X, Y))
    return np.asarray(vals)


def plot_heel_von_mises(path, model, u, title, magnification=400.0,
                        box=(-3.0, 6.0, -3.0, 3.0), triangles=None):
    """Fig. 12 style: deformed mesh near the heel (magnification 400) with the von Mises
    stress (tripcolor per triangle, both regions), zoom on the first metres.
    triangles: ``mesh_cells(model)`` if the caller has it."""
    gf = model.to_gridfunction(u)
    P, reg, C = mesh_cells(model, box=(box[0] - 1, box[1] + 1, box[2] - 1, box[3] + 1),
                           triangles=triangles)
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
    fig, ax = subplots(figsize=(8, 6))
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


def plot_mesh(path, model, title, triangles=None):
    """Fig. 8b style: the mesh (dam and rock) and a zoom on the heel.
    triangles: ``mesh_cells(model)`` if the caller has it."""
    P, reg, C = mesh_cells(model, triangles=triangles)
    fig, axs = subplots(1, 2, figsize=(13, 5.5), gridspec_kw={"width_ratios": [2, 1]})
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


# ---------------------------------------------------------------------------------------------
# ---------------------------------------------------------------------------------------------


def damage_xmax(snaps, x):
    """x range of the D(x) plots: where damage lives, at least 5 m."""
    D = np.max(np.asarray(snaps["D"]), axis=0) if len(snaps["D"]) else np.zeros_like(x)
    nz = np.flatnonzero(D > 1e-6)
    x0 = float(x[0])
    xm = (float(x[nz[-1]]) - x0) * 1.5 if nz.size else 5.0
    return x0 + float(min(max(5.0, xm), x.max() - x0))
