"""The step's five products in their faster layouts (solve/products.py ``FusedPair.products5``:
C formed in the loop for Rayleigh damping, dense row groups for the reduced bulk's blocks)
against scipy's products. Both layouts keep every row's sum in scipy's order, so the check is
bit for bit (``np.array_equal``), not a tolerance: a reordered sum fails it."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from ngs_driver.solve.products import BLOCK_MIN_ROWS, FusedPair, row_groups


def _spd(rng, n, density):
    A = sp.random(n, n, density=density, random_state=rng, format="csr")
    return (A + A.T + sp.diags(n * (1.0 + rng.random(n)))).tocsr()


def _reduced_like(rng):
    """Two dense boundary blocks (one column pattern per block: the reduced bulk's K_bb, M_bb
    of two parts) and modal rows with a diagonal entry each (their own patterns)."""
    nb1, nb2, nm = 30, 21, 9
    n = nb1 + nb2 + nm
    D = np.zeros((n, n))
    for lo, hi in ((0, nb1), (nb1, nb1 + nb2)):
        X = rng.standard_normal((hi - lo, hi - lo))
        D[lo:hi, lo:hi] = X @ X.T + (hi - lo) * np.eye(hi - lo)
    Km = D.copy()
    Km[nb1 + nb2:, nb1 + nb2:] = np.diag(1.0 + rng.random(nm))          # diag omega^2
    Mm = 0.1 * D.copy()
    Mm[nb1 + nb2:, nb1 + nb2:] = np.eye(nm)                              # identity modal block
    cpl = 0.01 * rng.standard_normal((nm, nb1))                          # M_{eta b}: part 1
    Mm[nb1 + nb2:, :nb1] = cpl
    Mm[:nb1, nb1 + nb2:] = cpl.T
    return sp.csr_matrix(Km), sp.csr_matrix(Mm)


def _vectors(rng, n):
    vs = [rng.standard_normal(n) * 10.0 ** rng.integers(-6, 6) for _ in range(4)]
    vs[0][rng.random(n) < 0.1] = 0.0
    return vs


def _check(fp, K, M, C, rng, reps=4):
    n = K.shape[0]
    for _ in range(reps):
        u, v, x, y = _vectors(rng, n)
        out = [np.full(n, np.nan) for _ in range(5)]
        fp.products5(u, v, x, y, *out)
        for got, want in zip(out, (K @ u, M @ v, M @ x, C @ y, C @ v)):
            assert np.array_equal(got, want)


@pytest.mark.parametrize("rayleigh", [True, False])
def test_row_groups_bitwise_scipy(rayleigh):
    """Reduced-bulk-like matrices: the row-group layout (dense column-major blocks, SIMD over
    a group's rows) gives scipy's K u, M v, M x, C y, C v bit for bit, with C = a0 M + a1 K
    formed in the loop (rayleigh) or read (C with an extra term: the check refuses the
    Rayleigh form)."""
    rng = np.random.default_rng(3)
    K, M = _reduced_like(rng)
    a0, a1 = 1.241896936, 0.001506401626
    C = (a0 * M + a1 * K).tocsr()
    if not rayleigh:
        C = (C + sp.diags(rng.random(K.shape[0]))).tocsr()
    fp = FusedPair(M, C, K, rayleigh=(a0, a1))
    assert fp.blocks is not None                         # the two dense blocks are groups
    assert (fp.rayleigh is not None) == rayleigh
    sizes = np.diff(fp.blocks[0].astype(np.int64))
    assert sorted(sizes[sizes >= BLOCK_MIN_ROWS]) == [21, 30]
    _check(fp, K, M, C, rng)


def test_rayleigh_csr_bitwise_scipy():
    """A finite-element-like pattern (no row groups: the full bulk) with Rayleigh damping:
    the CSR pass that forms C's values in its loop equals scipy's five products bit for bit;
    a0 = 0 (stiffness-proportional damping) too."""
    rng = np.random.default_rng(5)
    n = 400
    K, M = _spd(rng, n, 0.02), _spd(rng, n, 0.01)
    for a0, a1 in ((0.731, 2.3e-3), (0.0, 1.7e-3)):
        C = (a0 * M + a1 * K).tocsr()
        fp = FusedPair(M, C, K, rayleigh=(a0, a1))
        assert fp.blocks is None and fp.rayleigh == (a0, a1)
        _check(fp, K, M, C, rng)
    # a C that is not a0 M + a1 K (one entry changed in its last bit): the stored C is read
    C = (0.731 * M + 2.3e-3 * K).tocsr()
    C.data[17] = np.nextafter(C.data[17], np.inf)
    fp = FusedPair(M, C, K, rayleigh=(0.731, 2.3e-3))
    assert fp.rayleigh is None
    _check(fp, K, M, C, rng, reps=2)


def test_row_groups_cover_every_entry_once():
    """``row_groups``' take index visits each stored entry exactly once (a group's values
    column by column) and every row is in one group."""
    rng = np.random.default_rng(9)
    K, M = _reduced_like(rng)
    A = (K + M).tocsr()
    gptr, grows, cptr, gcols, take = row_groups(A.indptr, A.indices)
    assert np.array_equal(np.sort(take), np.arange(A.nnz))
    assert np.array_equal(np.sort(grows), np.arange(A.shape[0]))
    for g in range(gptr.size - 1):
        rows = grows[gptr[g]:gptr[g + 1]]
        for r in rows:
            assert np.array_equal(A.indices[A.indptr[r]:A.indptr[r + 1]],
                                  gcols[cptr[g]:cptr[g + 1]])
