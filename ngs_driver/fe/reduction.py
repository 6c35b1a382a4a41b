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

__all__ = ["Reduction", "FullBulk", "ReducedCoordinates", "reduce_model", "boundary_dofs",
           "available_modes", "BULKS", "DENSE_EIG", "MAX_CUTOFF_MODES"]

BULKS = ("full", "reduced")
# interior parts up to this many DOFs get every mode from a dense eigensolver (eigsh needs
# k < n): the reduced bulk with every mode kept is then the full bulk (tests)
DENSE_EIG = 1500
# the most modes eigsh is asked for while it looks for a cut-off (solver.bulk_cutoff_hz): a
# cut-off at or above the mesh's MAX_CUTOFF_MODES-th fixed-interface mode (it would keep this
# many or more) is refused (docs/reduced_bulk.md sec. 4); a part that gives this many modes
# all below the cut-off proves it. eigsh's cost grows ~k^2: on Koyna's rock interior (8 922
# DOFs) k = 256, 512, 1024 took 3.4, 12.8, 49 s (2026-11-27, 2 cores, load ~2-3; peak RSS 423 MB
# up to k = 512, 572 MB at 1024, with the model), so 512 bounds a refused search at about one
# reduced Koyna run; the shipped scenes' cut-off at the resolved frequency (setup/bulk.py) keeps
# at most 167 modes (Koyna, 136.4 Hz). Below DENSE_EIG: every part eigsh solves has more modes.
MAX_CUTOFF_MODES = 512


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


def _mass_parts(Kii, Mii) -> list:
    """The connected parts of the interior (a dam block, the rock) that have mass, in the
    order of ``connected_components``: (indices, K_cc, M_cc) each. A massless part (a
    massless rock) has no dynamics and no mode."""
    ncomp, lab = connected_components(Kii, directed=False)
    parts = []
    for c in range(ncomp):
        idx = np.flatnonzero(lab == c)
        Kc = Kii[idx][:, idx].tocsc()
        Mc = Mii[idx][:, idx].tocsc()
        if Mc.nnz == 0 or not np.any(Mc.diagonal() > 0):
            continue                                   # massless (no dynamics)
        parts.append((idx, Kc, Mc))
    return parts


def _part_modes(n: int) -> int:
    """The modes a part of n DOFs can give: all from the dense eigensolver (n <= DENSE_EIG),
    at most n - 1 from eigsh (it needs k < n)."""
    return n if n <= DENSE_EIG else n - 1


def _available(parts) -> int:
    """The fixed-interface modes the interior's parts with mass can give (``_part_modes``)."""
    return sum(_part_modes(idx.size) for idx, _, _ in parts)


def _interior(model):
    """(boundary DOFs, interior DOFs, K_ii, M_ii) of the model's free DOFs."""
    b = boundary_dofs(model)
    inner = np.ones(model.nfree, bool)
    inner[b] = False
    i = np.flatnonzero(inner)
    K, M = model.K.tocsr(), model.M.tocsr()
    return b, i, K[i][:, i].tocsc(), M[i][:, i].tocsr()


def available_modes(model) -> int:
    """The number of fixed-interface modes the model's interior can give: the upper end of
    ``solver.bulk_modes`` on this mesh (the sum over the interior's parts with mass of each
    part's modes, ``_part_modes``)."""
    _, _, Kii, Mii = _interior(model)
    return _available(_mass_parts(Kii, Mii))


def _check_count(parts, n_modes: int) -> None:
    """solver.bulk_modes above the modes the interior has: refused (before any eigensolve)."""
    sizes = [idx.size for idx, _, _ in parts]
    avail = _available(parts)
    if n_modes <= avail:
        return
    if avail == 0:
        raise ValueError(f"solver.bulk_modes = {n_modes!r}: this mesh's interior has no mass "
                         "(no fixed-interface mode); allowed: solver.bulk = 'full'")
    raise ValueError(f"solver.bulk_modes = {n_modes!r}: more than the {avail} fixed-interface "
                     f"modes this mesh's interior has (its parts with mass: "
                     f"{' + '.join(str(n) for n in sizes)} DOFs); allowed: 1 .. {avail}, or "
                     "solver.bulk = 'full'")


def _modes(parts, Mii, n_modes, cutoff_hz):
    """Fixed-interface modes of (K_ii, M_ii), each connected part with
    mass (``_mass_parts``: a dam block, the rock) on its own (a cut-off through a degenerate
    pair then never mixes two regions), the lowest ``n_modes`` kept, or every one below
    ``cutoff_hz`` (> 0) if that is below the mesh's MAX_CUTOFF_MODES-th mode (else ValueError
    naming the key)."""
    n_rows = Mii.shape[0]
    if not parts:
        key = (f"solver.bulk_cutoff_hz = {cutoff_hz!r}" if cutoff_hz > 0 else
               f"solver.bulk_modes = {n_modes!r}")
        raise ValueError(f"{key}: this mesh's interior has no mass (no fixed-interface mode); "
                         "allowed: solver.bulk = 'full'")
    vecs, lams = [], []
    capped = False                        # a part's search stopped at the ceiling
    for idx, Kc, Mc in parts:
        if idx.size <= DENSE_EIG:                      # small: every mode, dense
            lam, X = sla.eigh(Kc.toarray(), Mc.toarray())
            Vc = np.zeros((n_rows, lam.size))
            Vc[idx] = X
            vecs.append(Vc)
            lams.append(lam)
            continue
        luc = _spd_lu(Kc)
        op = spl.LinearOperator(Kc.shape, matvec=luc.solve, dtype=np.float64)
        top = idx.size - 1                             # eigsh needs k < n
        if cutoff_hz > 0:                              # never more than the ceiling
            top = min(top, MAX_CUTOFF_MODES)
        kk = min(top, 32 if cutoff_hz > 0 else n_modes)
        while True:
            # a fixed start vector: the same basis when a run is resumed; pseudo-random, not
            # ones (a symmetric part's modes may be orthogonal to a symmetric start)
            v0 = np.random.default_rng(idx.size).standard_normal(idx.size)
            lam, X = spl.eigsh(Kc, k=kk, M=Mc, sigma=0.0, which="LM", OPinv=op, v0=v0)
            o = np.argsort(lam)
            lam, X = lam[o], X[:, o]
            passed = np.sqrt(max(lam[-1], 0.0)) / (2 * np.pi) > cutoff_hz
            if cutoff_hz <= 0 or passed:
                break
            if kk >= top:
                capped = True
                break
            kk = min(2 * kk, top)
        Vc = np.zeros((n_rows, lam.size))
        Vc[idx] = X
        vecs.append(Vc)
        lams.append(lam)
    lam = np.concatenate(lams)
    V = np.hstack(vecs)
    o = np.argsort(lam, kind="stable")
    lam, V = lam[o], V[:, o]
    f = np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi)
    if cutoff_hz > 0 and (capped or np.count_nonzero(f <= cutoff_hz) >= MAX_CUTOFF_MODES):
        # the cut-off is at or above the mesh's MAX_CUTOFF_MODES-th mode: every part holds
        # each of its modes up to that mode's frequency (a part either passed the cut-off, or
        # gave its lowest MAX_CUTOFF_MODES, or every mode it has), so f's entry is the mesh's
        reach = f[min(MAX_CUTOFF_MODES, f.size) - 1]
        avail = _available(parts)
        raise ValueError(f"solver.bulk_cutoff_hz = {cutoff_hz!r}: at or above this mesh's "
                         f"{MAX_CUTOFF_MODES}th fixed-interface mode ({reach:.6g} Hz), the "
                         f"most a cut-off may reach (fe/reduction.py MAX_CUTOFF_MODES: eigsh "
                         f"is asked for no more modes); allowed: a cut-off below {reach:.6g} "
                         f"Hz, or solver.bulk_modes = a count (1 .. {avail}) with no cut-off, "
                         "or solver.bulk = 'full'")
    keep = f <= cutoff_hz if cutoff_hz > 0 else np.arange(lam.size) < n_modes
    V = V[:, keep]
    # M_ii-normalised (eigsh's are, to round-off): normalise again, and the sign fixed (the
    # largest entry positive) so that a rebuilt basis gives the same coordinates (--resume)
    V = V / np.sqrt(np.einsum("ij,ij->j", V, Mii @ V))
    V = V * np.sign(V[np.argmax(np.abs(V), axis=0), np.arange(V.shape[1])])
    return V, f[keep]


def reduce_model(model, n_modes: int = 40, cutoff_hz: float = 0.0):
    """The model on its Craig-Bampton basis (module docstring): the lowest ``n_modes``
    fixed-interface modes (at most ``available_modes(model)``), or (``cutoff_hz`` > 0) every
    mode up to that frequency (below the mesh's MAX_CUTOFF_MODES-th mode); ValueError naming
    the key, the value and what is allowed otherwise."""
    if model.rock_sides == "absorbing":
        raise ValueError("solver.bulk = 'reduced' with geometry.rock_sides = 'absorbing': not "
                         "supported; allowed: rock_sides 'fixed' | 'roller' | 'free'")
    if n_modes < 1 and cutoff_hz <= 0:
        raise ValueError(f"solver.bulk_modes = {n_modes!r}: keeps no mode; allowed: >= 1")
    b, i, Kii, Mii = _interior(model)
    n = model.nfree
    K, M = model.K.tocsr(), model.M.tocsr()
    parts = _mass_parts(Kii, Mii)
    if cutoff_hz <= 0:                       # the count against the mesh, before any solve
        _check_count(parts, int(n_modes))
    Kib = K[i][:, b].tocsr()
    Mib = M[i][:, b].tocsr()
    lu = _spd_lu(Kii)
    V, f = _modes(parts, Mii, int(n_modes), float(cutoff_hz))
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
