"""The post-earthquake check (FERC guidelines ch. 3; USACE EM 1110-2-2100): a static solve from
the final interface state -- the crack left by the shaking carries no cohesion, friction is the
law's current one, uplift per ``in_crack`` -- and the sliding FS of every joint against
``FS_CRITERION``."""
from __future__ import annotations

import numpy as np

from ..solve.stepping import SolverError
from .checkpoint import SolverPart
from .safety import FS_CAP, FS_CRITERION
from .statics import spring_supported

__all__ = ["PostEarthquakeCheck", "resultant_verdict"]


def resultant_verdict(fs: float) -> str:
    """What the base's FS from the load resultants says when the static solve found no
    equilibrium: below 1 the loads exceed the friction and the dam slides; at or above 1 the
    resultants hold the dam, and the solve's failure is the joint's numerics (an active set
    it cycles between), not a sliding mechanism."""
    if fs < 1.0:
        return f"base FS {fs:.3g} < 1, the loads exceed the friction: the dam slides"
    return (f"base FS {fs:.3g} >= 1, the resultants hold the dam (the static solve's failure "
            "is not a sliding mechanism)")


class PostEarthquakeCheck:
    def __init__(self, max_slip: float, model, joints, safety, uplift, absorbing=None):
        self.max_slip, self.joints = float(max_slip), joints
        self.safety, self.uplift, self.absorbing = safety, uplift, absorbing
        # dam DOFs and the x / y components (the load resultants when no equilibrium exists)
        self.dam = np.asarray(model.dam_dofs, bool)
        self.ydof = np.abs(model.r_y) > 0.5
        self.xdof = np.abs(model.r_x) > 0.5

    @property
    def slip_bound(self) -> float:
        """The largest mean slip a static solve may add before it counts as no equilibrium
        (a frictional joint that cannot hold the loads slides without bound): 0.05 m, or
        time.max_slip if smaller."""
        return min(self.max_slip, 0.05)

    def run(self, solver, f_base_static) -> dict:
        """``f_base_static``: gravity + water (+ tailwater), without uplift. A solve that finds
        no equilibrium reports FS from the load resultants (statically determinate for a
        rigid block) and says so."""

        uplift = self.uplift
        if self.absorbing is not None:       # unsupported rock: the static springs again
            main = solver
            solver = spring_supported(main, self.absorbing.K_support)
            solver.set_initial(u=main.u)
        uplift.p = uplift.pressure(solver.state)
        saved = SolverPart(solver)
        final = saved.checkpoint()
        slip0 = self._mean_slips(solver.g)
        try:
            # no relaxation at a limit load here (it is for the crack growth of the
            # pre-earthquake static solve): from a slid final state whose static Newton cycles
            # between active sets it ran its 5000 steps and found nothing, 75 s of a 205 s IDA
            # run (docs/safety.md §5)
            rep, p, f = uplift.solve(solver, lambda f: solver.static(f, relax=False),
                                     f_base_static, uplift.p, uplift.state_dependent)
            # a frictional base that cannot hold the loads has no equilibrium, but Newton's
            # gap residual is relative to |g| and can "converge" on a runaway slip: accept the
            # solve only if the force balance holds and no joint slid beyond the run's
            # small-displacement bound
            r = f - solver.K @ solver.u - solver.internal_force(solver.t)
            dslip = np.abs(self._mean_slips(solver.g) - slip0).max()
            if np.linalg.norm(r) > 1e-6 * np.linalg.norm(f) or dslip > self.slip_bound:
                raise SolverError(f"the static solve slid {dslip:.3g} m (force residual "
                                  f"{np.linalg.norm(r) / np.linalg.norm(f):.1e} relative)")
            uplift.p = p
            m = self.safety.joint_measures(solver.t, solver.state, p)
            ok, note = True, "static solve from the final interface state"
            iters = int(rep.iterations)
        except SolverError as e:
            saved.restore(final)
            uplift.p = uplift.pressure(solver.state)
            m = self._resultant_measures(solver, f_base_static)
            ok, iters = False, None
            note = (f"no static equilibrium from the final state ({e}); FS from the load "
                    f"resultants on the dam: {resultant_verdict(m['base']['sliding_fs'])}")
        joints = {}
        for name in self.joints.names:
            d = dict(m[name])
            d["meets_criterion"] = bool(d["sliding_fs"] >= FS_CRITERION)
            joints[name] = d
        return {"converged": ok, "newton_iterations": iters, "criterion": FS_CRITERION,
                "note": note, "joints": joints}

    def collapsed(self, collapse: dict) -> dict:
        """No post-earthquake state after a collapse or a stop outside the model's range (a
        block sliding without bound, sliding off, or rotated past time.max_rotation; the
        small-kinematics static solve would find a meaningless equilibrium): no FS, the
        criterion is not met."""
        return {"converged": False, "newton_iterations": None, "criterion": FS_CRITERION,
                "skipped": True,
                "note": f"not computed: the run stopped at t = {collapse['time']:.4g} s "
                        f"({collapse['reason']})",
                "joints": {name: {"sliding_fs": None, "meets_criterion": False}
                           for name in self.joints.names}}

    def _mean_slips(self, g) -> np.ndarray:
        w = self.joints.w
        return np.array([np.dot(w[sl], g[sl, 1]) / w[sl].sum() for sl in self.joints.slices])

    def _resultant_measures(self, solver, f_base):
        """Joint forces from the loads when no static equilibrium exists (base only: the
        dam's total load; a lift joint takes the same figures scaled by nothing better, so
        only the base is given this way)."""
        p = self.uplift.p
        f = f_base + (self.uplift.load(p) if self.uplift.active else 0.0)
        out = self.safety.joint_measures(solver.t, solver.state, p)
        b = out["base"]
        U = b["uplift_force"]
        Fy = float(np.sum(f[self.dam & self.ydof]))       # net vertical load on the dam
        Fx = float(np.sum(f[self.dam & self.xdof]))
        N = -Fy       # N' = W - U - (other vertical loads)
        T = abs(Fx)
        C = b["cohesion_force"]
        num = b["friction"] * max(N, 0.0) + C
        b.update(normal_force=N, shear_force=T, uplift_force=U,
                 sliding_fs=num / T if T > num / FS_CAP else FS_CAP)
        return out
