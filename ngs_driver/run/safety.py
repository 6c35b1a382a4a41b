"""What a dam-safety review reads (issue #13): uplift on the joints, the forces on each joint, the
sliding factor of safety FS(t), and the post-earthquake static state.

Uplift enters the condensed solver as an **external load vector**

    f_U = B^T W (p e_N)          (p >= 0 the pore pressure at each joint point)

i.e. a traction p on both faces of every point pushing them apart (the virtual work of the
pressure is p dg_N). For a given p it is linear in u and leaves the solver's equations and its
Newton loop untouched. p depends on the crack state only through ``uplift.in_crack``
("zero", "full_headwater"; "unchanged" freezes the pre-earthquake p): for those, each static
solve and each time step is repeated from the committed state with the p of the crack state it
ended in until the crack state no longer changes (a fixed point over the whole step, not a lag:
the accepted step satisfies the equations with the p of its own end-of-step crack state).

Safety measures per joint (docs/safety.md §4):

    N' = -sum w t_N    effective normal force [N/m] (compression positive; uplift already out)
    T  = |sum w t_T|   shear force [N/m]
    U  = sum w p       uplift force [N/m]
    L_b = sum w over bonded points;  C = sum_bonded w c_p,
    c_p = (1 - D) tau_max (l_Nc/l_Tc) min(1, (1 - kappa)/(1 - lambda_max))   (current law)
    FS = (f max(N', 0) + C) / T      (USACE EM 1110-2-2100 eq. 3-1 with the law's f and c)
"""
from __future__ import annotations

import numpy as np

from ..setup.uplift import heads, joint_extent, pressure_profile
from .joints import debonded_measures

__all__ = ["UpliftField", "Safety", "tailwater_load", "SAFETY_KEYS", "FS_CRITERION"]

SAFETY_KEYS = ("normal_force", "shear_force", "uplift_force", "bonded_length", "sliding_fs")
FS_CRITERION = 1.3        # post-earthquake sliding criterion (FERC guidelines ch. 3; issue #13)
FS_CAP = 1e6              # FS reported when the shear force vanishes
_SOLVER_FIELDS = ("u", "v", "a", "f", "time", "t", "g", "_phi", "_active")


def tailwater_load(model, level: float, rho_w: float, gravity: float):
    """Hydrostatic tailwater on the downstream face (and the rock top downstream of the toe)
    as a free-DOF load vector; None when there is no tailwater. Traction -p n_out, n_out the
    dam's outward normal (n_x > 0 on the downstream face)."""
    if level <= 0.0:
        return None
    import ngsolve as ngs

    from ..fe.ngs_helpers import vec

    test = model.fes.TestFunction()
    test = tuple(test) if isinstance(test, (list, tuple)) else (test,)
    nb = sum(1 for r in model.regions if r != "rock")
    pw = rho_w * gravity * ngs.IfPos(level - ngs.y, level - ngs.y, 0.0)
    nrm = ngs.specialcf.normal(2)
    n_out = ngs.IfPos(nrm[0], 1.0, -1.0) * nrm
    lf = ngs.LinearForm(model.fes)
    for vv in test[:nb]:
        lf += -pw * ngs.InnerProduct(n_out, vv) * ngs.ds("downstream", bonus_intorder=2)
    if "rock" in model.regions and "rock_top_down" in set(model.mesh.GetBoundaries()):
        lf += -rho_w * gravity * level * test[-1][1] * ngs.ds("rock_top_down")
    lf.Assemble()
    return vec(lf)[model.free]


class UpliftField:
    """The pore pressure at the interface points (all joints) and its load vector."""

    def __init__(self, scene, iface, names, slices):
        self.names, self.slices = list(names), list(slices)
        self.B, self.w = iface.B, iface.w
        self.BT = iface.B.T.tocsr()
        tables = dict(scene.uplift_tables())
        rho_g = scene.loads.water_density * scene.loads.gravity
        self.spec = []
        for name, sl in zip(self.names, self.slices):
            up = tables[name]
            y, xu, xd = joint_extent(scene, name)
            hh, ht = heads(scene, y, up)
            self.spec.append((up, iface.x[sl] - xu, xd - xu, rho_g * hh, rho_g * ht))
        self.active = any(s[0].model != "none" for s in self.spec)
        self.state_dependent = any(s[0].model != "none" and s[0].in_crack != "unchanged"
                                   for s in self.spec)
        self.p_pre = None              # frozen pre-earthquake pressure ("unchanged")
        self.p = np.zeros(iface.w.size)

    def pressure(self, state) -> np.ndarray:
        """p [Pa] at every point for the crack state ``state`` (module docstring)."""
        p = np.zeros(self.w.size)
        deb = None
        for (up, s, L, ph, pt), sl in zip(self.spec, self.slices):
            if up.model == "none":
                continue
            if deb is None:
                deb = np.asarray(state.debonded, bool)
            if up.in_crack == "unchanged" and self.p_pre is not None:
                p[sl] = self.p_pre[sl]
            elif up.in_crack == "zero":
                p[sl] = np.where(deb[sl], 0.0, pressure_profile(s, L, ph, pt, up))
            else:      # full_headwater; "unchanged" before the shaking: the cracked drawing
                a = debonded_measures(deb[sl], self.w[sl])[1]
                p[sl] = pressure_profile(s, L, ph, pt, up, crack=a)
        return p

    def load(self, p) -> np.ndarray:
        """B^T W (p e_N): the free-DOF load of the pressure p."""
        gv = np.zeros(2 * self.w.size)
        gv[0::2] = self.w * p
        return self.BT @ gv


def _snapshot(solver):
    snap = {k: getattr(solver, k) for k in _SOLVER_FIELDS if hasattr(solver, k)}
    snap = {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in snap.items()}
    snap["state"] = solver.state.copy()
    return snap


def _restore(solver, snap):
    for k, v in snap.items():
        setattr(solver, k, v.copy() if isinstance(v, np.ndarray) else
                (v.copy() if k == "state" else v))


class Safety:
    """Uplift, safety measures and the post-earthquake solve of one run."""

    MAX_FIXED_POINT = 20

    def __init__(self, scene, model, joints, gm=None):
        self.scene = scene
        self.joints = joints
        self._step_keys = [(n, k, f"{n}_{k}") for n in joints.names for k in SAFETY_KEYS]
        self.uplift = UpliftField(scene, model.interface, joints.names, joints.slices)
        u = scene.uplift
        self.f_tail = tailwater_load(model, u.tailwater, scene.loads.water_density,
                                     scene.loads.gravity)
        self.fixed_point_iterations = 0     # extra solves spent on the p(crack) fixed point
        self.fixed_point_unconverged = 0    # steps accepted at the iteration cap
        self.p_static = np.zeros(joints.w.size)
        self.static = None
        self.screening = Screening(scene, model) if scene.screening.enabled else None
        self.absorbing = None                # fe.foundation.AbsorbingRock
        self.f_reaction = np.zeros(model.nfree)
        if scene.geometry.rock_sides == "absorbing":
            from ..fe.foundation import AbsorbingRock
            self.absorbing = AbsorbingRock(model, scene.materials.rock, gm,
                                           scene.ground_motion.start)

    def modal_model(self, model):
        """The model the modal analysis sees: with absorbing (unsupported) rock boundaries,
        the static support springs (the dashpots have no stiffness)."""
        if self.absorbing is None:
            return model
        import dataclasses
        return dataclasses.replace(model, K=(model.K + self.absorbing.K_support).tocsr())

    def input_force(self, t: float):
        """Free-field forces of absorbing boundaries at analysis time t (else 0)."""
        return 0.0 if self.absorbing is None else self.absorbing.force(t)

    def static_extra(self):
        """What the static load holds besides gravity, water and tailwater: the uplift of the
        static state and, with absorbing boundaries, the support reactions."""
        f = self.f_reaction.copy()
        if self.uplift.active:
            f += self.uplift.load(self.p_static)
        return f

    # ---------------------------------------------------------------- loads and solves
    def extra_static_load(self, nfree):
        """Loads this module adds to the static ones besides the uplift (tailwater)."""
        return np.zeros(nfree) if self.f_tail is None else self.f_tail

    def _solve(self, solver, call, f_base, p0, dependent):
        """``call(f)`` (solver.static or solver.step) with f = f_base + f_U(p), p consistent
        with the crack state the solve ends in. Returns (report, p, f)."""
        p = p0
        if not dependent:
            f = f_base + self.uplift.load(p) if self.uplift.active else f_base
            return call(f), p, f
        snap = _snapshot(solver)
        for k in range(self.MAX_FIXED_POINT):
            f = f_base + self.uplift.load(p)
            rep = call(f)
            p_new = self.uplift.pressure(solver.state)
            if np.array_equal(p_new, p):
                return rep, p, f
            self.fixed_point_iterations += 1
            if k == self.MAX_FIXED_POINT - 1:
                break
            _restore(solver, snap)
            p = p_new
        self.fixed_point_unconverged += 1
        return rep, p, f

    def solve_static(self, solver, f_base):
        """The pre-earthquake static state; freezes the pre-earthquake pressure. Returns
        (report, f_static) with f_static = f_base + f_U(p_static)."""
        p0 = self.uplift.pressure(solver.state)
        main = solver
        if self.absorbing is not None:       # no supports: solve on springs, keep reactions
            from ..solve.newmark import NewmarkSolver
            solver = NewmarkSolver(main.K + self.absorbing.K_support, main.M, None, main.B,
                                   main.w, main.law, dt=main.dt, tol_residual=main.tol_residual,
                                   max_iter=main.max_iter)
            solver.state = main.state
        # before the shaking every drawing depends on the static crack (cracked-base rule)
        rep, p, f = self._solve(solver, solver.static, f_base, p0, self.uplift.active)
        if self.absorbing is not None:
            self.f_reaction = -(self.absorbing.K_support @ solver.u)
            f = f + self.f_reaction
            main.state = solver.state
            main.set_initial(u=solver.u, v=np.zeros(main.ndof), a=np.zeros(main.ndof), f=f)
            solver = main
        self.p_static = p.copy()
        self.uplift.p_pre = p.copy()
        self.uplift.p = p.copy()
        if self.screening is not None:
            self.screening.static(solver.u)
        return rep, f

    def step(self, solver, f_k):
        """One time step; f_k already holds the static uplift. Returns (report, load used)."""
        if self.absorbing is not None:
            f_k = f_k + self.absorbing.force(solver.time + solver.dt)
        if not self.uplift.state_dependent:
            rep, f = solver.step(f_k), f_k
        else:
            f_base = f_k - self.uplift.load(self.p_static)
            rep, p, f = self._solve(solver, solver.step, f_base, self.uplift.p, True)
            self.uplift.p = p
        if self.screening is not None:
            self.screening.update(solver.u, solver.time, solver.dt)
        return rep, f

    # ---------------------------------------------------------------- measures
    def joint_measures(self, t, state, p, scan=None) -> dict:
        """{joint: {normal_force, shear_force, uplift_force, bonded_length, cohesion_force,
        friction, sliding_fs}} from tractions t, state and pressure p. scan: the
        ``JointScan`` of (state, t) if the caller has it (bonded points, their c_p)."""
        if scan is None:
            scan = self.joints.scan(state, np.zeros_like(t), t)
        out = {}
        w = self.joints.w
        for i, (name, sl, law) in enumerate(zip(self.joints.names, self.joints.slices,
                                                self.joints.laws)):
            ws = w[sl]
            N = -float(np.dot(ws, t[sl, 0]))
            T = abs(float(np.dot(ws, t[sl, 1])))
            U = float(np.dot(ws, p[sl]))
            wb, cpb = scan.bonded(i)
            C = float(np.dot(wb, cpb))
            f = 0.0 if law.friction is None else float(law.friction.f)
            num = f * max(N, 0.0) + C
            fs = num / T if T > num / FS_CAP else FS_CAP
            out[name] = {"normal_force": N, "shear_force": T, "uplift_force": U,
                         "bonded_length": float(scan.flts[i, 3]), "cohesion_force": C,
                         "friction": f, "sliding_fs": fs}
        return out

    def step_measures(self, t, state, scan=None) -> dict:
        """The per-step history columns "<joint>_<SAFETY_KEYS>"."""
        m = self.joint_measures(t, state, self.uplift.p, scan)
        return {key: m[n][k] for n, k, key in self._step_keys}

    def history_keys(self) -> list[str]:
        return [f"{n}_{k}" for n in self.joints.names for k in SAFETY_KEYS]

    def static_measures(self, solver) -> dict:
        m = self.joint_measures(solver.t, solver.state, self.uplift.p)
        for name, sl in zip(self.joints.names, self.joints.slices):
            ws = self.joints.w[sl]
            m[name]["slip_mean"] = float(np.dot(ws, solver.g[sl, 1]) / ws.sum())
        self.static = m
        return m

    # ---------------------------------------------------------------- after the shaking
    def post_earthquake(self, solver, f_base_static) -> dict:
        """Static solve from the final interface state (the crack left by the shaking carries
        no cohesion, friction is the law's current one, uplift per in_crack); the sliding FS
        of every joint against FS_CRITERION. ``f_base_static``: gravity + water (+ tailwater),
        without uplift. A solve that finds no equilibrium reports FS from the load resultants
        (statically determinate for a rigid block) and says so."""
        from ..solve.newmark import NewmarkSolver, SolverError

        if self.absorbing is not None:       # unsupported rock: the static springs again
            main = solver
            solver = NewmarkSolver(main.K + self.absorbing.K_support, main.M, None, main.B,
                                   main.w, main.law, dt=main.dt, tol_residual=main.tol_residual,
                                   max_iter=main.max_iter)
            solver.state = main.state
            solver.set_initial(u=main.u)
        self.uplift.p = self.uplift.pressure(solver.state)
        final = _snapshot(solver)
        slip0 = self._mean_slips(solver.g)
        try:
            rep, p, f = self._solve(solver, solver.static, f_base_static, self.uplift.p,
                                    self.uplift.state_dependent)
            # a frictional base that cannot hold the loads has no equilibrium, but Newton's
            # gap residual is relative to |g| and can "converge" on a runaway slip: accept the
            # solve only if the force balance holds and no joint slid beyond the run's
            # small-displacement bound (time.stop_slip, or 0.05 m)
            r = f - solver.K @ solver.u - solver._fint(solver.t)
            dslip = np.abs(self._mean_slips(solver.g) - slip0).max()
            if np.linalg.norm(r) > 1e-6 * np.linalg.norm(f) or dslip > self.slip_bound:
                raise SolverError(f"the static solve slid {dslip:.3g} m (force residual "
                                  f"{np.linalg.norm(r) / np.linalg.norm(f):.1e} relative)")
            self.uplift.p = p
            m = self.joint_measures(solver.t, solver.state, p)
            ok, note = True, "static solve from the final interface state"
            iters = int(rep.iterations)
        except SolverError as e:
            _restore(solver, final)
            self.uplift.p = self.uplift.pressure(solver.state)
            m = self._resultant_measures(solver, f_base_static)
            ok, iters = False, None
            note = (f"no static equilibrium from the final state ({e}); FS from the load "
                    "resultants on the dam: the dam slides")
        joints = {}
        for name in self.joints.names:
            d = dict(m[name])
            d["meets_criterion"] = bool(d["sliding_fs"] >= FS_CRITERION)
            joints[name] = d
        return {"converged": ok, "newton_iterations": iters, "criterion": FS_CRITERION,
                "note": note, "joints": joints}

    @property
    def slip_bound(self) -> float:
        return self.scene.time.stop_slip if self.scene.time.stop_slip > 0 else 0.05

    def _mean_slips(self, g) -> np.ndarray:
        w = self.joints.w
        return np.array([np.dot(w[sl], g[sl, 1]) / w[sl].sum() for sl in self.joints.slices])

    def _resultant_measures(self, solver, f_base):
        """Joint forces from the loads when no static equilibrium exists (base only: the
        dam's total load; a lift joint takes the same figures scaled by nothing better, so
        only the base is given this way)."""
        p = self.uplift.p
        f = f_base + (self.uplift.load(p) if self.uplift.active else 0.0)
        out = self.joint_measures(solver.t, solver.state, p)
        dam = self._dam_mask
        if dam is not None:
            b = out["base"]
            U = b["uplift_force"]
            Fy = float(np.sum(f[dam & self._ydof]))       # net vertical load on the dam
            Fx = float(np.sum(f[dam & self._xdof]))
            N = -Fy       # N' = W - U - (other vertical loads)
            T = abs(Fx)
            C = b["cohesion_force"]
            num = b["friction"] * max(N, 0.0) + C
            b.update(normal_force=N, shear_force=T, uplift_force=U,
                     sliding_fs=num / T if T > num / FS_CAP else FS_CAP)
        return out

    _dam_mask = None
    _ydof = None
    _xdof = None

    def set_dof_masks(self, model):
        """Dam DOFs and y-component DOFs (for the load resultants)."""
        self._dam_mask = np.asarray(model.dam_dofs, bool)
        self._ydof = np.abs(model.r_y) > 0.5
        self._xdof = np.abs(model.r_x) > 0.5

    # ---------------------------------------------------------------- summary
    def summary(self, H, dt) -> dict:
        """Per joint: minimum FS and when, time below 1, cumulative and residual slip."""
        out = {}
        t = H["t"]
        for name in self.joints.names:
            fs = H[f"{name}_sliding_fs"] if t.size else np.zeros(0)
            sm = H[f"{name}_slip_mean"] if t.size else np.zeros(0)
            s0 = self.static[name]["slip_mean"] if self.static else 0.0
            path = np.concatenate([[s0], sm])
            i = int(np.argmin(fs)) if fs.size else None
            out[name] = {
                "min_sliding_fs": float(fs[i]) if fs.size else None,
                "t_min_sliding_fs": float(t[i]) if fs.size else None,
                "time_fs_below_1": float(dt * np.count_nonzero(fs < 1.0)),
                "cumulative_slip": float(np.sum(np.abs(np.diff(path)))),
                "residual_slip": float(path[-1] - s0),
                "max_uplift_force": float(H[f"{name}_uplift_force"].max()) if t.size
                else None,
            }
        return out

    def checkpoint_arrays(self) -> dict:
        out = {"safety_p_static": self.p_static, "safety_p": self.uplift.p,
               "safety_f_reaction": self.f_reaction,
               "safety_counts": np.array([self.fixed_point_iterations,
                                          self.fixed_point_unconverged], dtype=np.int64)}
        if self.screening is not None:
            out.update(self.screening.arrays())
        return out

    def restore(self, arrs, static_info):
        if "safety_p_static" in arrs:
            self.p_static = np.array(arrs["safety_p_static"])
            self.uplift.p_pre = self.p_static.copy()
            self.uplift.p = np.array(arrs["safety_p"])
        if "safety_counts" in arrs:
            self.fixed_point_iterations, self.fixed_point_unconverged = (
                int(c) for c in arrs["safety_counts"])
        if "safety_f_reaction" in arrs:
            self.f_reaction = np.array(arrs["safety_f_reaction"])
        if self.screening is not None and "screen_max" in arrs:
            self.screening.restore(arrs)
        self.static = (static_info or {}).get("joints")


class Screening:
    """Linear screening of the dam body (USACE EM 1110-2-6053; docs/safety.md §10): per dam
    element (P1 triangles: constant stress) the demand-capacity ratio DCR = max principal
    stress / tensile strength at the static state and every step, its maximum over time and
    the cumulative inelastic duration (time with DCR > 1)."""

    def __init__(self, scene, model):
        import ngsolve as ngs
        import scipy.sparse as sp

        from ..fe.ngs_helpers import to_scipy, vec

        self.ft = float(scene.screening.tensile_strength)
        mesh, fes, free = model.mesh, model.fes, model.free
        trial = fes.TrialFunction()
        trial = tuple(trial) if isinstance(trial, (list, tuple)) else (trial,)
        blocks = [r for r in model.regions if r != "rock"]
        rows = {c: [] for c in ("xx", "yy", "xy")}
        xs, ys, tris = [], [], []
        for k, reg in enumerate(blocks):
            Q = ngs.Compress(ngs.L2(mesh, order=0, definedon=mesh.Materials(reg)))
            q, pq = Q.TestFunction(), Q.TrialFunction()
            dxr = ngs.dx(definedon=mesh.Materials(reg))
            mq = ngs.BilinearForm(Q)
            mq += pq * q * dxr
            mq.Assemble()
            area = to_scipy(mq.mat).diagonal()
            mat = model.materials[reg]
            e = ngs.Sym(ngs.Grad(trial[k]))
            s = mat.lam * ngs.Trace(e) * ngs.Id(2) + 2 * mat.mu * e
            for c, (i, j) in (("xx", (0, 0)), ("yy", (1, 1)), ("xy", (0, 1))):
                b = ngs.BilinearForm(trialspace=fes, testspace=Q)
                b += s[i, j] * q * dxr
                b.Assemble()
                rows[c].append(sp.diags(1.0 / area) @ to_scipy(b.mat, (Q.ndof, fes.ndof))
                               [:, free])
            for cf, out in ((ngs.x, xs), (ngs.y, ys)):
                lf = ngs.LinearForm(Q)
                lf += cf * q * dxr
                lf.Assemble()
                out.append(vec(lf) / area)
            tri = np.zeros((Q.ndof, 3, 2))
            for el in mesh.Elements(ngs.VOL):
                d = Q.GetDofNrs(el)
                if len(d) and d[0] >= 0:
                    tri[d[0]] = [mesh.vertices[v.nr].point[:2] for v in el.vertices]
            tris.append(tri)
        self.S = {c: sp.vstack(v).tocsr() for c, v in rows.items()}
        self.x, self.y = np.concatenate(xs), np.concatenate(ys)
        self.triangles = np.concatenate(tris)
        n = self.x.size
        self.max_dcr = np.full(n, -np.inf)
        self.t_max = np.zeros(n)
        self.duration = np.zeros(n)
        self.static_dcr = None

    def dcr(self, u) -> np.ndarray:
        sxx, syy, sxy = (self.S[c] @ u for c in ("xx", "yy", "xy"))
        s1 = 0.5 * (sxx + syy) + np.sqrt(0.25 * (sxx - syy) ** 2 + sxy ** 2)
        return s1 / self.ft

    def static(self, u):
        """The static state (t = 0) enters the maximum, not the duration (it is not time)."""
        self.static_dcr = self.dcr(u)
        self.max_dcr = self.static_dcr.copy()
        self.t_max = np.zeros_like(self.max_dcr)

    def update(self, u, t, dt):
        d = self.dcr(u)
        new = d > self.max_dcr
        self.max_dcr[new] = d[new]
        self.t_max[new] = t
        self.duration += dt * (d > 1.0)

    def summary(self) -> dict:
        i = int(np.argmax(self.duration)) if self.duration.any() else int(np.argmax(self.max_dcr))
        j = int(np.argmax(self.max_dcr))
        return {"method": "USACE EM 1110-2-6053 linear screening: DCR = max principal stress "
                          "/ tensile strength per dam element (P1: constant stress)",
                "tensile_strength": self.ft, "elements": int(self.x.size),
                "static_max_dcr": float(self.static_dcr.max()) if self.static_dcr is not None
                else None,
                "max_dcr": float(self.max_dcr[j]), "max_dcr_at": [float(self.x[j]),
                                                                  float(self.y[j])],
                "t_max_dcr": float(self.t_max[j]),
                "elements_dcr_over_1": int(np.count_nonzero(self.max_dcr > 1.0)),
                "worst_element": {"x": float(self.x[i]), "y": float(self.y[i]),
                                  "max_dcr": float(self.max_dcr[i]),
                                  "cumulative_inelastic_duration": float(self.duration[i])}}

    def arrays(self) -> dict:
        return {"screen_max": self.max_dcr, "screen_tmax": self.t_max,
                "screen_dur": self.duration,
                "screen_static": self.static_dcr if self.static_dcr is not None
                else np.zeros(0)}

    def restore(self, arrs):
        self.max_dcr = np.array(arrs["screen_max"])
        self.t_max = np.array(arrs["screen_tmax"])
        self.duration = np.array(arrs["screen_dur"])
        st = np.array(arrs["screen_static"])
        self.static_dcr = st if st.size else None
