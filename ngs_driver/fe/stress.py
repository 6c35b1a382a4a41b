"""Element stresses of the dam blocks as sparse operators on the free displacements: for P1
triangles the stress is constant per element, sigma_ij = S_ij u (plane strain, each block its
own Lame constants). Used by the linear screening of the dam body (run/screening.py)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .ngs_helpers import to_scipy, vec

__all__ = ["ElementStress", "element_stress"]


@dataclass
class ElementStress:
    S: dict              # {"xx" | "yy" | "xy": (elements, nfree) CSR}: element stress = S u
    x: np.ndarray        # element centroids
    y: np.ndarray
    triangles: np.ndarray    # (elements, 3, 2) vertex coordinates (figures)


def element_stress(model) -> ElementStress:
    """The constant stress of every dam element (rock excluded) as S u: the L2 projection of
    sigma(u) onto piecewise constants (exact for P1), element by element."""
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs


    mesh, fes, free = model.mesh, model.fes, model.free
    trial = fes.TrialFunction()
    trial = tuple(trial) if isinstance(trial, (list, tuple)) else (trial,)
    blocks = [r for r in model.regions if r != "rock"]
    rows = {c: [] for c in ("xx", "yy", "xy")}
    xs, ys, tris = [], [], []
    for k, reg in enumerate(blocks):
        Q = ngs.Compress(ngs.L2(mesh, order=0, definedon=mesh.Materials(reg)))
        q, pq = Q.TestFunction(), Q.TrialFunction()
        dxr = ngs.dx(definedon=mesh.Materials(reg))
        mq = ngs.BilinearForm(Q)
        mq += pq * q * dxr
        mq.Assemble()
        area = to_scipy(mq.mat).diagonal()
        mat = model.materials[reg]
        e = ngs.Sym(ngs.Grad(trial[k]))
        s = mat.lam * ngs.Trace(e) * ngs.Id(2) + 2 * mat.mu * e
        for c, (i, j) in (("xx", (0, 0)), ("yy", (1, 1)), ("xy", (0, 1))):
            b = ngs.BilinearForm(trialspace=fes, testspace=Q)
            b += s[i, j] * q * dxr
            b.Assemble()
            rows[c].append(sp.diags(1.0 / area) @ to_scipy(b.mat, (Q.ndof, fes.ndof))
                           [:, free])
        for cf, out in ((ngs.x, xs), (ngs.y, ys)):
            lf = ngs.LinearForm(Q)
            lf += cf * q * dxr
            lf.Assemble()
            out.append(vec(lf) / area)
        tri = np.zeros((Q.ndof, 3, 2))
        for el in mesh.Elements(ngs.VOL):
            d = Q.GetDofNrs(el)
            if len(d) and d[0] >= 0:
                tri[d[0]] = [mesh.vertices[v.nr].point[:2] for v in el.vertices]
        tris.append(tri)
    return ElementStress({c: sp.vstack(v).tocsr() for c, v in rows.items()},
                         np.concatenate(xs), np.concatenate(ys), np.concatenate(tris))
