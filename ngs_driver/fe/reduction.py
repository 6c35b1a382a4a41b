"""The reduced bulk (``solver.bulk = "reduced"``): the linear dam and rock on a Craig-Bampton
basis, the joints exact (Craig & Bampton 1968, AIAA J. 6(7):1313; docs/reduced_bulk.md).

The free DOFs split into boundary DOFs b -- every DOF the joints' gap operator B touches (both
faces), the wet face of the acoustic water (the rows of its coupling Q), the DOFs of
the faces a sliding joint can be paired with anew (``fe.pairing.lower_faces``), the Westergaard
added mass's rows and the crest -- and interior DOFs i (the rest). With the constraint modes
Psi = -K_ii^-1 K_ib and the fixed-interface normal modes V of (K_ii, M_ii) (V^T M_ii V = I,
V^T K_ii V = diag(omega^2)) up to the cut-off

    u = Phi q,   Phi = [[I, 0], [Psi, V]],   q = (u_b, eta),

and the reduced matrices are K_r = Phi^T K Phi = blockdiag(K_bb + K_bi Psi, diag(omega^2)),
M_r = Phi^T M Phi (dense, small), loads Phi^T f. The boundary DOFs stay physical (rows of Phi
are unit rows there), so every operator that touches boundary DOFs only (B, the water's Q,
the added mass, the crest) is the same operator re-indexed: B_r = B Phi has B's values, and
the joints' law, pairing and the condensed Newton act on the same interface system as with
the full bulk. Statically the reduction is exact (the constraint modes are the static
response to the boundary motion); its dynamic error is set by the cut-off.

Vectors of the model's coordinates: a load f becomes Phi^T f (``load_rows``); a field that
lies in the span of Phi -- a dam block's rigid motion, exactly (the block's interior is the
static extension of its boundary) -- or a DOF mask becomes its boundary rows and zero modal
coordinates (``field_rows``); the influence vectors r_x, r_y (the rock's is not in the span:
its bottom is fixed) are the M-orthogonal projections, so that M_r r = Phi^T M r (the seismic
load) exactly; a state q is recovered as u = Phi q (``expand``, one solve with K_ii).

Sums of a load with a field that is *not* in the span (a block's lever arms (x - x_c, y - y_c),
which the finite rotations' moments need: run/rotation.py) are not those of the reduced
coordinates: the reduced model keeps the full mass matrix, gravity load and influence vectors
(``FullBulk``, the model's ``full_bulk()``) for them.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spl
from scipy.sparse.csgraph import connected_components

from .pairing import lower_faces

__all__ = ["Reduction", "FullBulk", "ReducedCoordinates", "reduce_model", "boundary_dofs", "BULKS"]

BULKS = ("full", "reduced")
# interior parts up to this many DOFs get every mode from a dense eigensolver (eigsh needs
# k < n): the reduced bulk with every mode kept is then the full bulk (tests)
DENSE_EIG = 1500


@dataclass
class FullBulk:
    """The full model's quantities on its free DOFs that a reduced model keeps (module
    docstring): named as the model's own, so that ``model.full_bulk()`` reads alike for both
    bulks."""
    M: sp.csr_matrix            # (nfull, nfull) the mass matrix (with the added mass)
    f_gravity: np.ndarray       # (nfull,) the dead load
    r_x: np.ndarray             # (nfull,) the influence vectors
    r_y: np.ndarray


@dataclass
class Reduction:
    """The Craig-Bampton basis of a model (module docstring); Psi is never kept (it is
    n_interior x n_boundary): recoveries solve with the factor of K_ii."""
    nfull: int                  # free DOFs of the full model
    bdofs: np.ndarray           # full free indices of the boundary DOFs (sorted)
    idofs: np.ndarray           # ... of the interior DOFs
    Kib: sp.csr_matrix          # (n_i, n_b)
    Kii_lu: Any                 # scipy splu of K_ii
    V: np.ndarray               # (n_i, n_m) fixed-interface modes, V^T M_ii V = I
    freqs_hz: np.ndarray        # (n_m,) their frequencies
    cutoff_hz: float            # the requested cut-off (0: the count decides)
    n_requested: int            # the requested count
    full: Any = None            # FullBulk: the full model's M, f_gravity, r_x, r_y

    @property
    def nb(self) -> int:
        return self.bdofs.size

    @property
    def nm(self) -> int:
        return self.V.shape[1]

    @property
    def n(self) -> int:
        return self.nb + self.nm

    def dof_map(self) -> np.ndarray:
        """(nfull,) the reduced index of each full free DOF (-1: interior)."""
        m = -np.ones(self.nfull, dtype=np.int64)
        m[self.bdofs] = np.arange(self.nb)
        return m

    def expand(self, q) -> np.ndarray:
        """u = Phi q (one solve with K_ii); q (n,) or (n, k)."""
        q = np.asarray(q, dtype=np.float64)
        qb, qm = q[:self.nb], q[self.nb:]
        u = np.zeros((self.nfull,) + q.shape[1:])
        u[self.bdofs] = qb
        u[self.idofs] = -self.Kii_lu.solve(np.asarray(self.Kib @ qb)) + self.V @ qm
        return u

    def project(self, f) -> np.ndarray:
        """Phi^T f: [f_b + Psi^T f_i, V^T f_i] (K symmetric: Psi^T f_i = -K_bi K_ii^-1 f_i)."""
        f = np.asarray(f, dtype=np.float64)
        fi = f[self.idofs]
        out = np.empty((self.n,) + f.shape[1:])
        out[:self.nb] = f[self.bdofs] - self.Kib.T @ self.Kii_lu.solve(fi)
        out[self.nb:] = self.V.T @ fi
        return out

    def rows(self, v) -> np.ndarray:
        """[v_b, 0]: a field that lies in the span of Phi (or a DOF mask) in reduced
        coordinates."""
        v = np.asarray(v)
        out = np.zeros((self.n,) + v.shape[1:], dtype=v.dtype)
        out[:self.nb] = v[self.bdofs]
        return out

    def columns(self, A) -> sp.csr_matrix:
        """A Phi for A whose columns are boundary DOFs only (B): the columns re-indexed."""
        A = sp.csr_matrix(A, copy=True)
        A.eliminate_zeros()                  # stored zeros (NGSolve's patterns) touch nothing
        m = self.dof_map()
        cols = m[A.indices]
        if np.any(cols < 0):
            raise ValueError("reduced bulk: an operator touches an interior DOF; its DOFs must "
                             "be boundary DOFs (fe/reduction.py)")
        return sp.csr_matrix((A.data.copy(), cols, A.indptr.copy()), shape=(A.shape[0], self.n))

    def both(self, A) -> sp.csr_matrix:
        """Phi^T A Phi for A on boundary DOFs only (the added mass): rows and columns
        re-indexed."""
        return self.columns(self.columns(A).T).T.tocsr()

    def summary(self) -> dict:
        return {"bulk": "reduced", "boundary_dofs": int(self.nb), "modes_kept": int(self.nm),
                "modes_requested": int(self.n_requested),
                "cutoff_hz": float(self.cutoff_hz) if self.cutoff_hz > 0 else None,
                "highest_mode_hz": float(self.freqs_hz[-1]) if self.nm else None,
                "reduced_dofs": int(self.n), "full_dofs": int(self.nfull)}


class ReducedCoordinates:
    """What makes a ``fe.model.Model`` a reduced one (``reduce_model`` builds the dataclass
    ``ReducedModel`` from it and the model's own class): K, M, loads, influence vectors,
    interface and joint operators, crest and dam masks, reservoir coupling are in the reduced
    coordinates q (module docstring); ``free`` and ``fes`` are the full model's (the fe
    functions that assemble on them finish with ``load_rows`` / ``field_rows`` /
    ``dof_map``)."""
    reduction: Reduction

    @property
    def nfree(self) -> int:
        return self.reduction.n

    def dof_map(self) -> np.ndarray:
        return self.reduction.dof_map()

    def field_rows(self, v):
        return self.reduction.rows(v)

    def load_rows(self, f):
        return self.reduction.project(f)

    def expand(self, u):
        return self.reduction.expand(u)

    def full_bulk(self):
        """The full model's M, f_gravity, r_x, r_y on its free DOFs (``FullBulk``)."""
        return self.reduction.full

    def to_gridfunction(self, u_free, gf=None):
        return super().to_gridfunction(self.reduction.expand(u_free), gf)

    def summary(self) -> dict:
        d = super().summary()
        d["bulk"] = self.reduction.summary()
        return d


_CLASSES: dict = {}


def _reduced_class(base):
    """The dataclass ReducedModel(ReducedCoordinates, base) with the field ``reduction``."""
    cls = _CLASSES.get(base)
    if cls is None:
        cls = dataclasses.make_dataclass(
            "ReducedModel", [("reduction", Any, dataclasses.field(default=None))],
            bases=(ReducedCoordinates, base))
        _CLASSES[base] = cls
    return cls


def boundary_dofs(model) -> np.ndarray:
    """The DOFs kept physical (module docstring), full free indices, sorted."""
    sets = [np.unique(model.interface.B.indices), np.asarray(model.crest_dofs, np.int64)]
    res = getattr(model, "reservoir", None)
    if res is not None:
        if res.added_mass is not None:
            sets.append(np.unique(sp.csr_matrix(res.added_mass).indices))
        if res.acoustic is not None:
            sets.append(np.unique(res.acoustic.Q.nonzero()[0]))
            if res.acoustic.added_mass is not None:
                sets.append(np.unique(sp.csr_matrix(res.acoustic.added_mass).indices))
    for _, face in lower_faces(model).values():
        if face is not None:
            d = face.dofs.ravel()
            sets.append(d[d >= 0])
    return np.unique(np.concatenate(sets)).astype(np.int64)


def _spd_lu(A):
    """SuperLU of a symmetric positive definite matrix: symmetric mode, MMD on A^T + A, no
    pivoting (a sparser factor than the default COLAMD: its solves are what the reduction
    costs)."""
    return spl.splu(sp.csc_matrix(A), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                    options=dict(SymmetricMode=True))


def _modes(Kii, Mii, n_modes, cutoff_hz):
    """Fixed-interface modes of (K_ii, M_ii), each connected part of the interior (a dam
    block, the rock) on its own (a cut-off through a degenerate pair then never mixes two
    regions), the lowest ``n_modes`` kept, or every one below ``cutoff_hz`` (> 0)."""
    ncomp, lab = connected_components(Kii, directed=False)
    vecs, lams = [], []
    for c in range(ncomp):
        idx = np.flatnonzero(lab == c)
        Kc = Kii[idx][:, idx].tocsc()
        Mc = Mii[idx][:, idx].tocsc()
        if Mc.nnz == 0 or not np.any(Mc.diagonal() > 0):
            continue                                   # massless (no dynamics)
        if idx.size <= DENSE_EIG:                      # small: every mode, dense
            lam, X = sla.eigh(Kc.toarray(), Mc.toarray())
            Vc = np.zeros((Kii.shape[0], lam.size))
            Vc[idx] = X
            vecs.append(Vc)
            lams.append(lam)
            continue
        luc = _spd_lu(Kc)
        op = spl.LinearOperator(Kc.shape, matvec=luc.solve, dtype=np.float64)
        top = idx.size - 1                             # eigsh needs k < n
        kk = min(top, 32 if cutoff_hz > 0 else n_modes)
        while True:
            # a fixed start vector: the same basis when a run is resumed; pseudo-random, not
            # ones (a symmetric part's modes may be orthogonal to a symmetric start)
            v0 = np.random.default_rng(idx.size).standard_normal(idx.size)
            lam, X = spl.eigsh(Kc, k=kk, M=Mc, sigma=0.0, which="LM", OPinv=op, v0=v0)
            o = np.argsort(lam)
            lam, X = lam[o], X[:, o]
            if (cutoff_hz <= 0 or kk >= top
                    or np.sqrt(max(lam[-1], 0.0)) / (2 * np.pi) > cutoff_hz):
                break
            kk = min(2 * kk, top)
        Vc = np.zeros((Kii.shape[0], lam.size))
        Vc[idx] = X
        vecs.append(Vc)
        lams.append(lam)
    lam = np.concatenate(lams)
    V = np.hstack(vecs)
    o = np.argsort(lam, kind="stable")
    lam, V = lam[o], V[:, o]
    f = np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi)
    keep = f <= cutoff_hz if cutoff_hz > 0 else np.arange(lam.size) < n_modes
    V = V[:, keep]
    # M_ii-normalised (eigsh's are, to round-off): normalise again, and the sign fixed (the
    # largest entry positive) so that a rebuilt basis gives the same coordinates (--resume)
    V = V / np.sqrt(np.einsum("ij,ij->j", V, Mii @ V))
    V = V * np.sign(V[np.argmax(np.abs(V), axis=0), np.arange(V.shape[1])])
    return V, f[keep]


def reduce_model(model, n_modes: int = 40, cutoff_hz: float = 0.0):
    """The model on its Craig-Bampton basis (module docstring): the lowest ``n_modes``
    fixed-interface modes, or (``cutoff_hz`` > 0) every mode up to that frequency."""
    if model.rock_sides == "absorbing":
        raise ValueError("solver.bulk = 'reduced' with geometry.rock_sides = 'absorbing': not "
                         "supported; allowed: rock_sides 'fixed' | 'roller' | 'free'")
    if n_modes < 1 and cutoff_hz <= 0:
        raise ValueError(f"solver.bulk_modes = {n_modes!r}: keeps no mode; allowed: >= 1")
    b = boundary_dofs(model)
    n = model.nfree
    inner = np.ones(n, bool)
    inner[b] = False
    i = np.flatnonzero(inner)
    K, M = model.K.tocsr(), model.M.tocsr()
    Kii = K[i][:, i].tocsc()
    Kib = K[i][:, b].tocsr()
    Mii = M[i][:, i].tocsr()
    Mib = M[i][:, b].tocsr()
    lu = _spd_lu(Kii)
    V, f = _modes(Kii, Mii, int(n_modes), float(cutoff_hz))
    if V.shape[1] == 0:
        raise ValueError(f"solver.bulk_cutoff_hz = {cutoff_hz!r}: keeps no mode (the lowest "
                         "fixed-interface mode is above it); allowed: a higher cut-off")
    # the constraint modes part by part of the interior (a dam block, the rock): each part's
    # Psi_c = -K_cc^-1 K_cb is zero outside the part and on the boundary columns the part does
    # not touch (Psi^T M Psi is ~4x cheaper this way on Koyna than on the whole interior)
    nb = b.size
    Kr_bb = K[b][:, b].toarray()
    Mr_bb = M[b][:, b].toarray()
    Mr_mb = np.zeros((V.shape[1], nb))
    _, lab = connected_components(Kii, directed=False)
    for c in np.unique(lab):
        idx = np.flatnonzero(lab == c)
        Kcb, Mcb = Kib[idx], Mib[idx]
        cols = np.union1d(np.unique(Kcb.indices), np.unique(Mcb.indices))
        if cols.size == 0:
            continue
        Kcb, Mcb = Kcb[:, cols], Mcb[:, cols].toarray()
        Psi = -_spd_lu(Kii[idx][:, idx]).solve(Kcb.toarray())      # (n_c, |cols|)
        MPsi = Mii[idx][:, idx] @ Psi
        MbP = Mcb.T @ Psi
        ix = np.ix_(cols, cols)
        Kr_bb[ix] += np.asarray(Kcb.T @ Psi)
        Mr_bb[ix] += MbP + MbP.T + Psi.T @ MPsi
        Mr_mb[:, cols] += V[idx].T @ (Mcb + MPsi)
        del Psi, MPsi
    nm = V.shape[1]
    lam = np.einsum("ij,ij->j", V, Kii @ V)
    Kr = np.zeros((nb + nm, nb + nm))
    Kr[:nb, :nb] = 0.5 * (Kr_bb + Kr_bb.T)
    Kr[nb:, nb:] = np.diag(lam)
    Mr = np.zeros_like(Kr)
    Mr[:nb, :nb] = 0.5 * (Mr_bb + Mr_bb.T)
    Mr[nb:, :nb] = Mr_mb
    Mr[:nb, nb:] = Mr_mb.T
    Mr[nb:, nb:] = np.eye(nm)
    red = Reduction(n, b, i, Kib, lu, V, f, float(cutoff_hz), int(n_modes),
                    full=FullBulk(M, np.asarray(model.f_gravity, dtype=np.float64),
                                  np.asarray(model.r_x, dtype=np.float64),
                                  np.asarray(model.r_y, dtype=np.float64)))
    Mr_s = sp.csr_matrix(Mr)
    # influence vectors: the M-orthogonal projections (M_r r_r = Phi^T M r, the seismic load);
    # on massless DOFs (a massless rock: its rows of M_r vanish, and those of Phi^T M r) the
    # boundary rows, which the masks of the collapse rule and the resultants read
    massless = ~np.any(Mr != 0.0, axis=1)
    heavy = np.flatnonzero(~massless)
    rx, ry = (red.rows(r).astype(np.float64) for r in (model.r_x, model.r_y))
    for rr, r in ((rx, model.r_x), (ry, model.r_y)):
        rr[heavy] = np.linalg.solve(Mr[np.ix_(heavy, heavy)], red.project(M @ r)[heavy])
    iface = dataclasses.replace(model.interface, B=red.columns(model.interface.B))
    joints = {k: dataclasses.replace(j, B=red.columns(j.B)) for k, j in model.joints.items()}
    dmap = red.dof_map()
    res = model.reservoir
    if res is not None:
        ac = res.acoustic
        if ac is not None:
            if ac.incompressible:
                raise ValueError("solver.bulk = 'reduced' with reservoir.compressible = false "
                                 "(acoustic): not supported; allowed: compressible water, or "
                                 "reservoir.model = 'westergaard'")
            Qr = red.columns(ac.Q.T.tocsr()).T.tocsr()
            ac = dataclasses.replace(ac, Q=Qr)
        res = dataclasses.replace(res, acoustic=ac, added_mass=None if res.added_mass is None
                                  else red.both(res.added_mass))
    kw = {f.name: getattr(model, f.name) for f in dataclasses.fields(model)}
    kw.update(K=sp.csr_matrix(Kr), M=Mr_s, f_gravity=red.project(model.f_gravity),
              f_water=red.project(model.f_water), r_x=rx, r_y=ry, interface=iface,
              crest_dofs=(int(dmap[model.crest_dofs[0]]), int(dmap[model.crest_dofs[1]])),
              dam_dofs=red.rows(model.dam_dofs), reservoir=res, joints=joints, reduction=red)
    return _reduced_class(type(model))(**kw)
