"""The fill's level and loose bulk density, read as a lab reads them (demcal.virtual.fill)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from demcal.virtual.fill import bulk_density, fill_level

R_TUBE = 0.05  # m
R = 0.0025  # sphere radius, m


def _lattice(layers: int, *, radius: float = R, tube: float = R_TUBE) -> np.ndarray:
    """Simple-cubic layers of touching spheres inside the cylinder (centres, m)."""
    g = np.arange(-tube + radius, tube - radius + 1e-12, 2 * radius)
    x, y = np.meshgrid(g, g, indexing="ij")
    keep = np.hypot(x, y) <= tube - radius
    xy = np.column_stack([x[keep], y[keep]])
    return np.vstack([np.column_stack([xy, np.full(len(xy), radius * (2 * k + 1))])
                      for k in range(layers)])


def test_a_flat_fill_reads_its_top_and_the_lattice_density() -> None:
    centres = _lattice(6)
    level = fill_level(centres, np.full(len(centres), R), tube_radius=R_TUBE, cell=2 * R)
    assert level == pytest.approx(12 * R)
    rho_p = 1000.0
    mass = len(centres) * rho_p * 4 / 3 * math.pi * R**3
    # the lattice fills the cylinder's cross-section up to the wall's gap: close to the
    # simple-cubic packing fraction pi/6, less the wall's missing partial cells
    rho_b = bulk_density(mass, level, R_TUBE)
    assert 0.85 * math.pi / 6 * rho_p < rho_b < math.pi / 6 * rho_p


def test_one_sphere_on_top_does_not_lift_the_level() -> None:
    """The highest particle is not the level (a lab reads the surface, not its tallest stalk)."""
    centres = _lattice(6)
    stray = np.vstack([centres, [[0.0, 0.0, 30 * R]]])
    radii = np.full(len(stray), R)
    level = fill_level(stray, radii, tube_radius=R_TUBE, cell=2 * R)
    top = float(np.max(stray[:, 2] + radii))
    assert level < 12 * R * 1.02 < top


def test_the_wall_ring_is_left_out() -> None:
    """A ring of spheres heaped against the wall does not count (its cells are outside)."""
    centres = _lattice(4)
    ring = np.column_stack([0.95 * R_TUBE * np.cos(np.linspace(0, 2 * np.pi, 60)),
                            0.95 * R_TUBE * np.sin(np.linspace(0, 2 * np.pi, 60)),
                            np.full(60, 20 * R)])
    all_c = np.vstack([centres, ring])
    level = fill_level(all_c, np.full(len(all_c), R), tube_radius=R_TUBE, cell=2 * R)
    assert level == pytest.approx(8 * R)


def test_nothing_to_read() -> None:
    assert fill_level(np.empty((0, 3)), np.empty(0), tube_radius=R_TUBE, cell=2 * R) is None
    assert bulk_density(1.0, None, R_TUBE) is None
    assert bulk_density(0.0, 0.1, R_TUBE) is None
