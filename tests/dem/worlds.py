"""Builders of small test worlds and engine-state snapshots for the DEM validation tests."""

from __future__ import annotations

import math

import numpy as np

from demcal.dem.materials import Interaction, Material, MaterialTable
from demcal.dem.shapes import sphere_template, stalk_template, template_from_spheres
from demcal.dem.simulation import Simulation
from demcal.dem.state import ClumpGroup, World, random_quaternions
from demcal.dem.walls import PlaneWall, TubeWall

PARTICLE = Material("p", density=1000.0, shear_modulus=1.0e7, poisson=0.3)
STEEL = Material("wall", density=7865.0, shear_modulus=7.9e10, poisson=0.3)


def table(pp: Interaction, pw: Interaction | None = None, particle: Material = PARTICLE,
          wall: Material = STEEL) -> MaterialTable:
    """One particle material and one wall material."""
    return MaterialTable([particle, wall], {("p", "p"): pp, ("p", "wall"): pw or pp})


def floor(z: float = 0.0, **kw) -> PlaneWall:
    return PlaneWall(origin=np.array([0.0, 0.0, z]), normal=np.array([0.0, 0.0, 1.0]),
                     u_axis=np.array([1.0, 0.0, 0.0]), **kw)


def spheres_world(mats: MaterialTable, radius: float, positions, velocities=None,
                  angular_velocities=None, walls=(), gravity=(0.0, 0.0, 0.0), **kw) -> World:
    pos = np.asarray(positions, dtype=float).reshape(-1, 3)
    group = ClumpGroup(sphere_template(radius), "p", len(pos), positions=pos,
                       velocities=velocities, angular_velocities=angular_velocities)
    return World(mats, [group], walls=list(walls), gravity=gravity, **kw)


def random_world(rng: np.random.Generator, mats: MaterialTable, n_clumps: int = 12,
                 box: float = 0.012, materials=("p", "p", "p")) -> World:
    """Spheres, 7-sphere stalks and an irregular 3-sphere clump, randomly sized, oriented
    and moving, crowded in a box with a floor rectangle, an inclined infinite plane and a
    tube, so that sphere-sphere and every kind of wall contact occurs."""
    odd = template_from_spheres([[0.0, 0.0, 0.0], [1.6e-3, 0.4e-3, 0.0], [0.3e-3, 1.5e-3, 0.9e-3]],
                                [1.0e-3, 0.8e-3, 0.7e-3])
    templates = [sphere_template(1.2e-3), stalk_template(), odd]
    groups = []
    per = n_clumps // len(templates)
    for t, mat in zip(templates, materials, strict=True):
        pos = rng.uniform([-box / 2, -box / 2, 0.0], [box / 2, box / 2, box], size=(per, 3))
        groups.append(ClumpGroup(
            t, mat, per, scales=rng.uniform(0.75, 1.25, per), positions=pos,
            orientations=random_quaternions(per, rng),
            velocities=rng.normal(0.0, 0.3, (per, 3)),
            angular_velocities=rng.normal(0.0, 60.0, (per, 3))))
    walls = [
        PlaneWall(origin=np.array([0.0, 0.0, 0.0005]), normal=np.array([0.0, 0.0, 1.0]),
                  half_size=(0.004, 0.005), u_axis=np.array([1.0, 0.0, 0.0]),
                  velocity=np.array([0.01, 0.0, 0.02]), name="plate"),
        PlaneWall(origin=np.array([0.004, 0.0, 0.0]), normal=np.array([-1.0, 0.2, 0.3]),
                  u_axis=np.array([0.0, 1.0, 0.0]), name="slope"),
        TubeWall(base=np.array([-0.001, 0.0005, 0.002]), axis=np.array([0.1, 0.0, 1.0]),
                 inner_radius=0.004, thickness=0.001, length=0.006,
                 velocity=np.array([0.0, 0.0, 0.05]), name="tube"),
    ]
    return World(mats, groups, walls=walls, domain_lo=(-0.05, -0.05, -0.05),
                 domain_hi=(0.05, 0.05, 0.05), gravity=(0.0, 0.0, -9.81))


def current_side(sim: Simulation) -> str:
    """Which neighbour buffer holds the current list ("a" or "b")."""
    return sim.runner.neighbor_side


def slot_pairs(sim: Simulation):
    """(sphere i, slot k, neighbour j) of every stored neighbour slot of the current list."""
    side = current_side(sim)
    sim.runner.pull(f"nb_count_{side}", f"nb_index_{side}")
    count = sim.arrays[f"nb_count_{side}"]
    index = sim.arrays[f"nb_index_{side}"]
    for i in range(len(count)):
        for k in range(min(count[i], index.shape[1])):
            yield i, k, int(index[i, k])


def wall_descriptions(sim: Simulation) -> list[list[dict]]:
    """Walls of each world for :mod:`naive`, at their current origins."""
    sim.runner.pull("wall_origin", "wall_vel", "wall_omega")
    out = []
    for w, world in enumerate(sim.worlds):
        walls = []
        for k, wall in enumerate(world.walls):
            origin = sim.arrays["wall_origin"][w, k].copy()
            vel = sim.arrays["wall_vel"][w, k].copy()
            spin = sim.arrays["wall_omega"][w, k].copy()
            if isinstance(wall, PlaneWall):
                n = np.asarray(wall.normal, float) / np.linalg.norm(wall.normal)
                u = np.asarray(wall.u_axis, float)
                u = u - np.dot(u, n) * n
                u /= np.linalg.norm(u)
                walls.append(dict(type="plane", origin=origin, normal=n, u=u, v=np.cross(n, u),
                                  hu=float(wall.half_size[0]), hv=float(wall.half_size[1]),
                                  velocity=vel, omega=spin, material=wall.material))
            else:
                ax = np.asarray(wall.axis, float) / np.linalg.norm(wall.axis)
                walls.append(dict(type="tube", origin=origin, axis=ax, r_in=wall.inner_radius,
                                  r_out=wall.inner_radius + wall.thickness, length=wall.length,
                                  velocity=vel, omega=spin, material=wall.material))
        out.append(walls)
    return out


def randomize_history(sim: Simulation, rng: np.random.Generator, scale: float) -> None:
    """Give every stored contact slot a random tangential (and rolling) history, the same
    on both sides of a pair, as the engine keeps them."""
    side = current_side(sim)
    names = [f"nb_hist_{side}", f"nb_rhist_{side}", "w_hist", "w_rhist"]
    sim.runner.pull(*names)
    a = sim.arrays
    pair_vals: dict = {}
    rolling_c = a[f"nb_rhist_{side}"].shape[0] == sim.n_spheres
    for i, k, j in slot_pairs(sim):
        key = (min(i, j), max(i, j))
        if key not in pair_vals:
            pair_vals[key] = (rng.normal(0, scale, 3), rng.normal(0, 1e-6, 3))
        a[f"nb_hist_{side}"][i, k] = pair_vals[key][0]
        if rolling_c:
            a[f"nb_rhist_{side}"][i, k] = pair_vals[key][1]
    # wall slots: those the engine tracks, the candidate walls of the last neighbour build
    # (the others stay zero between builds); the reference then checks that no wall in
    # contact is missing from the candidates
    sim.runner.pull("s_wall_near")
    bits = (a["s_wall_near"][:, None] >> np.arange(sim.max_walls)) & 1
    near = bits.astype(bool)
    n_near = int(near.sum())
    a["w_hist"][near] = rng.normal(0, scale, (n_near, 3))
    if rolling_c:
        a["w_rhist"][near] = rng.normal(0, 1e-6, (n_near, 3))
    sim.runner.push(*names)


def snapshot(sim: Simulation) -> dict:
    """Everything :func:`naive.contact_forces` needs, copied from the engine's state."""
    side = current_side(sim)
    names = ["s_pos", "c_pos", "c_veval", "c_omega", "c_state", "w_hist", "w_rhist",
             f"nb_hist_{side}", f"nb_rhist_{side}"]
    sim.runner.pull(*names)
    a = sim.arrays
    st = {k: np.array(a[k]) for k in ("s_pos", "s_radius", "s_clump", "c_pos", "c_veval",
                                      "c_omega", "c_mass", "c_world", "c_state", "world_dt",
                                      "w_hist")}
    st["w_rhist"] = (np.array(a["w_rhist"]) if a["w_rhist"].shape[0] == sim.n_spheres
                     else np.zeros_like(st["w_hist"]))
    names_by_world = [w.materials.names for w in sim.worlds]
    st["s_material_name"] = [names_by_world[a["c_world"][c]][m]
                             for c, m in zip(a["s_clump"], a["s_material"], strict=True)]
    hist, rhist = {}, {}
    rolling_c = a[f"nb_rhist_{side}"].shape[0] == sim.n_spheres
    for i, k, j in slot_pairs(sim):
        key = (min(i, j), max(i, j))
        hist[key] = np.array(a[f"nb_hist_{side}"][i, k])
        if rolling_c:
            rhist[key] = np.array(a[f"nb_rhist_{side}"][i, k])
    st["hist"] = hist
    st["rhist"] = rhist
    st["walls"] = wall_descriptions(sim)
    return st


def engine_outputs(sim: Simulation) -> dict:
    """The engine's forces and new histories after a step (per sphere, per slot pair)."""
    side = current_side(sim)
    names = ["s_force", "s_torque", "s_roll", "s_wall_force", "w_hist", "w_rhist",
             f"nb_hist_{side}", f"nb_rhist_{side}"]
    sim.runner.pull(*names)
    a = sim.arrays
    rolling_c = a[f"nb_rhist_{side}"].shape[0] == sim.n_spheres
    hist: dict = {}
    rhist: dict = {}
    for i, k, j in slot_pairs(sim):
        key = (min(i, j), max(i, j))
        hist.setdefault(key, []).append(np.array(a[f"nb_hist_{side}"][i, k]))
        if rolling_c:
            rhist.setdefault(key, []).append(np.array(a[f"nb_rhist_{side}"][i, k]))
    return dict(force=np.array(a["s_force"]), torque=np.array(a["s_torque"]),
                roll=np.array(a["s_roll"]), wall_force=np.array(a["s_wall_force"]),
                w_hist=np.array(a["w_hist"]), w_rhist=np.array(a["w_rhist"]), hist=hist,
                rhist=rhist, rolling_c=rolling_c)


def hertz_peak_and_duration(v0: float, rstar: float, estar: float, mstar: float):
    """Peak overlap (m) and contact duration (s) of an elastic Hertz impact at speed v0.

    ``delta_max = (15 m* v0^2 / (16 E* sqrt(R*)))^(2/5)`` and
    ``t_c = 2 (delta_max / v0) integral_0^1 (1 - x^(5/2))^(-1/2) dx``, the integral being
    ``sqrt(pi) Gamma(7/5) / Gamma(9/10)``.
    """
    delta_max = (15.0 * mstar * v0**2 / (16.0 * estar * math.sqrt(rstar))) ** 0.4
    integral = math.sqrt(math.pi) * math.gamma(1.4) / math.gamma(0.9)
    return delta_max, 2.0 * delta_max / v0 * integral


def estar_of(a: Material, b: Material) -> float:
    ea = 2 * a.shear_modulus * (1 + a.poisson)
    eb = 2 * b.shear_modulus * (1 + b.poisson)
    return 1.0 / ((1 - a.poisson**2) / ea + (1 - b.poisson**2) / eb)


def rayleigh(radius: float, m: Material) -> float:
    return math.pi * radius * math.sqrt(m.density / m.shear_modulus) / (0.1631 * m.poisson
                                                                        + 0.8766)
