"""The damping of a run (``damping.model``; docs/sliding.md): Rayleigh C = a0 M + a1 K (bulk K
only), stiffness-proportional C = a1 K, or Rayleigh with the mass term off the blocks' rigid
sliding and rocking (``solve.damping``), its coefficients from the modal analysis with the
joints bonded at two modes or frequencies (Chopra, Dynamics of Structures, §11.4); plus the
Lysmer-Kuhlemeyer dashpots of absorbing rock boundaries."""
from __future__ import annotations

from ..fe.blocks import block_rigid_modes
from ..fe.modal import damping_from_modes
from ..solve.damping import DeformationDamping

__all__ = ["rayleigh_damping", "damping_matrix", "low_rank_damping", "modes_to_compute"]

N_MODES = 6        # the modes a run computes (summary.json frequencies_hz) ...


def modes_to_compute(d, n: int = N_MODES) -> int:
    """... or more, when the damping is set at a higher mode (``damping.modes`` up to 50).
    d: the scene's [damping] table."""
    if d.frequencies or not d.modes:
        return n
    return max(n, max(int(m) for m in d.modes))


def rayleigh_damping(modal, d, restart: dict | None = None) -> dict:
    """The Rayleigh coefficients (dict of ``fe.modal.damping_from_modes``). ARPACK's random
    start vector changes the last bits of the eigenvalues from call to call: a0, a1 are rounded
    to 10 significant digits so that runs (and restarts) are bitwise repeatable; a restart
    takes the checkpoint's values (``restart``: its meta). d: the scene's [damping] table."""
    damp = damping_from_modes(modal, d.ratio, d.modes, d.frequencies or None, d.model)
    damp["a0_unrounded"], damp["a1_unrounded"] = damp["a0"], damp["a1"]
    damp["a0"], damp["a1"] = float(f"{damp['a0']:.10g}"), float(f"{damp['a1']:.10g}")
    if restart is not None and "rayleigh" in restart:
        damp["a0"], damp["a1"] = restart["rayleigh"]["a0"], restart["rayleigh"]["a1"]
    return damp


def damping_matrix(model, damp, absorbing=None):
    """C = a0 M + a1 K (+ the dashpots of absorbing boundaries), CSR."""
    C = (damp["a0"] * model.M + damp["a1"] * model.K).tocsr()
    if absorbing is not None:
        C = (C + absorbing.C).tocsr()
    return C


def low_rank_damping(model, joints, damp):
    """``damping.model = "rayleigh_deformation"``: the dense low-rank part of C that keeps the
    mass term off each dam block's rigid motion on its joint (``solve.damping``); else None."""
    if damp.get("model") != "rayleigh_deformation" or damp["a0"] == 0.0:
        return None
    iface = model.interface
    R, cents = block_rigid_modes(model)
    return DeformationDamping(model.M, R, cents, iface.B, iface.x, iface.y, iface.w,
                              joints.slices, damp["a0"])
