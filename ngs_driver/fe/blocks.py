"""The dam's blocks as rigid bodies: their rigid-body motions and their kinematics at a joint.

A dam with lift joints is a stack of blocks (the base block on the foundation, then one block
above each joint), each with its own displacement field (fe/model.py). The rigid-body motions
of each block (two translations and the rotation about its centroid) span the motions that the
mass term of ``damping.model = "rayleigh_deformation"`` must not damp (solve/damping.py).
"""
from __future__ import annotations

import numpy as np

__all__ = ["block_rigid_modes", "linear_fields"]


def block_rigid_modes(model) -> tuple[np.ndarray, np.ndarray]:
    """(R, centroids): R (nfree, 3 n_blocks) holds, per dam block (``model.regions`` except
    "rock", bottom up), the free-DOF vectors of u = (1, 0), (0, 1) and (-(y - y_c), x - x_c)
    on that block and 0 elsewhere; centroids (n_blocks, 2) the (x_c, y_c) of each block (P1/Pk
    interpolation of a linear field is exact)."""
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs

    blocks = [k for k, r in enumerate(model.regions) if r != "rock"]
    cols, cents = [], []
    mesh = model.mesh
    for k in blocks:
        reg = model.regions[k]
        one = ngs.Integrate(ngs.CF(1.0), mesh, definedon=mesh.Materials(reg))
        xc = ngs.Integrate(ngs.x, mesh, definedon=mesh.Materials(reg)) / one
        yc = ngs.Integrate(ngs.y, mesh, definedon=mesh.Materials(reg)) / one
        cents.append((xc, yc))
        for cf in (ngs.CF((1.0, 0.0)), ngs.CF((0.0, 1.0)),
                   ngs.CF((-(ngs.y - yc), ngs.x - xc))):
            gf = ngs.GridFunction(model.fes)
            comp = gf if len(model.regions) == 1 else gf.components[k]
            comp.Set(cf)
            cols.append(model.field_rows(np.array(gf.vec.FV().NumPy(), copy=True)[model.free]))
    return np.column_stack(cols), np.array(cents, dtype=np.float64)


def linear_fields(model, regions) -> dict:
    """Free-DOF vectors of the linear fields u = (1, 0), (0, 1), (x, 0), (0, y), (y, 0) and
    (0, x) on the dam blocks ``regions`` and 0 elsewhere, keyed "Tx", "Ty", "Xx", "Yy", "Yx",
    "Xy" (the first letter the field, the second the component): every rigid motion and the
    lever arms of a load about any point are combinations of them (interpolation of a linear
    field is exact)."""
    import ngsolve as ngs

    x, y = ngs.x, ngs.y
    cfs = {"Tx": (1.0, 0.0), "Ty": (0.0, 1.0), "Xx": (x, 0.0), "Yy": (0.0, y),
           "Yx": (y, 0.0), "Xy": (0.0, x)}
    out = {}
    for key, (a, b) in cfs.items():
        gf = ngs.GridFunction(model.fes)
        for reg in regions:
            k = list(model.regions).index(reg)
            comp = gf if len(model.regions) == 1 else gf.components[k]
            comp.Set(ngs.CF((a, b)))
        out[key] = np.array(gf.vec.FV().NumPy(), copy=True)[model.free]
    return out
