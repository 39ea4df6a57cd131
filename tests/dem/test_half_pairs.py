"""The CPU's one-sided pair pass (demcal.dem.half_pairs) against the two-sided pass (the
GPU's, kernels.sphere_forces): the same forces, torques and histories bit for bit, for any
thread count; and both copies of a pair's histories equal outside a chunk."""

from __future__ import annotations

import numba
import numpy as np
import pytest
from worlds import current_side, random_world, randomize_history, slot_pairs, table

from demcal.dem.backends import cpu
from demcal.dem.containers import pack
from demcal.dem.kernels import sphere_forces
from demcal.dem.materials import Interaction
from demcal.dem.simulation import Simulation

OUTPUTS = ("s_force", "s_torque", "s_roll", "s_wall_force", "w_hist", "w_rhist")


@numba.njit
def _two_sided(args):
    # the GPU's pass, one sphere at a time as its threads run it
    sph, clu, nb, walls, worlds, prm, flags = args
    for i in range(sph.pos.shape[0]):
        sphere_forces(i, i + 1, sph, clu, nb, walls, worlds, prm, flags)


def _crowded(seed: int, rolling: str, gamma: float) -> Simulation:
    rng = np.random.default_rng(seed)
    mats = table(Interaction(0.4, 0.5, 0.1, surface_energy=gamma), Interaction(0.5, 0.6, 0.05))
    sim = Simulation([random_world(rng, mats, n_clumps=24),
                      random_world(rng, mats, n_clumps=15)], backend="cpu",
                     rolling_friction=rolling, dt_fraction=0.2, raise_on_unstable=False)
    sim.advance(10)
    randomize_history(sim, rng, 2e-6)
    return sim


def _forces(sim: Simulation, threads: int, one_sided: bool) -> dict:
    arrays = {k: v.copy() for k, v in sim.arrays.items()}
    arrays["world_active"][:] = 1  # as during a run
    st = pack(arrays, sim.params()._replace(threads=threads))
    nb = st.nb_a if current_side(sim) == "a" else st.nb_b
    args = (st.spheres, st.clumps, nb, st.walls, st.worlds, st.params, st.flags)
    if one_sided:
        # the blocks follow params.threads (here 1, 2 or 3 blocks of spheres), whatever
        # numba's thread count on this machine
        cpu.force_pass(*args)
        cpu.history_sync_pass(nb, st.params)
    else:
        _two_sided(args)
    side = current_side(sim)
    return {k: arrays[k] for k in (*OUTPUTS, f"nb_hist_{side}", f"nb_rhist_{side}")}


@pytest.mark.parametrize(("rolling", "gamma"), [("A", 0.0), ("A", 0.05), ("C", 0.05)])
def test_one_sided_pass_equals_the_two_sided_bitwise(rolling, gamma):
    sim = _crowded(3, rolling, gamma)
    pairs = {(min(i, j), max(i, j)) for i, _, j in slot_pairs(sim)}
    reference = _forces(sim, 1, one_sided=False)
    touching = np.count_nonzero(np.any(reference["s_force"] != 0.0, axis=1))
    assert len(pairs) > 50 and touching > 20  # a crowded world: many pairs, many contacts
    for threads in (1, 2, 3, 7):
        got = _forces(sim, threads, one_sided=True)
        for name, want in reference.items():
            assert np.array_equal(got[name], want), (name, threads)


def test_both_copies_of_a_history_agree_after_a_chunk():
    sim = _crowded(5, "C", 0.05)
    sim.advance(20)
    side = current_side(sim)
    hist = sim.arrays[f"nb_hist_{side}"]
    rhist = sim.arrays[f"nb_rhist_{side}"]
    slot = {(i, j): k for i, k, j in slot_pairs(sim)}
    in_contact = 0
    for (i, j), k in slot.items():
        if i < j:
            kj = slot[(j, i)]
            assert np.array_equal(hist[i, k], hist[j, kj]), (i, j)
            assert np.array_equal(rhist[i, k], rhist[j, kj]), (i, j)
            in_contact += bool(np.any(hist[i, k] != 0.0))
    assert in_contact > 10
