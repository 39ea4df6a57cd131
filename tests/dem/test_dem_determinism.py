"""Determinism (thread count, batching) and removal of clumps that leave the domain."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from worlds import table

from demcal.dem import _config
from demcal.dem.materials import Interaction
from demcal.dem.shapes import sphere_template, stalk_template
from demcal.dem.simulation import Simulation
from demcal.dem.state import ClumpGroup, World, random_quaternions
from demcal.dem.walls import PlaneWall, TubeWall

HERE = Path(__file__).parent
STATE = ("c_pos", "c_quat", "c_vel", "c_angmom", "c_omega", "c_state", "s_force", "s_torque",
         "s_wall_force", "w_hist")


def bed_world(seed: int, n: int = 30, gamma: float = 0.02, mu_s: float = 0.5) -> World:
    """Stalks and spheres dropped in a tube onto a small plate: contacts, JKR, rolling
    friction, a tube lifted during the run and clumps sliding off the plate (removed)."""
    rng = np.random.default_rng(seed)
    mats = table(Interaction(0.4, mu_s, 0.1, surface_energy=gamma),
                 Interaction(0.5, 0.6, 0.05))
    k = np.arange(n)
    pos = np.stack([0.013 * ((k % 3) - 1), 0.013 * (((k // 3) % 3) - 1),
                    0.007 + 0.013 * (k // 9)], axis=1) + rng.uniform(-4e-4, 4e-4, (n, 3))
    groups = [
        ClumpGroup(stalk_template(), "p", n, scales=rng.uniform(0.75, 1.25, n), positions=pos,
                   orientations=random_quaternions(n, rng),
                   velocities=rng.normal(0, 0.05, (n, 3))),
        ClumpGroup(sphere_template(1.5e-3), "p", 4,
                   positions=np.array([[0.03, 0.0, 0.01 * (j + 1)] for j in range(4)]),
                   velocities=np.array([[0.5, 0.2, 0.0]] * 4)),
    ]
    walls = [PlaneWall(origin=np.zeros(3), normal=np.array([0.0, 0.0, 1.0]),
                       half_size=(0.04, 0.04), name="plate"),
             TubeWall(base=np.array([0.0, 0.0, 0.0005]), axis=np.array([0.0, 0.0, 1.0]),
                      inner_radius=0.027, thickness=0.001, length=0.06,
                      velocity=np.array([0.0, 0.0, 0.05]), name="tube")]
    return World(mats, groups, walls=walls, domain_lo=(-0.05, -0.05, -0.01),
                 domain_hi=(0.05, 0.05, 0.2))


def digest(sim: Simulation, world: int | None = None) -> str:
    h = hashlib.sha256()
    for name in STATE:
        arr = sim.arrays[name]
        if world is not None:
            lo, hi = (sim.clump_range if name.startswith("c_") else sim.sphere_range)[world]
            arr = arr[lo:hi]
            if name in ("s_wall_force", "w_hist"):
                arr = arr[:, : len(sim.worlds[world].walls)]
        h.update(np.ascontiguousarray(arr).tobytes())
    return h.hexdigest()


def run_bed(steps: int = 5000) -> str:
    sim = Simulation([bed_world(1)])
    sim.advance(steps)
    return f"{digest(sim)} {sim.n_removed(0)} {sim.n_rebuilds}"


def test_trajectories_are_bitwise_identical_for_1_and_2_threads():
    out = []
    for threads in ("1", "2"):
        env = dict(os.environ, NUMBA_NUM_THREADS=threads, DEMCAL_SPHERES_PER_THREAD="0")
        code = (f"import sys; sys.path.insert(0, {str(HERE)!r}); "
                "import test_dem_determinism as t; print(t.run_bed())")
        proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                              text=True, timeout=600, cwd=HERE)
        assert proc.returncode == 0, proc.stderr[-3000:]
        out.append(proc.stdout.split())
    print("threads 1 vs 2:", out)
    assert out[0] == out[1]
    assert int(out[0][1]) > 0  # clumps were removed along the way
    assert int(out[0][2]) > 1  # and the neighbour lists rebuilt


def test_batched_worlds_equal_lone_worlds_bitwise():
    a = bed_world(2, n=18)
    b = bed_world(3, n=27, gamma=0.0, mu_s=0.3)
    both = Simulation([a, b])
    both.advance(1500)
    for w, world in enumerate((a, b)):
        alone = Simulation([world])
        alone.advance(1500)
        assert digest(both, w) == digest(alone, 0), f"world {w}"
    assert not np.allclose(both.arrays["c_pos"][:18], both.arrays["c_pos"][18:36])


def test_clumps_leaving_the_domain_are_removed_and_counted_without_errors():
    """Spheres shot off the plate leave the domain mid-chunk; the run goes on, they are
    counted, and no health check fires."""
    world = bed_world(4, n=9)
    sim = Simulation([world], raise_on_unstable=True)
    total = sim.n_clumps
    removed = []
    for _ in range(8):
        sim.run(0.01)
        removed.append(sim.n_removed(0))
    print("removed after each 0.01 s:", removed)
    assert sim.world_errors == [None]
    assert removed[-1] >= 4  # the four spheres left; the stalks may follow
    assert sim.n_removed(0) + sim.n_active(0) == total
    assert np.all(np.isfinite(sim.clump_positions(0)))
    state = sim.clump_state(0)
    lo, hi = np.array(world.domain_lo), np.array(world.domain_hi)
    pos = sim.arrays["c_pos"]
    assert np.all((pos[state == 1] >= lo) & (pos[state == 1] <= hi))
    assert np.all(np.any((pos[state == 2] < lo) | (pos[state == 2] > hi), axis=1))


def test_neighbour_and_bucket_overflow_are_handled_without_changing_the_trajectory(monkeypatch):
    """Tiny slot capacities force overflows (grow and redo); the trajectory is unchanged."""
    ref = Simulation([bed_world(5, n=18)])
    ref.advance(5000)
    monkeypatch.setattr(_config, "NEIGHBOR_CAPACITY", 1)
    monkeypatch.setattr(_config, "BUCKET_CAPACITY", 1)
    small = Simulation([bed_world(5, n=18)])
    assert small.arrays["nb_index_a"].shape[1] == 1
    small.advance(5000)
    assert small.arrays["nb_index_a"].shape[1] > 1 or small.arrays["nb_index_b"].shape[1] > 1
    assert small.arrays["bucket_members"].shape[1] > 1
    assert digest(small) == digest(ref)


def test_contact_history_survives_neighbour_rebuilds():
    """A thin skin rebuilds the lists ~10x more often than a thick one; as the tangential and
    rolling histories are carried over, the trajectories are bitwise the same."""
    runs = []
    for skin_frac in (0.02, 0.5):
        world = bed_world(6, n=18)
        r_max = 1.25 * 2e-3
        sim = Simulation([world], rolling_friction="C", skin=skin_frac * r_max)
        sim.advance(2000)
        runs.append((digest(sim), sim.n_rebuilds))
    print("rebuilds (thin, thick skin):", runs[0][1], runs[1][1])
    assert runs[0][1] > 3 * runs[1][1]
    assert runs[0][0] == runs[1][0]


def test_small_systems_run_on_fewer_threads_and_the_count_is_restored(monkeypatch):
    """A small system runs single-threaded (faster, bitwise the same); the caller's thread
    count is back afterwards, also after an error."""
    import numba

    from demcal.dem import _config

    seen = []
    real = numba.set_num_threads
    monkeypatch.setattr(numba, "set_num_threads", lambda n: (seen.append(n), real(n))[1])
    before = numba.get_num_threads()
    sim = Simulation([bed_world(1)])
    monkeypatch.setattr(_config, "SPHERES_PER_THREAD", 10**9)
    sim.advance(10)
    assert seen[0] == 1 and numba.get_num_threads() == before
    monkeypatch.setattr(_config, "SPHERES_PER_THREAD", 1)
    seen.clear()
    sim.advance(10)
    assert seen[0] == before


def piston_world(start: float = -2e-3) -> World:
    """Spheres at rest on a floor (no gravity) and a wall moving into them at 0.5 m/s from
    x = ``start`` (m): only the wall's motion can bring contacts, so a wall missing from the
    candidates would show."""
    mats = table(Interaction(0.5, 0.5, 0.05), Interaction(0.5, 0.5, 0.05))
    pos = [[1.6e-3 + 3.3e-3 * k, 0.0, 1.5e-3] for k in range(4)]
    walls = [PlaneWall(origin=np.zeros(3), normal=np.array([0.0, 0.0, 1.0]), name="floor"),
             PlaneWall(origin=np.array([start, 0.0, 0.0]), normal=np.array([1.0, 0.0, 0.0]),
                       half_size=(0.01, 0.01), velocity=np.array([0.5, 0.0, 0.0]),
                       name="piston")]
    group = ClumpGroup(sphere_template(1.5e-3), "p", len(pos), positions=np.array(pos))
    return World(mats, [group], walls=walls, gravity=(0.0, 0.0, 0.0),
                 domain_lo=(-0.05, -0.05, -0.01), domain_hi=(0.05, 0.05, 0.05))


def test_wall_candidates_give_the_trajectory_of_visiting_every_wall(monkeypatch):
    """The force pass visits only each sphere's candidate walls (found at neighbour builds;
    a wall moving half the skin triggers a build): bitwise the run that visits every wall at
    every step, for a lifted tube over a falling bed and for a piston pushing resting spheres."""
    runs = {}
    for use in (True, False):
        monkeypatch.setattr(_config, "WALL_CANDIDATES", use)
        bed = Simulation([bed_world(7, n=18)], rolling_friction="C")
        bed.advance(3000)
        piston = Simulation([piston_world()])
        piston.advance(1500)
        runs[use] = (digest(bed), bed.n_rebuilds, digest(piston), piston.n_rebuilds,
                     piston.clump_positions(0)[:, 0].copy(), piston.wall_forces(0).copy())
    on, off = runs[True], runs[False]
    print("rebuilds (bed, piston):", on[1], on[3], "piston x:", on[4], "wall forces:", on[5])
    assert on[0] == off[0] and on[2] == off[2]
    assert on[1] == off[1] and on[3] == off[3]
    # the piston did reach the spheres and push them along (they start at rest)
    assert np.all(on[4] > np.array([1.6e-3 + 3.3e-3 * k for k in range(4)]) + 3e-3)
    assert on[3] > 1


def run_piston(backend: str, steps: int = 200) -> list:
    """The piston started 0.6 mm from the first sphere, on ``backend``: x of the spheres (m),
    neighbour builds."""
    sim = Simulation([piston_world(-0.5e-3)], backend=backend)
    sim.advance(steps)
    return [sim.clump_positions(0)[:, 0].tolist(), sim.n_rebuilds]


def test_cuda_kernels_under_the_simulator_follow_a_moving_wall_like_the_cpu():
    """The CUDA step's glue for wall candidates (marked in ``search``, the build's wall
    positions kept by ``finish``, a wall moving half the skin raising a build in ``clumps``),
    under numba's CUDA simulator, against the CPU run: the piston reaches the first sphere
    only after several builds that its own motion triggered."""
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    code = (f"import sys; sys.path.insert(0, {str(HERE)!r}); import json; "
            "import test_dem_determinism as t; print(json.dumps(t.run_piston('cuda')))")
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=600, cwd=HERE)
    assert proc.returncode == 0, proc.stderr[-3000:]
    import json

    gpu = json.loads(proc.stdout.strip().splitlines()[-1])
    cpu = run_piston("cpu")
    print("x (cpu, cuda-sim):", cpu[0], gpu[0], "builds:", cpu[1], gpu[1])
    assert cpu[0][0] > 1.6e-3 + 1e-4  # pushed
    np.testing.assert_allclose(gpu[0], cpu[0], rtol=0, atol=1e-12)
    assert gpu[1] == cpu[1] and cpu[1] >= 3
