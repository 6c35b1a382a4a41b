"""The ``modal`` command: a scene's natural frequencies with the joints bonded, its Rayleigh
damping, written to ``modal.json`` (and the reservoir's coupled response when the scene has
water). The eigen-analysis itself is ``fe.modal``."""
from __future__ import annotations

from pathlib import Path

from ..fe.modal import damping_from_modes, k0_from_scene, modal_analysis
from ..post.modal import write_frequency_response, write_modal_json
from ..run.damping import modes_to_compute
from ..run.joints import Joints
from ..solve.joint_laws import initial_stiffness

__all__ = ["run_modal"]


def run_modal(scene, out_dir=None, n_modes: int = 6, model=None):
    """Build the scene's model, run the modal analysis, write ``modal.json`` to out_dir
    (default: scene.output.dir).  Returns (model, ModalResult, damping dict)."""
    from ..fe.model import build_from_scene

    md = model if model is not None else build_from_scene(scene)
    kn, kt = k0_from_scene(scene)
    # each joint with its own initial stiffness (the base's alone without lift joints)
    k0 = initial_stiffness(Joints(scene, md.interface).solver_law(), md.interface.npts)
    res = modal_analysis(md, modes_to_compute(scene, n_modes), k0[:, 0], k0[:, 1])
    d = scene.damping
    damp = damping_from_modes(res, d.ratio, d.modes, d.frequencies or None, d.model)
    out = Path(out_dir if out_dir is not None else scene.output.dir)
    extra = {"scene": scene.name, "nfree": md.nfree,
             "plane": getattr(scene.materials, "plane", "strain"),
             "f1_hz": float(res.frequencies_hz[0])}
    if getattr(md, "reservoir", None) is not None:          # docs/reservoir.md
        from ..fe.reservoir import modal_response
        info, resp = modal_response(md, scene, kn, kt)
        if resp is not None:
            info["frequency_response"] = write_frequency_response(out, scene, resp)
        extra["reservoir"] = info
    write_modal_json(out / "modal.json", res, damp, extra)
    return md, res, damp
