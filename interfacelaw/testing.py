"""Testing and benchmarking aids: not used by the law itself.

* :func:`evaluate_reference` — an independent plain-numpy implementation of the interface law
  (docs/law.md). It is public, not a test fixture, because it is useful beyond this
  repository's tests: a code that ports the law (a C/Fortran host of ``interfacelaw.cabi``, a
  re-implementation in another FE code) can check its numbers against a second implementation
  written from the specification, whose every branch is a readable ``np.where``.
* :func:`copy_roofline` — a numba kernel that moves the same bytes as the law with no
  arithmetic: the memory roofline the law's throughput is compared with (tests/bench).

The reference was written from the specification only, as a second implementation to
cross-check the numba kernel (``interfacelaw/_kernels.py``) and as the "numpy reference" of the
benchmarks. It is
vectorised over points: every branch is evaluated on all points and selected by masks with
``np.where``; divisors are made safe *before* dividing (``np.where`` evaluates both branches), so
finite input never produces NaN.

Conventions at the kinks (sets of measure zero, where the tangent is one-sided):
* ``g_N >= 0`` is the tension side (d<g_N>/dg_N = 1 at g_N = 0), ``g_N < 0`` is contact;
* loading (the history variable moves) only for ``lambda > kappa_old``;
* elastic for ``kappa <= lambda_max``, softening for ``lambda_max < kappa < 1``;
* damage grows only for ``Delta g > 0``; the clipped branches (``min(1, .)``) have zero slope
  when the clip is reached (``>=``);
* friction: stick for ``|F*| <= f|F_N|``, active for debonded and ``F_N < 0``.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from .law import InterfaceState

__all__ = ["evaluate_reference", "copy_roofline"]

# the damage-rate coefficient (d Delta D / d Delta g ~ alpha (Delta g/g_max)^(alpha-1)/g_max)
# is unbounded for alpha < 1 as Delta g -> 0+; it is capped here so that a subnormal Delta g
# cannot overflow to inf (and then inf * 0 = NaN in the tangent).
_RATE_CAP = 1e300


def _tnorm(gT: np.ndarray) -> np.ndarray:
    """|g_T| of (n, d-1) tangential vectors (abs in 2D, hypot in 3D)."""
    if gT.shape[1] == 1:
        return np.abs(gT[:, 0])
    return np.hypot(gT[:, 0], gT[:, 1])


def evaluate_reference(law, gap, state: InterfaceState, dt=None):
    """Traction (n,d), tangent (n,d,d) = d traction/d gap, and the end-of-step InterfaceState.

    Same semantics as ``InterfaceLaw.evaluate(gap, state, dt=dt)``; ``state`` is not modified.
    ``dt`` [s] is used by the damage form "rate" only (required there).
    """
    gap = np.asarray(gap, dtype=np.float64)
    n, d = gap.shape
    sig, tau, lN, lT, lm = law.cohesive.as_array()
    if law.damage is not None and law.damage.form == "rate" and dt is None:
        raise ValueError("evaluate_reference dt = None is not allowed for the rate form")
    with np.errstate(all="ignore"):
        return _evaluate(law, gap, state, n, d, sig, tau, lN, lT, lm, dt)


def _evaluate(law, gap, state, n, d, sig, tau, lN, lT, lm, dt):
    I = np.eye(d)
    It = np.eye(d - 1)
    k_old = np.asarray(state.kappa, dtype=np.float64)
    D_old = np.asarray(state.damage, dtype=np.float64)
    sep_old = np.asarray(state.separation, dtype=np.float64)
    sp_old = np.asarray(state.slip, dtype=np.float64).reshape(n, d - 1)
    diss_old = np.asarray(state.dissipated, dtype=np.float64)

    gN = gap[:, 0]
    gTv = gap[:, 1:]                                  # (n, d-1)
    gT = _tnorm(gTv)                                  # |g_T|
    tens = gN >= 0.0                                  # tension side: d<g_N>/dg_N = 1
    gNp = np.maximum(gN, 0.0)                         # <g_N>
    H = tens.astype(np.float64)

    # ---- 1.1 normalised gaps ------------------------------------------------------------
    u = gNp / lN
    v = gT / lT
    lam = np.hypot(u, v)                              # lambda
    lam_pos = lam > 0.0
    lam_s = np.where(lam_pos, lam, 1.0)
    # d lambda/d g = (<g_N>/l_Nc^2, g_T/l_Tc^2) / lambda   (d<g_N>/dg_N = 1 where <g_N> != 0)
    dlam = np.zeros((n, d))
    dlam[:, 0] = np.where(lam_pos, gNp / (lN * lN) / lam_s, 0.0)
    dlam[:, 1:] = np.where(lam_pos[:, None], gTv / (lT * lT) / lam_s[:, None], 0.0)

    # ---- 1.2 history: kappa = max(lambda, kappa_old) --------------------------------------
    loading = lam > k_old
    kap = np.where(loading, lam, k_old)
    elastic = kap <= lm
    soft = (kap > lm) & (kap < 1.0)
    kap_s = np.where(soft, kap, 1.0)
    # s(kappa): 1/lm | (1-k)/(k(1-lm)) | 0
    s = np.where(elastic, 1.0 / lm, np.where(soft, (1.0 - kap_s) / (kap_s * (1.0 - lm)), 0.0))
    # ds/dkappa = -1/(kappa^2 (1-lm)) on softening; ds/dg = ds/dkappa dlambda/dg while loading
    dsdk = np.where(soft & loading, -1.0 / (kap_s * kap_s * (1.0 - lm)), 0.0)
    ds = dsdk[:, None] * dlam                         # (n, d)

    # ---- a(g) = (sig <g_N>/l_Nc, tau l_Nc/l_Tc^2 g_T) and its (diagonal) gradient ---------
    cT = tau * lN / (lT * lT)
    a = np.empty((n, d))
    a[:, 0] = sig * gNp / lN
    a[:, 1:] = cT * gTv
    da = np.zeros((n, d))                             # da_i/dg_i (da is diagonal)
    da[:, 0] = sig / lN * H
    da[:, 1:] = cT
    amag = np.hypot(a[:, 0], _tnorm(a[:, 1:]))        # |a|
    amag_pos = amag > 0.0
    amag_s = np.where(amag_pos, amag, 1.0)
    # d|a|/dg = (a_i da_i) / |a|
    damag = np.where(amag_pos[:, None], a * da / amag_s[:, None], 0.0)

    # ---- separation g = hypot(<g_N>, |g_T|) ------------------------------------------------
    sep = np.hypot(gNp, gT)
    sep_pos = sep > 0.0
    sep_s = np.where(sep_pos, sep, 1.0)
    # d sep/d g = (<g_N>, g_T)/sep
    dsep = np.zeros((n, d))
    dsep[:, 0] = np.where(sep_pos, gNp / sep_s, 0.0)
    dsep[:, 1:] = np.where(sep_pos[:, None], gTv / sep_s[:, None], 0.0)

    # ---- 1.5 cyclic damage ---------------------------------------------------------------
    dDdg = np.zeros((n, d))
    if law.damage is not None:
        al, be, gmax, fth, _ = law.damage.as_array(law.cohesive)  # fth = F_th/sigma
        form = law.damage.form
        dg = sep - sep_old
        grow = dg > 0.0
        dgp = np.where(grow, dg, 0.0)
        r = s * amag / sig                            # r = s |a| / sigma_max
        dr = (ds * amag[:, None] + s[:, None] * damag) / sig     # dr/dg
        x = r - fth
        above = x > 0.0
        if be == 0.0:
            B = above.astype(np.float64)              # B = 1 if r > F_th/sigma_max else 0
            dBdr = np.zeros(n)
        else:
            xp = np.where(above, x, 0.0)
            B = np.where(above, xp ** be, 0.0)        # <r - F_th/sigma_max>^beta
            dBdr = np.where(above, be * np.where(above, xp, 1.0) ** (be - 1.0), 0.0)
            dBdr = np.minimum(dBdr, _RATE_CAP)
        Bpos = B > 0.0
        if form in ("paper", "rate"):
            X = (dgp / gmax) ** al                    # (Delta g/g_max)^alpha
            # rate form (docs §1.5): times (Delta t/t_ref)^(1-alpha); d/dg as for the paper's
            # form (the factor does not depend on the gap)
            ft = (dt / law.damage.t_ref) ** (1.0 - al) if form == "rate" else 1.0
            X = X * ft
            raw = np.where(grow & Bpos, X * np.where(Bpos, B, 0.0), 0.0)
            dD = np.minimum(1.0, raw)                 # Delta D
            D_new = np.minimum(1.0, D_old + dD)
            # d Delta D/dg = alpha (Dg/g_max)^(alpha-1)/g_max B dsep/dg + X dB/dr dr/dg, where
            # neither min(1, .) clips (zero slope on the clipped branches and for Delta g <= 0)
            free = grow & Bpos & (raw < 1.0) & (D_old + dD < 1.0)
            dX = al * np.where(free, dgp / gmax, 1.0) ** (al - 1.0) / gmax * ft
            dX = np.where(free, np.minimum(dX, _RATE_CAP), 0.0)
            c1 = np.where(free, dX * B, 0.0)
            c2 = np.where(free, X * dBdr, 0.0)
        else:
            # objective form: p/g_max = D_old^(1/alpha) + B Dg+/g_max, D_new = (p/g_max)^alpha
            act = grow & Bpos
            xp = np.clip(D_old, 0.0, 1.0) ** (1.0 / al) + np.where(act, B, 0.0) * dgp / gmax
            Dtry = xp ** al
            free = act & (Dtry < 1.0)
            D_new = np.where(act, np.minimum(1.0, Dtry), D_old)
            dDdp = np.where(free, al * np.where(free, xp, 1.0) ** (al - 1.0) / gmax, 0.0)
            c1 = np.where(free, dDdp * B, 0.0)
            c2 = np.where(free, dDdp * dgp * dBdr, 0.0)
        dDdg = c1[:, None] * dsep + c2[:, None] * dr
    else:
        D_new = D_old.copy()

    # ---- cohesive traction F = (1-D) s a -------------------------------------------------
    omD = 1.0 - D_new
    sa = s[:, None] * a
    F = omD[:, None] * sa
    # dF/dg = (1-D)(s diag(da) + a (x) ds) - s a (x) dD
    T = (omD[:, None, None] * (s[:, None, None] * (da[:, :, None] * I)
                               + a[:, :, None] * ds[:, None, :])
         - sa[:, :, None] * dDdg[:, None, :])

    # ---- 1.3 contact ---------------------------------------------------------------------
    # (a law without contact: a_N = 0 and da_N = 0 for g_N < 0, so F_N = 0 and its row is 0)
    if law.contact is not None:
        K, C, gref, m, cs = law.contact.as_array(law.cohesive)
        comp = gN < 0.0
        om = 1.0 - omD * lm * s                       # omega
        # d omega/dg = lm (s dD/dg - (1-D) ds/dg)
        dom = lm * (s[:, None] * dDdg - omD[:, None] * ds)
        z = np.where(comp, -gN / gref, 0.0)           # -g_N/g_ref >= 0
        # p = -C g_ref z^m up to z* = cs, then stiffness K (the cap): docs §1.3
        below = z <= cs
        zc = np.where(below, z, cs if np.isfinite(cs) else 0.0)
        csm = zc ** m
        p = np.where(below, -C * gref * z ** m, -(C * csm + K * (z - zc)) * gref)
        dp = np.where(below, C * m * z ** (m - 1.0), K)
        Pi = np.where(below, C * gref * gref * z ** (m + 1.0) / (m + 1.0),
                      gref * gref * (C * csm * zc / (m + 1.0) + C * csm * (z - zc)
                                     + 0.5 * K * (z - zc) ** 2))
        FN = (1.0 - om) * K * gN + om * p
        # dF_N/dg = ((1-omega) K + omega p') e_N + (p - K g_N) d omega/dg
        dFN = (p - K * gN)[:, None] * dom
        dFN[:, 0] += (1.0 - om) * K + om * dp
        F[:, 0] = np.where(comp, FN, F[:, 0])
        T[:, 0, :] = np.where(comp[:, None], dFN, T[:, 0, :])
        # released stored energy when bonded area becomes crack area at fixed g_N (docs §1.3):
        # (omega - omega_old)(K g_N^2/2 - Pi(g_N)),  Pi = C g_ref^2 z^(m+1)/(m+1)
        s_old = np.where(k_old <= lm, 1.0 / lm,
                         np.where(k_old >= 1.0, 0.0,
                                  (1.0 - k_old) / (np.where(k_old > 0, k_old, 1.0) * (1.0 - lm))))
        om_old = 1.0 - (1.0 - D_old) * lm * s_old
        diss_c = np.where(comp, (om - om_old) * (0.5 * K * gN * gN - Pi), 0.0)
    else:
        diss_c = np.zeros(n)
        dFN = np.zeros((n, d))

    # ---- 1.4 friction --------------------------------------------------------------------
    diss_f = np.zeros(n)
    if law.friction is not None:
        fc, CT = law.friction.as_array(law.cohesive)
        FNn = F[:, 0]
        deb = (kap >= 1.0) | (D_new >= 1.0)
        act = deb & (FNn < 0.0)
        trial = CT * (gTv - sp_old)                   # F* = C_T (g_T - s_p_old)
        tn = _tnorm(trial)
        lim = fc * np.abs(FNn)                        # f |F_N|
        slip = act & (tn > lim)
        stick = act & ~slip
        tn_s = np.where(slip, tn, 1.0)
        nv = np.where(slip[:, None], trial / tn_s[:, None], 0.0)
        FT = np.where(slip[:, None], lim[:, None] * nv, trial)
        F[:, 1:] = np.where(act[:, None], FT, F[:, 1:])
        # s_p: stick keeps it, slip returns, inactive follows g_T
        sp_new = np.where(slip[:, None], sp_old + ((tn - lim) / CT)[:, None] * nv,
                          np.where(act[:, None], sp_old, gTv))
        # F_T . Delta s_p = f|F_N| n . (|F*| - f|F_N|)/C_T n
        diss_f = np.where(slip, lim * (tn - lim) / CT, 0.0)
        # tangent rows of F_T:
        #   stick: dF_T/dg_T = C_T I, dF_T/dg_N = 0
        #   slip:  dF_T/dg_T = f|F_N| C_T/|F*| (I - n n),  dF_T/dg = -f n (x) dF_N/dg (|F_N| = -F_N)
        Tt = np.zeros((n, d - 1, d))
        Tt[:, :, 1:] = np.where(stick[:, None, None], CT * It, 0.0)
        Tslip = np.zeros((n, d - 1, d))
        Tslip[:, :, 1:] = (lim * CT / tn_s)[:, None, None] * (It - nv[:, :, None] * nv[:, None, :])
        Tslip -= fc * nv[:, :, None] * dFN[:, None, :]
        Tt = np.where(slip[:, None, None], Tslip, Tt)
        T[:, 1:, :] = np.where(act[:, None, None], Tt, T[:, 1:, :])
    else:
        sp_new = sp_old.copy()

    # ---- dissipation (1.2, 1.5) ----------------------------------------------------------
    # q = l_Nc (sig cos^2 phi + tau sin^2 phi), phi = atan2(v, u) (phi = 0 at lambda = 0)
    cphi = np.where(lam_pos, u / lam_s, 1.0)
    sphi = np.where(lam_pos, v / lam_s, 0.0)
    q = lN * (sig * cphi * cphi + tau * sphi * sphi)
    dk = (np.minimum(kap, 1.0) - np.maximum(k_old, lm)) / (1.0 - lm)
    dphi_k = np.where(dk > 0.0, (1.0 - D_old) * 0.5 * q * np.where(dk > 0.0, dk, 0.0), 0.0)
    # Q = sig <g_N>^2/l_Nc + tau l_Nc |g_T|^2/l_Tc^2;  dPhi_D = 1/2 s Q (D_new - D_old)
    Q = sig * gNp * gNp / lN + tau * lN * gT * gT / (lT * lT)
    dDD = D_new - D_old
    dphi_D = np.where((dDD != 0.0) & (s > 0.0), 0.5 * s * Q * dDD, 0.0)
    diss = diss_old + dphi_k + dphi_D + diss_f + diss_c

    new = InterfaceState(kap, D_new, sep, sp_new, diss)
    return F, T, new


@njit(cache=True, parallel=True)
def copy_roofline(gap, kappa, dmg, sep, slip, diss, F, T, kappa_n, dmg_n, sep_n, slip_n,
                  diss_n):
    """Moves the same bytes as the law (reads gap and state, writes traction, tangent and
    state) with no arithmetic: the memory roofline for the benchmark."""
    dim = gap.shape[1]
    for i in prange(gap.shape[0]):
        for a in range(dim):
            F[i, a] = gap[i, a]
            for b in range(dim):
                T[i, a, b] = gap[i, b]
        kappa_n[i] = kappa[i]
        dmg_n[i] = dmg[i]
        sep_n[i] = sep[i]
        for a in range(dim - 1):
            slip_n[i, a] = slip[i, a]
        diss_n[i] = diss[i]
