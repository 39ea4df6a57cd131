"""Host-side description of what a simulation holds: clump groups and worlds.

A :class:`World` is one independent simulation (its materials, walls, particles, domain);
one :class:`~demcal.dem.simulation.Simulation` runs many worlds at once (batched).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from demcal.dem.materials import MaterialTable
from demcal.dem.walls import PlaneWall, TubeWall
from demcal.errors import InputError

__all__ = ["ClumpGroup", "World", "random_quaternions"]


@dataclass
class ClumpGroup:
    """A set of clumps of one template and one material in a world.

    Parameters
    ----------
    template : ClumpTemplate
        Multi-sphere template (``offsets`` (n, 3) m in the principal frame, ``radii`` (n,) m,
        ``volume`` m^3, ``inertia_per_density`` (3,) m^5), see :mod:`demcal.dem.shapes`.
    material : str
        Name of the particle material in the world's :class:`MaterialTable`.
    count : int
        Number of clumps (the capacity, for clumps inserted later by a factory).
    scales : (count,) array_like, optional
        Size factor of each clump (lengths x s, mass x s^3, inertia x s^5); default 1.
    positions : (count, 3) array_like, optional
        Initial centres of mass, m. If omitted the clumps start inactive (to be placed with
        :meth:`Simulation.place_clumps`).
    orientations : (count, 4) array_like, optional
        Unit quaternions (w, x, y, z), body to space; default identity.
    velocities, angular_velocities : (count, 3) array_like, optional
        Initial velocities (m/s) and angular velocities (rad/s, space frame); default 0.
    """

    template: Any
    material: str
    count: int
    scales: np.ndarray | None = None
    positions: np.ndarray | None = None
    orientations: np.ndarray | None = None
    velocities: np.ndarray | None = None
    angular_velocities: np.ndarray | None = None

    def scale_array(self) -> np.ndarray:
        if self.scales is None:
            return np.ones(self.count)
        s = np.asarray(self.scales, dtype=np.float64).reshape(-1)
        if s.shape != (self.count,) or not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise InputError(f"scales must be {self.count} positive numbers")
        return s


@dataclass
class World:
    """One independent simulation.

    Parameters
    ----------
    materials : MaterialTable
        Materials and pair interactions.
    groups : list of ClumpGroup
        The particles.
    walls : list of PlaneWall or TubeWall
        The walls (at most a few; each sphere checks all of its world's walls).
    domain_lo, domain_hi : (3,) array_like
        Box outside which clumps are removed (and counted), m.
    gravity : (3,) array_like
        Gravitational acceleration, m/s^2.
    time_step : float, optional
        Fixed time step, s; default: the simulation's ``dt_fraction`` of the Rayleigh step of
        the world's smallest sphere.
    """

    materials: MaterialTable
    groups: list[ClumpGroup]
    walls: list[PlaneWall | TubeWall] = field(default_factory=list)
    domain_lo: tuple[float, float, float] = (-1.0, -1.0, -1.0)
    domain_hi: tuple[float, float, float] = (1.0, 1.0, 1.0)
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.81)
    time_step: float | None = None


def random_quaternions(n: int, rng: np.random.Generator) -> np.ndarray:
    """Uniformly distributed random unit quaternions (Shoemake 1992), ``(n, 4)`` (w, x, y, z)."""
    u1, u2, u3 = rng.random((3, n))
    a = np.sqrt(1.0 - u1)
    b = np.sqrt(u1)
    return np.stack([b * np.cos(2 * np.pi * u3), a * np.sin(2 * np.pi * u2),
                     a * np.cos(2 * np.pi * u2), b * np.sin(2 * np.pi * u3)], axis=1)


def rotate(quats: np.ndarray, vecs: np.ndarray) -> np.ndarray:
    """Rotate vectors ``(n, 3)`` by unit quaternions ``(n, 4)`` (w, x, y, z) (vectorised)."""
    w = quats[:, :1]
    u = quats[:, 1:]
    t = 2.0 * np.cross(u, vecs)
    return vecs + w * t + np.cross(u, t)


def rotate_inverse(quats: np.ndarray, vecs: np.ndarray) -> np.ndarray:
    """Rotate vectors by the inverse of unit quaternions (space -> body)."""
    conj = quats.copy()
    conj[:, 1:] *= -1.0
    return rotate(conj, vecs)
