"""interfacelaw — the rock–concrete interface law of Paggi, Ferro & Braga (2013), §3.

Mixed-mode bilinear cohesive zone (Geubelle–Baylor), unilateral contact (linear or rough-surface
penalty), Coulomb friction after decohesion, cyclic damage, and size-scale laws. Pure numpy +
numba: usable from any FE code, never imports NGSolve.
"""
from .params import CohesiveParams, ContactParams, DamageParams, FrictionParams
from .law import BoundLaw, InterfaceLaw, InterfaceState

__all__ = ["CohesiveParams", "ContactParams", "FrictionParams", "DamageParams",
           "InterfaceLaw", "InterfaceState", "BoundLaw"]
__version__ = "0.1.0"
