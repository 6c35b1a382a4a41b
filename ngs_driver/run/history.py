"""The per-step history of a run (one row of floats per step: the columns of timeseries.csv)
and the numbers taken from it for summary.json (no NGSolve). Not to be confused with a
ground-motion record (``setup.records``)."""
from __future__ import annotations

import operator

import numpy as np

from .parts import Part


# per-step histories: the CSV column order. The unprefixed crack/damage columns are the base's
# (kept under their original names; "base_<key>" columns hold the same values with the lift
# joints' columns beside them).
HIST_KEYS = ("step", "t", "crest_ux", "crest_uy", "iterations", "iterations_failed", "cuts",
             "substeps", "n_active", "n_debonded", "crack_length", "crack_length_heel",
             "max_D", "D_heel", "kappa_heel", "size_b", "sigma_max", "wall")


class History:
    """Columns of floats appended once per step (``keys`` fixed at construction), kept in one
    row-major float64 buffer that doubles when full: a checkpoint's ``arrays()`` copies
    columns instead of converting Python lists (O(steps) per checkpoint either way, but
    ~30x less work)."""

    def __init__(self, keys=HIST_KEYS, capacity: int = 1024):
        self.keys = tuple(keys)
        self._row = operator.itemgetter(*self.keys) if len(self.keys) > 1 else \
            (lambda kw, _k=self.keys: tuple(kw[k] for k in _k))
        self._buf = np.empty((max(int(capacity), 1), len(self.keys)))
        self._n = 0

    def append(self, **kw):
        if self._n == self._buf.shape[0]:
            grown = np.empty((2 * self._buf.shape[0], len(self.keys)))
            grown[:self._n] = self._buf
            self._buf = grown
        self._buf[self._n] = self._row(kw)
        self._n += 1

    @property
    def cols(self) -> dict:
        """{key: the column so far} (views: valid until the next append)."""
        return {k: self._buf[:self._n, i] for i, k in enumerate(self.keys)}

    def arrays(self) -> dict:
        return {k: self._buf[:self._n, i].copy() for i, k in enumerate(self.keys)}

    @classmethod
    def from_arrays(cls, d, keys=HIST_KEYS):
        cols = [np.asarray(d[k], dtype=float) for k in keys]
        n = cols[0].size if cols else 0
        h = cls(keys, capacity=max(1024, 2 * n))
        for i, c in enumerate(cols):
            h._buf[:n, i] = c
        h._n = n
        return h

    def __len__(self):
        return self._n


def snapshot_steps(n_steps: int, count: int) -> list[int]:
    s = sorted({int(round(v)) for v in np.linspace(0, n_steps, count + 1)[1:]})
    return [k for k in s if k >= 1]


SNAP_KEYS = ("step", "t", "D", "kappa", "opening", "slip")


class Snapshots(Part):
    """The joints' profiles (damage D, kappa, opening, slip at every point) at
    ``output.snapshots`` times spread over the record, and at the static state (step 0); a
    run part (``run.parts``)."""

    name = "snapshots"

    def __init__(self, n_steps: int, count: int):
        self.steps = set(snapshot_steps(n_steps, count))
        self.data = {k: [] for k in SNAP_KEYS}

    def due(self, k: int) -> bool:
        return k in self.steps

    def take(self, k, t, solver):
        st = solver.state
        for key, val in (("step", k), ("t", float(t)), ("D", st.damage.copy()),
                         ("kappa", st.kappa.copy()), ("opening", solver.g[:, 0].copy()),
                         ("slip", solver.g[:, 1].copy())):
            self.data[key].append(val)

    @property
    def last_step(self) -> int:
        return self.data["step"][-1]

    def after_step(self, ctx):
        if self.due(ctx.k):
            self.take(ctx.k, ctx.t, ctx.solver)

    def checkpoint(self) -> dict:
        return {k: np.asarray(v) for k, v in self.data.items()}

    def restore(self, d):
        self.data = {k: [float(v) if k == "t" else (int(v) if k == "step" else v)
                         for v in d[k]] for k in SNAP_KEYS}


class StepHistory(Part):
    """The history as a run part (``run.parts``): the step's own columns (time, crest,
    the solver's work, the base's damage columns) added to the row the parts before it
    formed, and the row appended. ``history``: the ``History`` (None before the static
    state)."""

    name = "history"

    def __init__(self, keys, crest_dofs):
        self.keys = list(keys)
        self.crest_dofs = crest_dofs
        self.history = None

    def start(self):
        self.history = History(self.keys)

    def after_step(self, ctx):
        s, rep, jm, st = ctx.solver, ctx.report, ctx.measures, ctx.state
        cx, cy = self.crest_dofs
        self.history.append(
            step=ctx.k, t=ctx.t, crest_ux=s.u[cx], crest_uy=s.u[cy],
            iterations=rep.iterations, iterations_failed=rep.iterations_failed, cuts=rep.cuts,
            substeps=len(rep.dts), n_active=rep.n_active, n_debonded=jm["base_n_debonded"],
            crack_length=jm["base_crack_length"],
            crack_length_heel=jm["base_crack_length_upstream"], max_D=jm["base_max_D"],
            D_heel=float(st.damage[0]), kappa_heel=float(st.kappa[0]),
            size_b=jm["base_size_b"], sigma_max=jm["base_sigma_max"], wall=rep.wall,
            **ctx.row)

    def checkpoint(self) -> dict:
        return self.history.arrays()

    def restore(self, d):
        self.history = History.from_arrays(d, self.keys)



def results_from_history(H) -> dict:
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


class HeelOpening(Part):
    """The state of the largest heel opening while the base still holds a bonded point (the
    paper's Fig. 12 shows it), a run part (``run.parts``): ``u`` the displacements, ``t`` the
    time, ``open`` the heel's opening."""

    name = "heel"

    def __init__(self, base):
        self.base = base                  # the base joint's point slice
        self.u, self.t, self.open = None, 0.0, 0.0

    def start(self, u, opening):
        self.u, self.t, self.open = u.copy(), 0.0, float(opening)

    def after_step(self, ctx):
        g = ctx.solver.g
        if (ctx.measures["base_n_debonded"] < self.base.stop - self.base.start
                and g[0, 0] > self.open):
            self.u, self.t, self.open = ctx.solver.u.copy(), float(ctx.t), float(g[0, 0])

    def checkpoint(self) -> dict:
        return {"u": self.u, "t": self.t, "open": self.open}

    def restore(self, d):
        self.u, self.t, self.open = np.array(d["u"]), float(d["t"]), float(d["open"])
