"""The modal analysis of a scene: build its model, frequencies and Rayleigh damping, write
``modal.json`` (and the reservoir's coupled response when the scene has water)."""
from __future__ import annotations

from pathlib import Path

from ..fe.modal import damping_from_modes, k0_from_scene, modal_analysis, write_modal_json
from ..solve.joint_laws import initial_stiffness
from .joints import JointSet

__all__ = ["run_modal"]


def run_modal(scene, out_dir=None, n_modes: int = 6, model=None):
    """Build the scene's model, run the modal analysis, write ``modal.json`` to out_dir
    (default: scene.output.dir).  Returns (model, ModalResult, damping dict)."""
    from ..fe.model import build_from_scene

    md = model if model is not None else build_from_scene(scene)
    kn, kt = k0_from_scene(scene)
    # each joint with its own initial stiffness (the base's alone without lift joints)
    k0 = initial_stiffness(JointSet(scene, md.interface).solver_law(), md.interface.npts)
    res = modal_analysis(md, n_modes, k0[:, 0], k0[:, 1])
    d = scene.damping
    damp = damping_from_modes(res, d.ratio, d.modes, d.frequencies or None)
    out = Path(out_dir if out_dir is not None else scene.output.dir)
    extra = {"scene": scene.name, "nfree": md.nfree}
    if getattr(md, "reservoir", None) is not None:          # docs/reservoir.md §5
        from ..fe.reservoir import modal_extra
        extra["reservoir"] = modal_extra(md, scene, kn, kt, out)
    write_modal_json(out / "modal.json", res, damp, extra)
    return md, res, damp



def main(argv=None):
    """python -m ngs_driver.run.modal [scene] [--set a.b=v ...] [--out DIR]"""
    import argparse

    from ..scene import load_scene

    ap = argparse.ArgumentParser(description="modal analysis of a scene (bonded interface)")
    ap.add_argument("scene", nargs="?", default="koyna")
    ap.add_argument("--set", action="append", default=[], dest="overrides")
    ap.add_argument("--out", default=None)
    ap.add_argument("-n", type=int, default=6)
    a = ap.parse_args(argv)
    sc = load_scene(a.scene, a.overrides)
    md, res, damp = run_modal(sc, a.out, a.n)
    print(f"scene {sc.name}: nfree {md.nfree}, interface points {md.interface.npts}")
    print("frequencies [Hz]:", " ".join(f"{f:.4f}" for f in res.frequencies_hz))
    print(f"Rayleigh a0 = {damp['a0']:.6g} 1/s, a1 = {damp['a1']:.6g} s "
          f"({damp['source']}: {damp['f_a']:.3f}, {damp['f_b']:.3f} Hz)")



if __name__ == "__main__":
    main()
