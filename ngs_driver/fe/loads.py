"""Static loads assembled on the model besides gravity and the reservoir (fe/model.py):
hydrostatic tailwater (USACE EM 1110-2-2100 §3-3; docs/safety.md)."""
from __future__ import annotations

from .ngs_helpers import vec

__all__ = ["tailwater_load"]


def tailwater_load(model, level: float, rho_w: float, gravity: float):
    """Hydrostatic tailwater on the downstream face (and the rock top downstream of the toe)
    as a free-DOF load vector; None when there is no tailwater. Traction -p n_out, n_out the
    dam's outward normal (n_x > 0 on the downstream face)."""
    if level <= 0.0:
        return None
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs


    test = model.fes.TestFunction()
    test = tuple(test) if isinstance(test, (list, tuple)) else (test,)
    nb = sum(1 for r in model.regions if r != "rock")
    pw = rho_w * gravity * ngs.IfPos(level - ngs.y, level - ngs.y, 0.0)
    nrm = ngs.specialcf.normal(2)
    n_out = ngs.IfPos(nrm[0], 1.0, -1.0) * nrm
    lf = ngs.LinearForm(model.fes)
    for vv in test[:nb]:
        lf += -pw * ngs.InnerProduct(n_out, vv) * ngs.ds("downstream", bonus_intorder=2)
    if "rock" in model.regions and "rock_top_down" in set(model.mesh.GetBoundaries()):
        lf += -rho_w * gravity * level * test[-1][1] * ngs.ds("rock_top_down")
    lf.Assemble()
    return model.load_rows(vec(lf)[model.free])
