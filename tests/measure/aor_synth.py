"""Synthetic test data with a known angle: sphere cones and pile photos."""

from __future__ import annotations

import math

import numpy as np


def sphere_cone(angle_deg: float, *, base_radius: float = 0.02, radius: float = 0.001,
                rng: np.random.Generator, roughness: float = 0.35, spacing: float = 1.5,
                top_fraction: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Spheres filling a cone (axis at x = y = 0, base on z = 0) of slope ``angle_deg``.

    Centres on a jittered cubic lattice (pitch ``spacing * radius``, jitter uniform within
    ``roughness * radius``; radii uniform in 0.75-1.25 ``radius``) whose centres lie inside
    the cone, so the surface is rough on the particle scale. ``top_fraction`` < 1 cuts the
    cone flat at that fraction of its height (a mesa). Returns centres (n, 3) m, radii (n,) m.
    """
    tan = math.tan(math.radians(angle_deg))
    height = base_radius * tan
    pitch = spacing * radius
    g = np.arange(-base_radius - pitch, base_radius + pitch, pitch)
    zs = np.arange(0.5 * pitch, height, pitch)
    x, y, z = np.meshgrid(g, g, zs, indexing="ij")
    pts = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    pts = pts + rng.uniform(-roughness, roughness, pts.shape) * radius
    rho = np.hypot(pts[:, 0], pts[:, 1])
    inside = (pts[:, 2] <= (base_radius - rho) * tan) & (pts[:, 2] >= 0.5 * radius)
    inside &= pts[:, 2] <= top_fraction * height
    pts = pts[inside]
    radii = radius * rng.uniform(0.75, 1.25, len(pts))
    return pts, radii


def skirt_and_strays(base_radius: float, radius: float, *, rng: np.random.Generator,
                     skirt_to: float = 1.4, n_strays: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """A one-layer skirt of spheres on the plate out to ``skirt_to * base_radius`` and a few
    stray spheres far out on the plate (unconnected to the pile)."""
    n_skirt = int(4 * (skirt_to**2 - 0.5**2) * base_radius**2 / radius**2)
    rho = base_radius * np.sqrt(rng.uniform(0.5**2, skirt_to**2, n_skirt))
    phi = rng.uniform(0, 2 * math.pi, n_skirt)
    skirt = np.column_stack([rho * np.cos(phi), rho * np.sin(phi),
                             radius * rng.uniform(0.9, 1.1, n_skirt)])
    rho_s = base_radius * rng.uniform(2.0, 3.0, n_strays)
    phi_s = rng.uniform(0, 2 * math.pi, n_strays)
    strays = np.column_stack([rho_s * np.cos(phi_s), rho_s * np.sin(phi_s),
                              np.full(n_strays, radius)])
    centres = np.vstack([skirt, strays])
    return centres, np.full(len(centres), radius)

