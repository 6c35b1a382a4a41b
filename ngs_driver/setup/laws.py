"""Scene -> interface law(s) and size-scale laws (no NGSolve).

One validation truth: the law objects of ``interfacelaw`` check their own parameter ranges;
``scene.py`` builds them at load time (``validate_laws``) so that a bad value is reported with
its scene key before anything is meshed.
"""
from __future__ import annotations

import math

INTERFACE_LENGTH_A0 = 70.0          # a0 of Eq. 11: the whole (bonded) interface [m]



def build_law(scene):
    """InterfaceLaw of the scene's [interface] table (cohesive + contact + friction + damage)."""
    from interfacelaw import (CohesiveParams, ContactParams, DamageParams, FrictionParams,
                              InterfaceLaw)

    i = scene.interface
    coh = CohesiveParams.from_fracture_energy(i.sigma_max, i.tau_max, i.G_I, i.lambda_max,
                                              i.ratio_lTc_lNc)
    con = None if i.contact == "none" else ContactParams(kind=i.contact)
    fri = FrictionParams(f=i.friction) if (con is not None and i.friction > 0) else None
    dmg = (DamageParams(g_max=i.g_max, alpha=i.alpha, beta=i.beta, F_th=i.F_th,
                        form=i.damage_form) if i.damage else None)
    return InterfaceLaw(coh, con, fri, dmg)



def build_scaling(scene, law):
    """SizeScaling with the scene's reference parameters (None if interface.scaling is off)."""
    if not scene.interface.scaling:
        return None
    from interfacelaw.scaling import SizeScaling

    f_ref = scene.interface.friction if scene.interface.friction > 0 else 0.3
    return SizeScaling(law.cohesive, f_ref=f_ref)



def law_parts(scene) -> dict:
    i = scene.interface
    return {"cohesive": "Geubelle-Baylor bilinear mixed mode",
            "contact": i.contact,
            "friction": bool(i.contact != "none" and i.friction > 0),
            "damage": bool(i.damage), "damage_form": i.damage_form, "damage_alpha": i.alpha,
            "damage_beta": i.beta, "damage_g_max": i.g_max,
            "scaling": bool(getattr(i, "scaling", False))}



def characteristic_times(scene, l_Nc: float) -> dict:
    """Paper Eq. 11 for the dam concrete: t1 = rho c_L l_Nc/(2 sigma_max), t2 = a0/c_L."""
    m = scene.materials.dam
    s = scene.interface.sigma_max
    try:
        from interfacelaw.scaling import characteristic_times as ct
        r = ct(m.E, m.rho, l_Nc, s, INTERFACE_LENGTH_A0)
        t1, t2, c = float(r.t1), float(r.t2), float(r.c_L)
    except ImportError:  # pragma: no cover
        c = math.sqrt(m.E / m.rho)
        t1, t2 = m.rho * c * l_Nc / (2 * s), INTERFACE_LENGTH_A0 / c
    return {"t1": t1, "t2": t2, "c_L": c, "a0": INTERFACE_LENGTH_A0, "l_Nc": l_Nc,
            "material": "dam concrete", "equation": "paper Eq. 11"}
