"""Particle generation for virtual tests: templates, sizes, loose packings and a dynamic factory.

Placement is done on the host, without overlap against every sphere already there (checked on
a hash grid of sphere centres), and inside a vertical cylinder of given radius (the test's
tube), like EDEM's dynamic factory: a particle that does not fit at its random position is
tried again elsewhere a few times, then left for the next generation event.
"""

from __future__ import annotations

import math
from collections import defaultdict

import numpy as np

from demcal.dem.shapes import ClumpTemplate, cylinder_template, sphere_template, stalk_template
from demcal.dem.state import random_quaternions
from demcal.errors import InputError
from demcal.virtual.config import AoRTestConfig, ParticleShape

__all__ = ["SphereGrid", "draw_scales", "make_template", "pack_cylinder", "place_in_cylinder"]


def make_template(shape: ParticleShape) -> ClumpTemplate:
    """The clump template of a particle description (unscaled), m."""
    if shape.template == "stalk":
        return stalk_template(length=shape.length, diameter=shape.diameter,
                              n_spheres=shape.n_spheres)
    if shape.template == "cylinder":
        return cylinder_template(shape.length, shape.diameter)
    if shape.template == "sphere":
        return sphere_template(0.5 * shape.diameter)
    raise InputError(f"particle.template must be stalk, cylinder or sphere; got {shape.template}")


def draw_scales(n: int, shape: ParticleShape, rng: np.random.Generator) -> np.ndarray:
    """Size factors drawn uniformly from [size_min, size_max], ``(n,)``."""
    return rng.uniform(shape.size_min, shape.size_max, n)


class SphereGrid:
    """Hash grid of sphere centres for overlap queries during placement."""

    def __init__(self, cell: float):
        self.cell = float(cell)
        self.cells: dict[tuple[int, int, int], list[int]] = defaultdict(list)
        self.centres: list[np.ndarray] = []
        self.radii: list[float] = []

    def _key(self, p) -> tuple[int, int, int]:
        c = self.cell
        return (math.floor(p[0] / c), math.floor(p[1] / c), math.floor(p[2] / c))

    def add(self, centres: np.ndarray, radii: np.ndarray) -> None:
        for p, r in zip(centres, radii, strict=True):
            self.cells[self._key(p)].append(len(self.radii))
            self.centres.append(np.asarray(p, dtype=float))
            self.radii.append(float(r))

    def overlaps(self, centres: np.ndarray, radii: np.ndarray, gap: float = 0.0) -> bool:
        """True if any of the given spheres comes closer than ``gap`` to a stored sphere."""
        for p, r in zip(centres, radii, strict=True):
            kx, ky, kz = self._key(p)
            for dx in (-1, 0, 1):
                for dy in (-1, 0, 1):
                    for dz in (-1, 0, 1):
                        for j in self.cells.get((kx + dx, ky + dy, kz + dz), ()):
                            q = self.centres[j]
                            lim = r + self.radii[j] + gap
                            d0, d1, d2 = p[0] - q[0], p[1] - q[1], p[2] - q[2]
                            if d0 * d0 + d1 * d1 + d2 * d2 < lim * lim:
                                return True
        return False


def _rotated(quat: np.ndarray, offs: np.ndarray) -> np.ndarray:
    """``rotate`` of ``offs`` (n, 3) by one quaternion, bitwise the same, without np.cross.

    np.cross of 3-vectors computes each component as ``a_i b_j - a_j b_i`` (two rounded
    products, one rounded difference), exactly as written here; np.cross's axis handling cost
    ~70 us per call, most of the factory's placement time.
    """
    w, u0, u1, u2 = quat[0], quat[1], quat[2], quat[3]
    v0, v1, v2 = offs[:, 0], offs[:, 1], offs[:, 2]
    t0 = 2.0 * (u1 * v2 - u2 * v1)
    t1 = 2.0 * (u2 * v0 - u0 * v2)
    t2 = 2.0 * (u0 * v1 - u1 * v0)
    out = np.empty_like(offs)
    out[:, 0] = v0 + w * t0 + (u1 * t2 - u2 * t1)
    out[:, 1] = v1 + w * t1 + (u2 * t0 - u0 * t2)
    out[:, 2] = v2 + w * t2 + (u0 * t1 - u1 * t0)
    return out


def place_in_cylinder(template: ClumpTemplate, scales: np.ndarray, *, radius: float,
                      z_low: float, z_high: float, rng: np.random.Generator,
                      grid: SphereGrid | None = None, attempts: int = 50,
                      gap: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Place clumps at random, without overlap, inside a vertical cylinder around the z axis.

    Parameters
    ----------
    template : ClumpTemplate
        Unscaled template.
    scales : (n,) ndarray
        Size factor of each clump to place (in order).
    radius : float
        Inner radius of the containing cylinder, m; every sphere must lie inside it.
    z_low, z_high : float
        Vertical range for the clump centres, m.
    rng : numpy.random.Generator
        Random source (positions and orientations).
    grid : SphereGrid, optional
        Spheres already present (updated with the placed ones).
    attempts : int
        Random trials per clump before it is skipped.
    gap : float
        Extra clearance between spheres, m.

    Returns
    -------
    placed : (k,) int ndarray
        Indices (into ``scales``) of the clumps placed.
    positions : (k, 3) ndarray
        Their centres, m.
    orientations : (k, 4) ndarray
        Their unit quaternions (w, x, y, z).
    """
    if grid is None:
        grid = SphereGrid(2.0 * float(template.radii.max() * scales.max()) + gap)
    placed, positions, quats = [], [], []
    bounding = template.bounding_radius
    for k, s in enumerate(scales):
        offs, radii = template.offsets * s, template.radii * s
        # radial room: the clump's spheres must stay inside the cylinder
        rho_max = radius - s * bounding
        for _ in range(attempts):
            q = random_quaternions(1, rng)[0]
            if rho_max <= 0:
                raise InputError("the cylinder is narrower than a particle")
            u = rng.random()
            phi = rng.uniform(0.0, 2.0 * math.pi)
            rho = rho_max * math.sqrt(u)
            pos = np.array([rho * math.cos(phi), rho * math.sin(phi),
                            rng.uniform(z_low, z_high)])
            centres = pos + _rotated(q, offs)
            if np.any(np.hypot(centres[:, 0], centres[:, 1]) + radii > radius):
                continue
            if grid.overlaps(centres, radii, gap):
                continue
            grid.add(centres, radii)
            placed.append(k)
            positions.append(pos)
            quats.append(q)
            break
    return (np.asarray(placed, dtype=np.int64), np.asarray(positions).reshape(-1, 3),
            np.asarray(quats).reshape(-1, 4))


def pack_cylinder(template: ClumpTemplate, scales: np.ndarray, config: AoRTestConfig,
                  rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The loose packing of the ``packing`` fill: every clump placed in the test's tube.

    The clumps are placed in a column of the height that holds them at
    ``config.fill.packing_fraction`` (grown by x1.25 while some do not fit, at most 20 times),
    from just above the plate. Both engines (demcal's and LAMMPS) start from this packing, so
    the same seed gives them the same initial state.

    Parameters
    ----------
    template : ClumpTemplate
        Unscaled template.
    scales : (n,) ndarray
        Size factor of every clump.
    config : AoRTestConfig
        The test (tube radius, fill packing fraction).
    rng : numpy.random.Generator
        Random source (positions and orientations).

    Returns
    -------
    indices : (n,) int ndarray
        Clump indices (into ``scales``) in placement order.
    positions : (n, 3) ndarray
        Their centres, m.
    orientations : (n, 4) ndarray
        Their unit quaternions (w, x, y, z).

    Raises
    ------
    InputError
        If the clumps do not fit (lower ``fill.count``).
    """
    r_in = 0.5 * config.geometry.cylinder_inner_diameter
    n = len(scales)
    mean_vol = template.volume * float(np.mean(scales**3))
    height = n * mean_vol / (config.fill.packing_fraction * math.pi * r_in**2)
    z_low = float(scales.max() * template.bounding_radius)
    grid = SphereGrid(2.0 * float(template.radii.max() * scales.max()))
    todo = np.arange(n)
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    for _ in range(20):
        idx, pos, quat = place_in_cylinder(template, scales[todo], radius=r_in, z_low=z_low,
                                           z_high=z_low + height, rng=rng, grid=grid,
                                           attempts=30)
        if len(idx):
            parts.append((todo[idx], pos, quat))
        todo = np.delete(todo, idx)
        if len(todo) == 0:
            break
        height *= 1.25
    if len(todo):
        raise InputError(f"could not place {len(todo)} of {n} particles in the cylinder; "
                         "lower fill.count")
    return (np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
            np.concatenate([p[2] for p in parts]))
