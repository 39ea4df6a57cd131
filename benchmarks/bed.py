"""The benchmark bed: a woodpile of 7-sphere corn-stalk clumps in a steel box, settled.

Shared by ``engine.py`` (demcal's throughput) and ``lammps_bed.py`` (the same bed in LAMMPS):
the materials, the woodpile layout, the world and the settling run. See ``engine.py`` for the
description of the bed.
"""

from __future__ import annotations

import math
import time

import numpy as np

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
