"""Hydrodynamic reservoir models on the dam's free DOFs (docs/reservoir.md).

* ``westergaard_added_mass``: Westergaard's (1933) added mass m(y) = 7/8 rho_w sqrt(H (H - y))
  per unit area of the wetted upstream face, acting along the face normal (the generalised
  Westergaard form of Kuo 1982 / USACE EM 1110-2-6051: M_a = int m(y) (N n)(N n)^T ds), integrated
  consistently on the face and added to M.
* the acoustic water domain (pressure field) lives in ``fe/acoustic.py``.

``ReservoirModel`` is what ``fe.model.build_model`` keeps on ``Model.reservoir``: the matrices
it added and what the run needs (effective seismic load vectors, pressure recovery).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl

from .acoustic import AcousticReservoir
from .face import dam_normal_trial_test, region_bands
from .modal import modal_analysis
from .ngs_helpers import to_scipy

# quadrature: sqrt(H - y) has an unbounded derivative at the water line (a mesh vertex), so the
# face integral is done with a high rule; measured: the total mass on a vertical face is exact
# to < 1e-6 relative (tests/test_reservoir.py)
BONUS_INTORDER = 12


@dataclass
class ReservoirModel:
    """The hydrodynamic part of a Model (free-DOF numbering of the model)."""

    kind: str                       # "westergaard" | "acoustic"
    level: float
    water_density: float
    added_mass: sp.csr_matrix | None = None      # added to Model.M (westergaard, incompressible)
    acoustic: Any = None                          # acoustic.AcousticReservoir
    info: dict = field(default_factory=dict)

    def seismic_vectors(self, M_rx: np.ndarray, M_ry: np.ndarray):
        """Effective seismic load vectors (f = f_static - sx a_gx - sy a_gy) from the model's
        M r (M includes the added mass).  Westergaard: unchanged (the added mass moves with the
        face).  Incompressible acoustic: the ground-driven pressure of the reservoir bottom and
        a rigid far end is added (exact condensation, see acoustic.py)."""
        if self.acoustic is not None and self.acoustic.incompressible:
            return self.acoustic.seismic_vectors(M_rx, M_ry)
        return M_rx, M_ry


def westergaard_added_mass(fes, free: np.ndarray, level: float, water_density: float,
                           components=None, boundary: str = "upstream", bands=None):
    """Consistent Westergaard added-mass matrix (free x free) of the wetted ``boundary``:

        M_a = int_{face, y < H} 7/8 rho_w sqrt(H (H - y)) (u . n)(v . n) ds

    fes: the model's space (components: indices of the dam fields in a product space, None
    for the dam space alone)."""
    # deferred: NGSolve is optional: the package imports without it
    import ngsolve as ngs

    H = float(level)
    if H <= 0.0:
        return sp.csr_matrix((free.size, free.size))
    un, vn = dam_normal_trial_test(fes, components, bands)
    m = 7.0 / 8.0 * water_density * ngs.sqrt(H * ngs.IfPos(H - ngs.y, H - ngs.y, 0.0))
    a = ngs.BilinearForm(fes)
    a += m * un * vn * ngs.ds(boundary, bonus_intorder=BONUS_INTORDER)
    a.Assemble()
    Ma = to_scipy(a.mat)[free][:, free]
    return ((Ma + Ma.T) * 0.5).tocsr()


def build_reservoir(res, mesh, fes, free, water_density, components=None, regions=None,
                    **acoustic_kw):
    """The ReservoirModel of a scene's [reservoir] table (None for model = "none").  regions:
    the dam regions of ``components`` (blocks between lift joints), for their face bands."""
    if res is None or res.model == "none":
        return None
    bands = (region_bands(mesh, regions) if components is not None and regions is not None
             and len(regions) == len(components) else None)
    if res.model == "westergaard":
        Ma = westergaard_added_mass(fes, free, res.level, water_density, components,
                                    bands=bands)
        return ReservoirModel("westergaard", res.level, water_density, added_mass=Ma,
                              info={"model": "westergaard", "level": res.level})

    ac = AcousticReservoir.build(res, mesh, fes, free, water_density, components,
                                bands=bands, **acoustic_kw)
    return ReservoirModel("acoustic", res.level, water_density,
                          added_mass=ac.added_mass if ac.incompressible else None, acoustic=ac,
                          info=ac.summary())


# ---------------------------------------------------------------------------------------------
# modal analysis with the reservoir
# ---------------------------------------------------------------------------------------------
def frequency_response(model, k0_normal, k0_tangential, freqs_hz, eta: float = 0.1,
                       water: str = "compressible"):
    """Crest response to a unit harmonic horizontal ground acceleration e^{i w t} (the classic
    way of Fenves & Chopra / EAGD-84), constant hysteretic damping K (1 + i eta) in the dam:

        [[K* - w^2 M, -Q], [-rho w^2 Q^T, H - w^2 G + i w C_f]] [u; p] = [-M r_x; -rho g_x]

    water: "compressible" (the acoustic reservoir), "incompressible" (G = C_f = 0) or "none"
    (Q = 0).  M here is the structural mass (without any added mass).  Returns the complex
    crest x-displacement relative to the ground and the total crest acceleration / a_g."""

    res = model.reservoir
    ac = res.acoustic
    Kb = (model.K + model.interface.stiffness(k0_normal, k0_tangential)).tocsr()
    Ms = model.M - (res.added_mass if res.added_mass is not None else 0)
    Ms = sp.csr_matrix(Ms)
    W = ac.W
    nu = Kb.shape[0]
    cx = model.crest_dofs[0]
    ux = np.zeros(len(freqs_hz), complex)
    for i, f in enumerate(freqs_hz):
        w = 2 * np.pi * f
        Auu = (Kb * (1 + 1j * eta) - w ** 2 * Ms).tocsc()
        if water == "none":
            u = spl.spsolve(Auu, (-(Ms @ model.r_x)).astype(complex))
        else:
            App = W.H if water == "incompressible" else (W.H - w ** 2 * W.G + 1j * w * W.Cf)
            A = sp.bmat([[Auu, -ac.Q], [-ac.rho * w ** 2 * ac.Q.T, App]], format="csc")
            b = np.concatenate([-(Ms @ model.r_x), -ac.rho * ac.g_x]).astype(complex)
            u = spl.spsolve(A, b)[:nu]
        ux[i] = u[cx]
    w = 2 * np.pi * np.asarray(freqs_hz)
    return ux, 1.0 - w ** 2 * ux


def resonance_peaks(f, amp, min_prominence: float = 0.05) -> dict:
    """The fundamental resonance of a frequency response |H(f)| sampled on a grid: the FIRST
    local maximum whose height is at least ``min_prominence`` (5 %) above the deeper of the
    two minima that separate it from a higher point on either side (so that a ripple is not
    taken for a resonance), and the global maximum.  The peak's frequency and amplitude are
    refined by a parabola through the grid maximum and its two neighbours.  Engineers read the
    fundamental resonance (Fenves & Chopra 1984, UCB/EERC-84/10); on a dam with an empty or
    incompressible reservoir the global maximum of the crest acceleration is often the second
    mode's (docs/real_dams.md)."""
    f = np.asarray(f, float)
    a = np.abs(np.asarray(amp))

    def refine(i):
        if 0 < i < a.size - 1:
            y0, y1, y2 = a[i - 1], a[i], a[i + 1]
            den = y0 - 2 * y1 + y2
            if den < 0:
                d = 0.5 * (y0 - y2) / den              # vertex offset in grid steps, |d| <= 1/2
                h = 0.5 * (f[i + 1] - f[i - 1])
                return float(f[i] + d * h), float(y1 - 0.25 * (y0 - y2) * d)
        return float(f[i]), float(a[i])

    first = None
    for i in range(1, a.size - 1):
        if not (a[i] >= a[i - 1] and a[i] > a[i + 1]):
            continue
        hl = np.flatnonzero(a[:i] > a[i])
        hr = np.flatnonzero(a[i + 1:] > a[i])
        left = a[(hl[-1] if hl.size else 0):i + 1].min()
        right = a[i:(i + 1 + hr[0] if hr.size else a.size)].min()
        if a[i] >= (1 + min_prominence) * max(left, right):
            first = i
            break
    g = int(np.argmax(a))
    out = {"global_max": dict(zip(("f_hz", "amplitude"), refine(g)))}
    out["fundamental"] = (dict(zip(("f_hz", "amplitude"), refine(first))) if first is not None
                          else None)
    return out


def modal_response(model, damping_ratio, k0_normal, k0_tangential) -> tuple[dict, dict | None]:
    """What ``modal`` reports about the reservoir, and for compressible acoustic water the crest
    frequency response (else None): {"f": frequencies [Hz], "f_dry": the first frequency
    without water, "eta": hysteretic damping, "curves": {"none" | "incompressible" |
    "compressible": crest acceleration / a_g}, "peak_hz", "f1_reservoir_hz": c / 4H}. The
    files are written by ``post.modal.write_frequency_response``. damping_ratio: the scene's
    ``damping.ratio`` (eta = 2 ratio)."""
    res = model.reservoir
    d = dict(res.info)
    d["kind"] = res.kind
    if res.acoustic is None or res.acoustic.incompressible:
        d["note"] = ("frequencies_hz include the hydrodynamic added mass ("
                     + ("Westergaard" if res.kind == "westergaard" else
                        "incompressible acoustic water, condensed exactly") + ")")
        return d, None
    d["note"] = ("compressible water: frequencies_hz are those of the dam without water; the "
                 "coupled system is frequency dependent, see frequency_response")
    f_dry = modal_analysis(model, 1, k0_normal, k0_tangential).frequencies_hz[0]
    f = np.linspace(0.3 * f_dry, 3.5 * f_dry, 240)
    eta = 2 * damping_ratio
    curves = {k: frequency_response(model, k0_normal, k0_tangential, f, eta, k)[1]
              for k in ("none", "incompressible", "compressible")}
    peaks = {k: float(f[int(np.argmax(np.abs(v)))]) for k, v in curves.items()}
    # the fundamental resonance (first peak) beside the global maximum: on an empty or
    # incompressible reservoir the crest acceleration's global maximum is often the second
    # mode's (docs/real_dams.md)
    resonances = {k: resonance_peaks(f, v) for k, v in curves.items()}
    return d, {"f": f, "f_dry": float(f_dry), "eta": eta, "curves": curves, "peak_hz": peaks,
               "resonances": resonances,
               "f1_reservoir_hz": res.acoustic.c / (4 * res.level)}
