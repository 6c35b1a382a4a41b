"""Meshes of a gravity-dam section (``section.Section``) with its lift joints, on a rock block.

Coordinates: x downstream from the heel, y up, metres.  The dam-rock contact line
(0,0)-(W,0) is an internal boundary named ``"interface"`` (the joint called "base"); a lift
joint is an internal boundary named after the joint. Regions: the dam blocks "dam" (on the
base) and "dam_<joint>" (above each lift joint), and "rock".

Boundary names
    dam:  "upstream" (heel -> crest corner), "downstream" (toe -> crest),
          "crest" (the horizontal top edge, if any), "interface" (base), one per lift joint.
    rock: "rock_top_up" (upstream of the heel), "rock_top_down" (downstream of the toe),
          "rock_left", "rock_right", "rock_bottom".
    non-matching meshes only: "interface_rock" (the rock side of the interface; the dam
          side keeps the name "interface").

Meshes are graded from ``h_heel`` at the heel (0, 0) to ``h_coarse`` elsewhere.  Netgen's
2D mesher takes local sizes on points and edges and grades with the ``grading`` factor;
the heel refinement is a point size plus a chain of points along the interface whose
local sizes grow geometrically (``growth``), which makes the interface element size a
controlled function of the distance to the heel: h(d) = min(h_heel + (growth-1) d, h_int)
(see ``interface_size``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..section import polygon_area, polygon_centroid  # noqa: F401 (re-exported)


@dataclass(frozen=True)
class MeshInfo:
    """What was meshed (kept on the Model for summaries)."""

    foundation: str
    matching: bool
    h_heel: float
    h_coarse: float
    h_interface: float
    growth: float
    extent_up: float
    extent_down: float
    extent_depth: float
    n_vertices: int
    n_elements: int
    n_interface_segments: int
    h_interface_rock: float | None = None
    heel_zone: float = 0.0


def interface_size(d: float, h_heel: float, h_int: float, growth: float,
                   heel_zone: float = 0.0) -> float:
    """Target element size along the interface at distance d from the heel: h_heel on
    the first ``heel_zone`` metres, then growing linearly with slope (growth - 1)
    (element-to-element ratio ~ growth) up to h_int."""
    return min(h_heel + (growth - 1.0) * max(d - heel_zone, 0.0), h_int)


def _interface_stations(x0: float, x1: float, h_heel: float, h_int: float,
                        growth: float, heel_at_start: bool = True,
                        heel_zone: float = 0.0) -> list[tuple[float, float]]:
    """Stations (x, local h) along [x0, x1] with sizes graded from the heel.

    The stations are spaced so that each gap equals the local target size: points are
    inserted at x_{k+1} = x_k + h(x_k).  Between stations netgen meshes the edge with the
    edge maxh, so the stations themselves need not be nodes of any special kind.  To keep
    the number of spline segments small the chain stops once h reaches h_int."""
    L = x1 - x0
    st = [(0.0, h_heel)]
    d = 0.0
    while True:
        h = interface_size(d, h_heel, h_int, growth, heel_zone)
        if h >= h_int or d + h >= L - 1e-9:
            break
        # space the geometry points sparser than the elements (every ~4 elements, at
        # most 0.5 m inside the uniform heel zone so that it is really uniform)
        step = 4.0 * h if d >= heel_zone else min(4.0 * h, 0.5, heel_zone - d + 1e-12)
        d = d + step
        if d >= L - 1e-9:
            break
        st.append((d, interface_size(d, h_heel, h_int, growth, heel_zone)))
    if heel_at_start:
        return [(x0 + s, h) for s, h in st]
    return [(x1 - s, h) for s, h in st]


@dataclass(frozen=True)
class JointCut:
    """A lift joint to mesh: horizontal cut at ``elevation`` graded from both ends."""
    name: str
    elevation: float
    h_end: float
    h_joint: float


def dam_block_names(joints) -> list[str]:
    """Region names of the dam blocks, bottom up: "dam" on the base, "dam_<joint>" above."""
    return ["dam"] + [f"dam_{j.name}" for j in sorted(joints, key=lambda j: j.elevation)]


def dam_mesh(section, joints=(), foundation: str = "rock", h_heel: float = 0.1,
             h_coarse: float = 2.0, h_interface: float | None = 1.0, growth: float = 1.15,
             extent_up: float = 1.0, extent_down: float = 1.0, extent_depth: float = 1.0,
             grading: float = 0.25, matching: bool = True,
             h_heel_rock: float | None = None, h_interface_rock: float | None = None,
             heel_zone: float = 5.0, reservoir_level: float | None = None):
    """Netgen mesh of a dam section (``section.Section``) cut by lift ``joints``
    (``JointCut``) into blocks (regions ``dam_block_names``) and, for foundation="rock", its
    rock block (region "rock") of extent ``extent_* x base width`` upstream, downstream and
    below.

    ``h_interface`` (default ``h_coarse/2``) is the element size along the base away from the
    heel.  With ``matching=False`` dam and rock are meshed separately (rock with
    ``h_heel_rock``/``h_interface_rock``, default 1.7x the dam values so that no interface
    node coincides except the ends) and merged into one mesh whose rock-side interface is
    named "interface_rock"; the two regions then share no vertex.
    Returns an ``ngsolve.Mesh`` and a ``MeshInfo``.
    """
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs

    if foundation not in ("rock", "rigid"):
        raise ValueError(f"foundation={foundation!r}: allowed 'rock' or 'rigid'")
    joints = tuple(sorted(joints, key=lambda j: j.elevation))
    h_int = h_coarse / 2.0 if h_interface is None else h_interface
    if foundation == "rigid" or matching:
        ngmesh = _dam_geometry(section, joints, foundation, h_heel, h_coarse, h_int, growth,
                               extent_up, extent_down, extent_depth, grading, heel_zone,
                               reservoir_level)
        h_int_r = None
    else:
        hh_r = 1.7 * h_heel if h_heel_rock is None else h_heel_rock
        h_int_r = 1.7 * h_int if h_interface_rock is None else h_interface_rock
        dam = _dam_geometry(section, joints, "rigid", h_heel, h_coarse, h_int, growth,
                            extent_up, extent_down, extent_depth, grading, heel_zone,
                            reservoir_level)
        rock = _rock_only(section.base_width, hh_r, h_coarse, h_int_r, growth, extent_up,
                          extent_down, extent_depth, grading, heel_zone)
        ngmesh = merge_meshes(dam, rock)
    mesh = ngs.Mesh(ngmesh)
    nseg = sum(1 for el in mesh.Boundaries("interface").Elements())
    info = MeshInfo(foundation, bool(matching or foundation == "rigid"), h_heel, h_coarse,
                    h_int, growth, extent_up, extent_down, extent_depth, mesh.nv, mesh.ne,
                    nseg, h_int_r, heel_zone)
    return mesh, info


def _joint_stations(xu, xd, h_end, h_joint, growth):
    """Stations along a lift joint graded from both ends towards the middle."""
    half = 0.5 * (xd - xu)
    a = _interface_stations(xu, xu + half, h_end, h_joint, growth)
    b = _interface_stations(xd - half, xd, h_end, h_joint, growth, heel_at_start=False)
    pts = sorted(a + b)
    out = []
    for x, h in pts:
        if out and x - out[-1][0] < 0.5 * min(h, out[-1][1]):
            continue
        out.append((x, h))
    return out


def _dam_geometry(section, joints, foundation, h_heel, h_coarse, h_int, growth, eu, ed,
                  edep, grading, heel_zone=0.0, reservoir_level=None):
    """The netgen geometry of the section (and rock block), meshed.

    Points are appended in a fixed order (base stations, toe, the other profile vertices,
    upstream-face stations, joint points): for the Koyna profile without joints this is the
    order of the original Koyna mesher, so the mesh (and every result) is unchanged."""
    # deferred: NGSolve is optional: the package imports without it
    from netgen.geom2d import SplineGeometry

    P = section.vertices
    W = section.base_width
    top_y = section.height
    geo = SplineGeometry()
    # blocks bottom up: block k (1-based) lies between joint k-1 and joint k
    bounds = [0.0] + [j.elevation for j in joints] + [np.inf]

    def block(y):
        return int(np.searchsorted(bounds, y, side="right"))

    # base stations from the heel (0,0) towards the toe (W,0)
    st = _interface_stations(0.0, W, h_heel, h_int, growth, heel_zone=heel_zone)
    ip = [geo.AppendPoint(x, 0.0, maxh=h) for x, h in st]
    toe = geo.AppendPoint(W, 0.0, maxh=h_int)
    vid = {1: toe}
    for k in range(2, P.shape[0]):
        vid[k] = geo.AppendPoint(*P[k])
    # upstream face: stations by arc length from the heel, graded the same way
    L_up = section.upstream_length()
    sv = _interface_stations(0.0, L_up, h_heel, h_coarse, growth)
    if reservoir_level is not None and 0.0 < reservoir_level < top_y:
        # a vertex at the water line: the hydrostatic pressure is then linear on every
        # upstream edge and its integral exact
        sH = section.upstream_arclength(float(reservoir_level))
        if min(abs(s - sH) for s, _ in sv) > 1e-9:
            sv = sorted(sv + [(sH, interface_size(sH, h_heel, h_coarse, growth))])
    chain = section.upstream_chain()
    cum = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(chain, axis=0).T))])
    up_pts = []                                     # (arc length, point id, (x, y))
    s_joint = [(section.upstream_arclength(j.elevation), j.h_end) for j in joints]
    for s, h in sv[1:]:
        if np.min(np.abs(cum - s)) <= 1e-9:
            continue                                # a profile vertex already
        if any(abs(s - sj) < 0.5 * min(h, hj) for sj, hj in s_joint):
            continue                                # a joint's end point takes its place
        xy = section.upstream_point(s)
        up_pts.append((s, geo.AppendPoint(*xy, maxh=h), xy))
    # joint end points (on both faces) and stations
    jpts = []
    for j in joints:
        xu, xd = section.width_at(j.elevation)
        ends = []
        for face, x in (("upstream", xu), ("downstream", xd)):
            hit = np.flatnonzero(np.hypot(P[:, 0] - x, P[:, 1] - j.elevation) <= 1e-9)
            if hit.size:                          # the cut passes through a profile vertex
                ends.append(vid[int(hit[0])])
                continue
            pid = geo.AppendPoint(x, j.elevation, maxh=j.h_end)
            ends.append(pid)
            if face == "upstream":
                up_pts.append((section.upstream_arclength(j.elevation), pid,
                               (x, j.elevation)))
        jst = _joint_stations(xu, xd, j.h_end, j.h_joint, growth)
        mids = [geo.AppendPoint(x, j.elevation, maxh=h) for x, h in jst
                if xu + 0.5 * j.h_end < x < xd - 0.5 * j.h_end]
        jpts.append((j, ends[0], mids, ends[1], (xu, xd)))
    up_pts.sort(key=lambda t: t[0])

    # ---- segments ----
    dam = 1
    nblocks = len(joints) + 1
    rock = nblocks + 1
    rd = rock if foundation == "rock" else 0
    chain_b = ip + [toe]
    for a, b, (x, h) in zip(chain_b[:-1], chain_b[1:], st):
        geo.Append(["line", a, b], leftdomain=dam, rightdomain=rd, bc="interface",
                   maxh=h_int)
    # downstream face (toe -> crest corner), split at joint points, then the crest
    dpts = [(P[k, 1], vid[k], tuple(P[k])) for k in section.downstream]
    for j, e_up, mids, e_dn, (xu, xd) in jpts:
        if not any(pid == e_dn for _, pid, _ in dpts):
            dpts.append((j.elevation, e_dn, (xd, j.elevation)))
    dpts.sort(key=lambda t: (t[0], t[2][0] if t[0] >= top_y - 1e-9 else 0.0))
    # order along the face: by elevation, and along the crest edge (if any) right to left
    top_part = [q for q in dpts if q[0] >= top_y - 1e-9]
    dpts = [q for q in dpts if q[0] < top_y - 1e-9] + \
        [q for k in section.downstream for q in top_part if q[1] == vid[k]]
    for (ya, a, pa), (yb, b, pb) in zip(dpts[:-1], dpts[1:]):
        crest = ya >= top_y - 1e-9 and yb >= top_y - 1e-9
        geo.Append(["line", a, b], leftdomain=block(0.5 * (ya + yb)), rightdomain=0,
                   bc="crest" if crest else "downstream")
    # upstream face from the crest corner down to the heel
    ucorner = [(section.upstream_arclength(P[k, 1]) if k != section.i_top else L_up, vid[k],
                tuple(P[k])) for k in section.upstream[:-1]]
    upath = sorted(ucorner + up_pts, key=lambda t: -t[0]) + [(0.0, ip[0], (0.0, 0.0))]
    for (sa, a, pa), (sb, b, pb) in zip(upath[:-1], upath[1:]):
        geo.Append(["line", a, b], leftdomain=block(0.5 * (pa[1] + pb[1])), rightdomain=0,
                   bc="upstream")
    # lift joints: upstream -> downstream, the block above on the left
    for k, (j, e_up, mids, e_dn, _) in enumerate(jpts):
        jc = [e_up] + mids + [e_dn]
        for a, b in zip(jc[:-1], jc[1:]):
            geo.Append(["line", a, b], leftdomain=k + 2, rightdomain=k + 1, bc=j.name,
                       maxh=j.h_joint)
    for k, name in enumerate(dam_block_names(joints)):
        geo.SetMaterial(k + 1, name)
    if foundation == "rock":
        xl, xr, yb = -eu * W, W + ed * W, -edep * W
        # rock top upstream, graded away from the heel
        su = _interface_stations(xl, 0.0, h_heel, h_coarse, growth, heel_at_start=False)
        upt = [geo.AppendPoint(x, 0.0, maxh=h) for x, h in su[1:]]
        pl_top = geo.AppendPoint(xl, 0.0)
        pr_top = geo.AppendPoint(xr, 0.0)
        pbl = geo.AppendPoint(xl, yb)
        pbr = geo.AppendPoint(xr, yb)
        # rock boundary (rock = left domain, counter-clockwise): bottom, right, top-down
        geo.Append(["line", pbl, pbr], leftdomain=rock, rightdomain=0, bc="rock_bottom")
        geo.Append(["line", pbr, pr_top], leftdomain=rock, rightdomain=0, bc="rock_right")
        geo.Append(["line", pr_top, toe], leftdomain=rock, rightdomain=0, bc="rock_top_down")
        tchain = [ip[0]] + upt + [pl_top]
        for a, b in zip(tchain[:-1], tchain[1:]):
            geo.Append(["line", a, b], leftdomain=rock, rightdomain=0, bc="rock_top_up")
        geo.Append(["line", pl_top, pbl], leftdomain=rock, rightdomain=0, bc="rock_left")
        geo.SetMaterial(rock, "rock")
    return geo.GenerateMesh(maxh=h_coarse, grading=grading)


def _rock_only(W, h_heel, h_coarse, h_int, growth, eu, ed, edep, grading, heel_zone=0.0):
    # deferred: NGSolve is optional: the package imports without it
    from netgen.geom2d import SplineGeometry

    geo = SplineGeometry()
    xl, xr, yb = -eu * W, W + ed * W, -edep * W
    st = _interface_stations(0.0, W, h_heel, h_int, growth, heel_zone=heel_zone)
    ip = [geo.AppendPoint(x, 0.0, maxh=h) for x, h in st]
    toe = geo.AppendPoint(W, 0.0, maxh=h_int)
    su = _interface_stations(xl, 0.0, h_heel, h_coarse, growth, heel_at_start=False)
    upt = [geo.AppendPoint(x, 0.0, maxh=h) for x, h in su[1:]]
    pl_top = geo.AppendPoint(xl, 0.0)
    pr_top = geo.AppendPoint(xr, 0.0)
    pbl = geo.AppendPoint(xl, yb)
    pbr = geo.AppendPoint(xr, yb)
    rock = 1
    geo.Append(["line", pbl, pbr], leftdomain=rock, rightdomain=0, bc="rock_bottom")
    geo.Append(["line", pbr, pr_top], leftdomain=rock, rightdomain=0, bc="rock_right")
    geo.Append(["line", pr_top, toe], leftdomain=rock, rightdomain=0, bc="rock_top_down")
    chain = ip + [toe]
    # rock lies below the interface: going toe -> heel keeps rock on the left
    for a, b in zip(chain[::-1][:-1], chain[::-1][1:]):
        geo.Append(["line", a, b], leftdomain=rock, rightdomain=0, bc="interface_rock",
                   maxh=h_int)
    tchain = [ip[0]] + upt + [pl_top]
    for a, b in zip(tchain[:-1], tchain[1:]):
        geo.Append(["line", a, b], leftdomain=rock, rightdomain=0, bc="rock_top_up")
    geo.Append(["line", pl_top, pbl], leftdomain=rock, rightdomain=0, bc="rock_left")
    geo.SetMaterial(rock, "rock")
    return geo.GenerateMesh(maxh=h_coarse, grading=grading)


def merge_meshes(*ngmeshes):
    """Merge 2D netgen meshes into one netgen mesh WITHOUT identifying coincident
    vertices (regions and boundary names are merged by name).  Used for non-matching
    interfaces: the parts share no vertex, each keeps its own interface segments."""
    # deferred: NGSolve is optional: the package imports without it
    from netgen.meshing import Mesh, MeshPoint, Element2D, Element1D, FaceDescriptor
    from netgen.csg import Pnt

    out = Mesh(dim=2)
    mats: dict[str, int] = {}
    bcs: dict[str, int] = {}
    for m in ngmeshes:
        pmap = {}
        for i, p in enumerate(m.Points()):
            pmap[i + 1] = out.Add(MeshPoint(Pnt(p[0], p[1], 0.0)))
        # regions
        local_mat = {}
        for idx in range(1, 1000):
            try:
                name = m.GetMaterial(idx)
            except Exception:
                break
            if not name:
                break
            if name not in mats:
                fd = out.Add(FaceDescriptor(bc=len(mats) + 1))
                mats[name] = fd
                out.SetMaterial(fd, name)
            local_mat[idx] = mats[name]
        for el in m.Elements2D():
            vs = [pmap[v.nr] for v in el.vertices]
            out.Add(Element2D(local_mat[el.index], vs))
        for el in m.Elements1D():
            name = m.GetBCName(el.index - 1)
            if name not in bcs:
                bcs[name] = len(bcs) + 1
                out.SetBCName(bcs[name] - 1, name)
            vs = [pmap[v.nr] for v in el.vertices]
            out.Add(Element1D(vs, index=bcs[name]))
    return out


def two_block_mesh(width: float = 1.0, h_top: float = 0.5, h_bot: float = 0.5,
                   n_top: int = 4, n_bot: int = 3, structured: bool = True):
    """Rectangle ("dam", [0,width]x[0,h_top]) on a rectangle ("rock",
    [0,width]x[-h_bot,0]) with NON-matching interface node spacing: n_top interface
    segments on the dam side, n_bot on the rock side.  Dam-side interface boundary
    "interface", rock side "interface_rock"; other boundaries: dam "upstream" (x=0),
    "downstream" (x=width), "crest" (top); rock "rock_left", "rock_right",
    "rock_bottom".  Structured triangles (two per quad) so that the patch test is
    independent of netgen.  Pass n_top == n_bot for a matching (but still duplicated
    node) interface.  Returns an ``ngsolve.Mesh``."""
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs
    from netgen.meshing import Mesh, MeshPoint, Element2D, Element1D, FaceDescriptor
    from netgen.csg import Pnt

    out = Mesh(dim=2)
    bc_names = ["interface", "upstream", "downstream", "crest", "interface_rock",
                "rock_left", "rock_right", "rock_bottom"]
    for i, n in enumerate(bc_names):
        out.SetBCName(i, n)
    bcid = {n: i + 1 for i, n in enumerate(bc_names)}
    for k, name in enumerate(("dam", "rock")):
        out.Add(FaceDescriptor(bc=k + 1))
        out.SetMaterial(k + 1, name)

    def block(x0, x1, y0, y1, nx, ny, matidx, names):
        # names: bottom, right, top, left
        P = {}
        for j in range(ny + 1):
            for i in range(nx + 1):
                P[i, j] = out.Add(MeshPoint(Pnt(x0 + (x1 - x0) * i / nx,
                                                y0 + (y1 - y0) * j / ny, 0.0)))
        for j in range(ny):
            for i in range(nx):
                a, b, c, d = P[i, j], P[i + 1, j], P[i + 1, j + 1], P[i, j + 1]
                out.Add(Element2D(matidx, [a, b, c]))
                out.Add(Element2D(matidx, [a, c, d]))
        for i in range(nx):
            out.Add(Element1D([P[i, 0], P[i + 1, 0]], index=bcid[names[0]]))
            out.Add(Element1D([P[i + 1, ny], P[i, ny]], index=bcid[names[2]]))
        for j in range(ny):
            out.Add(Element1D([P[nx, j], P[nx, j + 1]], index=bcid[names[1]]))
            out.Add(Element1D([P[0, j + 1], P[0, j]], index=bcid[names[3]]))

    ny_t = max(1, round(n_top * h_top / width))
    ny_b = max(1, round(n_bot * h_bot / width))
    block(0.0, width, 0.0, h_top, n_top, ny_t, 1,
          ("interface", "downstream", "crest", "upstream"))
    block(0.0, width, -h_bot, 0.0, n_bot, ny_b, 2,
          ("rock_bottom", "rock_right", "interface_rock", "rock_left"))
    return ngs.Mesh(out)
