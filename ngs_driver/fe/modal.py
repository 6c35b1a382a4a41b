"""Modal analysis with the interface bonded, and Rayleigh damping coefficients.

The bonded interface is the linear spring layer B^T diag(w k0) B with the initial elastic
stiffness of the interface law; for the paper's law k0 = sigma_max / (lambda_max l_Nc),
l_Nc = 2 G_I / sigma_max (``setup.laws.paper_k0``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as sla



@dataclass
class ModalResult:
    frequencies_hz: np.ndarray     # (n,)
    modes: np.ndarray              # (nfree, n), M-orthonormal
    k0_normal: float
    k0_tangential: float
    effective_mass_x: np.ndarray   # (n,) modal participating mass, x [kg/m]
    effective_mass_y: np.ndarray

    def to_dict(self) -> dict:
        return {"frequencies_hz": [float(f) for f in self.frequencies_hz],
                "periods_s": [float(1 / f) for f in self.frequencies_hz],
                "k0_normal": self.k0_normal, "k0_tangential": self.k0_tangential,
                "effective_mass_x_kg_per_m": [float(v) for v in self.effective_mass_x],
                "effective_mass_y_kg_per_m": [float(v) for v in self.effective_mass_y]}


def modal_analysis(model, n_modes: int = 6, k0_normal: float = 9.0e10,
                   k0_tangential: float = 9.0e10) -> ModalResult:
    """First ``n_modes`` natural frequencies [Hz] and M-normalised mode shapes of
    (K + B^T diag(w k0) B) phi = omega^2 M phi  (shift-invert Lanczos at sigma = 0).
    k0_normal / k0_tangential: scalars or one value per interface point (several joints)."""
    Kb = (model.K + model.interface.stiffness(k0_normal, k0_tangential)).tocsc()
    M = model.M.tocsc()
    # a fixed start vector: ARPACK's random one changed the last bits of the frequencies (and so
    # of the Rayleigh coefficients) from call to call, which made runs not bitwise repeatable
    v0 = np.random.default_rng(0).uniform(0.5, 1.5, Kb.shape[0])
    lam, V = sla.eigsh(Kb, k=n_modes, M=M, sigma=0.0, which="LM", v0=v0)
    idx = np.argsort(lam)
    lam, V = lam[idx], V[:, idx]
    # normalise: phi^T M phi = 1, sign so that the crest x-displacement is >= 0
    V = V / np.sqrt(np.einsum("ij,ij->j", V, M @ V))
    ix = model.crest_dofs[0]
    V = V * np.where(V[ix] < 0, -1.0, 1.0)
    f = np.sqrt(np.maximum(lam, 0.0)) / (2 * math.pi)
    Lx = V.T @ (M @ model.r_x)
    Ly = V.T @ (M @ model.r_y)
    # the interface stiffness may differ per joint (per point): report the base's (point 0)
    return ModalResult(f, V, float(np.ravel(k0_normal)[0]), float(np.ravel(k0_tangential)[0]),
                       Lx ** 2, Ly ** 2)


def rayleigh_coefficients(f_a: float, f_b: float, ratio: float = 0.05) -> tuple[float, float]:
    """(a0, a1) of C = a0 M + a1 K giving ``ratio`` of critical damping at f_a and f_b
    [Hz]: a0 = 2 zeta w_a w_b/(w_a + w_b), a1 = 2 zeta/(w_a + w_b) (Chopra, Dynamics of
    Structures, §11.4)."""
    if not (f_a > 0 and f_b > 0) or f_a == f_b:
        raise ValueError(f"Rayleigh frequencies must be positive and distinct: {f_a}, {f_b}")
    wa, wb = 2 * math.pi * f_a, 2 * math.pi * f_b
    return 2 * ratio * wa * wb / (wa + wb), 2 * ratio / (wa + wb)


def rayleigh_ratio(f: np.ndarray, a0: float, a1: float) -> np.ndarray:
    """Damping ratio of a Rayleigh model at frequency f [Hz]."""
    w = 2 * math.pi * np.asarray(f, float)
    return a0 / (2 * w) + a1 * w / 2


def damping_from_modes(res: ModalResult, ratio: float = 0.05, modes=(1, 3),
                       frequencies=None, model: str = "rayleigh") -> dict:
    """Damping coefficients (a0, a1) of C = a0 M + a1 K at the given 1-based mode numbers
    (default modes 1 and 3) or at explicit ``frequencies`` [Hz].

    model "rayleigh" and "rayleigh_deformation" (the same a0, a1; the mass term of the
    latter acts on deformation only, solve/damping.py): ``ratio`` at both frequencies.
    model "stiffness": C = a1 K, a1 = 2 ratio / omega_a at the first frequency (the ratio grows
    linearly with frequency above it; Chopra, Dynamics of Structures, §11.4)."""
    if model == "stiffness":
        fa = float(frequencies[0]) if frequencies else float(res.frequencies_hz[modes[0] - 1])
        src = "frequencies" if frequencies else f"mode {modes[0]}"
        a1 = 2 * ratio / (2 * math.pi * fa)
        return {"model": model, "a0": 0.0, "a1": a1, "ratio": ratio, "f_a": fa, "f_b": None,
                "source": src,
                "ratio_at_modes": [float(z) for z in rayleigh_ratio(res.frequencies_hz, 0.0,
                                                                    a1)]}
    if frequencies:
        fa, fb = (float(v) for v in frequencies)
        src = "frequencies"
    else:
        fa, fb = (float(res.frequencies_hz[m - 1]) for m in modes)
        src = f"modes {tuple(modes)}"
    a0, a1 = rayleigh_coefficients(fa, fb, ratio)
    return {"model": model, "a0": a0, "a1": a1, "ratio": ratio, "f_a": fa, "f_b": fb,
            "source": src,
            "ratio_at_modes": [float(z) for z in rayleigh_ratio(res.frequencies_hz, a0, a1)]}
