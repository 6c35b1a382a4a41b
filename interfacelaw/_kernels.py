"""numba kernels of the interface law. No checks, no allocation, no globals: the public class
(`interfacelaw.law.InterfaceLaw`) validates and allocates; these functions only write into the
output arrays they are given.

Optional parts (contact, friction, damage) are passed as a float64 parameter array or ``None``;
numba compiles one specialisation per combination and prunes the branches of the parts that are
``None`` at compile time, so a law without friction or damage never computes them.

The equations are those of docs/decisions.md §1, derivatives written beside each formula.
Components: 0 = normal, 1 and 2 = tangential (2 is absent in 2D).
"""
import math

from numba import njit, prange


@njit(cache=True, inline="always")
def secant(k, lm):
    """Secant factor s(κ) of Eqs. 2–3 and ds/dκ."""
    if k <= lm:
        return 1.0 / lm, 0.0
    if k >= 1.0:
        return 0.0, 0.0
    return (1.0 - k) / (k * (1.0 - lm)), -1.0 / (k * k * (1.0 - lm))


@njit(cache=True, inline="always")
def _point(i, gap, dim, coh, contact, friction, damage,
           kappa, dmg, sep, slip, diss,
           F, T, kappa_n, dmg_n, sep_n, slip_n, diss_n):
    sig = coh[0]
    tau = coh[1]
    lN = coh[2]
    lT = coh[3]
    lm = coh[4]

    gN = gap[i, 0]
    gT1 = gap[i, 1]
    gT2 = gap[i, 2] if dim == 3 else 0.0
    gNp = gN if gN > 0.0 else 0.0
    hN = 1.0 if gN > 0.0 else 0.0                  # d<gN>/dgN

    # Eq. 1 with <gN>: lam = hypot(u, v)
    u = gNp / lN
    t1 = gT1 / lT
    t2 = gT2 / lT
    v = math.hypot(t1, t2)
    lam = math.hypot(u, v)

    ko = kappa[i]
    Do = dmg[i]
    bonded_old = ko < 1.0 and Do < 1.0

    # irreversibility: kappa = max(lam, lambda_h)
    loading = lam > ko
    kn = lam if loading else ko
    s, sp = secant(kn, lm)
    dk0 = 0.0
    dk1 = 0.0
    dk2 = 0.0
    if loading and sp != 0.0:                      # d lam / d gap (lam > lm > 0 here)
        dk0 = u / (lN * lam)
        dk1 = t1 / (lT * lam)
        dk2 = t2 / (lT * lam)

    # a = grad(Q/2): a0 = sig <gN>/lN, aT = tau lN/lT^2 gT ; H = d a / d gap (diagonal)
    kT = tau * lN / (lT * lT)
    a0 = sig * u
    a1 = kT * gT1
    a2 = kT * gT2
    H0 = sig / lN * hN

    # separation for damage (docs §1.5): g = hypot(<gN>, |gT|)
    gs = math.hypot(gNp, math.hypot(gT1, gT2))
    sep_n[i] = gs

    # ---- cyclic damage, Eq. 7 ------------------------------------------------------------
    Dn = Do
    dD0 = 0.0
    dD1 = 0.0
    dD2 = 0.0
    if damage is not None:
        if bonded_old:
            dg = gs - sep[i]
            if dg > 0.0:
                alpha = damage[0]
                beta = damage[1]
                gmax = damage[2]
                fth = damage[3]
                amag = math.hypot(a0, math.hypot(a1, a2))
                r = s * amag / sig                   # F/sigma^t, independent of D
                x = r - fth
                if x > 0.0:
                    B = 1.0 if beta == 0.0 else x ** beta
                    base = dg / gmax
                    inc = base ** alpha * B
                    if inc < 1.0 and Do + inc < 1.0:
                        Dn = Do + inc
                        c1 = inc * alpha / dg          # d inc / d gs
                        dD0 = c1 * gNp / gs
                        dD1 = c1 * gT1 / gs
                        dD2 = c1 * gT2 / gs
                        if beta != 0.0:
                            c2 = base ** alpha * beta * x ** (beta - 1.0) / sig   # d inc/d r / sig
                            # dr*sig = sp*amag*dk + s*d|a|
                            dD0 += c2 * (sp * amag * dk0 + s * a0 * H0 / amag)
                            dD1 += c2 * (sp * amag * dk1 + s * a1 * kT / amag)
                            dD2 += c2 * (sp * amag * dk2 + s * a2 * kT / amag)
                    else:
                        Dn = 1.0
    dmg_n[i] = Dn
    kappa_n[i] = kn
    bonded = kn < 1.0 and Dn < 1.0

    # ---- cohesive traction F = (1-D) s a ---------------------------------------------------
    cf = (1.0 - Dn) * s
    F0 = cf * a0
    F1 = cf * a1
    F2 = cf * a2
    # dF = (1-D)[s H + sp a (x) dk] - s a (x) dD
    e = (1.0 - Dn) * sp
    T00 = cf * H0 + e * a0 * dk0 - s * a0 * dD0
    T01 = e * a0 * dk1 - s * a0 * dD1
    T02 = e * a0 * dk2 - s * a0 * dD2
    T10 = e * a1 * dk0 - s * a1 * dD0
    T11 = cf * kT + e * a1 * dk1 - s * a1 * dD1
    T12 = e * a1 * dk2 - s * a1 * dD2
    T20 = e * a2 * dk0 - s * a2 * dD0
    T21 = e * a2 * dk1 - s * a2 * dD1
    T22 = cf * kT + e * a2 * dk2 - s * a2 * dD2

    # ---- dissipation: softening (exact for proportional paths) + damage release -----------
    dphi = 0.0
    if loading and kn > lm:
        hi = kn if kn < 1.0 else 1.0
        lo = ko if ko > lm else lm
        if hi > lo:
            q = lN * (sig * u * u + tau * v * v) / (lam * lam)
            dphi += (1.0 - Do) * 0.5 * q * (hi - lo) / (1.0 - lm)
    if Dn > Do:
        dphi += 0.5 * s * (a0 * gNp + a1 * gT1 + a2 * gT2) * (Dn - Do)

    # ---- contact, docs §1.3 -----------------------------------------------------------------
    FNc = 0.0
    dFNc0 = 0.0
    if contact is not None:
        if gN < 0.0:
            Kint = contact[0]
            CN = contact[1]
            gref = contact[2]
            m = contact[3]
            w = 1.0 - (1.0 - Dn) * lm * s               # lost stiffness fraction omega
            c = -gN / gref
            p = -CN * gref * c ** m
            pp = CN * m * c ** (m - 1.0)
            FNc = (1.0 - w) * Kint * gN + w * p
            dFNc0 = (1.0 - w) * Kint + w * pp
            jump = p - Kint * gN
            # d omega = lm [s dD - (1-D) sp dk]
            T00 += dFNc0 + jump * lm * (s * dD0 - e * dk0)
            T01 += jump * lm * (s * dD1 - e * dk1)
            T02 += jump * lm * (s * dD2 - e * dk2)
            F0 += FNc

    # ---- friction after decohesion, Eqs. 4-5 (return map) -----------------------------------
    if friction is not None:
        s1 = slip[i, 0]
        s2 = slip[i, 1] if dim == 3 else 0.0
        if (not bonded) and FNc < 0.0:
            f = friction[0]
            CT = friction[1]
            tr1 = CT * (gT1 - s1)
            tr2 = CT * (gT2 - s2)
            trm = math.hypot(tr1, tr2)
            lim = -f * FNc
            if trm <= lim:                                  # stick
                F1 += tr1
                F2 += tr2
                T11 += CT
                T22 += CT
                n1 = s1
                n2 = s2
            else:                                           # slip
                nn1 = tr1 / trm
                nn2 = tr2 / trm
                F1 += lim * nn1
                F2 += lim * nn2
                dl = (trm - lim) / CT
                n1 = s1 + dl * nn1
                n2 = s2 + dl * nn2
                dphi += lim * (nn1 * (n1 - s1) + nn2 * (n2 - s2))
                T10 += -f * dFNc0 * nn1
                T20 += -f * dFNc0 * nn2
                rr = lim * CT / trm
                T11 += rr * (1.0 - nn1 * nn1)
                T12 += -rr * nn1 * nn2
                T21 += -rr * nn2 * nn1
                T22 += rr * (1.0 - nn2 * nn2)
        else:                                               # bonded or open: spring unloaded
            n1 = gT1
            n2 = gT2
        slip_n[i, 0] = n1
        if dim == 3:
            slip_n[i, 1] = n2

    diss_n[i] = diss[i] + dphi
    F[i, 0] = F0
    F[i, 1] = F1
    T[i, 0, 0] = T00
    T[i, 0, 1] = T01
    T[i, 1, 0] = T10
    T[i, 1, 1] = T11
    if dim == 3:
        F[i, 2] = F2
        T[i, 0, 2] = T02
        T[i, 1, 2] = T12
        T[i, 2, 0] = T20
        T[i, 2, 1] = T21
        T[i, 2, 2] = T22


@njit(cache=True)
def evaluate_serial(gap, coh, contact, friction, damage, kappa, dmg, sep, slip, diss,
                    F, T, kappa_n, dmg_n, sep_n, slip_n, diss_n):
    dim = gap.shape[1]
    for i in range(gap.shape[0]):
        _point(i, gap, dim, coh, contact, friction, damage, kappa, dmg, sep, slip, diss,
               F, T, kappa_n, dmg_n, sep_n, slip_n, diss_n)


@njit(cache=True, parallel=True)
def evaluate_parallel(gap, coh, contact, friction, damage, kappa, dmg, sep, slip, diss,
                      F, T, kappa_n, dmg_n, sep_n, slip_n, diss_n):
    dim = gap.shape[1]
    for i in prange(gap.shape[0]):
        _point(i, gap, dim, coh, contact, friction, damage, kappa, dmg, sep, slip, diss,
               F, T, kappa_n, dmg_n, sep_n, slip_n, diss_n)


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
