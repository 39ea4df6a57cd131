"""Health checks: a blown-up world is stopped with an error naming world, time and cause."""

from __future__ import annotations

import numpy as np
import pytest
from worlds import floor, spheres_world, table

from demcal.dem.materials import Interaction
from demcal.dem.simulation import Simulation
from demcal.errors import SimulationUnstable

R = 2e-3


def _drop(time_step=None):
    """A sphere hitting the floor at 2 m/s, with the given (possibly far too large) step."""
    return spheres_world(table(Interaction(0.5, 0.5)), R, [[0, 0, 1.2 * R]],
                         velocities=np.array([[0, 0, -2.0]]), walls=[floor()],
                         gravity=(0, 0, -9.81), time_step=time_step)


def test_a_too_large_step_raises_naming_world_time_and_cause():
    sim = Simulation([_drop(), _drop(1e-3)])
    with pytest.raises(SimulationUnstable) as err:
        sim.run(0.01)
    msg = str(err.value)
    assert msg.startswith("world 1:") and "t=" in msg and "dt_fraction" in msg
    assert err.value.world == 1
    assert 0 < err.value.time_s <= 0.01 + 1e-12


def test_a_failing_world_is_stopped_and_the_others_go_on():
    alone = Simulation([_drop()])
    alone.run(0.01)
    sim = Simulation([_drop(), _drop(1e-3)], raise_on_unstable=False)
    sim.run(0.01)
    assert sim.world_errors[0] is None
    assert sim.world_errors[1] is not None and "world 1" in sim.world_errors[1]
    assert not sim.is_enabled(1)
    # the healthy world is unaffected (bitwise) by its failing neighbour
    np.testing.assert_array_equal(sim.clump_positions(0), alone.clump_positions(0))
    t1 = sim.time[1]
    sim.run(0.005)  # the stopped world stays where it failed
    assert sim.time[1] == t1
