"""Engine step time inside a real angle-of-repose test: the workload a study pays for.

``engine.py`` times a settled, dry woodpile (the bed LAMMPS also runs). A study's CPU goes to
the cylinder-lifting test instead: a cohesive (JKR) pile of multi-sphere stalks, most of it
in the lift phase (~90 % of a ``small`` test's wall time). This script runs one test of a
fidelity up to the start of a phase, then times steps of that very engine state (the best of
``--repeat`` runs of ``--steps`` steps) with each thread count, and stops. The engine is
caught by wrapping :class:`~demcal.dem.simulation.Simulation` in
:mod:`demcal.virtual.aor` for this process only (the test keeps its own construction).

Usage::

    python -m uv run python benchmarks/aor_step.py                      # small, lift, seed 1
    python -m uv run python benchmarks/aor_step.py --fidelity standard --phase pile_settle

Prints one line per thread count: microseconds per step, spheres, and contacts per sphere.
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np
from bed import contacts_per_sphere

import demcal.virtual.aor as aor
from demcal.dem import _config
from demcal.dem.simulation import Simulation
from demcal.virtual.config import fidelity_config
from demcal.virtual.presets import preset_parameters


class _Reached(Exception):
    """The test reached the phase to time."""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fidelity", default="small")
    ap.add_argument("--phase", default="lift", help="fill_settle, lift or pile_settle")
    ap.add_argument("--preset", default="corn_stalk")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    caught: dict = {}

    class Caught(Simulation):
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            caught["sim"] = self

    def progress(_run, phase, _t, wall):
        if phase != args.phase:
            return
        sim = caught["sim"]
        print(f"{args.fidelity} test, seed {args.seed}, {args.preset}: reached {phase} after "
              f"{wall:.1f} s; {sim.n_spheres} spheres, "
              f"{contacts_per_sphere(sim):.2f} contacts per sphere", flush=True)
        most = numba.get_num_threads()
        live = int(np.count_nonzero(sim.arrays["c_state"][sim.arrays["s_clump"]] == 1))
        per = _config.SPHERES_PER_THREAD
        for threads in sorted({1, most}):
            numba.set_num_threads(threads)
            # the runner itself uses fewer threads on a small system (_config)
            used = threads if per <= 0 else max(1, min(threads, live // per))
            best = min(_timed(sim, args.steps) for _ in range(args.repeat))
            print(f"  {threads} thread(s) asked, {used} used: {best:.1f} us per step "
                  f"({1e6 / best * sim.n_spheres:.3g} sphere-steps/s)", flush=True)
        numba.set_num_threads(most)
        raise _Reached

    aor.Simulation = Caught
    try:
        aor.run_aor([preset_parameters(args.preset)], config=fidelity_config(args.fidelity),
                    seeds=[args.seed], backend="cpu", progress=progress)
        print(f"the test ended before {args.phase}")
    except _Reached:
        pass
    finally:
        aor.Simulation = Simulation


def _timed(sim: Simulation, steps: int) -> float:
    """Microseconds per step of ``steps`` steps (the runner's loop only: no host checks)."""
    t0 = time.perf_counter()
    sim.runner.run_steps(steps)
    return (time.perf_counter() - t0) / steps * 1e6


if __name__ == "__main__":
    main()
