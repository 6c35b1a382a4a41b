"""The scene's interface-law kernels compiled in a separate process while the run builds its
model (``dam-seismic run`` and ``run-paper``; docs/run.md §7 "The command's memory").

With a cold numba cache (a fresh clone's first run) the law's loops -- compiled with a forced
vector width and one specialisation per kind of law -- are compiled by LLVM in the run's own
process, and what numba keeps of that compile stays resident: 328 against 157 MB for the law
alone, measured (koyna_engineering's law evaluated on one point, cold and then warm cache).
Added to the model's memory it took `make run`'s peak to 629 MB (`run koyna_engineering`) and
704 MB (`run-paper koyna`). The command therefore starts this module as a child process
before it builds anything: the child builds the scene's joint laws (``setup``: no NGSolve) and
evaluates each on one point, which compiles (or loads) their loops into numba's cache and
exits, giving that memory back. The run's own first call of a loop waits for the child's
compile to finish (``interfacelaw._kernels.cache_lock``, the lock every first call takes)
and then loads the loop from the cache. With a warm cache the child only loads the loops
(~0.5 s of the other core). The child's failure costs nothing but the warm-up: the run then
compiles what it needs itself.

    python -m ngs_driver.apps.warm < args.json   # ["koyna", ["interface.alpha=1", ...]] on stdin
"""
from __future__ import annotations

import json
import subprocess
import sys

__all__ = ["start", "finish", "warm_laws"]


def start(scene, overrides) -> subprocess.Popen | None:
    """The child process for the scene the command loads (its name or path and its --set
    overrides, as ``scene.load_scene`` takes them), or None when it cannot be started; its
    output goes nowhere (a warm-up has nothing to say)."""
    try:
        p = subprocess.Popen([sys.executable, "-m", "ngs_driver.apps.warm"],
                             stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)      # the command's environment
    except OSError:
        return None
    try:
        p.stdin.write(json.dumps([str(scene), list(overrides)]).encode())
        p.stdin.close()
    except OSError:                      # the child died at once: nothing to warm
        pass
    return p


def finish(p: subprocess.Popen | None, wait: bool = True) -> None:
    """No process left behind: after a run that went through, wait for the child (it is
    short, a run outlives it); after one that failed or was interrupted, stop it (the user
    has the run's message and should not wait for a warm-up; numba writes each cache file
    whole, by a rename, so a stopped compile leaves nothing half-written)."""
    if p is None:
        return
    if not wait:
        p.terminate()
    try:
        p.wait(timeout=600 if wait else 10)
    except subprocess.TimeoutExpired:    # pragma: no cover - a hung warm-up
        p.kill()
        p.wait()


def warm_laws(scene) -> int:
    """Evaluate each joint's law of ``scene`` on one point, through ``evaluate`` and the bound
    law a solver uses (``InterfaceLaw.bind``), at the scene's time step: their loops compiled
    or loaded. Returns the number of laws evaluated."""
    # deferred: the child imports the law's set-up only (no NGSolve)
    import numpy as np

    from ..setup import build_law
    from ..setup.inputs import joint_inputs

    dt = float(scene.time.dt)
    n = 0
    for j in joint_inputs(scene):
        law = build_law(j.law)
        gap = np.zeros((1, 2))
        state = law.initial_state(1)
        law.evaluate(gap, state, dt=dt)
        law.bind(state, dt)(gap.reshape(-1))
        n += 1
    return n


def main() -> int:
    # deferred: only the child process reads a scene
    from ..scene import load_scene
    name, overrides = json.loads(sys.stdin.read())
    warm_laws(load_scene(name, overrides))
    return 0


if __name__ == "__main__":
    sys.exit(main())
