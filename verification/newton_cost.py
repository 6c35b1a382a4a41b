"""What the condensed Newton on the interface gaps costs a step (issue 32, item 3), on the far-field
IDA's scene: ``koyna_engineering`` with the reduced bulk (the whole base debonds and slides).

Runs the scene's time loop in-process (set-up, modal and static solve not timed) and times each
step (``Analysis.step``) and the Newton loop on the gaps inside it (``NewtonControl.solve``: the
law, the residual, the interface system's directions, the line search) by wall clock and by the
thread's CPU time; the first 20 steps are left out of the medians. Prints one JSON line with the
medians and means, the Newton loop's total, the interface system's counts
(``CondensedNewton.stats``: factorisations, GMRES reuses and iterations) and the 1-min load.

    python verification/newton_cost.py [--scene koyna_engineering] [--duration 4]
    python verification/newton_cost.py --compare /path/to/old/checkout --repeat 3

``--compare OLD``: alternates OLD's code and this checkout's, each in its own process (this
script run with PYTHONPATH set to the checkout), ``--repeat`` times, and prints both lines of
each round (the machine is shared: alternate, and compare medians with the load).
Figures: BENCHMARKS.md "Condensed Newton on a sliding base"."""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

import ngs_driver                   # the code on PYTHONPATH (--compare: each checkout in turn)
from ngs_driver.post.outputs import RunOutputs
from ngs_driver.run.analysis import prepare
from ngs_driver.scene import load_scene

ROOT = pathlib.Path(__file__).resolve().parents[1]
WARM = 20


def measure(scene: str, duration: float) -> dict:
    """The time loop of ``scene`` (reduced bulk) with the step and the Newton loop timed."""
    sc = load_scene(scene, ["solver.bulk=reduced", f"time.duration={duration}"])
    a = prepare(sc, pathlib.Path(tempfile.mkdtemp()), outputs=RunOutputs(plots=False),
                progress=False, log=lambda *x, **k: None)
    a.static()
    ctl = a.solver.newton.control
    solve = ctl.solve
    wall, cpu = [], []

    def timed(*args, **kw):
        t, c = time.perf_counter(), time.thread_time()
        try:
            return solve(*args, **kw)
        finally:
            wall[-1] += time.perf_counter() - t
            cpu[-1] += time.thread_time() - c

    ctl.solve = timed
    steps = []
    load0 = os.getloadavg()[0]
    c0, w0 = time.thread_time(), time.perf_counter()
    while True:
        wall.append(0.0)
        cpu.append(0.0)
        t = time.perf_counter()
        more = a.step()
        steps.append(time.perf_counter() - t)
        if not more:
            break
    loop_cpu, loop_wall = time.thread_time() - c0, time.perf_counter() - w0
    ms = lambda x: 1e3 * np.asarray(x[WARM:])               # noqa: E731
    return dict(code=str(pathlib.Path(ngs_driver.__file__).resolve().parents[1]), scene=scene,
                duration=duration, steps=len(steps),
                step_median_ms=float(np.median(ms(steps))), step_mean_ms=float(np.mean(ms(steps))),
                newton_median_ms=float(np.median(ms(wall))),
                newton_mean_ms=float(np.mean(ms(wall))),
                newton_cpu_median_ms=float(np.median(ms(cpu))),
                newton_total_s=float(np.sum(wall)), newton_cpu_total_s=float(np.sum(cpu)),
                loop_wall_s=loop_wall, loop_cpu_s=loop_cpu,
                stats=dict(a.solver.newton.stats), load_start=load0,
                load_end=os.getloadavg()[0])


def compare(old: str, repeat: int, scene: str, duration: float) -> list:
    """Alternate OLD's code and this checkout's, ``repeat`` rounds, each in its own process."""
    out = []
    for _ in range(repeat):
        for code in (old, str(ROOT)):
            env = dict(os.environ, PYTHONPATH=code)
            r = subprocess.run([sys.executable, __file__, "--scene", scene, "--duration",
                                str(duration)], env=env, capture_output=True, text=True,
                               check=True)
            line = r.stdout.strip().splitlines()[-1]
            print(line, flush=True)
            out.append(json.loads(line))
    return out


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", default="koyna_engineering")
    p.add_argument("--duration", type=float, default=4.0)
    p.add_argument("--compare", default=None)
    p.add_argument("--repeat", type=int, default=3)
    args = p.parse_args(argv)
    if args.compare:
        compare(args.compare, args.repeat, args.scene, args.duration)
        return 0
    print(json.dumps(measure(args.scene, args.duration)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
