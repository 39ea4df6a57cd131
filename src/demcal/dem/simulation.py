"""The :class:`Simulation`: batched worlds of multi-sphere clumps, stepped on CPU or GPU.

Typical use::

    sim = Simulation([world_a, world_b], backend="cpu")
    sim.run(0.5)                       # every enabled world advances 0.5 s
    pos = sim.clump_positions(0)       # (n, 3) m, active clumps of world 0

The host keeps the arrays (structure of arrays, SI units) in :attr:`Simulation.arrays`; the
backend runs chunks of steps on them (on the GPU it mirrors them on the device and copies back
what a query needs). Health checks run after every chunk: a world with NaN, an excessive
overlap or a runaway speed is stopped and reported (:class:`~demcal.errors.SimulationUnstable`
names the world, the time and the likely cause).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from demcal.dem import _config
from demcal.dem.backends import Backend, make_backend, resolve_backend
from demcal.dem.contact import N_PAIR_FIELDS, rayleigh_time_step
from demcal.dem.containers import Params, alloc_neighbors
from demcal.dem.kernels import (
    ACTIVE,
    INACTIVE,
    MAX_WALLS,
    REMOVED,
    ROLLING_A,
    ROLLING_C,
    ROLLING_NONE,
)
from demcal.dem.state import World, rotate, rotate_inverse
from demcal.dem.walls import check_spin_axis, contact_point, pack_walls
from demcal.errors import InputError, SimulationUnstable

__all__ = ["ROLLING_MODELS", "Simulation"]

ROLLING_MODELS = {"none": ROLLING_NONE, "A": ROLLING_A, "C": ROLLING_C}

#: arrays that change during a run (what a snapshot must hold to restart)
DYNAMIC_ARRAYS = (
    "s_pos", "s_ref", "s_cellkey", "c_pos", "c_quat", "c_vel", "c_veval", "c_angmom",
    "c_omega", "c_state",
    "nb_count_a", "nb_index_a", "nb_hist_a", "nb_rhist_a", "nb_count_b", "nb_index_b",
    "nb_hist_b", "nb_rhist_b", "w_hist", "w_rhist", "wall_origin", "wall_vel", "world_time",
    "world_steps", "world_active", "flag_rebuild", "flag_nan", "flag_overlap", "stats",
    "s_wall_near", "wall_ref", "wall_omega",
)
#: dynamic arrays a snapshot of an older demcal may lack: rebuilt by a neighbour build
REBUILT_ARRAYS = ("s_wall_near", "wall_ref")
#: dynamic arrays a snapshot of an older demcal may lack: kept as built from the walls'
#: description (before walls could spin, none did)
DESCRIBED_ARRAYS = ("wall_omega",)


def _pow2_at_least(n: float) -> int:
    return 1 << max(4, math.ceil(math.log2(max(n, 16))))


class Simulation:
    """Many independent DEM worlds stepped together.

    Parameters
    ----------
    worlds : sequence of World
        The simulations to run (each with its own materials, walls and particles).
    backend : {"auto", "cpu", "cuda"}
        Where to run; "auto" picks the GPU when numba finds one.
    dt_fraction : float
        Time step as a fraction of the Rayleigh time step of each world's smallest sphere
        (ignored for worlds with an explicit ``time_step``); in (0, 1].
    rolling_friction : {"A", "C", "none"}
        Rolling friction model: "A" constant directional torque (EDEM's standard), "C" EPSD
        spring (history-dependent), "none".
    skin : float, optional
        Verlet skin, m; default ``_config.SKIN_FRACTION`` x the largest sphere radius.
    raise_on_unstable : bool
        If True (default) a numerical failure raises; if False the failing world is stopped,
        its reason kept in :attr:`world_errors`, and the others go on.
    """

    def __init__(self, worlds: Sequence[World], *, backend: str = "cpu",
                 dt_fraction: float = _config.DT_FRACTION, rolling_friction: str = "A",
                 skin: float | None = None, raise_on_unstable: bool = True):
        if not worlds:
            raise InputError("a simulation needs at least one world")
        if not (0.0 < dt_fraction <= 1.0):
            raise InputError(f"dt_fraction must be in (0, 1]; got {dt_fraction}")
        if rolling_friction not in ROLLING_MODELS:
            raise InputError(f"rolling_friction must be one of {', '.join(ROLLING_MODELS)}; "
                             f"got {rolling_friction!r}")
        self.backend = resolve_backend(backend)
        self.worlds = list(worlds)
        self.dt_fraction = float(dt_fraction)
        self.rolling_model = ROLLING_MODELS[rolling_friction]
        self.raise_on_unstable = raise_on_unstable
        self.world_errors: list[str | None] = [None] * len(self.worlds)
        self._enabled = np.ones(len(self.worlds), dtype=bool)
        self.arrays: dict[str, np.ndarray] = {}
        self._build(skin)
        #: the backend that runs the steps and holds the device copies (push/pull)
        self.runner: Backend = make_backend(self)

    # ------------------------------------------------------------------ building
    def _build(self, skin: float | None) -> None:
        n_worlds = len(self.worlds)
        max_walls = max(1, max(len(w.walls) for w in self.worlds))
        if max_walls > MAX_WALLS:
            raise InputError(f"a world has {max_walls} walls; at most {MAX_WALLS} are allowed")
        n_mat = max(len(w.materials.materials) for w in self.worlds)
        sphere_offsets, sphere_radii, sphere_mats = [], [], []
        c_world, c_first, c_count, c_mass, c_inertia, c_state = [], [], [], [], [], []
        c_pos, c_quat, c_vel, c_omega = [], [], [], []
        self.clump_range = np.zeros((n_worlds, 2), dtype=np.int64)
        self.sphere_range = np.zeros((n_worlds, 2), dtype=np.int64)
        pair = np.full((n_worlds, n_mat, n_mat, N_PAIR_FIELDS), np.nan)
        world_dt = np.zeros(n_worlds)
        r_max = 0.0
        margin = 0.0
        n_sph = 0
        n_clu = 0
        for w, world in enumerate(self.worlds):
            table = world.materials
            pt = table.pair_table()
            pair[w, : pt.shape[0], : pt.shape[1]] = pt
            self.clump_range[w, 0] = n_clu
            self.sphere_range[w, 0] = n_sph
            r_min_world = math.inf
            dt_world = math.inf
            for g, group in enumerate(world.groups):
                if group.count < 0:
                    raise InputError(f"world {w} group {g}: count must be >= 0")
                mat = table.material(group.material)
                mat_idx = table.index(group.material)
                scales = group.scale_array()
                tpl = group.template
                offsets = np.asarray(tpl.offsets, dtype=np.float64)
                radii = np.asarray(tpl.radii, dtype=np.float64)
                inertia = np.asarray(tpl.inertia_per_density, dtype=np.float64)
                ns = len(radii)
                if group.count == 0:
                    continue
                r_lo = float(radii.min() * scales.min())
                r_min_world = min(r_min_world, r_lo)
                r_max = max(r_max, float(radii.max() * scales.max()))
                dt_world = min(dt_world, self.dt_fraction * rayleigh_time_step(
                    r_lo, mat.density, mat.shear_modulus, mat.poisson))
                pos = self._group_array(group.positions, group.count, 3, f"world {w} group {g}"
                                        " positions", None)
                active = pos is not None
                quat = self._group_array(group.orientations, group.count, 4,
                                         f"world {w} group {g} orientations",
                                         np.array([1.0, 0, 0, 0]))
                quat = self._unit_quaternions(quat, f"world {w} group {g} orientations")
                vel = self._group_array(group.velocities, group.count, 3,
                                        f"world {w} group {g} velocities", np.zeros(3))
                omg = self._group_array(group.angular_velocities, group.count, 3,
                                        f"world {w} group {g} angular_velocities", np.zeros(3))
                for k in range(group.count):
                    s = scales[k]
                    c_world.append(w)
                    c_first.append(n_sph)
                    c_count.append(ns)
                    c_mass.append(mat.density * tpl.volume * s**3)
                    c_inertia.append(mat.density * inertia * s**5)
                    c_state.append(ACTIVE if active else INACTIVE)
                    c_pos.append(pos[k] if active else np.zeros(3))
                    c_quat.append(quat[k])
                    c_vel.append(vel[k])
                    c_omega.append(omg[k])
                    sphere_offsets.append(offsets * s)
                    sphere_radii.append(radii * s)
                    sphere_mats.append(np.full(ns, mat_idx, dtype=np.int32))
                    n_sph += ns
                    n_clu += 1
            self.clump_range[w, 1] = n_clu
            self.sphere_range[w, 1] = n_sph
            if world.time_step is not None:
                if not (world.time_step > 0):
                    raise InputError(f"world {w} time_step must be > 0 s")
                dt_world = float(world.time_step)
            if not math.isfinite(dt_world):
                dt_world = 1e-5
            world_dt[w] = dt_world
            del r_min_world
        if n_clu == 0:
            raise InputError("the simulation has no particles (every group has count 0)")
        for world in self.worlds:
            margin = max(margin, world.materials.max_contact_margin(r_max))
        margin *= 1.01
        self.r_max = r_max
        self.skin = float(skin) if skin is not None else _config.SKIN_FRACTION * r_max
        if not (self.skin > 0):
            raise InputError(f"skin must be > 0 m; got {self.skin}")
        self.contact_margin = margin
        # a wall is a sphere's candidate within r + skin + margin (inf: every wall, always)
        self.wall_reach_extra = (self.skin + margin) if _config.WALL_CANDIDATES else math.inf
        self.cell_size = 2.0 * r_max + self.skin + margin
        a = self.arrays
        a["s_offset"] = np.concatenate(sphere_offsets).astype(np.float64)
        a["s_radius"] = np.concatenate(sphere_radii).astype(np.float64)
        a["s_material"] = np.concatenate(sphere_mats).astype(np.int32)
        a["s_clump"] = np.repeat(np.arange(n_clu, dtype=np.int32), c_count)
        a["c_world"] = np.asarray(c_world, dtype=np.int32)
        a["c_first"] = np.asarray(c_first, dtype=np.int32)
        a["c_count"] = np.asarray(c_count, dtype=np.int32)
        a["c_mass"] = np.asarray(c_mass, dtype=np.float64)
        a["c_inertia"] = np.asarray(c_inertia, dtype=np.float64).reshape(n_clu, 3)
        a["c_state"] = np.asarray(c_state, dtype=np.int32)
        a["c_pos"] = np.asarray(c_pos, dtype=np.float64).reshape(n_clu, 3)
        a["c_quat"] = np.asarray(c_quat, dtype=np.float64).reshape(n_clu, 4)
        a["c_vel"] = np.asarray(c_vel, dtype=np.float64).reshape(n_clu, 3)
        a["c_veval"] = a["c_vel"].copy()
        omega = np.asarray(c_omega, dtype=np.float64).reshape(n_clu, 3)
        a["c_omega"] = omega
        a["c_angmom"] = self._angmom_from_omega(a["c_quat"], a["c_inertia"], omega)
        a["c_scratch"] = np.zeros((n_clu, 6))  # within a step only (kernels.clump_step)
        a["s_pos"] = np.zeros((n_sph, 3))
        self._place_all_spheres()
        a["s_ref"] = a["s_pos"].copy()
        a["s_cellkey"] = np.full(n_sph, -1, dtype=np.int64)
        a["s_force"] = np.zeros((n_sph, 3))
        a["s_torque"] = np.zeros((n_sph, 3))
        a["s_roll"] = np.zeros((n_sph, 3))
        self._build_walls(max_walls, n_sph)
        rolling_c = self.rolling_model == ROLLING_C
        cap = _config.NEIGHBOR_CAPACITY
        for side in ("a", "b"):
            alloc_neighbors(a, side, n_sph, cap, rolling_c)
        n_buckets = _pow2_at_least(_config.BUCKETS_PER_SPHERE * n_sph)
        a["bucket_count"] = np.zeros(n_buckets, dtype=np.int32)
        a["bucket_members"] = np.zeros((n_buckets, _config.BUCKET_CAPACITY), dtype=np.int32)
        a["pair_params"] = pair
        a["world_dt"] = world_dt
        self._build_world_arrays(n_worlds)
        self.n_worlds = n_worlds
        self.n_clumps = n_clu
        self.n_spheres = n_sph
        self.n_materials = n_mat
        self.max_walls = max_walls

    def _build_walls(self, max_walls: int, n_sph: int) -> None:
        """The walls' arrays (packed per world) and the per-sphere wall contact state."""
        a = self.arrays
        wtype, worigin, wgeom, (wvel, wspin) = pack_walls([w.walls for w in self.worlds],
                                                          max_walls)
        wmat = np.zeros((len(self.worlds), max_walls), dtype=np.int32)
        for w, world in enumerate(self.worlds):
            for k, wall in enumerate(world.walls):
                wmat[w, k] = world.materials.index(wall.material)
        # every particle material must interact with every wall material of its world
        for world in self.worlds:
            for group in world.groups:
                for wall in world.walls:
                    world.materials.interaction(group.material, wall.material)
                for other in world.groups:
                    world.materials.interaction(group.material, other.material)
        a["wall_type"] = wtype
        a["wall_origin"] = worigin
        a["wall_geom"] = wgeom
        a["wall_vel"] = wvel
        a["wall_omega"] = wspin
        a["wall_material"] = wmat
        a["wall_ref"] = worigin.copy()
        a["s_wall_near"] = np.zeros(n_sph, dtype=np.int64)
        a["s_wall_force"] = np.zeros((n_sph, max_walls, 3))
        a["w_hist"] = np.zeros((n_sph, max_walls, 3))
        rolling_c = self.rolling_model == ROLLING_C
        a["w_rhist"] = np.zeros((n_sph, max_walls, 3) if rolling_c else (1, 1, 3))

    def _build_world_arrays(self, n_worlds: int) -> None:
        """Per-world gravity, domain, clocks and the run's flags and counters."""
        a = self.arrays
        a["world_gravity"] = np.array([self._vec3(w.gravity, f"world {k} gravity (m/s^2)")
                                       for k, w in enumerate(self.worlds)])
        lo = np.array([self._vec3(w.domain_lo, f"world {k} domain_lo (m)")
                       for k, w in enumerate(self.worlds)])
        hi = np.array([self._vec3(w.domain_hi, f"world {k} domain_hi (m)")
                       for k, w in enumerate(self.worlds)])
        if np.any(hi <= lo):
            raise InputError("every world's domain_hi must exceed domain_lo on each axis")
        a["world_lo"] = lo
        a["world_hi"] = hi
        a["grid_lo"] = lo.copy()
        a["world_active"] = np.ones(n_worlds, dtype=np.int32)
        a["world_time"] = np.zeros(n_worlds)
        a["world_steps"] = np.zeros(n_worlds, dtype=np.int64)
        a["flag_rebuild"] = np.ones(1, dtype=np.int32)
        a["flag_nan"] = np.zeros(n_worlds, dtype=np.int32)
        a["flag_overlap"] = np.zeros(n_worlds, dtype=np.int32)
        a["stats"] = np.zeros(4, dtype=np.int64)

    @staticmethod
    def _vec3(value, label: str) -> np.ndarray:
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            arr = np.full(1, np.nan)
        if arr.shape != (3,) or not np.all(np.isfinite(arr)):
            raise InputError(f"{label} must be 3 finite numbers; got {value!r}")
        return arr

    @staticmethod
    def _group_array(value, count: int, width: int, label: str, default):
        if value is None:
            if default is None:
                return None
            return np.tile(default, (count, 1)).astype(np.float64)
        arr = np.asarray(value, dtype=np.float64)
        if arr.shape != (count, width) or not np.all(np.isfinite(arr)):
            raise InputError(f"{label} must be a finite ({count}, {width}) array; "
                             f"got shape {arr.shape}")
        return arr

    @staticmethod
    def _unit_quaternions(quat: np.ndarray, label: str) -> np.ndarray:
        norm = np.linalg.norm(quat, axis=1, keepdims=True)
        if np.any(norm < 1e-12):
            raise InputError(f"{label} must be non-zero quaternions (w, x, y, z)")
        return quat / norm

    @staticmethod
    def _angmom_from_omega(quat, inertia, omega):
        body = rotate_inverse(quat, omega) * inertia
        return rotate(quat, body)

    def _place_all_spheres(self) -> None:
        a = self.arrays
        c = a["s_clump"]
        a["s_pos"] = a["c_pos"][c] + rotate(a["c_quat"][c], a["s_offset"])

    # ------------------------------------------------------------------ backend view
    @property
    def carry_rolling(self) -> bool:
        """True when contacts keep a rolling history (type C)."""
        return self.rolling_model == ROLLING_C

    @property
    def parity(self) -> int:
        """Which neighbour buffer holds the current list (0: "a", 1: "b"); the backend's."""
        return self.runner.parity

    def params(self) -> Params:
        """The scalars of a run, as the compiled code takes them (read at each run, so a
        patched ``_config.MAX_OVERLAP_FRACTION`` applies to the next one)."""
        return Params(
            rolling_model=int(self.rolling_model), carry_rolling=self.carry_rolling,
            contact_margin=float(self.contact_margin),
            max_overlap_fraction=float(_config.MAX_OVERLAP_FRACTION),
            extra=self.skin + self.contact_margin, wall_extra=float(self.wall_reach_extra),
            half_skin=0.5 * self.skin, inv_cell=1.0 / self.cell_size,
            mask=len(self.arrays["bucket_count"]) - 1)

    # ------------------------------------------------------------------ running
    @property
    def dt(self) -> np.ndarray:
        """Time step of each world, s, ``(n_worlds,)``."""
        return self.arrays["world_dt"].copy()

    @property
    def time(self) -> np.ndarray:
        """Simulated time of each world, s, ``(n_worlds,)``."""
        self.runner.pull("world_time")
        return self.arrays["world_time"].copy()

    @property
    def steps(self) -> np.ndarray:
        """Steps taken by each world, ``(n_worlds,)`` int64."""
        self.runner.pull("world_steps")
        return self.arrays["world_steps"].copy()

    @property
    def n_rebuilds(self) -> int:
        """Neighbour-list builds so far."""
        self.runner.pull("stats")
        return int(self.arrays["stats"][2])

    def set_world_enabled(self, world: int, enabled: bool) -> None:
        """Pause (False) or resume (True) a world; paused worlds cost almost nothing."""
        self._check_world(world)
        self._enabled[world] = bool(enabled)

    def is_enabled(self, world: int) -> bool:
        return bool(self._enabled[world]) and self.world_errors[world] is None

    def set_time_step(self, world: int, dt: float) -> None:
        """Set a world's time step, s (e.g. a retry with a smaller step)."""
        self._check_world(world)
        if not (dt > 0 and math.isfinite(dt)):
            raise InputError(f"time step must be > 0 s; got {dt}")
        self.arrays["world_dt"][world] = dt
        self.runner.push("world_dt")

    def set_gravity(self, world: int, gravity) -> None:
        """Set a world's gravitational acceleration, m/s^2 (e.g. a tilting or pulling test)."""
        self._check_world(world)
        self.runner.pull("world_gravity")
        self.arrays["world_gravity"][world] = self._vec3(gravity, f"world {world} gravity "
                                                                   "(m/s^2)")
        self.runner.push("world_gravity")

    def advance(self, n_steps: int) -> None:
        """Advance every enabled world by ``n_steps`` steps (health-checked in chunks)."""
        n_steps = int(n_steps)
        if n_steps < 0:
            raise InputError(f"n_steps must be >= 0; got {n_steps}")
        done = 0
        while done < n_steps:
            k = min(_config.CHUNK_STEPS, n_steps - done)
            self._set_active()
            if not self.arrays["world_active"].any():
                return
            self.runner.run_steps(k)
            done += k
            self._health_check()

    def run(self, duration: float) -> None:
        """Advance every enabled world by ``duration`` seconds of its own time (to the step)."""
        if not (duration >= 0 and math.isfinite(duration)):
            raise InputError(f"duration must be a finite time >= 0 s; got {duration}")
        dt = self.arrays["world_dt"]
        remaining = np.where(self._enabled, np.ceil(duration / dt - 1e-9).astype(np.int64), 0)
        saved = self._enabled.copy()
        try:
            while True:
                live = (remaining > 0) & saved & np.array(
                    [e is None for e in self.world_errors])
                if not live.any():
                    break
                k = int(min(_config.CHUNK_STEPS, remaining[live].min()))
                self._enabled = live
                self._set_active()
                self.runner.run_steps(k)
                remaining[live] -= k
                self._health_check()
        finally:
            self._enabled = saved
            self._set_active()

    def _set_active(self) -> None:
        ok = self._enabled & np.array([e is None for e in self.world_errors])
        act = ok.astype(np.int32)
        if not np.array_equal(act, self.arrays["world_active"]):
            self.arrays["world_active"] = act
            self.runner.push("world_active")

    def _check_world(self, world: int) -> None:
        if not (0 <= world < self.n_worlds):
            raise InputError(f"world must be in [0, {self.n_worlds - 1}]; got {world}")

    def _health_check(self) -> None:
        self.runner.pull("flag_nan", "flag_overlap", "c_vel", "c_state", "world_time")
        a = self.arrays
        speeds = np.linalg.norm(a["c_vel"], axis=1)
        active = a["c_state"] == ACTIVE
        for w in range(self.n_worlds):
            if self.world_errors[w] is not None or not self._enabled[w]:
                continue
            t = float(a["world_time"][w])
            lo, hi = self.clump_range[w]
            reason = None
            if a["flag_nan"][w]:
                reason = ("a particle's state became NaN/infinite (time step too large for the "
                          "stiffness, or overlapping particles at insertion); lower dt_fraction")
            elif a["flag_overlap"][w]:
                reason = (f"a contact overlap exceeded {_config.MAX_OVERLAP_FRACTION:.0%} of the "
                          "sphere radius (time step too large, particles too soft, or "
                          "particles inserted overlapping); lower dt_fraction")
            else:
                sel = active[lo:hi]
                if sel.any():
                    vmax = float(speeds[lo:hi][sel].max())
                    if vmax > _config.MAX_SPEED:
                        reason = (f"a particle reached {vmax:.3g} m/s (> {_config.MAX_SPEED} "
                                  "m/s): energy blow-up; lower dt_fraction")
            if reason is not None:
                msg = f"world {w}: {reason} (at t={t:.6g} s)"
                self.world_errors[w] = msg
                if self.raise_on_unstable:
                    raise SimulationUnstable(msg, world=w, time_s=t)
        self._set_active()

    # ------------------------------------------------------------------ placing clumps
    def place_clumps(self, world: int, indices: Sequence[int] | np.ndarray,
                     positions: np.ndarray, orientations: np.ndarray | None = None,
                     velocities: np.ndarray | None = None,
                     angular_velocities: np.ndarray | None = None) -> None:
        """Activate (insert) clumps of a world at given poses.

        Parameters
        ----------
        world : int
            World index.
        indices : (k,) int array_like
            Indices of the clumps within the world (0 .. n_clumps_in_world - 1).
        positions : (k, 3) array_like
            Centres of mass, m.
        orientations : (k, 4) array_like, optional
            Unit quaternions (w, x, y, z); default identity.
        velocities, angular_velocities : (k, 3) array_like, optional
            m/s and rad/s (space frame); default 0.
        """
        self._check_world(world)
        idx = np.asarray(indices, dtype=np.int64).reshape(-1)
        lo, hi = self.clump_range[world]
        if idx.size and (idx.min() < 0 or idx.max() >= hi - lo):
            raise InputError(f"clump indices must be in [0, {hi - lo - 1}] for world {world}")
        k = idx.size
        if k == 0:
            return
        g = idx + lo
        pos = self._group_array(positions, k, 3, "positions", None)
        quat = self._group_array(orientations, k, 4, "orientations", np.array([1.0, 0, 0, 0]))
        quat = self._unit_quaternions(quat, "orientations")
        vel = self._group_array(velocities, k, 3, "velocities", np.zeros(3))
        omg = self._group_array(angular_velocities, k, 3, "angular_velocities", np.zeros(3))
        names = ("c_pos", "c_quat", "c_vel", "c_veval", "c_angmom", "c_omega", "c_state",
                 "s_pos", "flag_rebuild")
        self.runner.pull(*names)
        a = self.arrays
        a["c_pos"][g] = pos
        a["c_quat"][g] = quat
        a["c_vel"][g] = vel
        a["c_veval"][g] = vel
        a["c_omega"][g] = omg
        a["c_angmom"][g] = self._angmom_from_omega(quat, a["c_inertia"][g], omg)
        a["c_state"][g] = ACTIVE
        for c in g:
            f, n = a["c_first"][c], a["c_count"][c]
            a["s_pos"][f:f + n] = a["c_pos"][c] + rotate(
                np.repeat(a["c_quat"][c][None], n, 0), a["s_offset"][f:f + n])
        a["flag_rebuild"][0] = 1
        self.runner.push(*names)

    def remove_clumps(self, world: int, indices: Sequence[int] | np.ndarray) -> None:
        """Remove clumps of a world (they are counted as removed, like clumps leaving)."""
        self._check_world(world)
        idx = np.asarray(indices, dtype=np.int64).reshape(-1)
        lo, hi = self.clump_range[world]
        if idx.size and (idx.min() < 0 or idx.max() >= hi - lo):
            raise InputError(f"clump indices must be in [0, {hi - lo - 1}] for world {world}")
        idx = idx + lo
        self.runner.pull("c_state", "flag_rebuild")
        self.arrays["c_state"][idx] = REMOVED
        self.arrays["flag_rebuild"][0] = 1
        self.runner.push("c_state", "flag_rebuild")

    # ------------------------------------------------------------------ walls
    def _check_wall(self, world: int, wall: int) -> None:
        self._check_world(world)
        if not (0 <= wall < len(self.worlds[world].walls)):
            raise InputError(f"wall must be in [0, {len(self.worlds[world].walls) - 1}]")

    def set_wall_velocity(self, world: int, wall: int, velocity) -> None:
        """Set the translation velocity of a wall, m/s."""
        self._check_wall(world, wall)
        v = np.asarray(velocity, dtype=np.float64)
        if v.shape != (3,) or not np.all(np.isfinite(v)):
            raise InputError("velocity must be 3 finite numbers (m/s)")
        self.runner.pull("wall_vel")
        self.arrays["wall_vel"][world, wall] = v
        self.runner.push("wall_vel")

    def set_wall_angular_velocity(self, world: int, wall: int, omega) -> None:
        """Set the spin of a wall about its origin, rad/s: along a tube's axis (a drum's
        shell) or a plane's normal (a drum's end wall); see :mod:`demcal.dem.walls`. The
        surface at ``p`` then moves at ``v + omega x (p - origin)``. Takes effect at the next
        step; the walls' description (``World.walls``) keeps its initial value."""
        self._check_wall(world, wall)
        geom = self.arrays["wall_geom"][world, wall]
        spin = check_spin_axis(omega, geom[0:3], self.worlds[world].walls[wall].name)
        self.runner.pull("wall_omega")
        self.arrays["wall_omega"][world, wall] = spin
        self.runner.push("wall_omega")

    def wall_angular_velocity(self, world: int, wall: int) -> np.ndarray:
        """Current spin of a wall about its origin, rad/s."""
        self._check_wall(world, wall)
        self.runner.pull("wall_omega")
        return self.arrays["wall_omega"][world, wall].copy()

    def wall_torques(self, world: int) -> np.ndarray:
        """Torque the particles exert on each wall of a world about the wall's origin,
        ``(n_walls, 3)``, N m (at the last step).

        The sum over the wall's contacts of the lever from its origin to the contact point
        (the middle of the overlap, where the kernels apply the force) times the force on the
        wall. About a drum's axis it is what the drum's drive must overcome:
        ``-omega . torque`` is the power the wall gives the particles through the contact
        forces, W. Rolling-resistance couples are not in it (the kernels keep no per-wall
        record of them; type A is no couple between two bodies at all).
        """
        self._check_world(world)
        self.runner.pull("s_wall_force", "s_pos", "wall_origin")
        a = self.arrays
        lo, hi = self.sphere_range[world]
        out = np.zeros((len(self.worlds[world].walls), 3))
        for k in range(len(out)):
            forces = a["s_wall_force"][lo:hi, k]
            wall = (int(a["wall_type"][world, k]), a["wall_origin"][world, k],
                    a["wall_geom"][world, k])
            for i in np.flatnonzero(np.any(forces != 0.0, axis=1)):
                lever = contact_point(wall, a["s_pos"][lo + i], a["s_radius"][lo + i]) - wall[1]
                out[k] += np.cross(lever, forces[i])
        return out

    def wall_origin(self, world: int, wall: int) -> np.ndarray:
        """Current origin (plane centre / tube base) of a wall, m."""
        self.runner.pull("wall_origin")
        return self.arrays["wall_origin"][world, wall].copy()

    def wall_forces(self, world: int) -> np.ndarray:
        """Force exerted by the particles on each wall of a world, ``(n_walls, 3)``, N."""
        self._check_world(world)
        self.runner.pull("s_wall_force")
        lo, hi = self.sphere_range[world]
        return self.arrays["s_wall_force"][lo:hi].sum(axis=0)[: len(self.worlds[world].walls)]

    # ------------------------------------------------------------------ queries
    def _clump_sel(self, world: int, states=(ACTIVE,)) -> np.ndarray:
        self._check_world(world)
        self.runner.pull("c_state")
        lo, hi = self.clump_range[world]
        return lo + np.flatnonzero(np.isin(self.arrays["c_state"][lo:hi], states))

    def clump_state(self, world: int) -> np.ndarray:
        """State of each clump of a world: 0 inactive, 1 active, 2 removed, ``(n,)`` int."""
        self._check_world(world)
        self.runner.pull("c_state")
        lo, hi = self.clump_range[world]
        return self.arrays["c_state"][lo:hi].copy()

    def clump_positions(self, world: int) -> np.ndarray:
        """Centres of mass of the active clumps of a world, ``(n, 3)``, m."""
        self.runner.pull("c_pos")
        return self.arrays["c_pos"][self._clump_sel(world)].copy()

    def clump_velocities(self, world: int) -> np.ndarray:
        """Velocities of the active clumps of a world, ``(n, 3)``, m/s (half-step values)."""
        self.runner.pull("c_vel")
        return self.arrays["c_vel"][self._clump_sel(world)].copy()

    def clump_masses(self, world: int) -> np.ndarray:
        """Masses of the active clumps of a world, ``(n,)``, kg."""
        return self.arrays["c_mass"][self._clump_sel(world)].copy()

    def spheres(self, world: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Active spheres of a world: centres ``(n, 3)`` m, radii ``(n,)`` m, clump ids ``(n,)``
        (indices within the world)."""
        self._check_world(world)
        self.runner.pull("s_pos", "c_state")
        a = self.arrays
        lo, hi = self.sphere_range[world]
        clump = a["s_clump"][lo:hi]
        sel = a["c_state"][clump] == ACTIVE
        return (a["s_pos"][lo:hi][sel].copy(), a["s_radius"][lo:hi][sel].copy(),
                clump[sel] - self.clump_range[world, 0])

    def n_active(self, world: int) -> int:
        return len(self._clump_sel(world))

    def n_removed(self, world: int) -> int:
        """Clumps removed from a world (left the domain, or removed by the host)."""
        return len(self._clump_sel(world, (REMOVED,)))

    def kinetic_energy(self, world: int) -> float:
        """Kinetic energy (translation + rotation) of a world's active clumps, J."""
        self.runner.pull("c_vel", "c_angmom", "c_omega", "c_state")
        a = self.arrays
        sel = self._clump_sel(world)
        trans = 0.5 * np.sum(a["c_mass"][sel] * np.sum(a["c_vel"][sel] ** 2, axis=1))
        rot = 0.5 * np.sum(a["c_angmom"][sel] * a["c_omega"][sel])
        return float(trans + rot)

    def max_speed(self, world: int) -> float:
        """Largest clump speed in a world, m/s (0 if none active)."""
        self.runner.pull("c_vel", "c_state")
        sel = self._clump_sel(world)
        if len(sel) == 0:
            return 0.0
        return float(np.linalg.norm(self.arrays["c_vel"][sel], axis=1).max())

    # ------------------------------------------------------------------ state i/o
    def state_dict(self) -> dict[str, np.ndarray]:
        """Copies of every array (static and dynamic): enough to restart the simulation."""
        self.runner.pull(*DYNAMIC_ARRAYS)
        out = {k: v.copy() for k, v in self.arrays.items()}
        out["parity"] = np.array(self.parity)
        return out

    def load_state(self, state: dict[str, np.ndarray]) -> None:
        """Restore the dynamic arrays saved by :meth:`state_dict` (same worlds and sizes)."""
        rebuild = False
        for name in DYNAMIC_ARRAYS:
            if name not in state and name in REBUILT_ARRAYS:
                rebuild = True
                continue
            if name not in state and name in DESCRIBED_ARRAYS:
                continue
            if name not in state:
                raise InputError(f"snapshot lacks array {name!r}")
            arr = np.asarray(state[name])
            mine = self.arrays.get(name)
            if mine is not None and mine.shape != arr.shape and not name.startswith("nb_"):
                raise InputError(f"snapshot array {name!r} has shape {arr.shape}; this "
                                 f"simulation needs {mine.shape}")
            self.arrays[name] = arr.astype(mine.dtype if mine is not None else arr.dtype,
                                           copy=True)
        if rebuild:
            self.arrays["flag_rebuild"][0] = 1
        self.runner.push_all(parity=int(state.get("parity", 0)))
