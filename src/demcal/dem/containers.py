"""The engine's state as typed containers: what the launchers and kernel bodies take.

The host keeps every array in :attr:`Simulation.arrays <demcal.dem.simulation.Simulation>`
(a dict: one name per array, as snapshots store them). A backend packs them into the
named tuples below with :func:`pack` (the one place where names meet fields), and the
compiled code takes those, not dozens of arrays: numba compiles a named tuple of arrays into
a struct whose fields are read like attributes (``sph.pos[i, 0]``). A container is only a
view of the dict's arrays: after an array is replaced (growth, a snapshot), pack again.

Containers and their arrays (``n_s`` spheres, ``n_c`` clumps, ``n_w`` worlds, ``n_k`` walls
per world, ``cap`` neighbour slots, SI units):

- :class:`Spheres`: per sphere;
- :class:`Clumps`: per clump (rigid body);
- :class:`Neighbors`: one neighbour list; the engine holds two of the same shape, the current
  one and the one the next build fills (they swap at each build);
- :class:`Walls`: per wall of each world, and per sphere x wall slot (contact history);
- :class:`Grid`: the hash grid of the neighbour search;
- :class:`Worlds`: per world (clock, gravity, domain, pair parameters);
- :class:`Flags`: what the compiled code reports to the host;
- :class:`Params`: the scalars of a run.

No field may be named like a method of ``tuple`` (``count``, ``index``): numba-cuda's typing
resolves ``nb.index`` to the tuple's method, so the CUDA kernels do not compile, while the CPU
and the CUDA simulator run. Array names in :data:`KEYS` are free of that rule.

Adding an array: see ``docs/engine.md`` (a field here, its name in :data:`KEYS`, its
allocation in :meth:`Simulation._build <demcal.dem.simulation.Simulation>`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = [
    "KEYS",
    "Clumps",
    "EngineState",
    "Flags",
    "Grid",
    "Neighbors",
    "Params",
    "Spheres",
    "Walls",
    "Worlds",
    "alloc_neighbors",
    "neighbor_keys",
    "pack",
]


class Spheres(NamedTuple):
    """Per sphere, ``(n_s, ...)``."""

    pos: np.ndarray  #: (n_s, 3) centre, m
    ref: np.ndarray  #: (n_s, 3) centre at the last neighbour build, m
    radius: np.ndarray  #: (n_s,) m
    clump: np.ndarray  #: (n_s,) int32 index of the owning clump
    material: np.ndarray  #: (n_s,) int32 material index in its world's table
    offset: np.ndarray  #: (n_s, 3) centre in the clump's principal frame, m
    cellkey: np.ndarray  #: (n_s,) int64 packed hash-grid cell (-1: not binned)
    force: np.ndarray  #: (n_s, 3) contact force, N
    torque: np.ndarray  #: (n_s, 3) contact + type-C rolling torque about the clump's COM, N m
    roll: np.ndarray  #: (n_s, 3) type-A rolling torque, N m


class Clumps(NamedTuple):
    """Per clump (rigid body), ``(n_c, ...)``."""

    pos: np.ndarray  #: (n_c, 3) centre of mass, m
    quat: np.ndarray  #: (n_c, 4) unit quaternion (w, x, y, z), body -> space
    vel: np.ndarray  #: (n_c, 3) velocity at the half step, m/s
    veval: np.ndarray  #: (n_c, 3) on-step velocity estimate for the forces, m/s
    angmom: np.ndarray  #: (n_c, 3) angular momentum (space frame), kg m^2/s
    omega: np.ndarray  #: (n_c, 3) angular velocity (space frame), rad/s
    mass: np.ndarray  #: (n_c,) kg
    inertia: np.ndarray  #: (n_c, 3) principal moments, kg m^2
    world: np.ndarray  #: (n_c,) int32 world index
    state: np.ndarray  #: (n_c,) int32 INACTIVE / ACTIVE / REMOVED
    first: np.ndarray  #: (n_c,) int32 index of its first sphere
    n_spheres: np.ndarray  #: (n_c,) int32 number of its spheres
    scratch: np.ndarray  #: (n_c, 6) within a step: body-frame angular momentum, torque (N m)


class Neighbors(NamedTuple):
    """One neighbour list (slots sorted by neighbour index)."""

    found: np.ndarray  #: (n_s,) int32 neighbours found (may exceed ``cap``: grow)
    partner: np.ndarray  #: (n_s, cap) int32 neighbour sphere of each slot
    hist: np.ndarray  #: (n_s, cap, 3) tangential spring of each slot, m
    rhist: np.ndarray  #: (n_s, cap, 3) type-C rolling spring, N m ((1, 1, 3) unless type C)


class Walls(NamedTuple):
    """Per wall ``(n_w, n_k, ...)`` and per sphere x wall slot ``(n_s, n_k, ...)``."""

    type: np.ndarray  #: (n_w, n_k) int32 WALL_NONE / WALL_PLANE / WALL_TUBE
    origin: np.ndarray  #: (n_w, n_k, 3) current origin, m
    geom: np.ndarray  #: (n_w, n_k, GEOM_SIZE) shape (see demcal.dem.walls)
    vel: np.ndarray  #: (n_w, n_k, 3) translation velocity, m/s
    omega: np.ndarray  #: (n_w, n_k, 3) spin about the origin, along the axis/normal, rad/s
    material: np.ndarray  #: (n_w, n_k) int32 material index
    ref: np.ndarray  #: (n_w, n_k, 3) origin at the last neighbour build, m
    near: np.ndarray  #: (n_s,) int64 candidate walls of each sphere (bit k: wall k)
    hist: np.ndarray  #: (n_s, n_k, 3) tangential spring of each sphere-wall slot, m
    rhist: np.ndarray  #: (n_s, n_k, 3) type-C rolling spring, N m ((1, 1, 3) unless type C)
    force: np.ndarray  #: (n_s, n_k, 3) force of each sphere on each wall, N


class Grid(NamedTuple):
    """The hash grid of the neighbour search."""

    lo: np.ndarray  #: (n_w, 3) lower corner of each world's grid, m
    bucket_count: np.ndarray  #: (n_buckets,) int32 spheres in each bucket
    bucket_members: np.ndarray  #: (n_buckets, bucket_cap) int32 sphere indices


class Worlds(NamedTuple):
    """Per world, ``(n_w, ...)``."""

    dt: np.ndarray  #: (n_w,) time step, s
    gravity: np.ndarray  #: (n_w, 3) m/s^2
    active: np.ndarray  #: (n_w,) int32 1: stepped in this run
    lo: np.ndarray  #: (n_w, 3) domain lower corner, m (clumps leaving it are removed)
    hi: np.ndarray  #: (n_w, 3) domain upper corner, m
    time: np.ndarray  #: (n_w,) simulated time, s
    steps: np.ndarray  #: (n_w,) int64 steps taken
    pair_params: np.ndarray  #: (n_w, n_mat, n_mat, N_PAIR_FIELDS) see demcal.dem.contact


class Flags(NamedTuple):
    """What the compiled code reports to the host."""

    rebuild: np.ndarray  #: (1,) int32 a neighbour build is due
    nan: np.ndarray  #: (n_w,) int32 a non-finite state appeared
    overlap: np.ndarray  #: (n_w,) int32 an overlap exceeded the limit
    stats: np.ndarray  #: (4,) int64 needed slots, fullest bucket, builds, steps (CUDA)


class Params(NamedTuple):
    """The scalars of a run (fixed for a simulation, except on a change of _config)."""

    rolling_model: int  #: ROLLING_NONE / ROLLING_A / ROLLING_C (demcal.dem.contact)
    carry_rolling: bool  #: type C: rolling histories are kept and carried over
    contact_margin: float  #: largest JKR break-off gap, m
    max_overlap_fraction: float  #: overlap / smaller radius that flags a world
    extra: float  #: neighbour cut-off beyond r_i + r_j: skin + contact margin, m
    wall_extra: float  #: wall-candidate reach beyond r_i, m (inf: every wall)
    half_skin: float  #: a sphere or wall moving this far since the build raises one, m
    inv_cell: float  #: 1 / cell size, 1/m
    mask: int  #: buckets - 1 (a power of two minus one)
    threads: int = 1  #: CPU threads of the run (sets the kernel bodies' block size)


class EngineState(NamedTuple):
    """Every container of a simulation (what a launcher of a chunk of steps takes)."""

    spheres: Spheres
    clumps: Clumps
    nb_a: Neighbors
    nb_b: Neighbors
    walls: Walls
    grid: Grid
    worlds: Worlds
    flags: Flags
    params: Params


#: the array names (keys of ``Simulation.arrays``) of each container's fields, in order
KEYS: dict[type, tuple[str, ...]] = {
    Spheres: ("s_pos", "s_ref", "s_radius", "s_clump", "s_material", "s_offset", "s_cellkey",
              "s_force", "s_torque", "s_roll"),
    Clumps: ("c_pos", "c_quat", "c_vel", "c_veval", "c_angmom", "c_omega", "c_mass",
             "c_inertia", "c_world", "c_state", "c_first", "c_count", "c_scratch"),
    Walls: ("wall_type", "wall_origin", "wall_geom", "wall_vel", "wall_omega", "wall_material",
            "wall_ref",
            "s_wall_near", "w_hist", "w_rhist", "s_wall_force"),
    Grid: ("grid_lo", "bucket_count", "bucket_members"),
    Worlds: ("world_dt", "world_gravity", "world_active", "world_lo", "world_hi", "world_time",
             "world_steps", "pair_params"),
    Flags: ("flag_rebuild", "flag_nan", "flag_overlap", "stats"),
}


#: the array-name stems of :class:`Neighbors`' fields, in order (``nb_<stem>_<side>``)
NEIGHBOR_STEMS = ("count", "index", "hist", "rhist")


def neighbor_keys(side: str) -> tuple[str, ...]:
    """Array names of neighbour buffer ``side`` ("a" or "b"), in :class:`Neighbors` order."""
    return tuple(f"nb_{stem}_{side}" for stem in NEIGHBOR_STEMS)


def _take(cls, arrays):
    return cls(*(arrays[k] for k in KEYS[cls]))


def pack(arrays, params: Params) -> EngineState:
    """The containers of a simulation's arrays (host numpy arrays or device copies).

    Parameters
    ----------
    arrays : mapping of str to array
        ``Simulation.arrays`` or a backend's device mirror of it (same names).
    params : Params
        The run's scalars (:meth:`Simulation.params <demcal.dem.simulation.Simulation>`).
    """
    return EngineState(
        _take(Spheres, arrays), _take(Clumps, arrays),
        Neighbors(*(arrays[k] for k in neighbor_keys("a"))),
        Neighbors(*(arrays[k] for k in neighbor_keys("b"))),
        _take(Walls, arrays), _take(Grid, arrays), _take(Worlds, arrays),
        _take(Flags, arrays), params)


def alloc_neighbors(arrays: dict, side: str, n_spheres: int, cap: int,
                    rolling_c: bool) -> None:
    """(Re)allocate neighbour buffer ``side`` with ``cap`` empty slots per sphere.

    The rolling history is a (1, 1, 3) placeholder unless the rolling model is type C.
    """
    count, index, hist, rhist = neighbor_keys(side)
    arrays[count] = np.zeros(n_spheres, dtype=np.int32)
    arrays[index] = np.full((n_spheres, cap), -1, dtype=np.int32)
    arrays[hist] = np.zeros((n_spheres, cap, 3))
    arrays[rhist] = np.zeros((n_spheres, cap, 3) if rolling_c else (1, 1, 3))


def alloc_buckets(arrays: dict, bucket_cap: int) -> None:
    """(Re)allocate the hash grid's member slots with ``bucket_cap`` slots per bucket."""
    n_buckets = len(arrays["bucket_count"])
    arrays["bucket_members"] = np.zeros((n_buckets, bucket_cap), dtype=np.int32)
