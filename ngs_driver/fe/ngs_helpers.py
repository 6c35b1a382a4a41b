"""Small NGSolve <-> numpy/scipy helpers shared by the FE stage."""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["to_scipy", "vec", "find_vertex", "vertex_xy_dofs"]


def to_scipy(mat, shape=None) -> sp.csr_matrix:
    r, c, v = mat.COO()
    shape = shape or (mat.height, mat.width)
    return sp.csr_matrix((np.asarray(v), (np.asarray(r), np.asarray(c))), shape=shape)



def vec(lf) -> np.ndarray:
    return np.array(lf.vec.FV().NumPy(), copy=True)



def find_vertex(mesh, x, y, tol=1e-8) -> int:
    best, bd = -1, np.inf
    for v in mesh.vertices:
        p = v.point
        d = (p[0] - x) ** 2 + (p[1] - y) ** 2
        if d < bd:
            best, bd = v.nr, d
    if bd > tol:
        raise ValueError(f"no mesh vertex at ({x}, {y})")
    return best



def vertex_xy_dofs(V, dofs) -> tuple[int, int]:
    """(x dof, y dof) of a vertex of a compressed VectorH1 (component-block layout)."""
    d = sorted(int(i) for i in dofs)
    assert len(d) == 2 and d[1] - d[0] == V.ndof // 2, (d, V.ndof)
    return d[0], d[1]
