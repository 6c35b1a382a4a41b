"""The stall rule of the Newton attempts (``solver.stall_iterations``, docs/solver.md §4).

A dynamic attempt whose residual cycles above tolerance (the failing attempts of the Koyna
scenes: active sets of stick/slip alternating) is cut when the best residual of its last m
iterations is not below half the best before them, instead of running to ``max_iter``. The
rule must never cut an attempt that would converge: on the paper scene's collapse run the
same attempts converge and are cut with and without it (same iterations, cuts, final state
bit for bit), and only the failed attempts are shorter."""
import numpy as np
import pytest

pytest.importorskip("ngsolve")

from ngs_driver.apps.dam import run  # noqa: E402
from ngs_driver.scene import load_scene  # noqa: E402
from ngs_driver.solve.joint_solver import JointSolver  # noqa: E402

# an attempt cycling between active sets: the residual drops to 2e-4, then repeats
# 3e-4 ... 1.2e-4 without ever halving the best before (the failing attempts of
# koyna_engineering look like this, stuck at 1e-4 ... 2e-4)
CYCLING = [1e-2, 1e-3, 2e-4, 2e-4, 1.5e-4, 3e-4, 2e-4, 1.5e-4, 1.2e-4, 3e-4, 2e-4, 1.5e-4,
           1.2e-4]


def first_stall(hist, m):
    """Number of residuals seen when the rule first fires (None: never)."""
    for k in range(1, len(hist) + 1):
        if JointSolver.stalled(hist[:k], m):
            return k
    return None


def test_stall_rule_on_a_cycling_and_a_converging_history():
    # m = 6: at 9 residuals the best of the last six (1.2e-4) is above half the best of the
    # first three (1e-4); at 8 the first two (best 1e-3) were not yet matched by 5e-4
    assert first_stall(CYCLING, 6) == 9
    # m = 4: at 7 residuals, last four best 1.5e-4 > 1e-4
    assert first_stall(CYCLING, 4) == 7
    # Newton converging (quadratic, then linear at 0.4 per iteration) never stalls
    conv = [1e-2, 3e-3, 4e-4, 1.6e-4, 6.4e-5, 2.6e-5, 1e-5, 4e-6, 1.6e-6, 6.4e-7, 2.6e-7]
    assert first_stall(conv, 6) is None and first_stall(conv, 2) is None
    # exactly half the earlier best is progress (the rule wants strictly above half)
    assert first_stall([1.0, 0.9, 0.45, 0.45], 2) is None
    assert first_stall([1.0, 0.9, 0.46, 0.46], 2) == 4
    # m + 1 residuals at least before the rule can fire
    assert first_stall([1.0, 1.0, 1.0], 2) is None


def test_stall_rule_cuts_only_attempts_that_fail(tmp_path):
    res = {}
    for m in (0, 6):
        sc = load_scene("koyna", ["time.duration=1.0", f"solver.stall_iterations={m}"])
        s = run(sc, tmp_path / f"m{m}", progress=False, plots=False)
        u = np.load(tmp_path / f"m{m}" / "final_state.npz")["u"]
        res[m] = (s["solver_totals"], u, s["collapse"])
    t0, t6 = res[0][0], res[6][0]
    assert t0["cuts"] > 0                          # the run has failing attempts to cut
    assert t6["cuts"] == t0["cuts"] and t6["iterations"] == t0["iterations"]
    # the failing attempts of this run (10 cuts) each run to max_iter = 30 without the rule
    # (300 failed iterations) and stop at their stall with it (113 measured): below half
    assert t6["iterations_failed"] < 0.5 * t0["iterations_failed"]
    assert np.array_equal(res[0][1], res[6][1])   # the converged attempts are the same
    assert res[0][2]["time"] == res[6][2]["time"]
