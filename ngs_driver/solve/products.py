"""Two sparse matrix-vector products in one pass: A x and B y for two square CSR
matrices laid out on the union of their patterns (zeros where a matrix has no entry), so the
row loop reads the pattern once for both and keeps two independent sums in flight.

Each row is summed in the stored column order, like scipy's ``csr_matvec``: for canonical A
and B (sorted, no duplicates) the products are bitwise scipy's ``A @ x`` and ``B @ y`` (an
inserted zero adds +-0, which changes no partial sum; the sum starts at +0 as scipy's does).
Indices are unsigned (no negative-index wraparound test in the compiled loop: ~2.5x faster
than int32 for the four products of a Koyna step, measured), 16-bit column indices and 32-bit
row pointers while they fit (a further ~13 %). Used by the Newmark right-hand side (M, C) and the energy budget (K, M).

The step's five products (``FusedPair.products5``, docs/solver.md §6) take two further layouts,
both bitwise the same sums in the same order:

* Rayleigh damping, C = a0 M + a1 K entry by entry (``rayleigh=(a0, a1)``, checked bit for bit
  on the union pattern when built): C's values are formed in the loop, fl(fl(a0 m) + fl(a1 k)),
  which is what scipy's ``a0 * M + a1 * K`` stored, so one value stream less is read
  (``step_products5_rayleigh``);
* rows with one column pattern (the reduced bulk's dense boundary blocks: 320 and 222 rows on
  koyna_engineering) stored column by column as dense row-groups, each column's entries
  summed into the group's rows at once (``block_products5``): every row is still summed
  column after column from +0, so its sum is the CSR row's, and the loop over the group's rows
  runs in SIMD lanes instead of one dependent sum per product.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit

__all__ = ["FusedPair", "pair_products", "step_products5", "step_products5_rayleigh",
           "block_products5", "row_groups", "BLOCK_MIN_ROWS"]

# rows sharing one column pattern go to the row-group layout in groups of at least this many
# rows, and the layout is used when such groups hold at least half the entries (the full
# bulk's groups are a node's two DOFs: the CSR loop is as fast there)
BLOCK_MIN_ROWS = 8


def _canonical(A):
    A = sp.csr_matrix(A)
    if not A.has_canonical_format:
        A = A.copy()
        A.sum_duplicates()                         # sorted indices, duplicates summed
    return A


def _keys(A):
    """row * n + column of every stored entry, in the stored (row-major) order."""
    rows = np.repeat(np.arange(A.shape[0], dtype=np.int64), np.diff(A.indptr))
    return rows * A.shape[1] + A.indices.astype(np.int64)


@njit(cache=True)
def pair_products(indptr, indices, Ax, Bx, x, y, Axo, Byo):
    """Axo = A x, Byo = B y on one pattern (``FusedPair``'s arrays)."""
    for i in range(Axo.size):
        a = 0.0
        b = 0.0
        for jj in range(indptr[i], indptr[i + 1]):
            j = indices[jj]
            a += Ax[jj] * x[j]
            b += Bx[jj] * y[j]
        Axo[i] = a
        Byo[i] = b


@njit(cache=True)
def step_products5(indptr, indices, Mx, Cx, Kx, u, v, x, y, Ku, Mv, Mxo, Cyo, Cvo):
    """Ku = K u, Mv = M v, Mxo = M x, Cyo = C y, Cvo = C v on one pattern
    (``FusedPair(M, C, K)``'s arrays), five independent sums per row in one pass: the energy
    budget's products of a committed state and the next step's right-hand-side products (HHT /
    generalized alpha also take the committed internal force K u + C v; Newmark leaves C v)."""
    for i in range(Ku.size):
        a = 0.0
        b = 0.0
        c = 0.0
        d = 0.0
        e = 0.0
        for jj in range(indptr[i], indptr[i + 1]):
            j = indices[jj]
            a += Kx[jj] * u[j]
            b += Mx[jj] * v[j]
            c += Mx[jj] * x[j]
            d += Cx[jj] * y[j]
            e += Cx[jj] * v[j]
        Ku[i] = a
        Mv[i] = b
        Mxo[i] = c
        Cyo[i] = d
        Cvo[i] = e


@njit(cache=True)
def step_products5_rayleigh(indptr, indices, Mx, Kx, a0, a1, u, v, x, y, Ku, Mv, Mxo, Cyo,
                            Cvo):
    """``step_products5`` with C = a0 M + a1 K formed entry by entry in the loop (the same
    rounding as scipy's ``a0 * M + a1 * K``: bitwise the stored C, checked by ``FusedPair``)."""
    for i in range(Ku.size):
        a = 0.0
        b = 0.0
        c = 0.0
        d = 0.0
        e = 0.0
        for jj in range(indptr[i], indptr[i + 1]):
            j = indices[jj]
            m = Mx[jj]
            k = Kx[jj]
            cc = a0 * m + a1 * k
            a += k * u[j]
            b += m * v[j]
            c += m * x[j]
            d += cc * y[j]
            e += cc * v[j]
        Ku[i] = a
        Mv[i] = b
        Mxo[i] = c
        Cyo[i] = d
        Cvo[i] = e


@njit(cache=True)
def block_products5(gptr, grows, cptr, gcols, vptr, BM, BK, BC, rayleigh, a0, a1, u, v, x, y,
                    s0, s1, s2, s3, s4, Ku, Mv, Mxo, Cyo, Cvo):
    """``step_products5`` on row groups (``row_groups``; every index array unsigned, as in the
    CSR kernels: no wraparound test, which would keep the row loops out of SIMD): group g has
    the rows grows[gptr[g]:gptr[g+1]] and the columns gcols[cptr[g]:cptr[g+1]], its values
    column by column from vptr[g] in BM, BK (and BC unless ``rayleigh``: then C = a0 M + a1 K
    entry by entry). s0..s4: scratch of the largest group's row count. Each row is summed
    column after column from +0 (the CSR row's order); the loops over a group's rows are
    independent sums and run in SIMD lanes."""
    for g in range(gptr.size - 1):
        r0 = gptr[g]
        nr = gptr[g + 1] - r0
        off = vptr[g]
        c0 = cptr[g]
        if nr == 1:                                  # a row alone: the CSR row loop
            a = 0.0
            b = 0.0
            c = 0.0
            d = 0.0
            e = 0.0
            for cc in range(c0, cptr[g + 1]):
                j = gcols[cc]
                o = off + (cc - c0)
                m = BM[o]
                k = BK[o]
                w = a0 * m + a1 * k if rayleigh else BC[o]
                a += k * u[j]
                b += m * v[j]
                c += m * x[j]
                d += w * y[j]
                e += w * v[j]
            i = grows[r0]
            Ku[i] = a
            Mv[i] = b
            Mxo[i] = c
            Cyo[i] = d
            Cvo[i] = e
            continue
        for r in range(nr):
            s0[r] = 0.0
            s1[r] = 0.0
            s2[r] = 0.0
            s3[r] = 0.0
            s4[r] = 0.0
        for cc in range(c0, cptr[g + 1]):
            j = gcols[cc]
            uj = u[j]
            vj = v[j]
            xj = x[j]
            yj = y[j]
            for r in range(nr):
                s0[r] += BK[off + r] * uj
            for r in range(nr):
                m = BM[off + r]
                s1[r] += m * vj
                s2[r] += m * xj
            if rayleigh:
                for r in range(nr):
                    w = a0 * BM[off + r] + a1 * BK[off + r]
                    s3[r] += w * yj
                    s4[r] += w * vj
            else:
                for r in range(nr):
                    w = BC[off + r]
                    s3[r] += w * yj
                    s4[r] += w * vj
            off += nr
        for r in range(nr):
            i = grows[r0 + r]
            Ku[i] = s0[r]
            Mv[i] = s1[r]
            Mxo[i] = s2[r]
            Cyo[i] = s3[r]
            Cvo[i] = s4[r]


def row_groups(indptr, indices, min_rows: int = BLOCK_MIN_ROWS):
    """Rows of one column pattern as groups: (gptr, grows, cptr, gcols, take), the groups of
    at least ``min_rows`` rows first, then every other row alone; ``take`` indexes the CSR
    value arrays in the groups' layout (each group's values column by column). Candidate
    groups come from a vectorised key of each row (length, first column, sums of the columns
    and of their squares); only those of ``min_rows`` rows or more are compared entry by entry
    (0.05 s for 100 000 rows, where a dictionary of every row's pattern took 1 s)."""
    indptr = np.asarray(indptr, dtype=np.int64)
    n = indptr.size - 1
    lens = np.diff(indptr)
    ix = np.asarray(indices, dtype=np.int64)
    nz = lens > 0
    starts = indptr[:-1][nz]
    key = np.zeros((n, 4), np.int64)
    key[:, 0] = lens
    if ix.size:
        key[nz, 1] = ix[starts]
        key[nz, 2] = np.add.reduceat(ix, starts)
        key[nz, 3] = np.add.reduceat(ix * ix, starts)
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    big = []
    for k in np.flatnonzero(counts >= min_rows):
        pats = {}
        for i in np.flatnonzero(inv == k):
            pats.setdefault(ix[indptr[i]:indptr[i + 1]].tobytes(), []).append(int(i))
        big.extend(rows for rows in pats.values() if len(rows) >= min_rows)
    big.sort(key=lambda rows: rows[0])
    grouped = np.zeros(n, bool)
    for rows in big:
        grouped[rows] = True
    single = np.flatnonzero(~grouped)
    sizes = [len(rows) for rows in big] + [1] * single.size
    ncols = [int(lens[rows[0]]) for rows in big] + list(lens[single])
    gptr = np.concatenate(([0], np.cumsum(sizes, dtype=np.int64)))
    cptr = np.concatenate(([0], np.cumsum(ncols, dtype=np.int64)))
    rows_all = [np.asarray(rows, np.int64) for rows in big] + [single]
    cols_all = [ix[indptr[rows[0]]:indptr[rows[0] + 1]] for rows in big]
    take = [(indptr[np.asarray(rows)][None, :] + np.arange(lens[rows[0]])[:, None]).ravel()
            for rows in big]                                        # column-major
    alone = np.flatnonzero(~grouped[np.repeat(np.arange(n), lens)])  # the single rows' entries
    cols_all.append(ix[alone])
    take.append(alone)
    return (gptr, np.concatenate(rows_all), cptr, np.concatenate(cols_all),
            np.concatenate(take))


class FusedPair:
    """A and B (square, one shape; and C if given) on the union of their patterns: ``indptr``
    (uint32, or uint64), ``indices`` (uint16, or uint32), ``Ax``, ``Bx`` (``Cx``);
    ``products(x, y)`` -> (A x, B y). With C: ``products5`` (the step's five products, A = M,
    B = the damping, C = K); ``rayleigh=(a0, a1)``: B = a0 A + a1 C is checked bit for bit on
    the pattern and, when it holds, B's values are formed in the loop (``self.rayleigh``)."""

    def __init__(self, A, B, C=None, rayleigh=None):
        mats = [_canonical(X) for X in ((A, B) if C is None else (A, B, C))]
        if any(X.shape != mats[0].shape for X in mats) or mats[0].shape[0] != mats[0].shape[1]:
            raise ValueError(f"matrices of shapes {[X.shape for X in mats]}: square matrices "
                             "of one shape are needed")
        n = mats[0].shape[0]
        ks = [_keys(X) for X in mats]
        keys = ks[0]
        for k in ks[1:]:
            keys = np.union1d(keys, k)              # sorted: row-major, columns ascending
        rows = keys // n
        self.n = n
        u16, u32 = np.iinfo(np.uint16).max, np.iinfo(np.uint32).max
        self.indptr = np.searchsorted(rows, np.arange(n + 1)).astype(
            np.uint32 if keys.size <= u32 else np.uint64)
        self.indices = (keys - rows * n).astype(np.uint16 if n <= u16 else np.uint32)
        vals = []
        for X, k in zip(mats, ks):
            x = np.zeros(keys.size)
            x[np.searchsorted(keys, k)] = X.data
            vals.append(x)
        self.Ax, self.Bx = vals[0], vals[1]
        self.Cx = vals[2] if C is not None else None
        self.rayleigh = None
        if C is not None and rayleigh is not None:
            a0, a1 = float(rayleigh[0]), float(rayleigh[1])
            if np.array_equal(a0 * self.Ax + a1 * self.Cx, self.Bx):
                self.rayleigh = (a0, a1)
        self.blocks = None
        if C is not None:
            gptr, grows, cptr, gcols, take = row_groups(self.indptr, self.indices)
            sizes = np.diff(gptr)
            in_big = int(np.sum((np.diff(cptr) * sizes)[sizes >= BLOCK_MIN_ROWS]))
            if 2 * in_big >= keys.size:
                ray = self.rayleigh is not None
                vptr = np.concatenate(([0], np.cumsum(np.diff(cptr) * sizes)))
                ri = np.uint16 if n <= u16 else np.uint32
                self.blocks = (gptr.astype(np.uint64), grows.astype(ri),
                               cptr.astype(np.uint64), gcols.astype(ri),
                               vptr.astype(np.uint64), self.Ax[take], self.Cx[take],
                               np.zeros(1) if ray else self.Bx[take])
                self._scratch = np.empty((5, int(sizes.max())))

    def products5(self, u, v, x, y, Ku, Mv, Mxo, Cyo, Cvo):
        """Ku = C u, Mv = A v, Mxo = A x, Cyo = B y, Cvo = B v (``step_products5``: K u, M v,
        M x, C y, C v for ``FusedPair(M, C, K)``), bitwise the CSR row sums, in the fastest
        layout this pair has (module docstring)."""
        ray = self.rayleigh
        a0, a1 = ray if ray is not None else (0.0, 0.0)
        if self.blocks is not None:
            gptr, grows, cptr, gcols, vptr, BM, BK, BC = self.blocks
            s = self._scratch
            block_products5(gptr, grows, cptr, gcols, vptr, BM, BK, BC, ray is not None, a0,
                            a1, u, v, x, y, s[0], s[1], s[2], s[3], s[4], Ku, Mv, Mxo, Cyo,
                            Cvo)
        elif ray is not None:
            step_products5_rayleigh(self.indptr, self.indices, self.Ax, self.Cx, a0, a1, u, v,
                                    x, y, Ku, Mv, Mxo, Cyo, Cvo)
        else:
            step_products5(self.indptr, self.indices, self.Ax, self.Bx, self.Cx, u, v, x, y,
                           Ku, Mv, Mxo, Cyo, Cvo)

    def products(self, x, y):
        """(A x, B y) as new arrays (x, y contiguous float64 (n,))."""
        Ax, By = np.empty(self.n), np.empty(self.n)
        pair_products(self.indptr, self.indices, self.Ax, self.Bx, x, y, Ax, By)
        return Ax, By
