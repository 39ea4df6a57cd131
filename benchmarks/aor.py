"""Virtual angle-of-repose test timings: one quick test, one paper-fidelity test, a batch of 15.

Prints, per case, the wall time, the simulated time, the number of spheres and the engine's
throughput in sphere-timesteps per second (sum over worlds of spheres x steps, divided by the
wall time of the batch, compile time excluded by a warm-up run first).

Usage::

    python benchmarks/aor.py                 # quick test and a 15-world quick batch on CPU
    python benchmarks/aor.py --paper --json out.json
    python benchmarks/aor.py --backend cuda --paper --batch 15

The 15-world batch is a Box-Behnken design's worth of parameter sets (3 factors, 3 centre
points) around the corn-stalk preset, all in one engine instance.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

from demcal.doe.designs import box_behnken
from demcal.doe.factors import Factor, FactorSpace
from demcal.virtual.aor import run_aor
from demcal.virtual.config import fidelity_config
from demcal.virtual.presets import preset_parameters

BASE = {"pp.surface_energy": 0.0}


def _case(name: str, sets: list[dict], fidelity: str, backend: str) -> dict:
    config = fidelity_config(fidelity)
    params = [preset_parameters("corn_stalk", {**BASE, **s}) for s in sets]
    t0 = time.perf_counter()
    results = run_aor(params, config=config, seeds=list(range(1, len(params) + 1)),
                      backend=backend)
    wall = time.perf_counter() - t0
    sphere_steps = sum(r.sphere_steps for r in results)
    out = {
        "case": name, "fidelity": fidelity, "backend": backend, "n_worlds": len(results),
        "n_particles": [r.n_particles for r in results],
        "outcomes": [r.outcome for r in results],
        "aor_deg": [None if r.aor_deg is None else round(r.aor_deg, 2) for r in results],
        "sim_time_s": [round(r.sim_time_s, 3) for r in results],
        "time_step_s": results[0].time_step_s,
        "wall_time_s": round(wall, 2),
        "sphere_steps": sphere_steps,
        "sphere_steps_per_s": sphere_steps / wall,
    }
    print(f"{name:>14}: {len(results):3d} world(s), {wall:8.1f} s wall, "
          f"sim {max(out['sim_time_s']):.2f} s, {out['sphere_steps_per_s']:.3g} sphere-steps/s, "
          f"outcomes {sorted(set(out['outcomes']))}", flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--backend", default="cpu", choices=["cpu", "cuda", "auto"])
    ap.add_argument("--paper", action="store_true", help="also time one paper-fidelity test")
    ap.add_argument("--batch", type=int, default=15, help="worlds in the batch case (0: skip)")
    ap.add_argument("--json", help="write the numbers to this file")
    args = ap.parse_args()

    # warm-up: compile the kernels (numba caches them across runs)
    t0 = time.perf_counter()
    run_aor([preset_parameters("corn_stalk", BASE)],
            config=fidelity_config("quick", fill={"count": 10},
                                   phases={"fill_settle_max_time": 0.02,
                                           "pile_settle_max_time": 0.02}),
            seeds=[0], backend=args.backend)
    compile_s = time.perf_counter() - t0
    print(f"warm-up (compile or cache load): {compile_s:.1f} s", flush=True)

    cases = [_case("quick", [{}], "quick", args.backend)]
    if args.batch:
        space = FactorSpace([Factor("pp.static_friction", 0.35, 0.75),
                             Factor("pp.rolling_friction", 0.03, 0.15),
                             Factor("pw.static_friction", 0.4, 0.7)])
        design = box_behnken(space, center_points=3, randomize=False)
        sets = [dict(zip(space.names, row, strict=True)) for row in design.actual]
        sets = (sets * (args.batch // len(sets) + 1))[: args.batch]
        cases.append(_case(f"quick x{args.batch}", sets, "quick", args.backend))
    if args.paper:
        cases.append(_case("paper", [{}], "paper", args.backend))
    single = cases[0]["wall_time_s"]
    if args.batch:
        batch = cases[1]
        print(f"batch of {args.batch}: {batch['wall_time_s'] / args.batch:.1f} s per test "
              f"(x{single * args.batch / batch['wall_time_s']:.2f} vs one at a time)")
    report = {"machine": {"platform": platform.platform(), "cpus": os.cpu_count()},
              "compile_s": compile_s, "cases": cases}
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(report, fh, indent=2)


if __name__ == "__main__":
    main()
