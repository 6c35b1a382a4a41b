"""Single material-point drivers of the interface law (MTest-like), issue #3.

* :func:`gap_path` — drive one point, or a batch of points at once, along a piecewise-linear gap
  history (breakpoints ``times``/``gaps``, each segment cut into ``substeps`` increments).
* :func:`mixed_control` — impose the traction on some components and the gap on the others; each
  increment is solved by a local (damped) Newton with the law's consistent tangent. Failures are
  reported per increment in ``History.status`` and ``History.message`` (never raised from inside
  the loop); a traction target beyond the peak of the envelope is flagged ``LIMIT_POINT`` and the
  rows from that increment on are NaN: no value past a limit point is ever returned.
* Ready paths: :func:`mode_I`, :func:`mode_II`, :func:`mixed_mode`, :func:`load_unload_reload`,
  :func:`closure_reopening`, :func:`constant_amplitude_cycles`, :func:`shear_under_pressure`.
* Helpers: :func:`cycles_to_failure`, :func:`tangent_fd_error`.

Time: the breakpoint ``times`` are physical times [s]. Each increment passes its time step
``t[i] - t[i-1]`` to ``law.evaluate(..., dt=...)``, which the damage form "rate" uses (the other
forms ignore it); row 0 (the step from the start state to ``gaps[0]``) uses ``dt0``. The ready
paths take their duration (``duration``, or ``period`` per cycle) in seconds; the defaults
(1 s per path / per cycle) keep the pseudo-time of the other forms.

Conventions: component 0 is normal (opening / tension positive), 1 (and 2 in 3D) tangential.
Every array of a :class:`History` has the increment index first; a single-point run has shapes
``(m, dim)`` / ``(m,)``, a batch run ``(m, n, dim)`` / ``(m, n)``.
"""
from __future__ import annotations

import math
import io
import os
from dataclasses import dataclass, field, fields

import numpy as np

from .atomic import atomic_write_text

from .law import InterfaceLaw, InterfaceState

__all__ = [
    "History", "gap_path", "mixed_control",
    "mode_I", "mode_II", "mixed_mode", "load_unload_reload", "closure_reopening",
    "constant_amplitude_cycles", "shear_under_pressure",
    "cycles_to_failure", "tangent_fd_error", "direction_length",
    "OK", "NOT_CONVERGED", "SINGULAR", "LIMIT_POINT", "SKIPPED", "NONFINITE", "STATUS_NAMES",
]

# status codes of History.status (per increment and point)
OK = 0              # increment done (gap control) / Newton converged (mixed control)
NOT_CONVERGED = 1   # Newton hit maxiter with a positive-definite tangent all along
SINGULAR = 2        # the controlled block of the tangent is singular (e.g. debonded, open)
LIMIT_POINT = 3     # the traction target is beyond the peak of the envelope (no stable solution)
SKIPPED = 4         # not computed: an earlier increment of this point failed
NONFINITE = 5       # the law returned a non-finite traction or tangent
STATUS_NAMES = {OK: "ok", NOT_CONVERGED: "not converged", SINGULAR: "singular tangent",
                LIMIT_POINT: "limit point", SKIPPED: "skipped", NONFINITE: "non-finite"}


# ------------------------------------------------------------------------------------------
@dataclass
class History:
    """Result of a driver run. Rows are increments (row 0 is the state at ``times[0]``).

    t (m,); gap, traction (m,[n,]dim); tangent (m,[n,]dim,dim); damage, lambda_h, dissipated,
    work, status, iterations, residual (m,[n]).
    ``dissipated`` is the law's cumulative dissipated energy per unit area (state field);
    ``work`` is the trapezoid integral of traction·dgap from row 0 (so ``work[0] = 0``).
    Rows of a point after a failed increment are NaN (``status`` says why).
    ``state`` is the last committed state (all points); ``message`` is '' when all is well.
    """

    t: np.ndarray
    gap: np.ndarray
    traction: np.ndarray
    tangent: np.ndarray
    damage: np.ndarray
    lambda_h: np.ndarray
    dissipated: np.ndarray
    work: np.ndarray
    status: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    state: InterfaceState
    message: str = ""
    batch: bool = False
    info: dict = field(default_factory=dict)

    _ROW_FIELDS = ("gap", "traction", "tangent", "damage", "lambda_h", "dissipated", "work",
                   "status", "iterations", "residual")

    @property
    def converged(self) -> bool:
        """True when every increment of every point is OK."""
        return bool(np.all(self.status == OK))

    @property
    def ok(self) -> bool:
        return self.converged

    def valid(self) -> "History":
        """The rows before the first failure (of any point)."""
        st = self.status.reshape(len(self.t), -1)
        okrows = np.all(st == OK, axis=1)
        m = len(self.t) if okrows.all() else int(np.argmin(okrows))
        kw = {f.name: getattr(self, f.name) for f in fields(self)}
        kw["t"] = self.t[:m]
        for name in self._ROW_FIELDS:
            kw[name] = getattr(self, name)[:m]
        return History(**kw)

    def point(self, i: int) -> "History":
        """One point of a batch run as a single-point History."""
        if not self.batch:
            if i != 0:
                raise ValueError(f"History.point({i}): a single-point history has only point 0")
            return self
        kw = {f.name: getattr(self, f.name) for f in fields(self)}
        for name in self._ROW_FIELDS:
            kw[name] = getattr(self, name)[:, i]
        kw["state"] = self.state.take(np.array([i]))
        kw["batch"] = False
        return History(**kw)

    def to_csv(self, path) -> str:
        """Write the history as CSV, atomically (temporary file in the same folder, then
        ``os.replace``). Columns: t, then per point p (suffix ``_p`` only for a batch)
        gN, gT[, gT2], FN, FT[, FT2], damage, lambda_h, dissipated, work, status."""
        path = os.fspath(path)
        m = len(self.t)
        g = self.gap.reshape(m, -1, self.gap.shape[-1])
        F = self.traction.reshape(m, -1, self.gap.shape[-1])
        n, dim = g.shape[1], g.shape[2]
        comps = ["N", "T"] if dim == 2 else ["N", "T", "T2"]
        cols = [self.t]
        names = ["t"]
        for p in range(n):
            suf = f"_{p}" if self.batch else ""
            for a, c in enumerate(comps):
                cols.append(g[:, p, a])
                names.append(f"g{c}{suf}")
            for a, c in enumerate(comps):
                cols.append(F[:, p, a])
                names.append(f"F{c}{suf}")
            for name in ("damage", "lambda_h", "dissipated", "work", "status"):
                cols.append(getattr(self, name).reshape(m, -1)[:, p])
                names.append(name + suf)
        data = np.column_stack([np.asarray(c, dtype=float) for c in cols])
        buf = io.StringIO()
        np.savetxt(buf, data, delimiter=",", header=",".join(names), comments="", fmt="%.17g")
        atomic_write_text(path, buf.getvalue())
        return path


def _buffers(m, n, dim):
    """History buffers (NaN until an increment is written): traction, tangent, damage,
    lambda_h, dissipated, status."""
    nan = lambda *sh: np.full(sh, np.nan)  # noqa: E731
    return (nan(m, n, dim), nan(m, n, dim, dim), nan(m, n), nan(m, n), nan(m, n),
            np.zeros((m, n), dtype=np.int8))


def _work(gap, traction):
    """Cumulative trapezoid integral of traction·dgap along rows, (m, n)."""
    dg = np.diff(gap, axis=0)
    Fm = 0.5 * (traction[1:] + traction[:-1])
    w = np.zeros(gap.shape[:2])
    w[1:] = np.cumsum(np.einsum("mnd,mnd->mn", Fm, dg), axis=0)
    return w


def _finish(t, G, F, T, D, K, P, status, iters, res, state, message, batch, info):
    W = _work(G, F)
    h = History(t=t, gap=G, traction=F, tangent=T, damage=D, lambda_h=K, dissipated=P, work=W,
                status=status, iterations=iters, residual=res, state=state, message=message,
                batch=batch, info=info)
    if not batch:
        for name in History._ROW_FIELDS:
            setattr(h, name, getattr(h, name)[:, 0])
    return h


def _subdivide(times, values, substeps):
    """Breakpoints (k,) and values (k, ...) -> t (m,), v (m, ...), piecewise linear."""
    times = np.asarray(times, dtype=float)
    if times.ndim != 1 or times.size < 1:
        raise ValueError(f"times of shape {times.shape} is not allowed; allowed: a 1-D array "
                         "of breakpoints (at least one)")
    if times.size > 1 and not np.all(np.diff(times) > 0):
        raise ValueError("times is not strictly increasing; allowed: strictly increasing "
                         "breakpoints")
    if values.shape[0] != times.size:
        raise ValueError(f"{values.shape[0]} breakpoint values for {times.size} times; allowed: "
                         "one value row per time")
    nseg = times.size - 1
    sub = np.broadcast_to(np.asarray(substeps), (nseg,)) if nseg else np.zeros(0, int)
    if nseg and (np.any(sub < 1) or np.any(sub != np.round(sub))):
        raise ValueError(f"substeps = {substeps!r} is not allowed; allowed: integers >= 1 "
                         "(one per segment or one for all)")
    ts = [times[:1]]
    vs = [values[:1]]
    for k in range(nseg):
        s = int(sub[k])
        frac = np.arange(1, s + 1) / s
        ts.append(times[k] + (times[k + 1] - times[k]) * frac)
        seg = values[k] + (values[k + 1] - values[k]) * frac.reshape((-1,) + (1,) * (values.ndim - 1))
        seg[-1] = values[k + 1]                 # breakpoints hit exactly
        vs.append(seg)
    return np.concatenate(ts), np.concatenate(vs, axis=0)


def _as_batch(values, name):
    v = np.array(values, dtype=np.float64)
    if v.ndim == 2:
        return v[:, None, :], False
    if v.ndim == 3:
        return v, True
    raise ValueError(f"{name} of shape {v.shape} is not allowed; allowed: (k, dim) for one "
                     "point or (k, n, dim) for a batch, dim 2 or 3")


# ------------------------------------------------------------------------------------------
def _dts(t, dt0):
    """Time step of every row: row 0 takes dt0 (default: the first increment's step, or 1 s
    for a single row), row i > 0 takes t[i] - t[i-1]."""
    if dt0 is None:
        dt0 = float(t[1] - t[0]) if t.size > 1 else 1.0
    elif not (float(dt0) > 0 and math.isfinite(float(dt0))):
        raise ValueError(f"dt0 = {dt0!r} is not allowed; allowed: a finite time step > 0 [s]")
    return np.r_[float(dt0), np.diff(t)]


def gap_path(law: InterfaceLaw, times, gaps, substeps=1, state: InterfaceState | None = None,
             dt0: float | None = None) -> History:
    """Drive the law along a piecewise-linear gap history.

    law      : an InterfaceLaw.
    times    : (k,) strictly increasing breakpoint times [s] (the step t[i] - t[i-1] is passed
               as ``dt`` to the law: the damage form "rate" depends on it, the others do not).
    gaps     : (k, dim) for one point, or (k, n, dim) for a batch of n points, at the breakpoints.
    substeps : increments per segment, an int or a sequence of k-1 ints.
    state    : committed start state (default: virgin). Row 0 is the law evaluated at
               ``gaps[0]`` from ``state`` (one step from the start state).
    dt0      : time step [s] of row 0 (default: that of the first increment).
    Returns a History (status NONFINITE where the law returned non-finite numbers; such a point
    is not advanced further).
    """
    if not isinstance(law, InterfaceLaw):
        raise ValueError(f"gap_path law = {law!r} is not allowed; allowed: an InterfaceLaw")
    g3, batch = _as_batch(gaps, "gaps")
    k, n, dim = g3.shape
    if dim not in (2, 3):
        raise ValueError(f"gaps dim = {dim} is not allowed; allowed: 2 or 3")
    if not np.isfinite(g3).all():
        raise ValueError("gaps contains non-finite values; allowed: finite gaps")
    t, G = _subdivide(times, g3, substeps)
    m = t.size
    st = law.initial_state(n, dim) if state is None else state
    if st.n != n or st.dim != dim:
        raise ValueError(f"state of {st.n} points in {st.dim}D does not match gaps "
                         f"({n} points, dim {dim})")
    F, T, D, K, P, status = _buffers(m, n, dim)
    message = ""
    G = np.ascontiguousarray(G)
    dts = _dts(t, dt0)
    for i in range(m):
        Fi, Ti, new = law.evaluate(G[i], st, dt=dts[i], check=(i == 0))
        st = new
        F[i] = Fi
        T[i] = Ti
        D[i] = new.damage
        K[i] = new.kappa
        P[i] = new.dissipated
    # a non-finite number makes every later row of that point non-finite or meaningless:
    # mark the first one NONFINITE, the later ones SKIPPED, and blank them
    fin = (np.isfinite(F).all(axis=2) & np.isfinite(T).all(axis=(2, 3)) & np.isfinite(D)
           & np.isfinite(K) & np.isfinite(P))
    if not fin.all():
        for p in np.flatnonzero(~fin.all(axis=0)):
            i0 = int(np.argmin(fin[:, p]))
            status[i0, p] = NONFINITE
            status[i0 + 1:, p] = SKIPPED
            for arr in (F, T, D, K, P):
                arr[i0:, p] = np.nan
            if not message:
                message = (f"gap_path: increment {i0} (t={t[i0]:.6g}) point {p}: the law "
                           f"returned non-finite numbers at gap {G[i0, p].tolist()}; this and "
                           "later rows of this point are NaN")
    G = G.copy()
    G[status != OK] = np.nan
    # rows of dead points after their failure: NaN gaps too
    return _finish(t, G, F, T, D, K, P, status, np.zeros((m, n), np.int16),
                   np.zeros((m, n)), st, message, batch, {"driver": "gap_path"})


# ------------------------------------------------------------------------------------------
def _parse_control(control, dim):
    if isinstance(control, str):
        if len(control) != dim or any(c not in "FgGf" for c in control):
            raise ValueError(f"control = {control!r} is not allowed; allowed: a string of {dim} "
                             "letters, 'F' (traction imposed) or 'g' (gap imposed), e.g. 'Fg'")
        return np.array([c in "Ff" for c in control])
    c = np.asarray(control, dtype=bool)
    if c.shape != (dim,):
        raise ValueError(f"control = {control!r} is not allowed; allowed: {dim} booleans "
                         "(True = traction imposed)")
    return c


def mixed_control(law: InterfaceLaw, times, targets, control, substeps=1,
                  state: InterfaceState | None = None, tol: float = 1e-10, maxiter: int = 50,
                  max_halvings: int = 60, dt0: float | None = None) -> History:
    """Mixed traction/gap control, one local Newton per increment.

    targets : (k, dim) or (k, n, dim) breakpoint values: the traction [Pa] on the components
              marked traction-controlled, the gap [m] on the others (linear in between).
    control : e.g. ``"Fg"`` (normal traction and tangential gap imposed), or booleans
              (True = traction imposed).
    tol     : convergence when ``max |F_c - target_c| <= tol * max(sigma_max, |target_c|)``
              (tol is floored at 8 machine epsilons, the rounding level of the traction).
    maxiter : Newton iterations per increment; ``max_halvings``: backtracking line search on the
              residual norm (60 halvings reach any scale: a step taken with the fallback
              stiffness at a kink may overshoot a 1e6 times stiffer contact branch).
    times, dt0 : breakpoint times [s] and the time step of row 0, as in :func:`gap_path`.
    The unknown gap components start from the last converged values. The increment fails with
      * SINGULAR     if the controlled block of the tangent is singular (e.g. debonded and open,
                     or perfect-plastic slip under an imposed shear traction);
      * LIMIT_POINT  if Newton met a non-positive-definite controlled tangent (the traction peak
                     was crossed) and did not converge, or converged onto a descending branch —
                     a traction-controlled path cannot pass a peak;
      * NOT_CONVERGED otherwise.
    From the failed increment on that point's rows are NaN; ``History.message`` names the
    increment, the time and the imposed traction. Nothing is raised from inside the loop.
    """
    if not isinstance(law, InterfaceLaw):
        raise ValueError(f"mixed_control law = {law!r} is not allowed; allowed: an InterfaceLaw")
    y3, batch = _as_batch(targets, "targets")
    k, n, dim = y3.shape
    if not np.isfinite(y3).all():
        raise ValueError("targets contains non-finite values; allowed: finite values")
    if not (tol > 0 and math.isfinite(tol)):
        raise ValueError(f"tol = {tol!r} is not allowed; allowed: a finite number > 0")
    cm = _parse_control(control, dim)
    ci = np.flatnonzero(cm)
    gi = np.flatnonzero(~cm)
    nc = ci.size
    t, Y = _subdivide(times, y3, substeps)
    m = t.size
    dts = _dts(t, dt0)
    st = law.initial_state(n, dim) if state is None else state
    sig = law.cohesive.sigma_max
    G = np.full((m, n, dim), np.nan)
    F, T, D, K, P, status = _buffers(m, n, dim)
    iters = np.zeros((m, n), dtype=np.int16)
    resid = np.zeros((m, n))
    alive = np.ones(n, dtype=bool)
    messages = []
    g_prev = np.zeros((n, dim))                     # initial guess of the unknown components
    names = ["F_N", "F_T", "F_T2"][:dim]
    coh = law.cohesive
    K0c = np.diag([coh.k_normal] + [coh.k_tangential] * (dim - 1))[np.ix_(ci, ci)]

    for i in range(m):
        g = g_prev.copy()
        g[:, gi] = Y[i][:, gi]
        tgt = Y[i][:, ci]
        # tolerance, floored at the rounding level of the traction (a tol below ~1e-15 cannot
        # be met in floating point; such residuals count as converged)
        tref = np.maximum(sig, np.abs(tgt).max(axis=1) if nc else sig)
        scale = np.maximum(tol, 8 * np.finfo(float).eps) * tref
        act = np.flatnonzero(alive)
        stat_i = np.full(n, OK, dtype=np.int8)
        lost = np.zeros(n, dtype=bool)              # tangent lost positive-definiteness
        sing_seen = np.zeros(n, dtype=bool)         # singular controlled tangent met
        stalled = np.zeros(n, dtype=bool)           # line search found no decrease
        Fi = np.empty((n, dim))
        Ti = np.empty((n, dim, dim))
        it_i = np.zeros(n, dtype=np.int16)
        r_i = np.zeros(n)
        if act.size:
            sa = st.take(act)
            ga = np.ascontiguousarray(g[act])
            Fa, Ta, na = law.evaluate(ga, sa, dt=dts[i])
            todo = np.ones(act.size, dtype=bool)
            fail = np.zeros(act.size, dtype=np.int8)
            for it in range(maxiter + 1):
                R = Fa[:, ci] - tgt[act]
                rn = np.abs(R).max(axis=1) if nc else np.zeros(act.size)
                finite = np.isfinite(rn) & np.isfinite(Ta).all(axis=(1, 2))
                fail[todo & ~finite] = NONFINITE
                todo &= finite
                conv = rn <= scale[act]
                todo &= ~conv
                it_i[act[todo]] = it + 1 if it < maxiter else it
                if not todo.any() or it == maxiter:
                    break
                idx = np.flatnonzero(todo)
                J = Ta[idx][:, ci][:, :, ci].copy()
                Js = 0.5 * (J + np.swapaxes(J, 1, 2))
                ev = np.linalg.eigvalsh(Js)
                jscale = np.abs(J).max(axis=(1, 2))
                sing = ~(jscale > 0) | (np.abs(np.linalg.det(J)) <= 1e-13 * jscale ** nc)
                neg = ev.min(axis=1) < 0
                lost[act[idx[neg & ~sing]]] = True
                sing_seen[act[idx[sing]]] = True
                # singular (a kink, e.g. g_N = 0 exactly) or non-positive-definite (softening):
                # take a step with the initial elastic stiffness instead, so that the iterate
                # moves towards the stable (ascending) branch; classification is kept above
                fb = sing | neg
                if fb.any():
                    J[fb] = K0c
                dx = -np.linalg.solve(J, R[idx][:, :, None])[:, :, 0]
                # backtracking on the residual norm (the law is only piecewise smooth)
                step = np.ones(idx.size)
                base = ga[idx].copy()
                r0 = np.linalg.norm(R[idx], axis=1)
                pend = np.arange(idx.size)
                for _ in range(max_halvings + 1):
                    gt = base[pend].copy()
                    gt[:, ci] += step[pend, None] * dx[pend]
                    sp = sa.take(idx[pend])
                    Ft, Tt, nt = law.evaluate(gt, sp, dt=dts[i], check=False)
                    rt = np.linalg.norm(Ft[:, ci] - tgt[act[idx[pend]]], axis=1)
                    acc = ~(rt >= r0[pend]) | ~np.isfinite(rt)
                    jj = idx[pend[acc]]
                    ga[jj] = gt[acc]
                    Fa[jj] = Ft[acc]
                    Ta[jj] = Tt[acc]
                    for f_ in fields(na):
                        getattr(na, f_.name)[jj] = getattr(nt, f_.name)[acc]
                    pend = pend[~acc]
                    if pend.size == 0:
                        break
                    step[pend] *= 0.5
                if pend.size:
                    # no step along the Newton direction reduces the residual: |R| is at a
                    # local minimum != 0, i.e. the target lies beyond the reachable envelope
                    # (at a peak the elastic-side tangent points into the softening branch)
                    stalled[act[idx[pend]]] = True
                    todo[idx[pend]] = False
            R = Fa[:, ci] - tgt[act]
            rn = np.abs(R).max(axis=1) if nc else np.zeros(act.size)
            conv = (rn <= scale[act]) & (fail == OK)
            nc_ = (fail == OK) & ~conv
            # classification of a failed solve: a negative-definite controlled tangent met on
            # the way, or a stall (|R| at a local minimum != 0) with a regular tangent, means
            # the target is beyond the envelope; a singular tangent means no stiffness at all
            pa = act[nc_]
            fail[nc_] = np.where(lost[pa], LIMIT_POINT,
                                 np.where(sing_seen[pa], SINGULAR,
                                          np.where(stalled[pa], LIMIT_POINT, NOT_CONVERGED)))
            # converged onto a descending branch (non-PD controlled tangent): not reachable
            if nc:
                cidx = np.flatnonzero(conv)
                if cidx.size:
                    Jc = Ta[cidx][:, ci][:, :, ci]
                    evc = np.linalg.eigvalsh(0.5 * (Jc + np.swapaxes(Jc, 1, 2))).min(axis=1)
                    desc = evc < 0
                    fail[cidx[desc]] = LIMIT_POINT
            stat_i[act] = fail
            Fi[act] = Fa
            Ti[act] = Ta
            it_i_a = it_i[act]
            r_i[act] = rn
            okp = act[fail == OK]
            badp = act[fail != OK]
            if okp.size:
                pos = np.flatnonzero(fail == OK)
                st = st.put(okp, na.take(pos))
                g_prev[okp] = ga[pos]
                G[i, okp] = ga[pos]
                F[i, okp] = Fa[pos]
                T[i, okp] = Ta[pos]
                D[i, okp] = st.damage[okp]
                K[i, okp] = st.kappa[okp]
                P[i, okp] = st.dissipated[okp]
            iters[i, act] = it_i_a
            resid[i, act] = rn
            for p in badp:
                code = int(stat_i[p])
                tr = {names[c]: float(tgt[p, j]) for j, c in enumerate(ci)}
                last = f"increment {i - 1}" if i > 0 else "none"
                why = {LIMIT_POINT: "limit point: the imposed traction is beyond the peak of the "
                                    "envelope (the controlled tangent lost positive-definiteness)"
                                    " — a traction-controlled path cannot pass a peak; follow "
                                    "the softening with gap control (gap_path)",
                       SINGULAR: "the controlled block of the tangent is singular (no stiffness "
                                 "against the imposed traction, e.g. debonded and open, or "
                                 "perfect-plastic slip)",
                       NOT_CONVERGED: f"Newton did not converge in {maxiter} iterations "
                                      f"(residual {rn[np.flatnonzero(act == p)[0]]:.3e} Pa)",
                       NONFINITE: "the law returned non-finite numbers"}[code]
                messages.append(f"mixed_control: increment {i} (t={t[i]:.6g}) point {p}: "
                                f"{STATUS_NAMES[code]} at imposed traction {tr} Pa: {why}; "
                                f"last converged: {last}; this and later rows of the point "
                                "are NaN")
                alive[p] = False
                status[i + 1:, p] = SKIPPED
            status[i, act] = stat_i[act]
    message = messages[0] if len(messages) == 1 else "\n".join(messages[:5]) + (
        f"\n... and {len(messages) - 5} more" if len(messages) > 5 else "")
    return _finish(t, G, F, T, D, K, P, status, iters, resid, st, message, batch,
                   {"driver": "mixed_control", "control": cm, "tol": tol,
                    "target": Y if batch else Y[:, 0]})


# ------------------------------------------------------------------------------------------
# ready paths
def direction_length(law, psi, lam):
    """Gap magnitude along the physical angle psi (tan psi = gT/gN) at which lambda = lam."""
    c = law.cohesive
    return lam / math.hypot(math.cos(psi) / c.l_Nc, math.sin(psi) / c.l_Tc)


def _vec(dim, gN, gT):
    v = np.zeros(dim)
    v[0] = gN
    v[1] = gT
    return v


def _path(law, points, n, dim, state=None, duration=None):
    """Piecewise-linear path through ``points`` (list of (gN, gT)) with about n increments
    in total, distributed in proportion to the segment lengths in lambda units. Time: one
    second per unit of lambda travelled, or the whole path in ``duration`` seconds (the same
    rate in lambda units on every segment)."""
    c = law.cohesive
    P = np.array([_vec(dim, a, b) for a, b in points])
    seg = np.hypot(np.diff(P[:, 0]) / c.l_Nc, np.linalg.norm(np.diff(P[:, 1:], axis=0), axis=1)
                   / c.l_Tc)
    sub = np.maximum(1, np.round(n * seg / seg.sum())).astype(int)
    times = np.concatenate([[0.0], np.cumsum(seg)])
    if duration is not None:
        times = times * (_positive("duration", duration) / times[-1])
    return gap_path(law, times, P, sub, state)


def _positive(name, v):
    v = float(v)
    if not (v > 0 and math.isfinite(v)):
        raise ValueError(f"{name} = {v!r} is not allowed; allowed: a finite time > 0 [s]")
    return v


def mode_I(law, n: int = 100, lam_end: float = 1.5, dim: int = 2,
           duration: float = 1.0) -> History:
    """Monotonic opening 0 -> lam_end*l_Nc in n equal increments (g_T = 0) over ``duration``
    seconds. Peak sigma_max at g_N = lambda_max l_Nc; dissipated -> G_I = sigma_max l_Nc/2."""
    return mixed_mode(law, 0.0, n, lam_end, dim, duration)


def mode_II(law, n: int = 100, lam_end: float = 1.5, dim: int = 2,
            duration: float = 1.0) -> History:
    """Monotonic sliding 0 -> lam_end*l_Tc (g_N = 0) over ``duration`` seconds. Peak
    tau_max l_Nc/l_Tc at |g_T| = lambda_max l_Tc; dissipated -> G_II = tau_max l_Nc/2."""
    return mixed_mode(law, math.pi / 2, n, lam_end, dim, duration)


def mixed_mode(law, psi: float, n: int = 100, lam_end: float = 1.5, dim: int = 2,
               duration: float = 1.0) -> History:
    """Proportional path at physical angle psi (tan psi = g_T/g_N) up to lambda = lam_end,
    in n equal increments over ``duration`` seconds (a constant rate);
    dissipated -> CohesiveParams.G_mixed(psi)."""
    L = direction_length(law, psi, lam_end)
    end = _vec(dim, L * math.cos(psi), L * math.sin(psi))
    return gap_path(law, [0.0, _positive("duration", duration)],
                    np.array([np.zeros(dim), end]), n)


def load_unload_reload(law, lam_unload: float = 0.5, lam_end: float = 1.5, psi: float = 0.0,
                       n: int = 150, dim: int = 2, lam_reunload: float | None = None,
                       duration: float | None = None) -> History:
    """0 -> lam_unload -> 0 -> lam_end along the angle psi (about n increments in total;
    time: 1 s per unit of lambda travelled, or the whole path in ``duration`` seconds).
    The unloading and reloading follow the secant to the origin with the stiffness reached at
    lambda_h = lam_unload (no healing); reloading rejoins the envelope at lambda_h."""
    c, s = math.cos(psi), math.sin(psi)
    Lu = direction_length(law, psi, lam_unload)
    Le = direction_length(law, psi, lam_end)
    pts = [(0.0, 0.0), (Lu * c, Lu * s), (0.0, 0.0), (Le * c, Le * s)]
    return _path(law, pts, n, dim, duration=duration)


def closure_reopening(law, lam_open: float = 0.6, closure: float = 0.1, lam_end: float = 1.5,
                      n: int = 200, dim: int = 2, duration: float | None = None) -> History:
    """Mode I: open to lam_open*l_Nc, close to a penetration closure*l_Nc (g_N < 0: contact
    if the law has contact), reopen to lam_end*l_Nc (time as in :func:`load_unload_reload`)."""
    lN = law.cohesive.l_Nc
    pts = [(0.0, 0.0), (lam_open * lN, 0.0), (-closure * lN, 0.0), (lam_end * lN, 0.0)]
    return _path(law, pts, n, dim, duration=duration)


def constant_amplitude_cycles(law, amplitude: float, R: float = 0.0, n_cycles: int = 10,
                              n_per_cycle: int = 20, psi: float = 0.0, dim: int = 2,
                              state=None, period: float = 1.0) -> History:
    """Gap-controlled constant-amplitude cycles along the angle psi: the separation goes
    0 -> A -> R*A, then (R*A -> A -> R*A) for the remaining cycles, each leg at a constant
    rate (a triangle wave). ``amplitude`` A [m] may be a float or an array of n amplitudes (a
    batch, one point per amplitude). ``t`` [s] = cycles * ``period`` (cycle k spans
    t/period in (k-1, k]; its peak is at t/period = k - 1/2; with the default period of 1 s
    ``t`` counts cycles). n_per_cycle/2 increments per half cycle (the first loading too)."""
    A = np.atleast_1d(np.asarray(amplitude, dtype=float))
    if not (-1.0 <= R < 1.0):
        raise ValueError(f"R = {R!r} is not allowed; allowed: [-1, 1) (min/max gap ratio)")
    if n_cycles < 1 or n_per_cycle < 2:
        raise ValueError("n_cycles >= 1 and n_per_cycle >= 2 are required")
    d = np.zeros(dim)
    d[0], d[1] = math.cos(psi), math.sin(psi)
    period = _positive("period", period)
    levels = [0.0, 1.0] + [R, 1.0] * (n_cycles - 1) + [R]
    times = np.concatenate([[0.0], 0.5 * np.arange(1, len(levels))]) * period
    gaps = np.array(levels)[:, None, None] * A[None, :, None] * d[None, None, :]
    if np.ndim(amplitude) == 0:
        gaps = gaps[:, 0, :]
    h = gap_path(law, times, gaps, max(1, n_per_cycle // 2), state)
    h.info["period"] = period
    return h


def shear_under_pressure(law, pressure: float, slip_amplitude: float, n_cycles: int = 1,
                         n_per_cycle: int = 80, tol: float = 1e-10, dim: int = 2,
                         maxiter: int = 50, period: float = 1.0) -> History:
    """Direct shear test of a joint: constant normal compression ``pressure`` [Pa] (> 0,
    F_N = -pressure imposed) and a tangential gap cycled 0 -> +A -> -A -> +A ... (n_cycles full
    cycles) with A = slip_amplitude [m]. Mixed control "Fg". Once debonded (|g_T| >= l_Tc) and
    sliding, the friction plateau is |F_T| = f * pressure. t in [0, 1/4]: the pressure is
    ramped at g_T = 0; then the shear: +A at t = 1/2, -A at t = 1, +A at t = 3/2, ...
    (times in units of ``period`` [s], default 1 s)."""
    if not pressure > 0:
        raise ValueError(f"pressure = {pressure!r} is not allowed; allowed: > 0 (compression)")
    A = float(slip_amplitude)
    # t in [0, 1/4]: pressure ramped at g_T = 0 (so that `work` includes its work); then
    # +A at t = 1/2 (a quarter cycle) and half cycles -A, +A, ...
    levels = [0.0, 0.0, 1.0] + [-1.0, 1.0] * n_cycles
    tg = np.zeros((len(levels), dim))
    tg[1:, 0] = -pressure
    tg[:, 1] = np.array(levels) * A
    tt = np.concatenate([[0.0, 0.25, 0.5], 0.5 + 0.5 * np.arange(1, 2 * n_cycles + 1)]) \
        * _positive("period", period)
    sub = [max(1, n_per_cycle // 8), max(1, n_per_cycle // 4)] + \
        [max(1, n_per_cycle // 2)] * (2 * n_cycles)
    ctl = "Fg" if dim == 2 else "Fgg"
    return mixed_control(law, tt, tg, ctl, sub, tol=tol, maxiter=maxiter)


# ------------------------------------------------------------------------------------------
def cycles_to_failure(h: History):
    """Cycle number (1-based, t / period counted in cycles as in constant_amplitude_cycles) in
    which the point failed (D >= 1 or lambda_h >= 1); inf if it did not. Array for a batch."""
    fail = (h.damage >= 1.0) | (h.lambda_h >= 1.0)
    fail = fail.reshape(len(h.t), -1)
    out = np.full(fail.shape[1], np.inf)
    cyc = h.t / h.info.get("period", 1.0)
    for p in range(fail.shape[1]):
        idx = np.flatnonzero(fail[:, p])
        if idx.size:
            out[p] = math.ceil(cyc[idx[0]] - 1e-12)
    return out if h.batch else out[0]


def tangent_fd_error(law: InterfaceLaw, gap, state: InterfaceState, rel_step: float = 1e-6,
                     dt: float | None = None):
    """Max relative error of the law's tangent against central finite differences at the
    points ``gap`` (n, dim) from the committed ``state`` (step time ``dt``, for the rate form).
    The step of component j is ``rel_step * max(|gap_j|, l_j)`` (l_j = l_Nc or l_Tc); the error
    is ``max|T - T_fd| / max(|T|)`` per point. Returns (err (n,), T (n,dim,dim), T_fd)."""
    gap = np.array(gap, dtype=np.float64, ndmin=2)
    n, dim = gap.shape
    _, T, _ = law.evaluate(gap, state, dt=dt)
    c = law.cohesive
    lref = np.array([c.l_Nc] + [c.l_Tc] * (dim - 1))
    Tfd = np.empty_like(T)
    for j in range(dim):
        h = rel_step * np.maximum(np.abs(gap[:, j]), lref[j])
        gp = gap.copy()
        gm = gap.copy()
        gp[:, j] += h
        gm[:, j] -= h
        Fp = law.evaluate(gp, state, dt=dt)[0]
        Fm = law.evaluate(gm, state, dt=dt)[0]
        Tfd[:, :, j] = (Fp - Fm) / (2 * h[:, None])
    scale = np.abs(T).max(axis=(1, 2))
    scale = np.where(scale > 0, scale, 1.0)
    err = np.abs(T - Tfd).max(axis=(1, 2)) / scale
    return err, T, Tfd
