"""summary.json of a dam run, section by section (each function one section)."""
from __future__ import annotations

import numpy as np

from ..setup import law_parts

__all__ = ["ground_motion_summary", "reference_parameters", "joint_results", "block_motion",
           "energy_summary",
           "timings", "solver_totals"]


def ground_motion_summary(start, gm, note=None) -> dict:
    """The record as read from ``start`` [s]; note: ``setup.window_note`` (the window runs
    past its end)."""
    return {"label": gm.label, "synthetic": bool(gm.synthetic), "source": gm.source,
            "dt": gm.dt, "peak_g": list(gm.peak_g()), "start": start,
            # record metadata (event, station, magnitude, PGA, citation) when the reader
            # knows it (FEMA P695 / PEER NGA records)
            "metadata": dict(getattr(gm, "meta", None) or {}), "window_note": note}


def reference_parameters(g_max, joints) -> dict:
    """The base's reference law, its initial stiffness as the run starts (the law scaled to
    b_ref) and g_max / l_Nc (g_max: the base law's [m]). Taken before the first size-scale
    update."""
    coh = joints.reference[0].cohesive
    k0 = joints.laws[0].cohesive
    return {"sigma_max": coh.sigma_max, "tau_max": coh.tau_max, "l_Nc": coh.l_Nc,
            "l_Tc": coh.l_Tc, "k_normal": k0.k_normal, "k_tangential": k0.k_tangential,
            "g_max_over_l_Nc": g_max / coh.l_Nc}


def joint_results(joints, H, snaps) -> dict:
    """summary.json ``joints.<name>``: where the joint is and what happened to it."""
    out = {}
    t = H["t"]
    for name, sl, law in zip(joints.names, joints.slices, joints.laws):
        x = joints.x[sl]
        cu = H[f"{name}_crack_length_upstream"] if t.size else np.zeros(0)
        ct = H[f"{name}_crack_length"] if t.size else np.zeros(0)
        nd = H[f"{name}_n_debonded"] if t.size else np.zeros(0)
        first = np.flatnonzero(nd > 0)
        table = joints.tables[joints.names.index(name)]
        out[name] = {
            "elevation": float(joints.y[sl][0]), "x_upstream": float(x[0]),
            "x_downstream": float(x[-1]), "length": float(joints.w[sl].sum()),
            "points": int(sl.stop - sl.start), "law": law_parts(table),
            "crack_length_upstream_final": float(cu[-1]) if cu.size else 0.0,
            "crack_length_upstream_max": float(cu.max()) if cu.size else 0.0,
            "debonded_length_final": float(ct[-1]) if ct.size else 0.0,
            "debonded_length_max": float(ct.max()) if ct.size else 0.0,
            "max_D": float(np.max([np.max(D[sl]) for D in snaps["D"]])),
            "max_D_history": float(H[f"{name}_max_D"].max()) if t.size else 0.0,
            "t_first_debond": float(t[first[0]]) if first.size else None,
            **block_motion(H, name),
            "final_parameters": law_parts(table) | {
                "sigma_max": law.cohesive.sigma_max,
                "friction": None if law.friction is None else law.friction.f},
        }
    return out


def block_motion(H, name) -> dict:
    """A joint's slip and the rotation of the block above it, from the static state [m, rad]:
    the largest magnitude over the record (``*_max``) and the permanent, final signed value
    (``*_residual``)."""
    out = {}
    for key in ("slip", "rotation"):
        col = H[f"{name}_{key}"] if f"{name}_{key}" in H else np.zeros(0)
        out[f"{key}_max"] = float(np.max(np.abs(col))) if col.size else 0.0
        out[f"{key}_residual"] = float(col[-1]) if col.size else 0.0
    return out


def energy_summary(H, keys) -> dict:
    """Final budget terms and the largest balance residual relative to the input work (the
    external loads' and, with compressible water, the ground's work on the water)."""
    if H["t"].size == 0:
        return {}
    water = "W_water" in keys
    w_in = H["W_ext"] + H["W_water"] if water else H["W_ext"]
    scale = max(float(np.max(np.abs(w_in))), 1e-300)
    final = {k: float(H[k][-1]) for k in keys}
    return {"final": final, "max_abs_residual": float(np.max(np.abs(H["residual"]))),
            "max_residual_over_input_work": float(np.max(np.abs(H["residual"]))) / scale,
            "input_work_scale": scale,
            "definition": "residual = W_ext " + ("+ W_water " if water else "")
                          + "- (E_kin + E_bulk + E_damp + E_alg + E_stored + E_diss + E_scaling"
                          + (" + E_water_kin + E_water_pot + E_water_radiated + "
                             "E_water_absorbed + E_water_alg" if water else "")
                          + "), from the static state; docs/run.md §9 (energy budget), "
                            "docs/real_dams.md (water)"}


def timings(walls, **phases) -> dict:
    """The phases' wall times [s] and the per-step statistics of the solver's steps."""
    out = {k: phases[k] for k in ("build", "modal", "static", "dynamic")}
    out.update({"per_step_median": float(np.median(walls)) if walls.size else None,
                "per_step_mean": float(np.mean(walls)) if walls.size else None,
                "per_step_max": float(np.max(walls)) if walls.size else None})
    out.update({k: phases[k] for k in ("outputs", "total_this_process")})
    return out


def solver_totals(H) -> dict:
    n = H["wall"].size
    return {"iterations": int(H["iterations"].sum()),
            "iterations_failed": int(H["iterations_failed"].sum()),
            "cuts": int(H["cuts"].sum()),
            "max_iterations_per_step": int(H["iterations"].max()) if n else 0,
            "steps_with_cuts": int(np.count_nonzero(H["cuts"]))}
