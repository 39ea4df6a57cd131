"""The rotating drum's seeds one by one against the same seeds as worlds of one engine.

It runs ``--seeds`` drums of the ``corn_stalk_dry`` preset on a rough lining
(``pw.static_friction`` 0.9 in the drum) twice on the CPU backend in this process: each seed
alone (``run_drum`` with one run, one engine each), then all of them in one call (one engine,
a world per seed). It prints and writes to ``--json`` the wall and CPU time of both, their
ratio, and whether every run's result (all but its wall time) is the same both ways. The
numba kernels are compiled (or loaded from numba's cache) by a tiny warm-up run first, which
is not timed. The load average is recorded beside the times: on a shared machine they are
only as good as it was idle.

On one CPU thread a batch does the same work as its runs one after another, so expect a ratio
near 1; batching pays on a GPU (``--backend cuda``), where one engine turns every world at once.

Usage::

    python benchmarks/drum_batch.py --quick --json benchmarks/results/drum_batch_quick.json
    python benchmarks/drum_batch.py --seeds 6 --drum frames=40 --backend cuda
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

from demcal.virtual.drum import run_drum
from demcal.virtual.drum_settings import drum_settings
from demcal.virtual.presets import preset_parameters

#: ``--quick``: the quick drum (89 stalks) with 4 frames and a 2-frame steady window
QUICK = {"frames": 4, "steady_window": 2}
LINING = {"wall_static_friction": 0.9}


def timed(sets: list[dict], seeds: list[int], settings, backend: str) -> tuple[list, dict]:
    """``run_drum`` of ``sets`` and ``seeds`` in one call: its results and its wall and CPU
    time, s."""
    cpu, wall = time.process_time(), time.perf_counter()
    results = run_drum(sets, settings=settings, seeds=seeds, backend=backend)
    return results, {"wall_s": time.perf_counter() - wall, "cpu_s": time.process_time() - cpu}


def same(a, b) -> bool:
    """Two runs' results equal in every field but the wall time."""
    da, db = a.to_dict(), b.to_dict()
    return all(da[k] == db[k] for k in da if k != "wall_time_s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="3 seeds of the quick drum with 4 frames (~1-2 minutes on one core)")
    ap.add_argument("--seeds", type=int, default=None, help="seeds (default 3)")
    ap.add_argument("--fidelity", default="quick")
    ap.add_argument("--drum", nargs="*", default=[], metavar="NAME=VALUE",
                    help="drum settings over the fidelity's, e.g. frames=40")
    ap.add_argument("--backend", default="cpu")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    n = args.seeds if args.seeds is not None else 3
    if n < 1:
        ap.error("--seeds must be at least 1")
    drum = {**(QUICK if args.quick else {}), **LINING,
            **{k: json.loads(v) for k, _, v in (a.partition("=") for a in args.drum)}}
    settings = drum_settings(args.fidelity, {"drum": drum})
    params = preset_parameters("corn_stalk_dry")
    seeds = list(range(1, n + 1))
    warm = drum_settings("quick", {"drum": {"count": 10, "frames": 2, "steady_window": 1}})
    run_drum([params], settings=warm, seeds=[0], backend=args.backend)  # compile, untimed
    load_before = os.getloadavg()
    alone, one_by_one = [], {"wall_s": 0.0, "cpu_s": 0.0}
    for seed in seeds:
        (r,), t = timed([params], [seed], settings, args.backend)
        alone.append(r)
        one_by_one = {k: one_by_one[k] + t[k] for k in t}
        print(f"seed {seed} alone: {r.outcome} {r.dynamic_aor_deg} deg, {t['wall_s']:.1f} s",
              flush=True)
    batch, batched = timed([params] * n, seeds, settings, args.backend)
    print(f"{n} seeds batched: {batched['wall_s']:.1f} s", flush=True)
    out = {
        "meta": {"machine": platform.machine(), "processor": platform.processor(),
                 "python": platform.python_version(), "backend": args.backend,
                 "fidelity": args.fidelity, "drum": drum, "preset": "corn_stalk_dry",
                 "seeds": seeds, "started": time.ctime(),
                 "numba_threads": os.environ.get("NUMBA_NUM_THREADS"),
                 "load_average_before": load_before, "load_average_after": os.getloadavg()},
        "one_by_one": one_by_one, "batched": batched,
        "wall_ratio_batched_over_one_by_one": batched["wall_s"] / one_by_one["wall_s"],
        "cpu_ratio_batched_over_one_by_one": batched["cpu_s"] / one_by_one["cpu_s"],
        "results_identical": [same(a, b) for a, b in zip(alone, batch, strict=True)],
        "runs": [{"seed": r.seed, "outcome": r.outcome, "dynamic_aor_deg": r.dynamic_aor_deg,
                  "com_angle_deg": r.com_angle_deg, "frames": len(r.frames_deg),
                  "n_particles": r.n_particles, "time_step_s": r.time_step_s,
                  "sim_time_s": r.sim_time_s, "wall_alone_s": r.wall_time_s,
                  "wall_in_batch_s": b.wall_time_s} for r, b in zip(alone, batch, strict=True)],
    }
    print(f"one by one {one_by_one['wall_s']:.1f} s wall ({one_by_one['cpu_s']:.1f} CPU-s), "
          f"batched {batched['wall_s']:.1f} s ({batched['cpu_s']:.1f} CPU-s): ratio "
          f"{out['wall_ratio_batched_over_one_by_one']:.3f}; results identical: "
          f"{out['results_identical']}; load {load_before[0]:.2f} -> "
          f"{out['meta']['load_average_after'][0]:.2f}")
    if args.json is not None:
        args.json.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
