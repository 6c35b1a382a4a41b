"""Lognormal fragility functions fitted by maximum likelihood to multiple-stripe data.

Baker, J. W. (2015), "Efficient analytical fragility function fitting using dynamic structural
analysis", Earthquake Spectra 31(1):579-599, Eq. (11): at each intensity level x_j of the IDA
(a "stripe"), z_j of n_j runs exceed the limit state; with the lognormal fragility

    P(exceed | IM = x) = Phi( ln(x / theta) / beta )

the likelihood is prod_j C(n_j, z_j) p_j^z_j (1 - p_j)^(n_j - z_j), maximised over
(ln theta, ln beta) with scipy.optimize (Nelder-Mead, then a check of the gradient). Standard
errors come from the expected Fisher information at the estimate (asymptotic, large n).

Degenerate data have no finite maximum: no exceedance at any level (theta above the largest
level), exceedance everywhere (theta below the smallest), or stripes separated perfectly
(0 of n below some level, n of n above: beta -> 0). These are reported with a ``status`` and
the bracket of theta, not as numbers that look fitted.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.optimize import minimize
from scipy.special import log_ndtr
from scipy.stats import norm

# (name, demand column, threshold, description) -- the defaults (docs/studies.md). The
# sliding thresholds span the range Chopra & Zhang (1991, J. Struct. Eng. 117(12):3572,
# abstract) report for the permanent base sliding of gravity dams at 0.5 g, "inches to
# feet": 1 in (25 mm), 6 in (150 mm) and 2 ft (600 mm); no published damage-state
# thresholds for the permanent slip of a gravity dam could be read here, so these are this
# project's choice on that range, and ``--limit-state`` sets others. A run that collapsed
# (a joint sliding without bound, run/collapse.py) exceeds every sliding limit state.
DEFAULT_LIMIT_STATES = (
    ("heel_crack_1m", "crack_heel_max_m", 1.0, "heel crack length >= 1 m"),
    ("heel_crack_5m", "crack_heel_max_m", 5.0, "heel crack length >= 5 m"),
    ("residual_slip_25mm", "slip_residual_m", 0.025,
     "permanent base slip >= 25 mm (1 in; Chopra & Zhang 1991 range)"),
    ("residual_slip_150mm", "slip_residual_m", 0.150,
     "permanent base slip >= 150 mm (6 in; Chopra & Zhang 1991 range)"),
    ("residual_slip_600mm", "slip_residual_m", 0.600,
     "permanent base slip >= 600 mm (2 ft; Chopra & Zhang 1991 range)"),
    ("collapse", "collapse", 1.0, "collapse: a joint slides without bound or slides off "
                                  "(run/collapse.py; a run that left the model's range, "
                                  "verdict undetermined, is not a collapse)"),
    ("base_failure", "full_base_failure", 1.0, "full base failure (whole base debonded, or "
                                                "collapse)"),
)
# the demands a collapsed run exceeds whatever their value at the collapse (the run stopped)
COLLAPSE_EXCEEDS = ("slip_residual_m", "slip_max_m", "rotation_max_rad",
                    "rotation_residual_rad", "collapse")


def parse_limit_state(text: str):
    """``NAME=COLUMN:THRESHOLD`` (e.g. ``slip_1m=slip_residual_m:1.0``) -> a limit-state tuple;
    ValueError naming the part that is wrong."""
    name, eq, rest = text.partition("=")
    col, colon, thr = rest.partition(":")
    try:
        value = float(thr)
    except ValueError:
        value = None
    if not (eq and colon and name.strip() and col.strip()) or value is None or \
            not math.isfinite(value):
        raise ValueError(f"--limit-state {text!r}: allowed NAME=COLUMN:THRESHOLD with a "
                         "demand column of ida.csv and a finite number, e.g. "
                         "'slip_1m=slip_residual_m:1.0'")
    return (name.strip(), col.strip(), value, f"{col.strip()} >= {value:g}")


def _logcdf(u):
    return log_ndtr(u)


def neg_log_likelihood(params, x, n, z) -> float:
    """-ln L of (ln theta, ln beta) for stripes at x with z of n exceeding (constant dropped)."""
    mu, lb = params
    beta = math.exp(lb)
    u = (np.log(x) - mu) / beta
    return float(-np.sum(z * _logcdf(u) + (n - z) * _logcdf(-u)))


def fisher_se(x, n, theta: float, beta: float) -> tuple[float, float]:
    """Asymptotic standard errors (of ln theta, of beta) from the expected Fisher information
    I = sum_j n_j grad p_j grad p_j^T / (p_j (1 - p_j)) of the binomial stripes."""
    x, n = np.asarray(x, float), np.asarray(n, float)
    u = (np.log(x) - math.log(theta)) / beta
    p = norm.cdf(u)
    phi = norm.pdf(u)
    g = np.stack([-phi / beta, -phi * u / beta])           # d p / d(ln theta), d p / d beta
    wgt = n / np.maximum(p * (1 - p), 1e-300)
    info = (g * wgt) @ g.T
    try:
        cov = np.linalg.inv(info)
    except np.linalg.LinAlgError:
        return float("inf"), float("inf")
    return float(math.sqrt(max(cov[0, 0], 0.0))), float(math.sqrt(max(cov[1, 1], 0.0)))


def fit_lognormal(levels, n, z) -> dict:
    """MLE of (theta, beta) from stripes (levels x_j > 0, n_j runs, z_j exceedances)."""
    x = np.asarray(levels, float)
    n = np.asarray(n, float)
    z = np.asarray(z, float)
    if x.ndim != 1 or not (x.size == n.size == z.size) or x.size == 0:
        raise ValueError("fit_lognormal: levels, n and z must be 1-D of equal, non-zero length")
    if np.any(x <= 0) or np.any(n < 1) or np.any(z < 0) or np.any(z > n):
        raise ValueError("fit_lognormal: need levels > 0, n >= 1 and 0 <= z <= n")
    order = np.argsort(x)
    x, n, z = x[order], n[order], z[order]
    base = {"levels": x.tolist(), "n": n.astype(int).tolist(), "z": z.astype(int).tolist(),
            "fractions": (z / n).tolist(), "method": "maximum likelihood, multiple stripes "
            "(Baker 2015, Earthquake Spectra 31(1):579-599)"}
    if z.sum() == 0:
        return {**base, "status": "no exceedance", "theta": None, "beta": None,
                "theta_bracket": [float(x[-1]), None],
                "note": "no run exceeds the limit state: theta is above the largest level"}
    if np.all(z == n):
        return {**base, "status": "all exceed", "theta": None, "beta": None,
                "theta_bracket": [None, float(x[0])],
                "note": "every run exceeds the limit state: theta is below the smallest level"}
    # perfectly separated stripes: all-0 stripes strictly below all-n stripes, none partial
    partial = (z > 0) & (z < n)
    if not partial.any():
        lo = x[z == 0].max() if np.any(z == 0) else None
        hi = x[z == n].min() if np.any(z == n) else None
        if lo is not None and hi is not None and lo < hi:
            return {**base, "status": "separated", "theta": float(math.sqrt(lo * hi)),
                    "beta": 0.0, "theta_bracket": [float(lo), float(hi)],
                    "note": "stripes separate perfectly (none exceeds up to the lower level, "
                            "all from the upper): the likelihood grows as beta -> 0; theta "
                            "given as the geometric mean of the bracket"}
    # start: theta where the fraction crosses 1/2 (log-interpolated), beta 0.4
    frac = z / n
    mu0 = float(np.interp(0.5, np.maximum.accumulate(frac) + 1e-9 * np.arange(frac.size),
                          np.log(x)))
    starts = [(mu0, math.log(0.4)), (mu0, math.log(1.0)), (float(np.log(x).mean()), math.log(0.2))]
    best = None
    for s in starts:
        r = minimize(neg_log_likelihood, np.array(s), args=(x, n, z), method="Nelder-Mead",
                     options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 20000,
                              "maxfev": 40000})
        if best is None or r.fun < best.fun:
            best = r
    mu, lb = best.x
    theta, beta = float(math.exp(mu)), float(math.exp(lb))
    status = "ok"
    note = None
    se_t, se_b = fisher_se(x, n, theta, beta)
    if beta > 50 or beta < 1e-4 or not best.success or not (math.isfinite(se_t)
                                                           and math.isfinite(se_b)):
        status = "ill-conditioned"
        note = (f"optimiser: {best.message}; beta = {beta:.3g}, standard errors "
                f"({se_t:.3g}, {se_b:.3g}) -- the data hardly constrain the fit (few stripes, "
                "few exceedances, or a stripe at exactly 50 % next to a 100 % one)")
    return {**base, "status": status, "theta": theta, "beta": beta,
            "se_ln_theta": se_t, "se_beta": se_b,
            "neg_log_likelihood": float(best.fun), "note": note}


def probability(x, theta: float, beta: float):
    """Lognormal fragility Phi(ln(x/theta)/beta); beta = 0 gives the step at theta."""
    x = np.asarray(x, float)
    if beta == 0:
        return (x >= theta).astype(float)
    return norm.cdf(np.log(x / theta) / beta)


def exceedances(rows, column: str, threshold: float, failed: str = "exceed") -> dict:
    """Per level: n runs, z exceeding ``column >= threshold``. Runs that failed for a physical
    reason (solver error after all cuts) count as exceeding (``failed='exceed'``, numerical
    collapse as in IDA practice) or are left out (``'exclude'``). A run that stopped because it
    left the model's range (verdict undetermined: ``time.max_slip`` / ``time.max_rotation``,
    run/collapse.py) exceeds where the value it reached before the stop does; elsewhere its
    outcome is unknown and it follows ``failed`` like a failed run (counting it as not
    exceeding would bias the fragility low)."""
    lv = {}
    for r in rows:
        if r["status"] == "failed":
            if failed == "exclude":
                continue
            hit = True
        elif r["status"] != "ok":
            continue
        elif column in COLLAPSE_EXCEEDS and r.get("collapse"):
            hit = True                  # a collapsed run exceeds every sliding limit state
        elif r.get("undetermined"):
            v = r.get(column)
            if v is not None and not (isinstance(v, float) and math.isnan(v)) \
                    and float(v) >= threshold:
                hit = True              # reached before the run left the model's range
            elif failed == "exclude":
                continue
            else:
                hit = True
        else:
            v = r.get(column)
            if v is None or (isinstance(v, float) and math.isnan(v)):
                continue
            hit = float(v) >= threshold
        d = lv.setdefault(float(r["level_g"]), [0, 0])
        d[0] += 1
        d[1] += int(hit)
    xs = sorted(lv)
    return {"levels": xs, "n": [lv[k][0] for k in xs], "z": [lv[k][1] for k in xs]}
