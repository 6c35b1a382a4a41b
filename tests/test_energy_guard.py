"""No verdict from a step that breaks the physics.

* The re-pairing bug behind koyna_1967's "collapse" at 3.642 s: after a joint is paired anew
  (finite sliding) its gap carries an offset, g = B u + g_offset; the condensed Newton's
  factorised matrix holds B^T W K0 B (acting on B u only) and its correction phi = t - K0 g,
  so the elastic force K0 g_offset was applied to the dam as a spurious traction (9e10 Pa at a
  point that slid off its face, whose offset opens it by 1 m). The toy model's joint is given
  exactly such offsets; the condensed solver must then give the re-factorising full Newton's
  answer (which evaluates the law at B u + g_offset directly).
* The energy guard (run.energy.EnergyGuard): a step whose energy jump exceeds its limit is cut
  and repeated in 2, 4, ... sub-steps, and never accepted.
"""
import numpy as np
import pytest

from interfacelaw import CohesiveParams, ContactParams, FrictionParams, InterfaceLaw
from ngs_driver.run.energy import GUARD_FLOOR, GUARD_FRACTION, EnergyGuard
from ngs_driver.solve.joint_solver import JointSolver
from toymodel import block_on_block


@pytest.fixture(scope="module")
def model():
    return block_on_block(0.5)


def cracked_law():
    coh = CohesiveParams.from_fracture_energy(3e4, 3e4, 3.0, 0.2)
    return InterfaceLaw(coh, ContactParams("linear"), FrictionParams(0.6))


def offset_run(model, method, nsteps=20, dt=2e-3):
    """Static gravity on the bonded toy joint, then the joint 'paired anew' with the same B and
    an offset: 1e-5 m closing at every point (a continuous re-pairing's size, koyna_1967) and
    the last point opened by 1 m (slid off its face, run/pairing.OPEN_GAP); then steps under a
    crest load. Returns (solver, displacements)."""
    m = model
    s = JointSolver(m.K, m.M, None, m.B, m.w, cracked_law(), dt=dt, method=method,
                    tol_residual=1e-11)
    s.static(m.gravity)
    off = np.zeros(2 * m.npts)
    off[0::2] = -1e-5
    off[2 * (m.npts - 1)] = 1.0
    s.set_operator(m.B, s.g.ravel() + off - m.B @ s.u)
    U = []
    for n in range(1, nsteps + 1):
        s.step(m.gravity + 2e4 * np.sin(2 * np.pi * 10 * n * dt) * m.crest_x)
        U.append(s.u.copy())
    return s, np.array(U)


def test_condensed_solver_with_a_gap_offset_matches_full_newton(model):
    """Before the fix the condensed answer moved the dam by the force K0 g_offset w: at the
    opened point, the toy dam moved 20 m against 1.3e-4 m (measured with the correction
    removed: relative difference 1.5e5); after it both methods solve the same equations (the tolerance 1e-6: both
    converge to 1e-11 relative, the difference measured ~1e-9)."""
    sc, Uc = offset_run(model, "condensed")
    sf, Uf = offset_run(model, "full")
    scale = np.abs(Uf).max()
    assert scale < 1e-3                                   # a toy dam under its own weight
    assert np.abs(Uc - Uf).max() <= 1e-6 * scale, np.abs(Uc - Uf).max() / scale
    # the opened point carries no traction; the gap is B u + offset, 1 m open
    assert np.all(sc.t[-1] == 0.0) and sc.operator_gap()[-1, 0] > 0.99


def row(res=0.0, alg=0.0, wext=0.0, wj=0.0, damp=0.0):
    """A budget row with W_joints = wj (residual + stored + diss + scaling)."""
    return {"residual": res, "E_alg": alg, "W_ext": wext, "E_stored": wj - res, "E_diss": 0.0,
            "E_scaling": 0.0, "E_damp": damp}


def test_guard_rejects_a_step_that_creates_energy_and_accepts_one_within_its_limit():
    """jump = -d(residual + E_alg): the energy a step creates beyond its input; limit =
    GUARD_FRACTION x the step's work + GUARD_FLOOR x the scale (here the static 1e6 J/m)."""
    g = EnergyGuard(e_static=1e6)
    g.start()
    floor = GUARD_FLOOR * 1e6                      # 1000 J/m: the static scale's share
    # 4e3 J/m created in a step with 2e4 J/m of work: within 0.5 x 2e4 + 1e3, accepted
    ok, _ = g.check(row(res=-4e3, wext=1e4, wj=1e4), 0.002)
    # pytest.approx's default (1e-6 relative) in this test: the jumps and limits are sums and
    # differences of the rows' 1e4-sized terms, exact but for round-off (~1e-12 relative); a
    # wrong term would be off by at least 1 J/m (1e-4 relative)
    assert ok and g.max_jump == pytest.approx(4e3)
    # the integrator 'dissipating' -2e4 J/m (energy created) with 1e4 J/m of work: cut
    ok, why = g.check(row(res=-4e3, alg=-2e4, wext=2e4, wj=1e4), 0.004)
    assert not ok and "energy jump" in why and g.cuts == 1
    # the rejected row did not become the reference: the same step, smaller, passes
    ok, _ = g.check(row(res=-4e3, alg=10.0, wext=2e4, wj=1e4), 0.004)
    assert ok
    # the split between residual and E_alg does not matter (a rocking impact: the residual
    # gains 2430 J/m, E_alg loses 2350 J/m, sliding_block at 1.25 x its rocking threshold)
    ok, _ = g.check(row(res=-4e3 + 2430.0, alg=10.0 - 2350.0, wext=2e4, wj=1e4), 0.006)
    assert ok and g.max_jump == pytest.approx(4e3)
    # the limit: fraction x work + floor x scale (scale = max(e_static, |W_ext| so far))
    r0, a0 = -4e3 + 2430.0, 10.0 - 2350.0
    j, w, lim = g.measure(row(res=r0 - 1.0, alg=a0, wext=2e4 + 3.0, wj=1e4))
    assert j == pytest.approx(1.0) and w == pytest.approx(3.0)
    assert lim == pytest.approx(GUARD_FRACTION * 3.0 + floor)    # scale: the static 1e6
    ok, _ = g.check(row(res=r0 - 500.0, alg=a0, wext=2e4 + 3.0, wj=1e4), 0.008)
    assert ok                     # 500 J/m in a quiet step: below the floor
    ok, _ = g.check(row(res=r0 - 2500.0, alg=a0, wext=2e4 + 6.0, wj=1e4), 0.010)
    assert not ok                 # 2000 J/m made from 3 J/m of work: cut
    ok, _ = g.check(row(res=float("nan"), wext=2e4, wj=1e4), 0.010)
    assert not ok                 # a NaN is never accepted
    off = EnergyGuard(e_static=1e6, fraction=0.0)   # solver.energy_guard = 0: off
    off.start()
    assert off.check(row(res=-1e9, wext=1.0, wj=1.0), 0.002)[0]


def test_a_run_repeats_a_step_the_guard_rejects_and_never_accepts_it(tmp_path, monkeypatch):
    """A step forced to violate the guard (its check rejects the first attempt of step 5) is
    repeated from the committed state in 2 sub-steps: the history shows the cut and the two
    sub-steps, summary.json counts it, and the run's state at step 5 is that of a run whose
    step 5 is taken in halves from the start (the same sub-steps, bit for bit: nothing of the
    rejected attempt survives). A guard that rejects every attempt stops the run with a
    SolverError naming the step: no verdict."""
    from ngs_driver.apps.dam import run
    from ngs_driver.run import energy as energy_mod
    from ngs_driver.scene import load_scene
    from ngs_driver.solve.joint_solver import JointSolver, SolverError

    sets = ["time.duration=0.02", "output.checkpoint_every=0"]
    real = energy_mod.EnergyGuard.check
    seen = {"n": 0}

    def reject_step5_once(self, row, t):
        if abs(t - 0.010) < 1e-9 and seen["n"] == 0:
            seen["n"] += 1
            self.cuts += 1
            return False, "forced"
        return real(self, row, t)

    monkeypatch.setattr(energy_mod.EnergyGuard, "check", reject_step5_once)
    s = run(load_scene("sliding_block", sets), tmp_path / "a", progress=False, plots=False)
    assert s["energy"]["guard_cuts"] == 1 and s["verdict"] == "no_collapse"
    import csv
    with open(tmp_path / "a" / "timeseries.csv") as fh:
        rows = [r for r in csv.DictReader(line for line in fh if not line.startswith("#"))]
    r5 = rows[4]
    assert float(r5["t"]) == pytest.approx(0.010)
    assert float(r5["cuts"]) >= 1 and float(r5["substeps"]) == 2
    a = np.load(tmp_path / "a" / "final_state.npz")["u"]

    # the reference: step 5 taken in halves directly (split=1), no rejection
    monkeypatch.setattr(energy_mod.EnergyGuard, "check", real)
    step = JointSolver.step

    def halves_at_step5(self, f, split=0):
        return step(self, f, 1 if abs(self.time + self.dt - 0.010) < 1e-9 else split)

    monkeypatch.setattr(JointSolver, "step", halves_at_step5)
    run(load_scene("sliding_block", sets), tmp_path / "b", progress=False, plots=False)
    b = np.load(tmp_path / "b" / "final_state.npz")["u"]
    assert np.array_equal(a, b)

    monkeypatch.setattr(JointSolver, "step", step)
    monkeypatch.setattr(energy_mod.EnergyGuard, "check",
                        lambda self, row, t: (False, "forced"))
    with pytest.raises(SolverError, match=r"step 1 .*forced, even in 64 sub-steps"):
        run(load_scene("sliding_block", sets), tmp_path / "c", progress=False, plots=False)
