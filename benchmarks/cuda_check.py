"""CUDA backend check and GPU throughput (run on a machine with a GPU).

Checks, then times:
1. CPU vs CUDA on two small piles in a tube (positions after 3000 steps, max difference;
   contacts form from ~1500);
2. CUDA with and without graph replay, and with a tiny neighbour capacity (forced growth):
   bitwise identical on the GPU;
3. sphere-steps per second and microseconds per step for settled beds of 7-sphere stalks at
   the given sizes, and a batch of worlds.

Usage::

    python benchmarks/cuda_check.py --sizes 1000 10000 100000 --batch 16 --json out.json
    python benchmarks/cuda_check.py --backend cpu --sizes 200 --steps 200   # dry run on CPU
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numpy as np

from demcal.dem import _config
from demcal.dem.materials import Interaction, Material, MaterialTable
from demcal.dem.shapes import stalk_template
from demcal.dem.simulation import Simulation
from demcal.dem.state import ClumpGroup, World, random_quaternions
from demcal.dem.walls import PlaneWall, TubeWall


def corn_table(gamma: float = 0.0) -> MaterialTable:
    return MaterialTable(
        [Material("stalk", 114.36, 2.5e6, 0.3), Material("steel", 7865.0, 7.9e10, 0.3)],
        {("stalk", "stalk"): Interaction(0.3, 0.55, 0.14, gamma),
         ("stalk", "steel"): Interaction(0.45, 0.55, 0.15, 0.0)})


def tube_world(n: int, seed: int, gamma: float = 0.0) -> World:
    """n stalks on a lattice in a 50 mm tube on a plate."""
    tpl = stalk_template()
    rng = np.random.default_rng(seed)
    pts = []
    z = 7e-3
    while len(pts) < n:
        for x in np.arange(-16.5e-3, 17e-3, 11e-3):
            for y in np.arange(-16.5e-3, 17e-3, 11e-3):
                if x * x + y * y < (19e-3) ** 2 and len(pts) < n:
                    pts.append((x, y, z))
        z += 11e-3
    scales = rng.uniform(0.75, 1.05, n)
    g = ClumpGroup(tpl, "stalk", n, scales=scales, positions=np.array(pts),
                   orientations=random_quaternions(n, rng),
                   velocities=np.tile([0, 0, -0.5], (n, 1)))
    walls = [PlaneWall([0, 0, 0], [0, 0, 1], (0.15, 0.15), material="steel", name="plate"),
             TubeWall([0, 0, 0], [0, 0, 1], 25e-3, 2e-3, 0.15, material="steel", name="tube")]
    return World(corn_table(gamma), [g], walls, (-0.2, -0.2, -0.05), (0.2, 0.2, 0.6))


def bed_world(n: int, seed: int, gamma: float = 0.0) -> World:
    """n stalks on a square lattice in a box (layers of side x side), to settle into a bed."""
    tpl = stalk_template()
    rng = np.random.default_rng(seed)
    a = 13.2e-3
    layers = max(1, round((n / 10.0) ** (1 / 3) / 2))  # a wide, shallow bed
    side = math.ceil(math.sqrt(n / layers))
    layers = math.ceil(n / side**2)
    ii = np.arange(n)
    pos = np.stack([(ii % side + 0.5) * a, (ii // side % side + 0.5) * a,
                    (ii // (side * side) + 0.5) * a], 1)
    L = side * a
    pos[:, :2] -= L / 2
    g = ClumpGroup(tpl, "stalk", n, scales=rng.uniform(0.75, 1.25, n), positions=pos,
                   orientations=random_quaternions(n, rng))
    h = L / 2
    walls = [PlaneWall([0, 0, 0], [0, 0, 1], (h, h), material="steel", name="floor"),
             PlaneWall([-h, 0, 0], [1, 0, 0], (h, 1.0), u_axis=[0, 1, 0], material="steel"),
             PlaneWall([h, 0, 0], [-1, 0, 0], (h, 1.0), u_axis=[0, 1, 0], material="steel"),
             PlaneWall([0, -h, 0], [0, 1, 0], (h, 1.0), u_axis=[1, 0, 0], material="steel"),
             PlaneWall([0, h, 0], [0, -1, 0], (h, 1.0), u_axis=[1, 0, 0], material="steel")]
    return World(corn_table(gamma), [g], walls, (-h - 0.05, -h - 0.05, -0.05),
                 (h + 0.05, h + 0.05, layers * a + 0.2))


def compare(backend: str, steps: int) -> dict:
    out = {}
    sims = {}
    for name, be in (("cpu", "cpu"), (backend, backend)):
        sim = Simulation([tube_world(40, 1), tube_world(30, 2, gamma=0.01)], backend=be)
        sim.advance(steps)
        sims[name] = sim
    for w in range(2):
        a = sims["cpu"].clump_positions(w)
        b = sims[backend].clump_positions(w)
        out[f"world{w}_max_pos_diff_m"] = float(np.abs(a - b).max())
    # a comparison means something only with contacts (the piles fall for ~1500 steps)
    arrays = sims["cpu"].arrays
    out["cpu_spheres_in_contact"] = int(
        np.count_nonzero(np.linalg.norm(arrays["s_force"], axis=1))
        + np.count_nonzero(np.abs(arrays["s_wall_force"]).sum(axis=(1, 2))))
    out["cpu_rebuilds"] = sims["cpu"].n_rebuilds
    out[f"{backend}_rebuilds"] = sims[backend].n_rebuilds
    return out


def graph_and_growth(steps: int) -> dict:
    """GPU: graphs vs plain launches vs forced growth must be bitwise identical."""
    from demcal.dem.backends import cuda as cb

    res = {}
    ref = None
    for label, graphs, cap in (("graph", "1", 32), ("plain", "0", 32), ("grow", "1", 2)):
        os.environ["DEMCAL_CUDA_GRAPHS"] = graphs
        _config.NEIGHBOR_CAPACITY = cap
        _config.BUCKET_CAPACITY = 2 if label == "grow" else 16
        sim = Simulation([tube_world(40, 3)], backend="cuda")
        sim.advance(steps)
        p = sim.clump_positions(0)
        if ref is None:
            ref = p
        res[f"{label}_bitwise_equal"] = bool(np.array_equal(p, ref))
        res[f"{label}_nb_capacity"] = int(sim.arrays["nb_index_a"].shape[1])
        res[f"{label}_used_graphs"] = bool(sim.runner.use_graphs)
    os.environ["DEMCAL_CUDA_GRAPHS"] = "1"
    _config.NEIGHBOR_CAPACITY = 32
    _config.BUCKET_CAPACITY = 16
    del cb
    return res


def bench(backend: str, n: int, n_worlds: int, settle_s: float, steps: int) -> dict:
    worlds = [bed_world(n, s) for s in range(n_worlds)]
    t0 = time.perf_counter()
    sim = Simulation(worlds, backend=backend)
    sim.advance(10)
    t_first = time.perf_counter() - t0
    t0 = time.perf_counter()
    sim.run(settle_s)
    t_settle = time.perf_counter() - t0
    sim.advance(50)  # warm
    _ = sim.time
    t0 = time.perf_counter()
    sim.advance(steps)
    _ = sim.time  # synchronise
    el = time.perf_counter() - t0
    contacts = float(np.mean(np.linalg.norm(sim.arrays["s_force"], axis=1) > 0)) \
        if backend == "cpu" else None
    return {"backend": backend, "n_clumps": n * n_worlds, "n_spheres": sim.n_spheres,
            "n_worlds": n_worlds, "us_per_step": el / steps * 1e6,
            "sphere_steps_per_s": sim.n_spheres * steps / el, "first_call_s": t_first,
            "settle_wall_s": t_settle, "rebuilds": sim.n_rebuilds,
            "mean_neighbors": float(sim.arrays["nb_count_a"].mean()) if backend == "cpu"
            else None, "fraction_spheres_in_contact": contacts,
            "ke_J": sim.kinetic_energy(0)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--backend", default="cuda")
    ap.add_argument("--sizes", type=int, nargs="+", default=[1000, 10000, 100000])
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--settle", type=float, default=0.1)
    ap.add_argument("--skip-checks", action="store_true")
    ap.add_argument("--json", default=None)
    ap.add_argument("--profile", type=int, default=0,
                    help="also time each kernel on a bed of this many clumps")
    args = ap.parse_args()
    report: dict = {"argv": sys.argv}
    if args.backend == "cuda" and os.environ.get("NUMBA_ENABLE_CUDASIM") != "1":
        from numba import cuda

        dev = cuda.get_current_device()
        report["device"] = dev.name.decode() if isinstance(dev.name, bytes) else str(dev.name)
        print("device", report["device"], flush=True)
    if not args.skip_checks:
        t = time.perf_counter()
        report["compare_cpu"] = compare(args.backend, 3000)
        print("compare", report["compare_cpu"], f"{time.perf_counter() - t:.1f}s", flush=True)
        if args.backend == "cuda":
            t = time.perf_counter()
            report["graphs"] = graph_and_growth(300)
            print("graphs", report["graphs"], f"{time.perf_counter() - t:.1f}s", flush=True)
    report["cases"] = []
    for n in args.sizes:
        r = bench(args.backend, n, 1, args.settle, args.steps)
        report["cases"].append(r)
        print(json.dumps(r), flush=True)
    if args.batch:
        r = bench(args.backend, args.sizes[0], args.batch, args.settle, args.steps)
        report["cases"].append(r)
        print(json.dumps(r), flush=True)
    if args.profile:
        report["profile"] = profile(args.profile, args.settle, 200)
        print(json.dumps(report["profile"], indent=1), flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(report, f, indent=1)



def profile(n: int, settle_s: float, steps: int) -> dict:
    """Per-kernel GPU time (CUDA events, plain launches) and registers on a settled bed."""
    from numba import cuda

    from demcal.dem.backends import cuda as cb

    sim = Simulation([bed_world(n, 0)], backend="cuda")
    sim.run(settle_s)
    runner = sim.runner
    k = runner.k
    names = [n for n in dir(k) if n.startswith("k_")]
    timings = {name: 0.0 for name in names}
    original = {name: getattr(k, name) for name in names}

    class Timed:
        def __init__(self, name, kern):
            self.name, self.kern = name, kern

        def __getitem__(self, cfg):
            launch = self.kern[cfg]

            def call(*args):
                e0, e1 = cuda.event(), cuda.event()
                e0.record(runner.stream)
                launch(*args)
                e1.record(runner.stream)
                e1.synchronize()
                timings[self.name] += e0.elapsed_time(e1) / 1e3
            return call

    for name in names:
        setattr(k, name, Timed(name, original[name]))
    runner.use_graphs = False
    runner._graph = None
    r0 = sim.n_rebuilds
    sim.advance(steps)
    rebuilds = sim.n_rebuilds - r0
    for name in names:
        setattr(k, name, original[name])
    regs = {}
    for name in names:
        try:
            regs[name] = {str(k_): v for k_, v in
                          dict(original[name].get_regs_per_thread()).items()}
        except Exception as exc:  # pragma: no cover - depends on numba-cuda version
            regs[name] = str(exc)
    del cb
    return {"n_spheres": sim.n_spheres, "steps": steps, "rebuilds": rebuilds,
            "us_per_step_by_kernel": {k_: v / steps * 1e6 for k_, v in timings.items()},
            "registers": regs}


if __name__ == "__main__":
    main()
