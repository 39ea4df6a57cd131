"""The engine's contact forces against the slow plain-NumPy reference (tests/dem/naive.py).

Random crowded configurations of spheres and clumps (three templates, two particle
materials, JKR and plain Hertz pairs, random sizes, orientations, velocities and contact
histories) with finite/infinite planes and a tube, in two batched worlds with different
parameters. The engine takes one step from the snapshot; the forces it used, the torques,
the rolling torques, the wall forces and the updated histories must equal the reference's.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import naive
import numpy as np
import pytest
from worlds import (
    PARTICLE,
    STEEL,
    engine_outputs,
    floor,
    random_world,
    randomize_history,
    snapshot,
    spheres_world,
)

from demcal.dem import _config
from demcal.dem.materials import Interaction, Material, MaterialTable
from demcal.dem.simulation import Simulation
from demcal.dem.state import World

HERE = Path(__file__).parent
SOFT = Material("q", density=600.0, shear_modulus=4.0e6, poisson=0.25)


def _tables():
    t0 = MaterialTable([PARTICLE, SOFT, STEEL], {
        ("p", "p"): Interaction(0.4, 0.5, 0.1, surface_energy=5.0),
        ("p", "q"): Interaction(0.3, 0.6, 0.05, surface_energy=0.0),
        ("q", "q"): Interaction(0.6, 0.4, 0.2, surface_energy=2.0),
        ("p", "wall"): Interaction(0.5, 0.45, 0.08, surface_energy=3.0),
        ("q", "wall"): Interaction(0.35, 0.7, 0.12, surface_energy=0.0),
    })
    t1 = MaterialTable([PARTICLE, SOFT, STEEL], {
        ("p", "p"): Interaction(0.8, 0.3, 0.2),
        ("p", "q"): Interaction(0.2, 0.9, 0.01, surface_energy=1.0),
        ("q", "q"): Interaction(0.5, 0.5, 0.1),
        ("p", "wall"): Interaction(0.9, 0.2, 0.0),
        ("q", "wall"): Interaction(0.25, 0.55, 0.3, surface_energy=4.0),
    })
    return t0, t1


def _necks(rng: np.random.Generator, table: MaterialTable) -> World:
    """Pairs of spheres and spheres over a floor at overlaps between the JKR break-off
    overlap (a gap) and a small positive overlap, where the attraction dominates."""
    radius = 1.2e-3
    pp = naive.pair_props(PARTICLE, PARTICLE, table.interaction("p", "p"))
    pw = naive.pair_props(STEEL, PARTICLE, table.interaction("p", "wall"))
    dc_pp = naive.jkr_break_overlap(radius / 2, pp.estar, pp.gamma)
    dc_pw = naive.jkr_break_overlap(radius, pw.estar, pw.gamma)
    pos = []
    for k, frac in enumerate(np.linspace(0.95, -0.5, 6)):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        centre = np.array([0.01 * k, 0.0, 0.01])
        gap = frac * -dc_pp
        pos += [centre - 0.5 * (2 * radius + gap) * u, centre + 0.5 * (2 * radius + gap) * u]
        pos.append([0.01 * k, 0.02, radius + frac * -dc_pw])
    vel = rng.normal(0.0, 1e-3, (len(pos), 3))
    return spheres_world(table, radius, pos, velocities=vel, walls=[floor()],
                         gravity=(0.0, 0.0, -9.81), domain_lo=(-0.1, -0.1, -0.1),
                         domain_hi=(0.1, 0.1, 0.1))


def build(seed: int, rolling: str, backend: str = "cpu", spin: float = 0.0) -> Simulation:
    """The reference's worlds; ``spin`` (rad/s): every wall of the two random worlds turns
    about its axis (a plane's normal, a tube's axis) at that rate, in alternating senses."""
    rng = np.random.default_rng(seed)
    t0, t1 = _tables()
    worlds = [random_world(rng, t0, 12, materials=("p", "q", "p")),
              random_world(rng, t1, 9, materials=("q", "p", "q")), _necks(rng, t0)]
    sim = Simulation(worlds, backend=backend, rolling_friction=rolling, dt_fraction=0.2)
    if spin:
        for w in (0, 1):
            for k in range(len(worlds[w].walls)):
                axis = sim.arrays["wall_geom"][w, k, 0:3]
                sim.set_wall_angular_velocity(w, k, (-1) ** (w + k) * spin * axis)
    return sim


def compare(seed: int, rolling: str, backend: str = "cpu", spin: float = 0.0) -> dict:
    """Step once (build lists, histories), randomise the histories, snapshot, step again and
    compare with the reference. Returns the largest relative deviations and contact counts."""
    rng = np.random.default_rng(seed + 1000)
    sim = build(seed, rolling, backend, spin)
    saved = _config.MAX_OVERLAP_FRACTION, _config.MAX_SPEED
    # random crowding: deep overlaps (and the speeds they give) are wanted here
    _config.MAX_OVERLAP_FRACTION, _config.MAX_SPEED = 10.0, 1e9
    try:
        sim.advance(1)
        randomize_history(sim, rng, 2e-6)
        st = snapshot(sim)
        ref = naive.contact_forces(st, sim.worlds, rolling)
        sim.advance(1)
    finally:
        _config.MAX_OVERLAP_FRACTION, _config.MAX_SPEED = saved
    eng = engine_outputs(sim)

    def rel(x, y):
        scale = max(np.abs(y).max(), 1e-300)
        return float(np.abs(x - y).max() / scale)

    out = {
        "force": rel(eng["force"], ref.force),
        "torque": rel(eng["torque"], ref.torque),
        "wall_force": rel(eng["wall_force"], ref.wall_force),
        "w_hist": rel(eng["w_hist"], ref.wall_hist),
        "n_pairs": len(ref.pair_hist),
        "n_wall": int(np.count_nonzero(np.abs(ref.wall_force).sum(axis=2))),
        **{f"n_{k}": int(v) for k, v in ref.stats.items()},
    }
    if rolling == "A":
        out["roll"] = rel(eng["roll"], ref.roll)
    hist_err = 0.0
    scale = max(max((np.abs(v).max() for v in ref.pair_hist.values()), default=0.0), 1e-300)
    for key, vals in eng["hist"].items():
        want = ref.pair_hist.get(key, np.zeros(3))
        for v in vals:
            hist_err = max(hist_err, float(np.abs(v - want).max() / scale))
    out["hist"] = hist_err
    if rolling == "C":
        out["w_rhist"] = rel(eng["w_rhist"], ref.wall_rhist)
        rerr = 0.0
        rscale = max(max((np.abs(v).max() for v in ref.pair_rhist.values()), default=0.0),
                     1e-300)
        for key, vals in eng["rhist"].items():
            want = ref.pair_rhist.get(key, np.zeros(3))
            for v in vals:
                rerr = max(rerr, float(np.abs(v - want).max() / rscale))
        out["rhist"] = rerr
    return out


def _check(out: dict) -> None:
    # every branch is exercised: sphere and wall contacts, sticking and sliding, JKR necks
    assert out["n_pairs"] >= 10 and out["n_wall"] >= 5, out
    assert out["n_sliding"] >= 5 and out["n_sticking"] >= 5 and out["n_gap"] >= 1, out
    for k, v in out.items():
        if not k.startswith("n_"):
            assert v < 1e-12, (k, out)


@pytest.mark.parametrize(("seed", "rolling"), [(1, "A"), (2, "A"), (3, "C"), (4, "none")])
def test_cpu_kernels_equal_the_naive_reference(seed, rolling):
    out = compare(seed, rolling)
    print(seed, rolling, out)
    _check(out)


def _run_cudasim(rolling: str, spin: float = 0.0) -> str:
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    code = (f"import sys; sys.path.insert(0, {str(HERE)!r}); import test_dem_reference as t; "
            f"import json; print(json.dumps(t.compare(5, {rolling!r}, 'cuda', {spin!r})))")
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=600, cwd=HERE)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout.strip().splitlines()[-1]


@pytest.mark.parametrize("rolling", ["A", "C"])
def test_cuda_kernels_under_the_simulator_equal_the_naive_reference(rolling):
    out = json.loads(_run_cudasim(rolling))
    print(rolling, out)
    _check(out)


@pytest.mark.gpu
# a few clumps launch grids far smaller than the GPU: numba warns (the suite makes warnings
# errors), the kernels are right all the same
@pytest.mark.filterwarnings("ignore:.*will likely result in GPU under-utilization")
@pytest.mark.parametrize("rolling", ["A", "C"])
def test_cuda_kernels_on_a_gpu_equal_the_naive_reference(rolling):
    from demcal.dem.backends import cuda_available

    if not cuda_available():
        pytest.skip("no CUDA GPU")
    out = compare(6, rolling, "cuda")
    print(rolling, out)
    # the GPU contracts multiply-adds (FMA): rounding differs from the CPU's, not the law
    for k, v in out.items():
        if not k.startswith("n_"):
            assert v < 1e-10, (k, out)
