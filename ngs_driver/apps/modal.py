"""The ``modal`` command: a scene's natural frequencies with the joints bonded, its Rayleigh
damping, written to ``modal.json`` (and the reservoir's coupled response when the scene has
water). The eigen-analysis itself is ``fe.modal``."""
from __future__ import annotations

from pathlib import Path

from ..fe.modal import damping_from_modes, modal_analysis
from ..fe.model import build_from_scene
from ..fe.reservoir import modal_response
from ..post.modal import write_frequency_response, write_modal_json
from ..run.damping import modes_to_compute
from ..run.joints import Joints
from ..setup import joint_inputs, k0_from_scene
from ..solve.joint_laws import initial_stiffness

__all__ = ["run_modal", "MEASURED_PERIODS", "measured_comparison"]

#: measured fundamental periods of real dams, by section file: (reservoir level m, period s,
#: source). Pine Flat: forced-vibration tests of the dam (Rea, Liaw & Chopra, "Dynamic
#: properties of Pine Flat dam", UCB/EERC-72/7, 1972), as quoted in Chopra, Dynamics of
#: Structures, section 2.1 (docs/real_dams.md "Pine Flat: frequencies").
MEASURED_PERIODS = {
    "pine_flat.csv": [
        (94.5, 0.288, "Rea, Liaw & Chopra 1972 (UCB/EERC-72/7), forced vibration, "
                      "water 94.5 m (310 ft)"),
        (105.2, 0.306, "Rea, Liaw & Chopra 1972 (UCB/EERC-72/7), forced vibration, "
                       "water 105.2 m (345 ft)"),
    ],
}
#: a measurement is compared when the scene's water is within this of the test's level (the
#: tests' levels are given to 0.1 m; 0.5 m of water moves the resonance by < 0.5 %, measured
#: between 94.5 and 105.2 m: 5 % over 10.7 m)
LEVEL_TOL = 0.5


def measured_comparison(scene, fundamental) -> list[dict]:
    """The measured periods of this section at the scene's water level beside our fundamental
    resonance per water model (``fundamental``: {model: {"f_hz", ...} or None}); [] when no
    measurement matches."""
    pf = str(getattr(scene.geometry, "profile_file", "") or "")
    rows = []
    for key, meas in MEASURED_PERIODS.items():
        if not pf.endswith(key):
            continue
        for level, T, src in meas:
            if abs(float(scene.reservoir.level) - level) > LEVEL_TOL:
                continue
            ours = {k: (None if v is None else {"f_hz": v["f_hz"], "period_s": 1.0 / v["f_hz"],
                                                "period_over_measured": 1.0 / v["f_hz"] / T})
                    for k, v in fundamental.items()}
            rows.append({"level_m": level, "period_s": T, "f_hz": 1.0 / T, "source": src,
                         "ours": ours})
    return rows


def run_modal(scene, out_dir=None, n_modes: int = 6, model=None):
    """Build the scene's model, run the modal analysis, write ``modal.json`` to out_dir
    (default: scene.output.dir).  Returns (model, ModalResult, damping dict)."""

    md = model if model is not None else build_from_scene(scene)
    kn, kt = k0_from_scene(scene)
    # each joint with its own initial stiffness (the base's alone without lift joints)
    k0 = initial_stiffness(Joints(joint_inputs(scene), md.interface).solver_law(), md.interface.npts)
    res = modal_analysis(md, modes_to_compute(scene.damping, n_modes), k0[:, 0], k0[:, 1])
    d = scene.damping
    damp = damping_from_modes(res, d.ratio, d.modes, d.frequencies or None, d.model)
    out = Path(out_dir if out_dir is not None else scene.output.dir)
    extra = {"scene": scene.name, "nfree": md.nfree,
             "plane": getattr(scene.materials, "plane", "strain"),
             "f1_hz": float(res.frequencies_hz[0])}
    if getattr(md, "reservoir", None) is not None:          # docs/reservoir.md
        info, resp = modal_response(md, scene.damping.ratio, kn, kt)
        if resp is not None:
            info["frequency_response"] = write_frequency_response(out, scene, resp)
            info["measured"] = measured_comparison(
                scene, info["frequency_response"]["fundamental_resonance"])
        extra["reservoir"] = info
    write_modal_json(out / "modal.json", res, damp, extra)
    return md, res, damp
