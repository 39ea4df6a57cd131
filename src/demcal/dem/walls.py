"""Wall geometry: finite planes (rectangles) and finite thick cylinders (tubes), with motion.

Host side: :class:`PlaneWall` and :class:`TubeWall` describe walls in SI units. Device side:
walls are packed into ``wall_type`` (int32), ``wall_origin`` (3 floats, moves with the wall's
velocity) and ``wall_geom`` (:data:`GEOM_SIZE` floats), and :func:`closest_point` gives the
distance from a sphere centre to the wall's surface.

A wall moves by a translation velocity (its origin moves) and may also spin about an axis
through its origin (``angular_velocity``, rad/s): a tube about its own axis, a plane about
its normal. Such a spin leaves the surface where it is (a tube turned about its axis is the
same tube; a plane turned about its normal is the same plane), so only the surface's velocity
changes: at a point ``p`` of the surface it is ``v + omega x (p - origin)``
(:func:`surface_velocity`), which enters the contact's tangential and rolling relative
motion. This is a drum: a tube turning about its axis with two planes across its ends turning
with it. A finite rectangle's outline is *not* turned (only its surface moves): use a
turning rectangle where spheres stay clear of its edges, as a drum's end walls larger than
the drum.

A tube is the solid of revolution of the rectangle ``[r_in, r_out] x [0, length]`` in the
``(rho, z)`` plane around its axis, so its inner surface, outer surface, rims and edges are all
handled by one closest-point query in that plane. Its curvature is ignored in the contact
(R* = sphere radius), as for a flat wall.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from demcal.errors import InputError

__all__ = ["GEOM_SIZE", "WALL_NONE", "WALL_PLANE", "WALL_TUBE", "Drum", "PlaneWall", "TubeWall",
           "check_spin_axis", "closest_point", "contact_point", "pack_walls", "spin_relative_to",
           "surely_beyond", "surface_velocity"]

WALL_NONE = 0
WALL_PLANE = 1
WALL_TUBE = 2
GEOM_SIZE = 12


def _unit(vec, name: str) -> np.ndarray:
    v = np.asarray(vec, dtype=np.float64)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise InputError(f"{name} must be 3 finite numbers; got {vec!r}")
    n = float(np.linalg.norm(v))
    if n == 0.0:
        raise InputError(f"{name} must be a non-zero vector")
    return v / n


def _vec3(vec, name: str) -> np.ndarray:
    v = np.asarray(vec, dtype=np.float64)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise InputError(f"{name} must be 3 finite numbers; got {vec!r}")
    return v


def check_spin_axis(omega, axis: np.ndarray, name: str) -> np.ndarray:
    """A wall's angular velocity (rad/s) as 3 floats, checked to lie along ``axis``.

    A wall may only spin about its axis of symmetry (a tube's axis, a plane's normal), so that
    the spin leaves its surface in place and only the surface velocity changes; any other spin
    would move the surface, which the engine does not do. Raises :class:`InputError` otherwise.
    """
    w = _vec3(omega, f"wall {name!r} angular_velocity")
    rate = float(np.linalg.norm(w))
    if rate > 0.0 and float(np.linalg.norm(np.cross(w, axis))) > 1e-9 * rate:
        raise InputError(f"wall {name!r} angular_velocity {list(map(float, w))} rad/s must lie "
                         f"along its axis (a tube's axis, a plane's normal) "
                         f"{list(map(float, axis))}: only such a spin leaves the wall in place")
    return w


@dataclass
class PlaneWall:
    """A flat rectangle (or an infinite plane), two-sided.

    Parameters
    ----------
    origin : (3,) array_like
        Centre of the rectangle, m.
    normal : (3,) array_like
        Normal vector (need not be unit).
    half_size : (2,) array_like
        Half-lengths along the in-plane axes ``u`` and ``v = normal x u``, m; ``inf`` for an
        infinite plane.
    u_axis : (3,) array_like, optional
        First in-plane axis (projected onto the plane); chosen automatically if omitted.
    material : str
        Name of the wall's material.
    velocity : (3,) array_like
        Translation velocity, m/s.
    name : str
        Label (used in wall-force reports).
    angular_velocity : (3,) array_like
        Spin about the normal through ``origin``, rad/s (along the normal; default 0): the
        surface at ``p`` moves at ``velocity + angular_velocity x (p - origin)``, the outline
        stays (a drum's end wall, see the module's notes).
    """

    origin: np.ndarray
    normal: np.ndarray
    half_size: tuple[float, float] = (math.inf, math.inf)
    u_axis: np.ndarray | None = None
    material: str = "wall"
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    name: str = "plane"
    angular_velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def packed(self) -> tuple[int, np.ndarray, np.ndarray]:
        n = _unit(self.normal, f"wall {self.name!r} normal")
        if self.u_axis is None:
            trial = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        else:
            trial = _unit(self.u_axis, f"wall {self.name!r} u_axis")
        u = trial - np.dot(trial, n) * n
        if np.linalg.norm(u) < 1e-12:
            raise InputError(f"wall {self.name!r} u_axis must not be parallel to its normal")
        u /= np.linalg.norm(u)
        v = np.cross(n, u)
        hu, hv = (float(h) for h in self.half_size)
        if not (hu > 0 and hv > 0):
            raise InputError(f"wall {self.name!r} half_size must be > 0; got {self.half_size}")
        geom = np.zeros(GEOM_SIZE)
        geom[0:3] = n
        geom[3:6] = u
        geom[6:9] = v
        geom[9] = min(hu, 1e30)
        geom[10] = min(hv, 1e30)
        return WALL_PLANE, _vec3(self.origin, f"wall {self.name!r} origin"), geom


@dataclass
class TubeWall:
    """A finite thick cylinder (tube) with open ends.

    Parameters
    ----------
    base : (3,) array_like
        Centre of the bottom rim, m.
    axis : (3,) array_like
        Axis direction (bottom to top).
    inner_radius, thickness, length : float
        Inner radius, wall thickness and length of the tube, m.
    material, velocity, name
        As for :class:`PlaneWall`.
    angular_velocity : (3,) array_like
        Spin about the tube's own axis (through ``base``), rad/s (along ``axis``; default 0):
        a drum's shell. The surface at ``p`` moves at
        ``velocity + angular_velocity x (p - base)``.
    """

    base: np.ndarray
    axis: np.ndarray
    inner_radius: float
    thickness: float
    length: float
    material: str = "wall"
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    name: str = "tube"
    angular_velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def packed(self) -> tuple[int, np.ndarray, np.ndarray]:
        a = _unit(self.axis, f"wall {self.name!r} axis")
        for label, val in (("inner_radius", self.inner_radius), ("thickness", self.thickness),
                           ("length", self.length)):
            if not (np.isfinite(val) and val > 0):
                raise InputError(f"wall {self.name!r} {label} must be > 0 m; got {val}")
        geom = np.zeros(GEOM_SIZE)
        geom[0:3] = a
        geom[3] = self.inner_radius
        geom[4] = self.inner_radius + self.thickness
        geom[5] = self.length
        return WALL_TUBE, _vec3(self.base, f"wall {self.name!r} base"), geom


@dataclass
class Drum:
    """A drum: a tube turning about its axis between two end walls that turn with it.

    Parameters
    ----------
    centre : (3,) array_like
        Centre of the drum (on its axis, half-way between the end walls), m.
    axis : (3,) array_like
        Axis direction (need not be unit); the drum turns about it by the right-hand rule.
    radius, width : float
        Inner radius and inner width (between the end walls), m.
    angular_speed : float
        rad/s (0: at rest; negative: the other way).
    material : str
        Name of the walls' material (shell and end walls).
    thickness : float
        Shell thickness, m (only its inner side is meant to be touched).

    :meth:`walls` gives the three walls (shell, then the end walls at the axis' start and
    end); their origins lie on the axis, so their surface velocities are one rigid body's,
    ``omega x (p - centre)``. A world's walls may hold several drums or other walls;
    :meth:`set_speed` turns the three at once during a run.
    """

    centre: np.ndarray
    axis: np.ndarray
    radius: float
    width: float
    angular_speed: float = 0.0
    material: str = "wall"
    thickness: float = 1e-3

    def walls(self) -> list[PlaneWall | TubeWall]:
        """``[shell, end at -axis, end at +axis]``: a :class:`TubeWall` and two
        :class:`PlaneWall` squares (half-size ``radius + thickness``, normals inwards)."""
        a = _unit(self.axis, "drum axis")
        c = _vec3(self.centre, "drum centre")
        for label, val in (("radius", self.radius), ("width", self.width),
                           ("thickness", self.thickness)):
            if not (np.isfinite(val) and val > 0):
                raise InputError(f"drum {label} must be > 0 m; got {val}")
        if not np.isfinite(self.angular_speed):
            raise InputError(f"drum angular_speed must be finite; got {self.angular_speed}")
        spin = float(self.angular_speed) * a
        base = c - 0.5 * self.width * a
        half = self.radius + self.thickness
        return [
            TubeWall(base=base, axis=a, inner_radius=self.radius, thickness=self.thickness,
                     length=self.width, material=self.material, name="drum shell",
                     angular_velocity=spin.copy()),
            PlaneWall(origin=base, normal=a, half_size=(half, half), material=self.material,
                      name="drum end -", angular_velocity=spin.copy()),
            PlaneWall(origin=c + 0.5 * self.width * a, normal=-a, half_size=(half, half),
                      material=self.material, name="drum end +", angular_velocity=spin.copy()),
        ]

    def set_speed(self, sim, world: int, first_wall: int, angular_speed: float) -> None:
        """Turn the drum whose three walls are walls ``first_wall`` to ``first_wall + 2`` of
        ``world`` in the simulation ``sim`` at ``angular_speed`` (rad/s) from the next step
        (:meth:`Simulation.set_wall_angular_velocity
        <demcal.dem.simulation.Simulation.set_wall_angular_velocity>`)."""
        if not np.isfinite(angular_speed):
            raise InputError(f"drum angular_speed must be finite; got {angular_speed}")
        spin = float(angular_speed) * _unit(self.axis, "drum axis")
        for k in range(first_wall, first_wall + 3):
            sim.set_wall_angular_velocity(world, k, spin)


def pack_walls(walls_per_world: list[list[PlaneWall | TubeWall]], max_walls: int):
    """Pack walls of every world into device arrays.

    Returns ``wall_type (n_worlds, max_walls) int32``, ``wall_origin (n_worlds, max_walls, 3)``
    (m), ``wall_geom (n_worlds, max_walls, GEOM_SIZE)``, and the motion as one tuple
    ``(wall_velocity, wall_omega)``, each ``(n_worlds, max_walls, 3)`` (m/s, rad/s).
    """
    n_worlds = len(walls_per_world)
    wtype = np.zeros((n_worlds, max_walls), dtype=np.int32)
    origin = np.zeros((n_worlds, max_walls, 3))
    geom = np.zeros((n_worlds, max_walls, GEOM_SIZE))
    vel = np.zeros((n_worlds, max_walls, 3))
    spin = np.zeros((n_worlds, max_walls, 3))
    for w, walls in enumerate(walls_per_world):
        for k, wall in enumerate(walls):
            t, o, g = wall.packed()
            wtype[w, k] = t
            origin[w, k] = o
            geom[w, k] = g
            vel[w, k] = _vec3(wall.velocity, f"wall {wall.name!r} velocity")
            # geom[0:3]: the plane's normal, the tube's axis (the only spin axis allowed)
            spin[w, k] = check_spin_axis(wall.angular_velocity, g[0:3], wall.name)
    return wtype, origin, geom, (vel, spin)


def contact_point(wall, centre, radius: float) -> np.ndarray:
    """Where a sphere touches a wall, m: the middle of the overlap, as the kernels take it.

    ``wall`` = ``(type, origin (3,) m, geom)`` as packed; ``centre`` (3,) m and ``radius`` m
    of the sphere. (Host side, for queries such as :meth:`Simulation.wall_torques
    <demcal.dem.simulation.Simulation.wall_torques>`.)
    """
    wtype, origin, geom = wall
    d, nx, ny, nz, _, _, _ = closest_point(wtype, float(origin[0]), float(origin[1]),
                                           float(origin[2]), geom, float(centre[0]),
                                           float(centre[1]), float(centre[2]))
    lever = radius - 0.5 * (radius - d)
    return np.asarray(centre, dtype=np.float64) - lever * np.array([nx, ny, nz])


@njit(cache=True)
def surface_velocity(vel, spin, arm):
    """Velocity of a wall's surface at a point, m/s: ``vel + spin x arm``.

    Parameters
    ----------
    vel : tuple of 3 floats
        The wall's translation velocity, m/s.
    spin : tuple of 3 floats
        Its angular velocity about its origin, rad/s.
    arm : tuple of 3 floats
        From the wall's origin to the point, m.

    Returns ``vel`` itself (the very floats) when the wall does not spin, so that a
    non-spinning wall's contacts are bit for bit what they were before walls could spin.
    """
    if spin[0] == 0.0 and spin[1] == 0.0 and spin[2] == 0.0:
        return vel
    return (vel[0] + (spin[1] * arm[2] - spin[2] * arm[1]),
            vel[1] + (spin[2] * arm[0] - spin[0] * arm[2]),
            vel[2] + (spin[0] * arm[1] - spin[1] * arm[0]))


@njit(cache=True)
def spin_relative_to(body_spin, wall_spin):
    """A body's angular velocity relative to a wall's, rad/s (tuples of 3 floats): what
    type-C rolling resistance sees at a wall contact (a body carried round with a turning
    wall does not roll on it). Returns ``body_spin`` itself when the wall does not spin (bit
    for bit the non-spinning wall's contact)."""
    if wall_spin[0] == 0.0 and wall_spin[1] == 0.0 and wall_spin[2] == 0.0:
        return body_spin
    return (body_spin[0] - wall_spin[0], body_spin[1] - wall_spin[1],
            body_spin[2] - wall_spin[2])


@njit(cache=True)
def surely_beyond(wtype, ox, oy, oz, geom, px, py, pz, reach):
    """True when every point of the wall is farther than ``reach`` from ``p`` (a cheap bound).

    A conservative test, no square roots: a plane's points all lie in its plane, a tube's
    between radii ``r_in`` and ``r_out`` and heights 0 and ``length`` of its axis, so a point
    beyond those by more than ``reach`` (times 1 + 1e-9, against rounding) is surely out of
    contact. False means "compute the distance" (:func:`closest_point`), not "in contact".
    """
    margin = reach * (1.0 + 1e-9)
    sx = px - ox
    sy = py - oy
    sz = pz - oz
    if wtype == WALL_PLANE:
        dn = sx * geom[0] + sy * geom[1] + sz * geom[2]
        return dn > margin or dn < -margin
    ax = geom[0]
    ay = geom[1]
    az = geom[2]
    z = sx * ax + sy * ay + sz * az
    if z < -margin or z > geom[5] + margin:
        return True
    rx = sx - z * ax
    ry = sy - z * ay
    rz = sz - z * az
    rho2 = rx * rx + ry * ry + rz * rz
    out = geom[4] + margin
    if rho2 > out * out:
        return True
    inner = geom[3] - margin
    return inner > 0.0 and rho2 < inner * inner


@njit(cache=True)
def closest_point(wtype, ox, oy, oz, geom, px, py, pz):
    """Closest point of a wall's surface to a sphere centre.

    Parameters
    ----------
    wtype : int
        WALL_PLANE or WALL_TUBE.
    ox, oy, oz : float
        Wall origin (plane centre, tube bottom-rim centre), m.
    geom : (GEOM_SIZE,) float64 array
        Packed geometry.
    px, py, pz : float
        Sphere centre, m.

    Returns
    -------
    dist : float
        Signed distance from the surface to the centre, m (< 0: the centre is inside a tube's
        solid wall).
    nx, ny, nz : float
        Unit normal pointing from the wall to the centre.
    qx, qy, qz : float
        Closest point on the surface, m.
    """
    sx = px - ox
    sy = py - oy
    sz = pz - oz
    if wtype == WALL_PLANE:
        n0 = geom[0]
        n1 = geom[1]
        n2 = geom[2]
        cu = sx * geom[3] + sy * geom[4] + sz * geom[5]
        cv = sx * geom[6] + sy * geom[7] + sz * geom[8]
        hu = geom[9]
        hv = geom[10]
        cu = min(max(cu, -hu), hu)
        cv = min(max(cv, -hv), hv)
        qx = ox + cu * geom[3] + cv * geom[6]
        qy = oy + cu * geom[4] + cv * geom[7]
        qz = oz + cu * geom[5] + cv * geom[8]
        dx = px - qx
        dy = py - qy
        dz = pz - qz
        d = math.sqrt(dx * dx + dy * dy + dz * dz)
        if d > 1e-300:
            return d, dx / d, dy / d, dz / d, qx, qy, qz
        return 0.0, n0, n1, n2, qx, qy, qz
    # tube
    ax = geom[0]
    ay = geom[1]
    az = geom[2]
    rin = geom[3]
    rout = geom[4]
    length = geom[5]
    z = sx * ax + sy * ay + sz * az
    rx = sx - z * ax
    ry = sy - z * ay
    rz = sz - z * az
    rho = math.sqrt(rx * rx + ry * ry + rz * rz)
    if rho > 1e-300:
        ex = rx / rho
        ey = ry / rho
        ez = rz / rho
    else:
        # on the axis: any radial direction (perpendicular to the axis)
        if abs(ax) < 0.9:
            ex, ey, ez = 0.0, az, -ay
        else:
            ex, ey, ez = -az, 0.0, ax
        norm = math.sqrt(ex * ex + ey * ey + ez * ez)
        ex /= norm
        ey /= norm
        ez /= norm
    inside = rho > rin and rho < rout and z > 0.0 and z < length
    if inside:
        # deep penetration: leave through the nearest face
        d_in = rho - rin
        d_out = rout - rho
        d_bot = z
        d_top = length - z
        best = d_in
        rc = rin
        zc = z
        sr = -1.0
        sz_ = 0.0
        if d_out < best:
            best = d_out
            rc = rout
            sr = 1.0
        if d_bot < best:
            best = d_bot
            rc = rho
            zc = 0.0
            sr = 0.0
            sz_ = -1.0
        if d_top < best:
            best = d_top
            rc = rho
            zc = length
            sr = 0.0
            sz_ = 1.0
        nx = sr * ex + sz_ * ax
        ny = sr * ey + sz_ * ay
        nz = sr * ez + sz_ * az
        qx = ox + zc * ax + rc * ex
        qy = oy + zc * ay + rc * ey
        qz = oz + zc * az + rc * ez
        return -best, nx, ny, nz, qx, qy, qz
    rc = min(max(rho, rin), rout)
    zc = min(max(z, 0.0), length)
    dr = rho - rc
    dz = z - zc
    d = math.sqrt(dr * dr + dz * dz)
    qx = ox + zc * ax + rc * ex
    qy = oy + zc * ay + rc * ey
    qz = oz + zc * az + rc * ez
    if d > 1e-300:
        nx = (dr * ex + dz * ax) / d
        ny = (dr * ey + dz * ay) / d
        nz = (dr * ez + dz * az) / d
        return d, nx, ny, nz, qx, qy, qz
    return 0.0, -ex, -ey, -ez, qx, qy, qz
