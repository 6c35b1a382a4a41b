"""Per-step history of a run and the measures taken from it (no NGSolve)."""
from __future__ import annotations

import numpy as np

from .joints import crack_measures  # noqa: F401 (the measure lives with the joints)

# per-step histories: the CSV column order. The unprefixed crack/damage columns are the base's
# (kept under their original names; "base_<key>" columns hold the same values with the lift
# joints' columns beside them).
HIST_KEYS = ("step", "t", "crest_ux", "crest_uy", "iterations", "iterations_failed", "cuts",
             "substeps", "n_active", "n_debonded", "crack_length", "crack_length_heel",
             "max_D", "D_heel", "kappa_heel", "size_b", "sigma_max", "wall")


class History:
    """Columns of floats appended once per step (``keys`` fixed at construction)."""

    def __init__(self, keys=HIST_KEYS):
        self.keys = tuple(keys)
        self.cols = {k: [] for k in self.keys}

    def append(self, **kw):
        for k in self.keys:
            self.cols[k].append(kw[k])

    def arrays(self) -> dict:
        return {k: np.asarray(v, dtype=float) for k, v in self.cols.items()}

    @classmethod
    def from_arrays(cls, d, keys=HIST_KEYS):
        h = cls(keys)
        for k in h.keys:
            h.cols[k] = [float(x) for x in d[f"hist_{k}"]]
        return h

    def __len__(self):
        return len(self.cols["t"])


def snapshot_steps(n_steps: int, count: int) -> list[int]:
    s = sorted({int(round(v)) for v in np.linspace(0, n_steps, count + 1)[1:]})
    return [k for k in s if k >= 1]



def results_from_history(H, snaps, x, w) -> dict:
    """The numbers the paper's statements are compared with."""
    t = H["t"]
    if t.size == 0:
        return {}

    def first(mask):
        i = np.flatnonzero(mask)
        return float(t[i[0]]) if i.size else None

    ch = H["crack_length_heel"]
    final = float(ch[-1])
    t_final = None
    if final > 0:
        i = np.flatnonzero(ch >= final - 1e-12)
        t_final = float(t[i[0]])
    return {
        "max_D_heel": float(H["D_heel"].max()), "max_D": float(H["max_D"].max()),
        "t_D_heel_reaches_1": first(H["D_heel"] >= 1.0),
        "t_D_heel_reaches_0.1": first(H["D_heel"] >= 0.1),
        "t_first_debond": first(H["n_debonded"] > 0),
        "crack_length_heel_final": final, "crack_length_heel_max": float(ch.max()),
        "t_crack_heel_reaches_final": t_final,
        "crack_length_total_final": float(H["crack_length"][-1]),
        "crack_length_total_max": float(H["crack_length"].max()),
        "crest_ux_min": float(H["crest_ux"].min()), "crest_ux_max": float(H["crest_ux"].max()),
        "crest_uy_min": float(H["crest_uy"].min()), "crest_uy_max": float(H["crest_uy"].max()),
        "D_heel_final": float(H["D_heel"][-1]),
        "max_size_b": float(H["size_b"].max()),
        "min_sigma_max": float(H["sigma_max"].min()),
    }
