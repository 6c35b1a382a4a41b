"""Scene -> interface laws (one per joint) and size-scale laws (no NGSolve).

One validation truth: the parameter classes of ``interfacelaw`` check their own ranges;
``validate_laws`` builds every joint's law from the scene and re-raises the law's error with
the scene key (``interface.alpha``, ``joints[0].g_max``, ...), so ``--dry-run`` rejects what
the law would reject, before anything is meshed.
"""
from __future__ import annotations

import re

from interfacelaw import CohesiveParams, ContactParams, DamageParams, FrictionParams, InterfaceLaw
from interfacelaw.scaling import SizeScaling, characteristic_times as ct

__all__ = ["build_law", "build_scaling", "law_parts", "validate_laws", "characteristic_times",
           "paper_k0"]

# the scene key of each law parameter (class.field -> [interface] key)
_SCENE_KEY = {"CohesiveParams.sigma_max": "sigma_max", "CohesiveParams.tau_max": "tau_max",
              "CohesiveParams.l_Nc": "G_I", "CohesiveParams.l_Tc": "ratio_lTc_lNc",
              "CohesiveParams.G_I": "G_I", "CohesiveParams.ratio_lTc_lNc": "ratio_lTc_lNc",
              "CohesiveParams.lambda_max": "lambda_max", "FrictionParams.f": "friction",
              "DamageParams.g_max": "g_max", "DamageParams.alpha": "alpha",
              "DamageParams.beta": "beta", "DamageParams.F_th": "F_th",
              "DamageParams.form": "damage_form", "DamageParams.t_ref": "t_ref",
              "ContactParams.kind": "contact", "ContactParams.penalty": "contact_stiffness",
              "ContactParams.intact_stiffness": "contact_stiffness",
              "FrictionParams.penalty": "contact_stiffness"}


def _table(obj):
    """An [interface] table from a scene (its base table) or the table itself."""
    return obj.interface if hasattr(obj, "interface") else obj


def build_law(tbl):
    """InterfaceLaw of an [interface] table (or of a scene's base table): cohesive + contact
    + friction + damage, each part only if the table asks for it."""

    i = _table(tbl)
    coh = CohesiveParams.from_fracture_energy(i.sigma_max, i.tau_max, i.G_I, i.lambda_max,
                                              i.ratio_lTc_lNc)
    kc = getattr(i, "contact_stiffness", None)
    # the joint's compressive stiffness (closed crack and intact bond alike) and the stick
    # stiffness of friction: one named value, not the cohesive law's (docs/sliding.md)
    con = None if i.contact == "none" else ContactParams(kind=i.contact, penalty=kc,
                                                         intact_stiffness=kc)
    fri = (FrictionParams(f=i.friction, penalty=kc) if (con is not None and i.friction > 0)
           else None)
    dmg = None
    if i.damage:
        kw = dict(g_max=i.g_max, alpha=i.alpha, beta=i.beta, F_th=i.F_th, form=i.damage_form)
        if getattr(i, "t_ref", None) is not None and i.damage_form == "rate":
            kw["t_ref"] = i.t_ref
        dmg = DamageParams(**kw)
    return InterfaceLaw(coh, con, fri, dmg)


def validate_laws(scene) -> None:
    """Build every joint's law and size scaling; a ValueError names the scene key."""
    for k, (name, tbl) in enumerate(scene.joint_tables()):
        where = "interface" if name == "base" else f"joints[{k - 1}]"
        try:
            if tbl.friction < 0:     # the friction part is built only for f > 0: check it
                FrictionParams(f=tbl.friction)
            law = build_law(tbl)
            build_scaling(tbl, law)
        except (ValueError, TypeError) as e:
            msg = str(e)
            m = re.search(r"(\w+Params\.\w+)", msg)
            key = _SCENE_KEY.get(m.group(1)) if m else None
            if key is not None:
                raise ValueError(f"{where}.{key} = {getattr(tbl, key, '?')!r}: rejected by the "
                                 f"interface law: {msg}") from None
            raise ValueError(f"{where}: rejected by the interface law: {msg}") from None


def build_scaling(tbl, law):
    """SizeScaling with the table's reference parameters (None if scaling is off)."""
    i = _table(tbl)
    if not i.scaling:
        return None

    f_ref = i.friction if i.friction > 0 else 0.3
    # the stick stiffness of friction stays the joint's contact stiffness as the law scales
    # (docs/sliding.md §3), not the reference cohesive shear stiffness
    penalty = law.friction.penalty if law.friction is not None else "reference"
    return SizeScaling(law.cohesive, f_ref=f_ref, friction_penalty=penalty)


def law_parts(tbl) -> dict:
    i = _table(tbl)
    return {"cohesive": "Geubelle-Baylor bilinear mixed mode",
            "contact": i.contact,
            "friction": bool(i.contact != "none" and i.friction > 0),
            "damage": bool(i.damage), "damage_form": i.damage_form, "damage_alpha": i.alpha,
            "damage_beta": i.beta, "damage_g_max": i.g_max,
            "contact_stiffness": getattr(i, "contact_stiffness", None),
            "cracked": bool(getattr(i, "cracked", False)),
            "scaling": bool(getattr(i, "scaling", False))}


def characteristic_times(scene, l_Nc: float) -> dict:
    """Paper Eq. 11 for the dam concrete: t1 = rho c_L l_Nc/(2 sigma_max), t2 = a0/c_L, with
    a0 the (bonded) base width of the scene's section."""

    m = scene.materials.dam
    a0 = scene.section.base_width
    r = ct(m.E, m.rho, l_Nc, scene.interface.sigma_max, a0)
    return {"t1": float(r.t1), "t2": float(r.t2), "c_L": float(r.c_L), "a0": a0, "l_Nc": l_Nc,
            "material": "dam concrete", "equation": "paper Eq. 11"}


def paper_k0(sigma_max: float = 3e6, tau_max: float = 3e6, G_I: float = 250.0,
             lambda_max: float = 0.2, ratio_lTc_lNc: float = 1.0) -> tuple[float, float]:
    """Initial (bonded) stiffness [Pa/m] (normal, tangential) of the paper's law:
    k_N = sigma_max/(lambda_max l_Nc), k_T = tau_max l_Nc/(lambda_max l_Tc^2),
    l_Nc = 2 G_I/sigma_max, l_Tc = ratio l_Nc (docs/law.md §2).
    Paper values: 3e6 / (0.2 * 1.667e-4) = 9.0e10 Pa/m."""
    l_nc = 2.0 * G_I / sigma_max
    l_tc = ratio_lTc_lNc * l_nc
    return sigma_max / (lambda_max * l_nc), tau_max * l_nc / (lambda_max * l_tc ** 2)
