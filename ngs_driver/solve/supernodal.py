"""Supernodal triangular solves with a unit lower factor L (P A P^T = L D L^T), numba.

A supernode is a run of consecutive columns c0..c1-1 of L in which each column's entries below
the diagonal are the next column followed by that column's own entries: the columns form a chain
of the elimination tree and share one list of rows below the block (``I``). Stored per
supernode (issue #15; the Koyna factor: 550 k entries in 3 814 supernodes, 2/3 of the entries in
supernodes of width >= 9):

    T  the strictly lower triangle of the w x w diagonal block, column by column;
    X  the m x w block below it, column-major (column k of the supernode is contiguous);
    I  its m row indices.

Against the column-compressed L this stores one row index per block row instead of one per entry
(4.6 MB instead of 6.6 MB, and no reversed copy for the backward half: 13.2 MB before), reads y
once per block row in the forward half, and keeps several independent sums in the backward half
(a dot product per column was one long chain of dependent additions). Wide supernodes
(w >= ``WIDE``) go through BLAS gemv (numba's np.dot). The sums are associated differently from
the column-by-column solve: results agree with it to round-off, not bit for bit.

Every kernel visits a list of supernodes ``sl`` (ascending): all of them for a whole solve, or
the closure of a few rows (``closure``) for the partial solves of the condensed method.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["WIDE", "build", "reversed_blocks", "closure", "forward", "backward", "forward_mat", "backward_mat",
           "Supernodal"]

WIDE = 8     # supernode width from which the block products go through BLAS (measured: 8-24
#              equally good on the Koyna factor, both halves; 0.39/0.47 ms against 0.49/0.52
#              with the hand loops only)


@njit(cache=True)
def build(Lp, Li, Lx):
    """Supernodes of a CSC unit lower factor with sorted rows, diagonal first in each column.
    Returns (start, tp, T, xp, X, ip, I, col_sn): supernode s has columns start[s]..start[s+1]-1,
    its triangle T[tp[s]:tp[s+1]], block X[xp[s]:xp[s+1]] and rows I[ip[s]:ip[s+1]];
    col_sn[j] is the supernode of column j."""
    n = Lp.shape[0] - 1
    start = np.empty(n + 1, np.int32)
    start[0] = 0
    ns = 1
    for j in range(n - 1):
        c0 = Lp[j + 1] - Lp[j]
        c1 = Lp[j + 2] - Lp[j + 1]
        same = c0 == c1 + 1
        if same:
            for t in range(c1):
                if Li[Lp[j] + 1 + t] != Li[Lp[j + 1] + t]:
                    same = False
                    break
        if not same:
            start[ns] = j + 1
            ns += 1
    start[ns] = n
    start = start[:ns + 1].copy()
    tp = np.empty(ns + 1, np.int64)
    xp = np.empty(ns + 1, np.int64)
    ip = np.empty(ns + 1, np.int64)
    tp[0] = 0
    xp[0] = 0
    ip[0] = 0
    col_sn = np.empty(n, np.int32)
    for s in range(ns):
        c0 = start[s]
        c1 = start[s + 1]
        w = c1 - c0
        m = Lp[c1] - Lp[c1 - 1] - 1
        tp[s + 1] = tp[s] + w * (w - 1) // 2
        xp[s + 1] = xp[s] + m * w
        ip[s + 1] = ip[s] + m
        for c in range(c0, c1):
            col_sn[c] = s
    T = np.empty(tp[ns])
    X = np.empty(xp[ns])
    I = np.empty(ip[ns], np.int32)
    for s in range(ns):
        c0 = start[s]
        c1 = start[s + 1]
        w = c1 - c0
        m = ip[s + 1] - ip[s]
        q = tp[s]
        for k in range(w):
            j = c0 + k
            for t in range(w - 1 - k):
                T[q] = Lx[Lp[j] + 1 + t]
                q += 1
            base = Lp[j] + 1 + (w - 1 - k)
            for r in range(m):
                X[xp[s] + k * m + r] = Lx[base + r]
        base = Lp[c1 - 1] + 1
        for r in range(m):
            I[ip[s] + r] = Li[base + r]
    return start, tp, T, xp, X, ip, I, col_sn


@njit(cache=True)
def reversed_blocks(tp, T, xp, X, ip, I):
    """The same blocks with the supernodes stored last to first (supernode s at position
    ns-1-s; each block's own layout unchanged), for the backward half, which visits them last
    to first: read from the forward copy it walks memory downwards, which the hardware
    prefetcher does not follow (measured on the Koyna factor with the caches flushed between
    solves: 1.22 ms downwards against 0.82 ms for the column-compressed solve read upwards)."""
    ns = tp.shape[0] - 1
    tpr = np.empty(ns + 1, np.int64)
    xpr = np.empty(ns + 1, np.int64)
    ipr = np.empty(ns + 1, np.int64)
    tpr[0] = 0
    xpr[0] = 0
    ipr[0] = 0
    for k in range(ns):
        s = ns - 1 - k
        tpr[k + 1] = tpr[k] + tp[s + 1] - tp[s]
        xpr[k + 1] = xpr[k] + xp[s + 1] - xp[s]
        ipr[k + 1] = ipr[k] + ip[s + 1] - ip[s]
    Tr = np.empty(T.shape[0])
    Xr = np.empty(X.shape[0])
    Ir = np.empty(I.shape[0], np.int32)
    for k in range(ns):
        s = ns - 1 - k
        for q in range(tp[s + 1] - tp[s]):
            Tr[tpr[k] + q] = T[tp[s] + q]
        for q in range(xp[s + 1] - xp[s]):
            Xr[xpr[k] + q] = X[xp[s] + q]
        for q in range(ip[s + 1] - ip[s]):
            Ir[ipr[k] + q] = I[ip[s] + q]
    return tpr, Tr, xpr, Xr, ipr, Ir


@njit(cache=True)
def closure(start, ip, I, col_sn, cols):
    """Supernodes (ascending) holding the columns reachable from ``cols`` through L's stored
    structure: every nonzero of L^-1 b for b supported on ``cols``, and every entry that L^-T
    needs to give its result on ``cols``. A graph search over every block row, not a walk up
    the elimination tree: SuperLU's L need not hold the entries that make its structure the
    tree's (a 2-DOF grid's factor had 232 of 512 columns with rows off their tree path)."""
    ns = start.shape[0] - 1
    mark = np.zeros(ns, np.bool_)
    stack = np.empty(ns, np.int64)
    top = 0
    for a in range(cols.shape[0]):
        s = col_sn[cols[a]]
        if not mark[s]:
            mark[s] = True
            stack[top] = s
            top += 1
    while top > 0:
        top -= 1
        s = stack[top]
        for q in range(ip[s], ip[s + 1]):
            t = col_sn[I[q]]
            if not mark[t]:
                mark[t] = True
                stack[top] = t
                top += 1
    return np.flatnonzero(mark).astype(np.int32)


@njit(cache=True)
def forward(start, tp, T, xp, X, ip, I, sl, y, t):
    """y <- L^-1 y in place on the supernodes ``sl``; t: scratch of at least max(m) entries."""
    for a in range(sl.shape[0]):
        s = sl[a]
        c0 = start[s]
        w = start[s + 1] - c0
        q = tp[s]
        for k in range(w - 1):
            yk = y[c0 + k]
            for u in range(k + 1, w):
                y[c0 + u] -= T[q] * yk
                q += 1
        x0 = xp[s]
        i0 = ip[s]
        m = ip[s + 1] - i0
        if w == 1:
            y0 = y[c0]
            for r in range(m):
                y[I[i0 + r]] -= X[x0 + r] * y0
        elif w == 2:
            y0 = y[c0]
            y1 = y[c0 + 1]
            for r in range(m):
                y[I[i0 + r]] -= X[x0 + r] * y0 + X[x0 + m + r] * y1
        elif w < WIDE:
            y0 = y[c0]
            for r in range(m):
                t[r] = X[x0 + r] * y0
            for k in range(1, w):
                yk = y[c0 + k]
                o = x0 + k * m
                for r in range(m):
                    t[r] += X[o + r] * yk
            for r in range(m):
                y[I[i0 + r]] -= t[r]
        elif m > 0:
            tt = np.dot(y[c0:c0 + w], X[x0:x0 + w * m].reshape((w, m)))
            for r in range(m):
                y[I[i0 + r]] -= tt[r]


@njit(cache=True)
def backward(start, tp, T, xp, X, ip, I, D, sl, z, g):
    """z <- L^-T D^-1 z in place on the supernodes ``sl`` (taken last to first); the blocks are
    the reversed copy (``reversed_blocks``: supernode s at position ns-1-s); g: scratch of at
    least max(m) entries."""
    ns = start.shape[0] - 1
    for a in range(sl.shape[0] - 1, -1, -1):
        s = sl[a]
        sr = ns - 1 - s
        c0 = start[s]
        w = start[s + 1] - c0
        x0 = xp[sr]
        i0 = ip[sr]
        m = ip[sr + 1] - i0
        if w == 1:
            s0 = 0.0
            s1 = 0.0
            r = 0
            while r + 1 < m:
                s0 += X[x0 + r] * z[I[i0 + r]]
                s1 += X[x0 + r + 1] * z[I[i0 + r + 1]]
                r += 2
            if r < m:
                s0 += X[x0 + r] * z[I[i0 + r]]
            z[c0] = z[c0] / D[c0] - (s0 + s1)
            continue
        for r in range(m):
            g[r] = z[I[i0 + r]]
        if w >= WIDE and m > 0:
            acc = np.dot(X[x0:x0 + w * m].reshape((w, m)), g[:m])
            for k in range(w):
                z[c0 + k] = z[c0 + k] / D[c0 + k] - acc[k]
        else:
            for k in range(w):
                o = x0 + k * m
                s0 = 0.0
                s1 = 0.0
                s2 = 0.0
                s3 = 0.0
                r = 0
                while r + 3 < m:
                    s0 += X[o + r] * g[r]
                    s1 += X[o + r + 1] * g[r + 1]
                    s2 += X[o + r + 2] * g[r + 2]
                    s3 += X[o + r + 3] * g[r + 3]
                    r += 4
                while r < m:
                    s0 += X[o + r] * g[r]
                    r += 1
                z[c0 + k] = z[c0 + k] / D[c0 + k] - ((s0 + s1) + (s2 + s3))
        q = tp[sr + 1]
        for k in range(w - 1, -1, -1):
            q -= w - 1 - k                # column k's entries below the diagonal: rows k+1..
            acc0 = z[c0 + k]
            for u in range(k + 1, w):
                acc0 -= T[q + u - k - 1] * z[c0 + u]
            z[c0 + k] = acc0


@njit(cache=True)
def forward_mat(start, tp, T, xp, X, ip, I, sl, y):
    """``forward`` for y (n, k), C-contiguous (k right-hand sides)."""
    nr = y.shape[1]
    for a in range(sl.shape[0]):
        s = sl[a]
        c0 = start[s]
        w = start[s + 1] - c0
        q = tp[s]
        x0 = xp[s]
        i0 = ip[s]
        m = ip[s + 1] - i0
        for k in range(w):
            for u in range(k + 1, w):
                tv = T[q]
                q += 1
                for c in range(nr):
                    y[c0 + u, c] -= tv * y[c0 + k, c]
        for k in range(w):
            o = x0 + k * m
            for r in range(m):
                i = I[i0 + r]
                xv = X[o + r]
                for c in range(nr):
                    y[i, c] -= xv * y[c0 + k, c]


@njit(cache=True)
def backward_mat(start, tp, T, xp, X, ip, I, D, sl, z):
    """``backward`` for z (n, k), C-contiguous (blocks: the reversed copy)."""
    nr = z.shape[1]
    ns = start.shape[0] - 1
    for a in range(sl.shape[0] - 1, -1, -1):
        s = sl[a]
        sr = ns - 1 - s
        c0 = start[s]
        w = start[s + 1] - c0
        x0 = xp[sr]
        i0 = ip[sr]
        m = ip[sr + 1] - i0
        q = tp[sr + 1]
        for k in range(w - 1, -1, -1):
            j = c0 + k
            d = D[j]
            for c in range(nr):
                z[j, c] /= d
            o = x0 + k * m
            for r in range(m):
                i = I[i0 + r]
                xv = X[o + r]
                for c in range(nr):
                    z[j, c] -= xv * z[i, c]
            q -= w - 1 - k
            for u in range(k + 1, w):
                tv = T[q + u - k - 1]
                for c in range(nr):
                    z[j, c] -= tv * z[c0 + u, c]


class Supernodal:
    """L (unit lower, CSC with sorted rows and diagonal first) and D in supernodal storage;
    solves in the permuted space of the factorisation."""

    def __init__(self, Lp, Li, Lx, D):
        (self.start, self.tp, self.T, self.xp, self.X, self.ip, self.I,
         self.col_sn) = build(Lp, Li, Lx)
        self.D = np.ascontiguousarray(D, dtype=np.float64)
        self.all = np.arange(self.start.size - 1, dtype=np.int32)
        m = np.diff(self.ip)
        self.mmax = int(m.max()) if m.size else 0
        self._parts = (self.start, self.tp, self.T, self.xp, self.X, self.ip, self.I)
        self._rparts = (self.start,) + reversed_blocks(*self._parts[1:])

    @property
    def nnz(self) -> int:
        """Stored entries: the blocks, their triangles and D (the unit diagonal is implicit)."""
        return int(self.T.size + self.X.size + self.D.size)

    @property
    def nbytes(self) -> int:
        return int(2 * (self.T.nbytes + self.X.nbytes + self.I.nbytes + self.tp.nbytes
                        + self.xp.nbytes + self.ip.nbytes)
                   + self.D.nbytes + self.start.nbytes + self.col_sn.nbytes)

    def closure(self, cols) -> np.ndarray:
        return closure(self.start, self.ip, self.I, self.col_sn, np.asarray(cols, np.int64))

    def entries(self, sl) -> int:
        """Block and triangle entries of the supernodes ``sl``."""
        return int(np.sum(self.xp[sl + 1] - self.xp[sl]) + np.sum(self.tp[sl + 1] - self.tp[sl]))

    def forward(self, y, sl=None):
        """y <- L^-1 y in place (y (n,) or (n, k) C-contiguous)."""
        sl = self.all if sl is None else sl
        if y.ndim == 1:
            forward(*self._parts, sl, y, np.empty(self.mmax))
        else:
            forward_mat(*self._parts, sl, y)

    def backward(self, z, sl=None):
        """z <- L^-T D^-1 z in place."""
        sl = self.all if sl is None else sl
        if z.ndim == 1:
            backward(*self._rparts, self.D, sl, z, np.empty(self.mmax))
        else:
            backward_mat(*self._rparts, self.D, sl, z)
