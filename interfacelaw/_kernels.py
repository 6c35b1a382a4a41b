"""numba kernels of the interface law. No checks, no allocation, no globals: the public class
(`interfacelaw.law.InterfaceLaw`) validates and allocates; these functions only write into the
output arrays they are given.

Optional parts (contact, friction, damage) are passed as a float64 parameter array or ``None``;
numba compiles one specialisation per combination and prunes the branches of the parts that are
``None`` at compile time, so a law without friction or damage never computes them.

The equations are those of docs/law.md, derivatives written beside each formula.
Components: 0 = normal, 1 and 2 = tangential (2 is absent in 2D).

Speed (BENCHMARKS.md): the loops are written so that LLVM vectorises them (AVX2: 4
points per instruction). What that takes, measured: no Python exceptions in the loop
(``error_model="numpy"``: a float division by zero gives inf instead of raising, and every such
value is discarded by a select — the inputs are checked finite by ``InterfaceLaw``); no calls
(``x ** p`` is a call to ``pow``: the exponents of the common laws, 0, 1, 2 and 1/2, are done by
multiplication or sqrt in the *fast* specialisation, chosen per law by :func:`is_fast`); flat
arrays indexed with a compile-time stride (``gap[2 i + 1]``, not ``gap[i, 1]``, whose row stride
LLVM cannot see); the dimension and the specialisation are compile-time constants of inlined
loop copies. The branches stay in the source: LLVM turns them into selects. The branches on
*parameters* (damage exponent, form, zero threshold) it kept as branches inside the vector loop,
splitting it into blocks across which registers spill: the fast loop is compiled per kind of
law with those values as constants (:func:`code`, ``numba.literally``), which leaves one block.
"""
import contextlib
import math
import os
import sys
import tempfile

import numpy as np

from numba import config as numba_config, literally, njit, prange

try:
    import fcntl
except ImportError:                      # pragma: no cover - not POSIX: no lock
    fcntl = None

# points per parallel chunk (a chunk is one vectorised serial loop)
CHUNK = 4096
# the spec argument of _law outside the fast loops (ignored there)
_NO_SPEC = (1.0, 0.0, 1.0)


@njit(cache=True)
def sum_squares(x):
    """sum x_i^2 of a 1-D float64 array, in index order: the law's quick bound on every |x_i|
    (``law._QUICK_SQ``). A gap of ~1e155 m or more overflows it to inf and is refused by the
    full check; numpy's ``x.dot(x)`` printed a RuntimeWarning ("overflow encountered in dot")
    before that error, numba's loop raises none. ~0.4 us for the 666 values of Koyna's gap."""
    s = 0.0
    for i in range(x.size):
        s += x[i] * x[i]
    return s


@njit(cache=True, inline="always", error_model="numpy")
def secant(k, lm, ilm, ilm1):
    """Secant factor s(κ) of Eqs. 2–3 and ds/dκ (ilm = 1/λ_max, ilm1 = 1/(1-λ_max))."""
    if k <= lm:
        return ilm, 0.0
    if k >= 1.0:
        return 0.0, 0.0
    ik = 1.0 / k
    return (ik - 1.0) * ilm1, -ik * ik * ilm1


@njit(cache=True, inline="always", error_model="numpy")
def _pow(x, p, fast):
    """x**p. ``fast`` (a compile-time constant): p is known to be 0, 1 or 2 (is_fast), so no
    pow call: the loop stays vectorisable. Otherwise the common exponents still avoid pow."""
    if fast:
        return x if p == 1.0 else (x * x if p == 2.0 else 1.0)
    if p == 1.0:
        return x
    if p == 2.0:
        return x * x
    if p == 0.0:
        return 1.0
    return x ** p


@njit(cache=True, inline="always", error_model="numpy")
def _root(x, alpha, fast):
    """x**(1/alpha); ``fast``: alpha is 1 or 2 (is_fast)."""
    if fast:
        return x if alpha == 1.0 else np.sqrt(x)
    return _pow(x, 1.0 / alpha, False)


def is_fast(contact, damage) -> bool:
    """True when every exponent of the law is 0, 1 or 2 (damage alpha in {1, 2}, beta = 0;
    contact exponent m in {1, 2}): the loop then needs no pow call (see the module notes).
    ``contact``/``damage`` are the parameter tuples (or None) given to the kernels."""
    ok = True
    if damage is not None:
        ok = damage[0] in (1.0, 2.0) and damage[1] == 0.0
    if contact is not None:
        ok = ok and contact[3] in (1.0, 2.0)
    return ok


@njit(cache=True, inline="always", error_model="numpy")
def _norm(x, y):
    """sqrt(x^2 + y^2): the callers bound |x|, |y| far below 1e150 (InterfaceLaw checks |gap|),
    and an underflow to 0 only happens where the result is not divided by."""
    return np.sqrt(x * x + y * y)


@njit(cache=True, inline="always", error_model="numpy")
def _law(gN, gT1, gT2, ko, Do, sepo, s1, s2, coh, contact, friction, damage, rdt, fast,
         spec, three):
    """One material point, scalars in, scalars out (no arrays: nothing to reference-count).
    ``fast`` (compile-time constant): the law's exponents are 0, 1 or 2 (is_fast); then
    ``spec`` = (alpha, damage form code, 1.0 if F_th = 0 else 0.0) are compile-time constants
    equal to the law's own values (see :func:`code`), used instead of the run-time parameters:
    LLVM then drops the branches on them from the loop (ignored when not fast).
    ``three``: 3D; False (a compile-time constant in the 2D loops) drops the arithmetic on the
    absent second tangential component (gT2 = s2 = 0): without fast-math LLVM cannot fold
    ``0/l`` or ``x + 0*y`` itself (inf and -0), and those are divisions and a sqrt per point.

    damage = (alpha, beta, g_max, F_th/sigma_max, form code: 0 paper, 1 objective, 2 rate);
    rdt = dt/t_ref of the step (rate form only; > 0 and finite, checked by the caller).

    Returns (F0, F1, F2, T00, T01, T02, T10, T11, T12, T20, T21, T22,
             kappa_new, damage_new, separation_new, slip1_new, slip2_new, dissipated_increment).
    """
    # coh = (sigma, tau, l_Nc, l_Tc, lambda_max, 1/l_Nc, 1/l_Tc, tau l_Nc/l_Tc^2,
    #        1/lambda_max, 1/(1-lambda_max)); reciprocals precomputed once per law
    sig, tau, lN, lT, lm, ilN, ilT, kT, ilm, ilm1 = coh
    gNp = gN if gN > 0.0 else 0.0
    hN = 1.0 if gN >= 0.0 else 0.0                 # d<gN>/dgN (tension side at gN = 0)

    # Eq. 1 with <gN>: lam = hypot(u, v)
    # divisions, not reciprocals: a gap of exactly l_Nc (or l_Tc) must give lambda = 1 exactly
    u = gNp / lN
    t1 = gT1 / lT
    t2 = gT2 / lT if three else 0.0
    v2 = t1 * t1 + t2 * t2 if three else t1 * t1    # |g_T|^2 / l_Tc^2
    lam = np.sqrt(u * u + v2)

    bonded_old = ko < 1.0 and Do < 1.0

    # irreversibility: kappa = max(lam, lambda_h)
    loading = lam > ko
    kn = lam if loading else ko
    s, sp = secant(kn, lm, ilm, ilm1)
    dk0 = 0.0
    dk1 = 0.0
    dk2 = 0.0
    if loading and sp != 0.0:                      # d lam / d gap (lam > lm > 0 here)
        ilam = 1.0 / lam
        dk0 = u * ilN * ilam
        dk1 = t1 * ilT * ilam
        dk2 = t2 * ilT * ilam if three else 0.0

    # a = grad(Q/2): a0 = sig <gN>/lN, aT = tau lN/lT^2 gT ; H = d a / d gap (diagonal)
    a0 = sig * u
    a1 = kT * gT1
    a2 = kT * gT2 if three else 0.0
    H0 = sig * ilN * hN

    # separation for damage (docs §1.5): g = hypot(<gN>, |gT|)
    gs = np.sqrt(gNp * gNp + gT1 * gT1 + gT2 * gT2) if three else np.sqrt(gNp * gNp + gT1 * gT1)

    # ---- cyclic damage, Eq. 7 ------------------------------------------------------------
    Dn = Do
    dD0 = 0.0
    dD1 = 0.0
    dD2 = 0.0
    if damage is not None:
        if bonded_old:
            dg = gs - sepo
            if dg > 0.0:
                alpha, beta, gmax, fth, form = damage
                zero_th = fth == 0.0 and beta == 0.0
                if fast:           # the same values, as constants (fast: beta = 0, spec)
                    alpha = spec[0]
                    beta = 0.0
                    form = spec[1]
                    zero_th = spec[2] == 1.0
                amag2 = a0 * a0 + a1 * a1 + a2 * a2 if three else a0 * a0 + a1 * a1
                if zero_th:                          # r > 0 <=> s > 0 and |a| > 0: no sqrt
                    amag = 1.0
                    x = 1.0 if (s > 0.0 and amag2 > 0.0) else 0.0
                else:
                    amag = np.sqrt(amag2)
                    r = s * amag / sig               # F/sigma^t, independent of D
                    x = r - fth
                if x > 0.0:
                    B = 1.0 if (fast or beta == 0.0) else _pow(x, beta, fast)
                    base = dg / gmax
                    if form != 1.0:
                        if form == 0.0:                # the paper's form, Eq. 7
                            c2 = _pow(base, alpha, fast)     # d D / d B
                        else:  # rate form (docs §1.5): (dg/g_max)^a (dt/t_ref)^(1-a), written
                            # as (normalised rate)^a * rdt so that no factor overflows alone
                            c2 = _pow(base / rdt, alpha, fast) * rdt
                        inc = c2 * B
                        ok = inc < 1.0 and Do + inc < 1.0
                        Dtry = Do + inc
                        c1 = inc * alpha / (dg * gs)  # d D / d gs, over gs
                    else:  # step-size objective: D = (p/g_max)^alpha, dp = B dg+ (docs §3 D4)
                        xp = _root(Do, alpha, fast) + B * base
                        Dtry = _pow(xp, alpha, fast)
                        ok = Dtry < 1.0
                        dDdp = alpha * _pow(xp, alpha - 1.0, fast) / gmax
                        c1 = dDdp * B / gs
                        c2 = dDdp * dg
                    if ok:
                        Dn = Dtry
                        dD0 = c1 * gNp
                        dD1 = c1 * gT1
                        dD2 = c1 * gT2
                        if (not fast) and beta != 0.0:
                            c2 = c2 * beta * _pow(x, beta - 1.0, fast) / sig   # dD/dr / sig
                            # dr*sig = sp*amag*dk + s*d|a|
                            dD0 += c2 * (sp * amag * dk0 + s * a0 * H0 / amag)
                            dD1 += c2 * (sp * amag * dk1 + s * a1 * kT / amag)
                            dD2 += c2 * (sp * amag * dk2 + s * a2 * kT / amag)
                    else:
                        Dn = 1.0
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
            q = lN * (sig * u * u + tau * v2) / (lam * lam)
            dphi += (1.0 - Do) * 0.5 * q * (hi - lo) * ilm1
    if Dn > Do:
        ag = a0 * gNp + a1 * gT1 + a2 * gT2 if three else a0 * gNp + a1 * gT1
        dphi += 0.5 * s * ag * (Dn - Do)

    # ---- contact, docs §1.3 -----------------------------------------------------------------
    FNc = 0.0
    dFNc0 = 0.0
    if contact is not None:
        if gN < 0.0:
            Kint, CN, gref, m, cs = contact
            w = 1.0 - (1.0 - Dn) * lm * s               # lost stiffness fraction omega
            c = -gN / gref
            # crack law: p = -C_N g_ref c^m, stiffness C_N m c^(m-1) capped at K_int beyond
            # c* = cs (a closed crack is never stiffer than the bond), potential Pi
            if c <= cs:
                cm = _pow(c, m, fast)
                p = -CN * gref * cm
                pp = CN * m * _pow(c, m - 1.0, fast)
                Pi = CN * gref * gref * cm * c / (m + 1.0)
            else:
                csm = _pow(cs, m, fast)
                p = -(CN * csm + Kint * (c - cs)) * gref
                pp = Kint
                Pi = gref * gref * (CN * csm * cs / (m + 1.0) + CN * csm * (c - cs)
                                    + 0.5 * Kint * (c - cs) * (c - cs))
            FNc = (1.0 - w) * Kint * gN + w * p
            dFNc0 = (1.0 - w) * Kint + w * pp
            jump = p - Kint * gN
            # d omega = lm [s dD - (1-D) sp dk]
            T00 += dFNc0 + jump * lm * (s * dD0 - e * dk0)
            T01 += jump * lm * (s * dD1 - e * dk1)
            T02 += jump * lm * (s * dD2 - e * dk2)
            F0 += FNc
            # energy: moving bonded area into crack area at fixed g_N releases
            # (omega - omega_old)(K_int g_N^2/2 - Pi(g_N)) >= 0 (Pi <= K_int g_N^2/2 by the cap)
            so = secant(ko, lm, ilm, ilm1)[0]
            w_old = 1.0 - (1.0 - Do) * lm * so
            if w != w_old:
                dphi += (w - w_old) * (0.5 * Kint * gN * gN - Pi)

    # ---- friction after decohesion, Eqs. 4-5 (return map) -----------------------------------
    n1 = s1
    n2 = s2
    if friction is not None:
        if (not bonded) and FNc < 0.0:
            f, CT = friction
            tr1 = CT * (gT1 - s1)
            tr2 = CT * (gT2 - s2) if three else 0.0
            trm = _norm(tr1, tr2) if three else abs(tr1)
            lim = -f * FNc
            if trm <= lim:                                  # stick
                F1 += tr1
                F2 += tr2
                T11 += CT
                T22 += CT
            else:                                           # slip
                # 2D: tr1/|tr1| is +-1 exactly (|tr1| = trm > lim >= 0): no division
                nn1 = tr1 / trm if three else (1.0 if tr1 > 0.0 else -1.0)
                nn2 = tr2 / trm if three else 0.0
                F1 += lim * nn1
                F2 += lim * nn2
                dl = (trm - lim) / CT
                n1 = s1 + dl * nn1
                n2 = s2 + dl * nn2
                if three:
                    dphi += lim * (nn1 * (n1 - s1) + nn2 * (n2 - s2))
                else:
                    dphi += lim * (nn1 * (n1 - s1))
                T10 += -f * dFNc0 * nn1
                T20 += -f * dFNc0 * nn2
                if three:
                    rr = lim * CT / trm
                    T11 += rr * (1.0 - nn1 * nn1)
                    T12 += -rr * nn1 * nn2
                    T21 += -rr * nn2 * nn1
                    T22 += rr * (1.0 - nn2 * nn2)
                else:  # rr (1 - nn1^2) = +0 (rr >= 0): the sum kept, a -0 still becomes +0
                    T11 += 0.0
        else:                                               # bonded or open: spring unloaded
            n1 = gT1
            n2 = gT2
    return (F0, F1, F2, T00, T01, T02, T10, T11, T12, T20, T21, T22, kn, Dn, gs, n1, n2, dphi)


# The loops, one per dim, serial and parallel. ``code`` (see :func:`code`) is a compile-time
# constant (``numba.literally``: numba compiles one loop per value, each with one inlined copy
# of _law; inlining several copies into one function made numba's compile time explode, 12 s
# -> 9 min): -1 the general loop, 0..11 the fast loop of one kind of law (damage exponent,
# form and zero threshold). g, sl, F, T, sl_n are the flat (C-order) views of gap, slip,
# traction, tangent and new slip, indexed with constant strides.
@njit(cache=True, inline="always")
def _decode(code):
    """code -> (fast, spec): the inverse of :func:`code` (constants once ``code`` is)."""
    c = code if code >= 0 else 0
    return code >= 0, (2.0 if c % 2 else 1.0, float(c // 4), float((c // 2) % 2))


@njit(cache=True, error_model="numpy")
def _run2(code, g, coh, contact, friction, damage, rdt, kappa, dmg, sep, sl, diss,
          F, T, kappa_n, dmg_n, sep_n, sl_n, diss_n):
    literally(code)
    fast, spec = _decode(code)
    for i in range(kappa.shape[0]):
        r = _law(g[2 * i], g[2 * i + 1], 0.0, kappa[i], dmg[i], sep[i], sl[i], 0.0,
                 coh, contact, friction, damage, rdt, fast, spec, False)
        F[2 * i] = r[0]
        F[2 * i + 1] = r[1]
        T[4 * i] = r[3]
        T[4 * i + 1] = r[4]
        T[4 * i + 2] = r[6]
        T[4 * i + 3] = r[7]
        kappa_n[i] = r[12]
        dmg_n[i] = r[13]
        sep_n[i] = r[14]
        if friction is not None:
            sl_n[i] = r[15]
        diss_n[i] = diss[i] + r[17]


@njit(cache=True, error_model="numpy")
def _run3(code, g, coh, contact, friction, damage, rdt, kappa, dmg, sep, sl, diss,
          F, T, kappa_n, dmg_n, sep_n, sl_n, diss_n):
    literally(code)
    fast, spec = _decode(code)
    for i in range(kappa.shape[0]):
        r = _law(g[3 * i], g[3 * i + 1], g[3 * i + 2], kappa[i], dmg[i], sep[i],
                 sl[2 * i], sl[2 * i + 1], coh, contact, friction, damage, rdt, fast, spec,
                 True)
        F[3 * i] = r[0]
        F[3 * i + 1] = r[1]
        F[3 * i + 2] = r[2]
        T[9 * i] = r[3]
        T[9 * i + 1] = r[4]
        T[9 * i + 2] = r[5]
        T[9 * i + 3] = r[6]
        T[9 * i + 4] = r[7]
        T[9 * i + 5] = r[8]
        T[9 * i + 6] = r[9]
        T[9 * i + 7] = r[10]
        T[9 * i + 8] = r[11]
        kappa_n[i] = r[12]
        dmg_n[i] = r[13]
        sep_n[i] = r[14]
        if friction is not None:
            sl_n[2 * i] = r[15]
            sl_n[2 * i + 1] = r[16]
        diss_n[i] = diss[i] + r[17]


# Parallel versions: chunks of CHUNK points, each one call of the serial (vectorised) loop on
# views that start at the chunk (a loop index from 0, see the module notes).
@njit(cache=True, parallel=True, error_model="numpy")
def _par2(code, g, coh, contact, friction, damage, rdt, kappa, dmg, sep, sl, diss, F, T,
          kappa_n, dmg_n, sep_n, sl_n, diss_n):
    literally(code)
    n = kappa.shape[0]
    for b in prange((n + CHUNK - 1) // CHUNK):
        lo = b * CHUNK
        hi = min(n, lo + CHUNK)
        _run2(code, g[2 * lo:2 * hi], coh, contact, friction, damage, rdt, kappa[lo:hi],
              dmg[lo:hi], sep[lo:hi], sl[1 * lo:1 * hi], diss[lo:hi],
              F[2 * lo:2 * hi], T[4 * lo:4 * hi], kappa_n[lo:hi], dmg_n[lo:hi],
              sep_n[lo:hi], sl_n[1 * lo:1 * hi], diss_n[lo:hi])


@njit(cache=True, parallel=True, error_model="numpy")
def _par3(code, g, coh, contact, friction, damage, rdt, kappa, dmg, sep, sl, diss, F, T,
          kappa_n, dmg_n, sep_n, sl_n, diss_n):
    literally(code)
    n = kappa.shape[0]
    for b in prange((n + CHUNK - 1) // CHUNK):
        lo = b * CHUNK
        hi = min(n, lo + CHUNK)
        _run3(code, g[3 * lo:3 * hi], coh, contact, friction, damage, rdt, kappa[lo:hi],
              dmg[lo:hi], sep[lo:hi], sl[2 * lo:2 * hi], diss[lo:hi],
              F[3 * lo:3 * hi], T[9 * lo:9 * hi], kappa_n[lo:hi], dmg_n[lo:hi],
              sep_n[lo:hi], sl_n[2 * lo:2 * hi], diss_n[lo:hi])


def code(contact, damage) -> int:
    """The loop code of a law (``contact``/``damage``: the parameter tuples or None given to
    the kernels): -1 if not :func:`is_fast` (the general loop), else
    (alpha == 2) + 2 (F_th == 0) + 4 form, the damage values the fast loop compiles in as
    constants (no damage counts as alpha = 1, F_th = 0, form 0: no extra loops).
    Measured (BENCHMARKS.md): with these three as run-time values the branches on
    them split the vectorised loop into blocks whose registers spill (each alone costs ~13 %);
    as constants the 2D loop runs ~1.4x faster, bit for bit the same numbers. The contact
    exponent m would add loops for no gain (it only feeds selects, no branch)."""
    if not is_fast(contact, damage):
        return -1
    if damage is None:
        return 2
    return int(damage[0] == 2.0) + 2 * int(damage[3] == 0.0) + 4 * int(damage[4])


# Entries called from Python, one per (code, dim, parallel): a compiled function with no
# literal argument (a numba.literally function called from Python is re-typed at every call,
# ~20 ms) that calls the loop with its code as a constant. A closure over an int only: numba's
# disk cache keys it by the value.
_ENTRIES = {}


def loop(code, dim, parallel):
    """The compiled loop (an entry) for a law's :func:`code`, its dim and serial/parallel; it
    takes the arguments of _run2 after ``code``."""
    key = (code, dim, parallel)
    e = _ENTRIES.get(key)
    if e is None:
        e = _ENTRIES[key] = _entries(code)[(dim, parallel)]
    return e


def _entries(code):
    @njit(cache=True, error_model="numpy")
    def serial2(g, coh, contact, friction, damage, rdt, kappa, dmg, sep, sl, diss, F, T,
                kappa_n, dmg_n, sep_n, sl_n, diss_n):
        _run2(code, g, coh, contact, friction, damage, rdt, kappa, dmg, sep, sl, diss, F, T,
              kappa_n, dmg_n, sep_n, sl_n, diss_n)

    @njit(cache=True, error_model="numpy")
    def serial3(g, coh, contact, friction, damage, rdt, kappa, dmg, sep, sl, diss, F, T,
                kappa_n, dmg_n, sep_n, sl_n, diss_n):
        _run3(code, g, coh, contact, friction, damage, rdt, kappa, dmg, sep, sl, diss, F, T,
              kappa_n, dmg_n, sep_n, sl_n, diss_n)

    @njit(cache=True, error_model="numpy")
    def parallel2(g, coh, contact, friction, damage, rdt, kappa, dmg, sep, sl, diss, F, T,
                  kappa_n, dmg_n, sep_n, sl_n, diss_n):
        _par2(code, g, coh, contact, friction, damage, rdt, kappa, dmg, sep, sl, diss, F, T,
              kappa_n, dmg_n, sep_n, sl_n, diss_n)

    @njit(cache=True, error_model="numpy")
    def parallel3(g, coh, contact, friction, damage, rdt, kappa, dmg, sep, sl, diss, F, T,
                  kappa_n, dmg_n, sep_n, sl_n, diss_n):
        _par3(code, g, coh, contact, friction, damage, rdt, kappa, dmg, sep, sl, diss, F, T,
              kappa_n, dmg_n, sep_n, sl_n, diss_n)

    return {(2, False): serial2, (3, False): serial3, (2, True): parallel2,
            (3, True): parallel3}


@njit(cache=True, error_model="numpy")
def evaluate_serial(gap, coh, contact, friction, damage, rdt, kappa, dmg, sep, slip, diss,
                    F, T, kappa_n, dmg_n, sep_n, slip_n, diss_n):
    """One generic loop on (n, dim) arrays, dim at run time: the entry of the C ABI
    (interfacelaw.cabi), which needs one compiled function for every parameter value and both
    dims (one copy of _law: the shortest compile). Same numbers as the loops above (the fast
    specialisation differs only in computing x**2, x**1, x**0 and x**0.5 by multiplication and
    sqrt, which round the same way), not vectorised."""
    three = gap.shape[1] == 3
    for i in range(gap.shape[0]):
        r = _law(gap[i, 0], gap[i, 1], gap[i, 2] if three else 0.0,
                 kappa[i], dmg[i], sep[i], slip[i, 0], slip[i, 1] if three else 0.0,
                 coh, contact, friction, damage, rdt, False, _NO_SPEC, three)
        F[i, 0] = r[0]
        F[i, 1] = r[1]
        T[i, 0, 0] = r[3]
        T[i, 0, 1] = r[4]
        T[i, 1, 0] = r[6]
        T[i, 1, 1] = r[7]
        if three:
            F[i, 2] = r[2]
            T[i, 0, 2] = r[5]
            T[i, 1, 2] = r[8]
            T[i, 2, 0] = r[9]
            T[i, 2, 1] = r[10]
            T[i, 2, 2] = r[11]
        kappa_n[i] = r[12]
        dmg_n[i] = r[13]
        sep_n[i] = r[14]
        if friction is not None:
            slip_n[i, 0] = r[15]
            if three:
                slip_n[i, 1] = r[16]
        diss_n[i] = diss[i] + r[17]


# LLVM's cost model declines to vectorise these loops (it prices the if-converted branches of
# every point as always executed, and the interleaved (n, dim) accesses); forced to width 4 the
# vectorised loop is 3-4x faster than the scalar one and bit-for-bit identical (no fast-math:
# only the instruction width changes). The option is global to LLVM, so it is switched on only
# while a kernel is compiled (its first call for a combination of the optional parts) and off
# again; code compiled by others in between (another thread) would also be forced — harmless
# (vectorisation never changes results without fast-math) but noted.
#
# The first call of a loop in a process (compiled, or loaded from numba's disk cache) holds an
# exclusive lock shared by every process using the same cache (``cache_lock``). numba's cache
# is not safe for processes that write new overloads of one function at the same time: each
# reads the index, picks the first free data-file number and writes it, so two processes can
# write different loops (the entries differ only in the law's code, a closure constant) under
# one number, and the index then names the other process's machine code. A later process
# loads the wrong loop: a segfault (seen: a verification sweep's two workers on a fresh
# clone's cache, koyna with 1 256 points) or, where the layouts agree, wrong numbers. Held
# once per loop and process, the lock costs nothing in a run.
_compiled = set()
LOCK_NAME = "interfacelaw-compile.lock"


@contextlib.contextmanager
def cache_lock():
    """Exclusive lock on ``LOCK_NAME`` in numba's cache directory (NUMBA_CACHE_DIR, else the
    temporary directory): one process at a time compiles or loads a loop."""
    if fcntl is None:                    # pragma: no cover
        yield
        return
    folder = numba_config.CACHE_DIR or tempfile.gettempdir()
    os.makedirs(folder, exist_ok=True)
    fd = os.open(os.path.join(folder, LOCK_NAME), os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)                     # closing releases the lock


# what LLVM prints to the process's C stderr while a loop compiles with the forced vector width
# and that is not passed on: its analysis remarks on the loops it cannot vectorise (a call
# inside, a reduction), 9 lines on a first call with a cold cache (examples/ex01) -- noise for
# a user, not an error; the loops that matter are the points' loops, which it vectorises
_LLVM_REMARK = ("remark: ", "loop not vectorized")


@contextlib.contextmanager
def llvm_remarks_dropped():
    """Within: whatever is written to file descriptor 2 (the C stderr, where LLVM writes) is
    held and written there afterwards, but for LLVM's "loop not vectorized" remarks
    (``_LLVM_REMARK``). Nothing is filtered when stderr has no file descriptor."""
    try:
        fd = sys.__stderr__.fileno()
    except (AttributeError, ValueError, OSError):
        yield
        return
    sys.stderr.flush()
    saved = os.dup(fd)
    with tempfile.TemporaryFile() as held:
        os.dup2(held.fileno(), fd)
        try:
            yield
        finally:
            try:
                sys.stderr.flush()
            finally:
                os.dup2(saved, fd)
                os.close(saved)
            held.seek(0)
            kept = [line for line in held.read().splitlines(keepends=True)
                    if not (line.startswith(_LLVM_REMARK[0].encode())
                            and _LLVM_REMARK[1].encode() in line)]
            if kept:
                os.write(fd, b"".join(kept))


def compiled(kern, key) -> bool:
    """True when ``call`` has compiled ``kern`` for ``key`` (later calls may call it directly)."""
    return (kern, key) in _compiled


def call(kern, key, *args):
    """kern(*args), compiling it with the forced vector width on its first call for ``key``
    (under ``cache_lock``)."""
    if (kern, key) in _compiled:
        return kern(*args)
    import llvmlite.binding as llvm
    with cache_lock(), llvm_remarks_dropped():
        for opt, on, _ in _LLVM_OPTIONS:
            llvm.set_option("", f"-{opt}={on}")
        try:
            return kern(*args)
        finally:
            for opt, _, default in _LLVM_OPTIONS:
                llvm.set_option("", f"-{opt}={default}")
            _compiled.add((kern, key))


# (option, value while compiling, LLVM's default restored after). The two thresholds: in 3D the
# 13 arrays need more run-time overlap checks than LLVM's defaults allow ("too many SCEV
# assumptions"); the checks run once per call, not per point.
_LLVM_OPTIONS = (("force-vector-width", 4, 0),
                 ("vectorize-scev-check-threshold", 256, 16),
                 ("runtime-memory-check-threshold", 256, 8))
