"""The files of the ``modal`` command: ``modal.json`` (frequencies, modal masses, Rayleigh
damping) and, for compressible water, the crest frequency response (CSV and figure)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

__all__ = ["write_modal_json", "write_frequency_response"]


def write_modal_json(path, res, damping: dict | None = None, extra: dict | None = None) -> Path:
    """``res``: ``fe.modal.ModalResult``; ``damping``: the Rayleigh dict; ``extra``: more keys."""
    d = res.to_dict()
    if damping is not None:
        d["rayleigh"] = damping
    if extra:
        d.update(extra)
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(json.dumps(d, indent=2))
    return p


def write_frequency_response(out, scene, resp: dict) -> dict:
    """``frequency_response.csv`` / ``.png`` of ``fe.reservoir.modal_response``; returns the
    summary modal.json holds under ``reservoir.frequency_response``."""
    f, curves, f_dry, eta = resp["f"], resp["curves"], resp["f_dry"], resp["eta"]
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "frequency_response.csv", "w") as fh:
        fh.write("f_hz,f_over_f1_dry,crest_acc_empty,crest_acc_incompressible,"
                 "crest_acc_compressible\n")
        for i, fi in enumerate(f):
            fh.write(f"{fi:.6g},{fi / f_dry:.6g}," + ",".join(
                f"{abs(curves[k][i]):.6g}" for k in ("none", "incompressible",
                                                      "compressible")) + "\n")
    # deferred: matplotlib loads only when a figure is drawn
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4))
    alpha = scene.reservoir.bottom_reflection
    res = resp.get("resonances", {})
    for k, lab in (("none", "empty"), ("incompressible", "incompressible water"),
                   ("compressible", f"compressible, alpha = {alpha:g}")):
        ln, = ax.plot(f, np.abs(curves[k]), label=lab)
        fp = (res.get(k) or {}).get("fundamental")
        if fp is not None:
            ax.plot([fp["f_hz"]], [fp["amplitude"]], "o", color=ln.get_color(), ms=5)
            ax.annotate(f"{fp['f_hz']:.2f} Hz", (fp["f_hz"], fp["amplitude"]),
                        textcoords="offset points", xytext=(4, 4), fontsize=7,
                        color=ln.get_color())
    ax.axvline(resp["f1_reservoir_hz"], color="0.6", ls=":", lw=1,
               label="reservoir f1 = c / 4H")
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("|crest total acceleration| / a_g")
    ax.set_title(f"{scene.name}: crest response to harmonic horizontal ground acceleration "
                 f"(hysteretic eta = {eta:g})", fontsize=9)
    ax.legend(fontsize=8, title="o: fundamental resonance (first peak)", title_fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "frequency_response.png", dpi=120)
    plt.close(fig)
    peaks = resp["peak_hz"]
    fund = {k: (v or {}).get("fundamental") for k, v in res.items()}
    return {"files": ["frequency_response.csv", "frequency_response.png"],
            "fundamental_resonance": fund,
            "fundamental_hz": {k: (v["f_hz"] if v else None) for k, v in fund.items()},
            "global_max": {k: v["global_max"] for k, v in res.items()},
            "peak_hz": peaks, "hysteretic_eta": eta, "f1_dry_hz": f_dry,
            "peak_ratio_compressible_over_dry": peaks["compressible"] / f_dry,
            "fundamental_ratio_compressible_over_dry": (
                fund["compressible"]["f_hz"] / f_dry if fund.get("compressible") else None)}
