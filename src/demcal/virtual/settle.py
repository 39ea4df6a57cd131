"""When is a virtual test at rest? The settle criterion of a phase (pure functions, SI units).

A phase is settled when the root-mean-square clump speed (the kinetic energy per particle)
and the largest clump speed are below their thresholds, both taken over *the clumps that touch
another clump* (the pile). A clump that touches no other one (a stalk rolling away alone
across the plate on a low rolling friction) is not part of the pile and does not hold the test
back until it stops: with the corn stalk's lowest plate rolling friction (0.01) such stalks
rolled on for more than a second after the pile had come to rest. When at most half of the
clumps touch another (the material is scattered, or still falling), every clump counts.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["SettleState", "settle_state", "touching_clumps"]

#: (clump ids of the velocity rows, sphere centres, sphere radii, sphere clump ids)
Spheres = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


@dataclass(frozen=True)
class SettleState:
    """Speeds that decide the settle criterion (m/s) and the number of lone clumps."""

    settled: bool
    rms_speed: float
    max_speed: float
    n_alone: int


def touching_clumps(centres: np.ndarray, radii: np.ndarray, sphere_clump: np.ndarray,
                    tolerance: float) -> np.ndarray:
    """Ids of the clumps one of whose spheres touches (within ``tolerance``, m) a sphere of
    another clump. ``centres`` (n, 3) m, ``radii`` (n,) m, ``sphere_clump`` (n,) clump ids."""
    if len(radii) < 2:
        return np.empty(0, dtype=sphere_clump.dtype)
    tree = cKDTree(centres)
    pairs = tree.query_pairs(2.0 * float(radii.max()) + tolerance, output_type="ndarray")
    if len(pairs) == 0:
        return np.empty(0, dtype=sphere_clump.dtype)
    i, j = pairs[:, 0], pairs[:, 1]
    gap = np.linalg.norm(centres[i] - centres[j], axis=1) - radii[i] - radii[j]
    keep = (gap < tolerance) & (sphere_clump[i] != sphere_clump[j])
    return np.unique(np.concatenate([sphere_clump[i[keep]], sphere_clump[j[keep]]]))


def settle_state(velocities: np.ndarray, spheres: Callable[[], Spheres], *, rms_limit: float,
                 max_limit: float, tolerance: float) -> SettleState:
    """Whether clumps with these velocities are at rest (see the module docstring).

    Parameters
    ----------
    velocities : (m, 3) ndarray
        Clump velocities, m/s.
    spheres : callable
        Returns ``(clump_ids, centres, radii, sphere_clump)``: the ids of the clumps of
        ``velocities``' rows (m,), and their spheres' centres (n, 3) m, radii (n,) m and clump
        ids (n,). Called only when the speeds alone do not decide (most checks need no
        sphere data, which on a GPU is a copy from the device).
    rms_limit, max_limit : float
        Thresholds on the rms and the largest speed of the pile's clumps, m/s.
    tolerance : float
        Largest gap between two spheres that still counts as touching, m.
    """
    if len(velocities) == 0:
        return SettleState(True, 0.0, 0.0, 0)
    speed2 = np.sum(velocities * velocities, axis=1)
    if _settled(speed2, rms_limit, max_limit):
        return SettleState(True, *_speeds(speed2), 0)
    # only now is the (costlier) contact test needed: are the fast clumps part of the pile?
    clump_ids, centres, radii, sphere_clump = spheres()
    touching = np.isin(clump_ids, touching_clumps(centres, radii, sphere_clump, tolerance))
    n_alone = 0
    if 2 * np.count_nonzero(touching) > len(speed2):
        n_alone = int(np.count_nonzero(~touching))
        speed2 = speed2[touching]
    return SettleState(_settled(speed2, rms_limit, max_limit), *_speeds(speed2), n_alone)


def _speeds(speed2: np.ndarray) -> tuple[float, float]:
    return float(np.sqrt(np.mean(speed2))), float(np.sqrt(speed2.max()))


def _settled(speed2: np.ndarray, rms_limit: float, max_limit: float) -> bool:
    rms, vmax = _speeds(speed2)
    return rms < rms_limit and vmax < max_limit
