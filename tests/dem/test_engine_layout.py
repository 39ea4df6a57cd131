"""The engine's layout: every array in one state container, backends behind one protocol."""

from __future__ import annotations

import inspect

import numpy as np
import pytest
from test_dem_determinism import bed_world

from demcal.dem.backends import Backend
from demcal.dem.containers import KEYS, EngineState, Neighbors, neighbor_keys, pack
from demcal.dem.simulation import Simulation


@pytest.mark.parametrize("rolling", ["A", "C"])
def test_every_engine_array_is_in_exactly_one_container(rolling):
    sim = Simulation([bed_world(1, n=3)], rolling_friction=rolling)
    named = [k for keys in KEYS.values() for k in keys]
    named += list(neighbor_keys("a")) + list(neighbor_keys("b"))
    assert sorted(named) == sorted(sim.arrays), "add the array to a container's KEYS"
    for cls, keys in KEYS.items():
        assert len(keys) == len(cls._fields), cls.__name__
    st = pack(sim.arrays, sim.params())
    assert isinstance(st, EngineState)
    assert st.spheres.pos is sim.arrays["s_pos"] and st.walls.near is sim.arrays["s_wall_near"]
    assert isinstance(st.nb_b, Neighbors) and st.nb_b.hist is sim.arrays["nb_hist_b"]
    assert st.params.carry_rolling == (rolling == "C")


def test_the_cpu_backend_implements_the_protocol_and_owns_parity_and_growth():
    sim = Simulation([bed_world(1, n=6)])
    for name, member in inspect.getmembers(Backend):
        if not name.startswith("_") and callable(member):
            assert callable(getattr(sim.runner, name)), name
    assert sim.runner.neighbor_side == "a" and sim.parity == 0
    sim.advance(1)  # the first build fills buffer b, which becomes the current one
    assert sim.runner.neighbor_side == "b" and sim.parity == 1
    cap = sim.arrays["nb_index_a"].shape[1]
    sim.runner.grow(neighbors=2 * cap)  # the scratch buffer only
    assert sim.arrays["nb_index_a"].shape[1] > 2 * cap
    assert sim.arrays["nb_index_b"].shape[1] == cap
    state = sim.state_dict()
    sim.runner.push_all(parity=0)
    assert sim.parity == 0
    sim.load_state(state)
    assert sim.parity == 1
    assert np.array_equal(sim.arrays["s_pos"], state["s_pos"])
