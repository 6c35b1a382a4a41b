"""The wetted upstream face: its normal and the dam's normal displacement on it (shared by
the Westergaard added mass and the acoustic reservoir)."""
from __future__ import annotations

__all__ = ["face_normal_cf", "dam_normal_trial_test", "region_bands"]


def face_normal_cf():
    """Unit normal of the upstream face pointing from the water into the dam (+x side): the
    mesh normal's sign is not reliable on internal or merged boundaries, so it is fixed by its
    x-component (an upstream face that the water can wet has n_x != 0)."""
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs

    n = ngs.specialcf.normal(2)
    return ngs.IfPos(n[0], 1.0, -1.0) * n



def dam_normal_trial_test(fes, components, bands=None):
    """(u . n, v . n) of the dam displacement on the face: the sum over the dam fields of a
    product space (components: their indices), or the space itself (components None).  With
    lift joints each block's field is weighted by the indicator of its elevation band
    (bands: [(y_lo, y_hi)] per component): a block's field also has a trace on the face edges
    next to its joint vertex, which would count that edge twice (measured: Q^T r_x off by 20 %
    at the joint's pressure DOF)."""
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs

    n = face_normal_cf()
    u, v = fes.TnT()
    if components is None:
        return u * n, v * n
    if bands is None:
        bands = [None] * len(components)

    def chi(b):
        if b is None:
            return 1.0
        return ngs.IfPos(ngs.y - b[0], 1.0, 0.0) * ngs.IfPos(b[1] - ngs.y, 1.0, 0.0)

    un = sum(chi(b) * (u[k] * n) for k, b in zip(components, bands))
    vn = sum(chi(b) * (v[k] * n) for k, b in zip(components, bands))
    return un, vn



def region_bands(mesh, regions):
    """(y_min, y_max) of each region's vertices (the dam blocks between lift joints)."""
    out = []
    for r in regions:
        ys = [mesh.vertices[v.nr].point[1] for el in mesh.Materials(r).Elements()
              for v in el.vertices]
        out.append((min(ys), max(ys)))
    return out
