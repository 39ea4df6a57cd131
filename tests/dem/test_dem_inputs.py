"""Invalid inputs are refused with InputError naming the field (never a traceback or NaN)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from worlds import PARTICLE, STEEL, floor, table

from demcal.dem.materials import Interaction, Material, MaterialTable
from demcal.dem.shapes import sphere_template
from demcal.dem.simulation import Simulation
from demcal.dem.state import ClumpGroup, World
from demcal.dem.walls import PlaneWall, TubeWall
from demcal.errors import InputError

GOOD = Interaction(0.5, 0.5, 0.1, 0.0)


def _world(**kw) -> World:
    group = kw.pop("group", None) or ClumpGroup(sphere_template(1e-3), "p", 2,
                                                positions=np.array([[0, 0, 0.01],
                                                                    [0, 0, 0.02]]))
    args = dict(materials=table(GOOD), groups=[group], walls=[floor()])
    args.update(kw)
    return World(**args)


def _sim(**kw):
    return Simulation([_world()], **kw)


CASES = [
    ("density", lambda: Material("p", -1.0, 1e7, 0.3)),
    ("shear_modulus", lambda: Material("p", 1000.0, 0.0, 0.3)),
    ("poisson", lambda: Material("p", 1000.0, 1e7, 0.5)),
    ("poisson", lambda: Material("p", 1000.0, 1e7, math.nan)),
    ("restitution", lambda: table(Interaction(0.0, 0.5))),
    ("restitution", lambda: table(Interaction(1.2, 0.5))),
    ("static_friction", lambda: table(Interaction(0.5, -0.1))),
    ("rolling_friction", lambda: table(Interaction(0.5, 0.5, -1.0))),
    ("surface_energy", lambda: table(Interaction(0.5, 0.5, 0.1, math.inf))),
    ("unknown material", lambda: MaterialTable([PARTICLE], {("p", "steel"): GOOD})),
    ("unique", lambda: MaterialTable([PARTICLE, PARTICLE], {})),
    ("no interaction", lambda: Simulation([World(MaterialTable([PARTICLE, STEEL],
                                                               {("p", "p"): GOOD}),
                                                 _world().groups, walls=[floor()])])),
    ("unknown material", lambda: Simulation([_world(group=ClumpGroup(
        sphere_template(1e-3), "nope", 1, positions=np.zeros((1, 3))))])),
    ("scales", lambda: Simulation([_world(group=ClumpGroup(
        sphere_template(1e-3), "p", 2, scales=np.array([1.0, -1.0]),
        positions=np.zeros((2, 3))))])),
    ("positions", lambda: Simulation([_world(group=ClumpGroup(
        sphere_template(1e-3), "p", 2, positions=np.zeros((3, 3))))])),
    ("velocities", lambda: Simulation([_world(group=ClumpGroup(
        sphere_template(1e-3), "p", 1, positions=np.zeros((1, 3)),
        velocities=np.array([[np.nan, 0, 0]])))])),
    ("count", lambda: Simulation([_world(group=ClumpGroup(sphere_template(1e-3), "p", -1))])),
    ("time_step", lambda: Simulation([_world(time_step=-1e-6)])),
    ("domain", lambda: Simulation([_world(domain_lo=(0, 0, 0), domain_hi=(1, -1, 1))])),
    ("domain", lambda: Simulation([_world(domain_lo=(0, 0), domain_hi=(1, 1, 1))])),
    ("gravity", lambda: Simulation([_world(gravity=(0.0, math.nan, -9.81))])),
    ("gravity", lambda: Simulation([_world(gravity=(0.0, -9.81))])),
    ("normal", lambda: Simulation([_world(walls=[PlaneWall(np.zeros(3), np.zeros(3))])])),
    ("half_size", lambda: Simulation([_world(walls=[PlaneWall(
        np.zeros(3), np.array([0, 0, 1.0]), half_size=(0.0, 1.0))])])),
    ("inner_radius", lambda: Simulation([_world(walls=[TubeWall(
        np.zeros(3), np.array([0, 0, 1.0]), -0.01, 0.001, 0.1)])])),
    ("velocity", lambda: Simulation([_world(walls=[PlaneWall(
        np.zeros(3), np.array([0, 0, 1.0]), velocity=np.array([0.0, 1.0]))])])),
    ("dt_fraction", lambda: _sim(dt_fraction=0.0)),
    ("dt_fraction", lambda: _sim(dt_fraction=1.5)),
    ("rolling_friction", lambda: _sim(rolling_friction="B")),
    ("backend", lambda: _sim(backend="gpu")),
    ("skin", lambda: _sim(skin=-1.0)),
    ("at most 64", lambda: Simulation([_world(walls=[floor(z=-0.001 * k) for k in range(65)])])),
    ("at least one world", lambda: Simulation([])),
    ("no particles", lambda: Simulation([_world(group=ClumpGroup(
        sphere_template(1e-3), "p", 0))])),
]


@pytest.mark.parametrize(("field", "make"), CASES, ids=[f"{i}-{c[0]}" for i, c in
                                                        enumerate(CASES)])
def test_invalid_construction_is_refused_naming_the_field(field, make):
    with pytest.raises(InputError, match=field):
        make()


@pytest.mark.parametrize(("field", "call"), [
    ("n_steps", lambda s: s.advance(-1)),
    ("duration", lambda s: s.run(math.nan)),
    ("duration", lambda s: s.run(-1.0)),
    ("time step", lambda s: s.set_time_step(0, 0.0)),
    ("world", lambda s: s.set_time_step(3, 1e-6)),
    ("world", lambda s: s.clump_state(-1)),
    ("clump indices", lambda s: s.place_clumps(0, [5], np.zeros((1, 3)))),
    ("positions", lambda s: s.place_clumps(0, [0], np.zeros((2, 3)))),
    ("orientations", lambda s: s.place_clumps(0, [0], np.zeros((1, 3)),
                                              orientations=np.zeros((1, 4)))),
    ("clump indices", lambda s: s.remove_clumps(0, [7])),
    ("wall", lambda s: s.set_wall_velocity(0, 4, [0, 0, 1])),
    ("velocity", lambda s: s.set_wall_velocity(0, 0, [0, math.inf, 1])),
])
def test_invalid_calls_are_refused_naming_the_field(field, call):
    sim = _sim()
    with pytest.raises(InputError, match=field):
        call(sim)
    sim.advance(2)  # the simulation is still usable
    assert np.all(np.isfinite(sim.clump_positions(0)))
