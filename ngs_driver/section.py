"""A gravity-dam cross-section: the polygon of the scene's ``[geometry] profile`` (numpy only).

Conventions (docs/model.md §1): metres, x downstream, y up; the polygon is
counter-clockwise; the base is the edge from the heel (0, 0) to the toe (W, 0) on y = 0; the
downstream face rises from the toe to the crest, the upstream face comes down from the crest
to the heel. The crest is the highest vertex (or the horizontal top edge); the *upstream crest
corner* (where the crest displacement is read) is the last vertex at the top, counting
counter-clockwise. Lift joints are horizontal cuts at an elevation: each face must therefore
rise monotonically, so that a horizontal line meets the section in one interval.

Used by the scene schema (validation before anything is built) and by ``fe.geometry`` (mesh).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

__all__ = ["Section", "read_profile_csv", "polygon_area", "polygon_centroid"]

_TOL = 1e-9


def polygon_area(pts) -> float:
    """Shoelace area of a simple polygon (positive for counter-clockwise)."""
    p = np.asarray(pts, dtype=float)
    x, y = p[:, 0], p[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def polygon_centroid(pts) -> tuple[float, float]:
    p = np.asarray(pts, dtype=float)
    x, y = p[:, 0], p[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    c = x * yn - xn * y
    a = 0.5 * c.sum()
    return float(((x + xn) * c).sum() / (6 * a)), float(((y + yn) * c).sum() / (6 * a))


def _segments_cross(p1, p2, q1, q2) -> bool:
    """True if the closed segments p1p2 and q1q2 intersect (touching counts)."""
    def orient(a, b, c):
        v = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        return 0 if abs(v) <= _TOL * max(1.0, abs(b[0] - a[0]) + abs(b[1] - a[1])) ** 2 \
            else (1 if v > 0 else -1)

    def on(a, b, c):
        return (min(a[0], b[0]) - _TOL <= c[0] <= max(a[0], b[0]) + _TOL
                and min(a[1], b[1]) - _TOL <= c[1] <= max(a[1], b[1]) + _TOL)

    o1, o2 = orient(p1, p2, q1), orient(p1, p2, q2)
    o3, o4 = orient(q1, q2, p1), orient(q1, q2, p2)
    if o1 != o2 and o3 != o4 and 0 not in (o1, o2, o3, o4):
        return True
    return ((o1 == 0 and on(p1, p2, q1)) or (o2 == 0 and on(p1, p2, q2))
            or (o3 == 0 and on(q1, q2, p1)) or (o4 == 0 and on(q1, q2, p2)))


def read_profile_csv(path) -> list[list[float]]:
    """Two columns x, y (comma or white space; '#' comments; an optional header line)."""

    p = Path(path)
    if not p.is_file():
        raise ValueError(f"no such file {str(p)!r}")
    pts = []
    for k, ln in enumerate(p.read_text(encoding="utf-8", errors="replace").splitlines()):
        body = ln.split("#", 1)[0].strip()
        if not body:
            continue
        tok = body.replace(",", " ").split()
        try:
            vals = [float(t) for t in tok]
        except ValueError:
            if not pts and k == 0 or not pts:
                continue                      # a header line
            raise ValueError(f"{p}: line {k + 1}: {ln!r} is not two numbers x, y") from None
        if len(vals) != 2:
            raise ValueError(f"{p}: line {k + 1}: {ln!r} has {len(vals)} columns; allowed: 2 "
                             "(x, y in metres)")
        pts.append(vals)
    return pts


class Section:
    """A validated section polygon. Raises ``ValueError`` (without the scene key: the caller
    prefixes it) for anything the mesher could not take."""

    def __init__(self, profile):
        try:
            P = np.array(profile, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"{profile!r}: not a list of [x, y] pairs of numbers") from None
        if P.ndim != 2 or P.shape[1] != 2:
            raise ValueError(f"{_short(profile)}: not a list of [x, y] pairs")
        if P.shape[0] < 3:
            raise ValueError(f"{_short(profile)}: {P.shape[0]} points; allowed: at least 3 "
                             "(heel, toe, crest)")
        if not np.all(np.isfinite(P)):
            raise ValueError(f"{_short(profile)}: not finite")
        if np.any(np.hypot(*(np.roll(P, -1, axis=0) - P).T) <= _TOL):
            raise ValueError(f"{_short(profile)}: two consecutive points coincide")
        if (abs(P[0, 0]) <= _TOL and abs(P[0, 1]) <= _TOL and abs(P[-1, 1]) <= _TOL
                and P[-1, 0] > _TOL and abs(P[1, 1]) <= _TOL and P[1, 0] > _TOL):
            raise ValueError(f"{_short(profile)}: does not close at the heel: the last point "
                             f"{P[-1].tolist()} lies on the base; allowed: an outline that ends "
                             "on the upstream face (the edge back to the heel (0, 0) is implied)")
        if (abs(P[0, 0]) <= _TOL and abs(P[0, 1]) <= _TOL and abs(P[-1, 1]) <= _TOL
                and P[-1, 0] > _TOL):
            raise ValueError(f"{_short(profile)}: clockwise (the toe is the last point); "
                             "allowed: counter-clockwise (heel, toe, downstream face, crest, "
                             "upstream face)")
        if abs(P[0, 0]) > _TOL or abs(P[0, 1]) > _TOL:
            raise ValueError(f"{_short(profile)}: the first point (the heel) is "
                             f"{P[0].tolist()}; allowed: [0, 0]")
        if abs(P[1, 1]) > _TOL or P[1, 0] <= _TOL:
            raise ValueError(f"{_short(profile)}: the base (first to second point) is not on "
                             f"y = 0 going downstream: second point {P[1].tolist()}; allowed: "
                             "[W, 0] with W > 0 (the toe)")
        if np.any(P[2:, 1] <= _TOL):
            raise ValueError(f"{_short(profile)}: a point after the toe lies on or below "
                             "y = 0; allowed: only the base on y = 0")
        n = P.shape[0]
        for i in range(n):
            for j in range(i + 1, n):
                if j == i + 1 or (i == 0 and j == n - 1):
                    continue                  # adjacent edges share a vertex
                if _segments_cross(P[i], P[(i + 1) % n], P[j], P[(j + 1) % n]):
                    raise ValueError(f"{_short(profile)}: self-intersecting (edge {i}-{i + 1}"
                                     f" meets edge {j}-{(j + 1) % n}); allowed: a simple "
                                     "polygon")
        if polygon_area(P) <= 0:
            raise ValueError(f"{_short(profile)}: clockwise; allowed: counter-clockwise "
                             "(heel, toe, downstream face, crest, upstream face)")
        ymax = float(P[:, 1].max())
        top = np.flatnonzero(P[:, 1] >= ymax - _TOL)
        i_top = int(top.max())
        down = list(range(1, i_top + 1))
        up = list(range(i_top, n)) + [0]
        yd = P[down, 1]
        yu = P[up, 1]
        if np.any(np.diff(yd) < -_TOL):
            raise ValueError(f"{_short(profile)}: the downstream face (toe to crest) goes down "
                             "somewhere; allowed: faces that rise monotonically (each "
                             "horizontal line meets the section once)")
        if np.any(np.diff(yu) > _TOL):
            raise ValueError(f"{_short(profile)}: the upstream face (crest to heel) goes up "
                             "somewhere; allowed: faces that rise monotonically")
        for chain, nm in ((down, "downstream"), (up, "upstream")):
            for a, b in zip(chain[:-1], chain[1:]):
                if abs(P[a, 1] - P[b, 1]) <= _TOL and P[a, 1] < ymax - _TOL:
                    raise ValueError(f"{_short(profile)}: a horizontal edge on the {nm} face at"
                                     f" y = {P[a, 1]:g}; allowed: horizontal edges only at the "
                                     "base and the crest")
        self.vertices = P
        self.height = ymax
        self.base_width = float(P[1, 0])
        self.i_top = i_top
        self.downstream = down
        self.upstream = up

    # ------------------------------------------------------------------ derived quantities
    @property
    def area(self) -> float:
        return polygon_area(self.vertices)

    @property
    def centroid(self) -> tuple[float, float]:
        return polygon_centroid(self.vertices)

    @property
    def crest_upstream(self) -> tuple[float, float]:
        x, y = self.vertices[self.i_top]
        return float(x), float(y)

    def face_x(self, face: str, y: float) -> float:
        """x of the upstream or downstream face at elevation y (0 <= y <= height)."""
        pts = self.upstream_chain() if face == "upstream" else self.vertices[self.downstream]
        for a, b in zip(pts[:-1], pts[1:]):
            if a[1] - _TOL <= y <= b[1] + _TOL and b[1] - a[1] > _TOL:
                return float(a[0] + (y - a[1]) / (b[1] - a[1]) * (b[0] - a[0]))
        return float(pts[-1][0])          # y on the horizontal top edge: the face's end

    def width_at(self, y: float) -> tuple[float, float]:
        """(x upstream, x downstream) of the horizontal cut at elevation y."""
        return self.face_x("upstream", y), self.face_x("downstream", y)

    def upstream_chain(self) -> np.ndarray:
        """Vertices of the upstream face from the heel up to the crest corner."""
        return self.vertices[[0] + self.upstream[::-1][1:]]

    def upstream_length(self) -> float:
        c = self.upstream_chain()
        return float(np.sum(np.hypot(*np.diff(c, axis=0).T)))

    def upstream_point(self, s: float) -> tuple[float, float]:
        """The point at arc length s from the heel along the upstream face."""
        c = self.upstream_chain()
        d = np.hypot(*np.diff(c, axis=0).T)
        cum = np.concatenate([[0.0], np.cumsum(d)])
        k = int(np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(d) - 1))
        t = (s - cum[k]) / d[k]
        return float(c[k, 0] + t * (c[k + 1, 0] - c[k, 0])), \
            float(c[k, 1] + t * (c[k + 1, 1] - c[k, 1]))

    def upstream_arclength(self, y: float) -> float:
        """Arc length from the heel along the upstream face to elevation y."""
        c = self.upstream_chain()
        s = 0.0
        for a, b in zip(c[:-1], c[1:]):
            seg = math.hypot(b[0] - a[0], b[1] - a[1])
            if y <= b[1] + _TOL:
                return s + seg * (y - a[1]) / (b[1] - a[1]) if b[1] > a[1] else s
            s += seg
        return s


def _short(profile) -> str:
    s = repr(profile if not isinstance(profile, np.ndarray) else profile.tolist())
    return s if len(s) <= 120 else s[:117] + "..."
