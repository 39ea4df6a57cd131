"""The loose bulk density of the lift test's fill, read as a lab reads it.

A lab fills the cylinder loosely, reads the fill level on the cylinder (the mean height of the
material's top surface, not its highest stalk) and weighs the material: bulk density = mass /
(pi R^2 level). The simulated fill is read the same way once it has settled, before the lift:
the top surface is the highest sphere top in each cell of a square grid over the cylinder's
cross-section (cells of one particle diameter, only cells whose centre lies within
``interior`` of the radius, so the wall's own packing is left out), and the level is the mean
of those tops. Pure functions of the spheres (tested on constructed fills).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["bulk_density", "fill_level"]


def fill_level(centres: np.ndarray, radii: np.ndarray, *, tube_radius: float, cell: float,
               interior: float = 0.8) -> float | None:
    """The fill's level, m: the mean of the highest sphere top per occupied grid cell.

    Parameters
    ----------
    centres : (n, 3) ndarray
        Sphere centres, m (the cylinder's axis is the z axis, its floor at z = 0).
    radii : (n,) ndarray
        Sphere radii, m.
    tube_radius : float
        The cylinder's inner radius, m.
    cell : float
        Grid cell size, m (about one particle diameter: finer cells read the gaps between
        particles as the surface).
    interior : float
        Only cells whose centre lies within ``interior * tube_radius`` of the axis.

    Returns
    -------
    float or None
        None for an empty fill or one with no occupied interior cell.
    """
    c = np.asarray(centres, dtype=float).reshape(-1, 3)
    r = np.asarray(radii, dtype=float).reshape(-1)
    if c.shape[0] == 0 or not (cell > 0 and tube_radius > 0):
        return None
    reach = interior * tube_radius
    n_side = math.ceil(2 * reach / cell)
    ix = np.floor((c[:, 0] + reach) / cell).astype(np.int64)
    iy = np.floor((c[:, 1] + reach) / cell).astype(np.int64)
    inside = (ix >= 0) & (ix < n_side) & (iy >= 0) & (iy < n_side)
    cx = -reach + (ix + 0.5) * cell
    cy = -reach + (iy + 0.5) * cell
    inside &= np.hypot(cx, cy) <= reach
    if not inside.any():
        return None
    flat = ix[inside] * n_side + iy[inside]
    tops = np.full(n_side * n_side, -np.inf)
    np.maximum.at(tops, flat, c[inside, 2] + r[inside])
    occupied = tops[np.isfinite(tops)]
    return float(occupied.mean())


def bulk_density(mass_kg: float, level_m: float | None, tube_radius: float) -> float | None:
    """Loose bulk density, kg/m^3: ``mass / (pi R^2 level)``; None without a level."""
    if level_m is None or not level_m > 0 or not tube_radius > 0 or not mass_kg > 0:
        return None
    return float(mass_kg / (math.pi * tube_radius**2 * level_m))
