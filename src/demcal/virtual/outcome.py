"""Typed outcomes of a virtual angle-of-repose test and the criteria that decide them.

- ``pile``: the material formed a pile whose angle was measured;
- ``column``: the cylinder cleared the material but it still stands (little mass outside the
  cylinder's radius, most of its fill height);
- ``plug``: the material rose with the cylinder (much of it still inside the tube after the lift);
- ``scattered``: the material settled but forms no measurable pile (it spread flat or left the
  plate, so the flank fit found no straight part);
- ``unsettled``: a phase did not come to rest within its time limit;
- ``unstable``: numerical failure of the engine (NaN, runaway speed, excessive overlap).

Only ``pile`` carries an angle; the others are physical (or numerical) outcomes that the design
stages store and handle, never average in. The criteria are pure functions of particle states
(tested on constructed states) with thresholds from :class:`~demcal.virtual.config.OutcomeCriteria`.
"""

from __future__ import annotations

from enum import StrEnum

import numpy as np

from demcal.virtual.config import AoRTestConfig, OutcomeCriteria

__all__ = ["Outcome", "classify_after_lift", "classify_settled", "footprint", "mass_in_tube",
           "mass_outside"]


class Outcome(StrEnum):
    """Outcome of one virtual test."""

    PILE = "pile"
    COLUMN = "column"
    PLUG = "plug"
    SCATTERED = "scattered"
    UNSETTLED = "unsettled"
    UNSTABLE = "unstable"


def classify_after_lift(positions: np.ndarray, masses: np.ndarray, *, tube_bottom: float,
                        tube_height: float, tube_radius: float,
                        criteria: OutcomeCriteria) -> tuple[Outcome | None, str | None]:
    """``plug`` if at least ``criteria.plug_mass_fraction`` of the mass is still in the tube.

    Parameters
    ----------
    positions : (n, 3) ndarray
        Clump centres, m (the tube's axis is the z axis).
    masses : (n,) ndarray
        Clump masses, kg.
    tube_bottom, tube_height, tube_radius : float
        Current bottom rim height, length and inner radius of the tube, m.
    criteria : OutcomeCriteria
        Thresholds.

    Returns
    -------
    (Outcome.PLUG, reason) or (None, None)
    """
    total = float(np.sum(masses))
    if total <= 0:
        return None, None
    frac = mass_in_tube(positions, masses, tube_bottom=tube_bottom, tube_height=tube_height,
                        tube_radius=tube_radius) / total
    if frac >= criteria.plug_mass_fraction:
        return Outcome.PLUG, (f"{frac:.0%} of the mass rose with the cylinder (plug threshold "
                              f"{criteria.plug_mass_fraction:.0%})")
    return None, None


def mass_in_tube(positions: np.ndarray, masses: np.ndarray, *, tube_bottom: float,
                 tube_height: float, tube_radius: float) -> float:
    """The mass inside the cylinder, kg: clumps whose centre lies within its inner radius of
    its axis (the z axis) and between its bottom rim and its top.

    After the lift it is what the cylinder retained (the lift test's ``mass_left_kg``): the
    material held up in the tube by its wall friction or cohesion instead of flowing out into
    the pile; the plug rule (:func:`classify_after_lift`) reads it as a fraction. Clump centres
    decide, as for the plug, so a particle straddling the rim counts on one side only.

    Parameters
    ----------
    positions : (n, 3) ndarray
        Clump centres, m.
    masses : (n,) ndarray
        Clump masses, kg.
    tube_bottom, tube_height, tube_radius : float
        The cylinder's bottom rim height (where the lift left it), length and inner radius, m.

    Returns
    -------
    float
        kg; 0.0 for no clump.
    """
    positions = np.asarray(positions, dtype=float).reshape(-1, 3)
    masses = np.asarray(masses, dtype=float).reshape(-1)
    rho = np.hypot(positions[:, 0], positions[:, 1])
    inside = (rho < tube_radius) & (positions[:, 2] > tube_bottom) & (
        positions[:, 2] < tube_bottom + tube_height)
    return float(np.sum(masses[inside]))


def footprint(config: AoRTestConfig) -> dict[str, float]:
    """The cylinder's inner radius and the longest particle of a test, m: the footprint
    arguments (``tube_radius``, ``particle_length``) of :func:`classify_settled` and
    :func:`mass_outside`, the same for every engine."""
    return {"tube_radius": 0.5 * config.geometry.cylinder_inner_diameter,
            "particle_length": config.particle.length * config.particle.size_max}


def mass_outside(positions: np.ndarray, masses: np.ndarray, *, tube_radius: float,
                 particle_length: float) -> float:
    """Fraction of the mass (0-1) outside the cylinder's footprint: clump centres farther
    than ``tube_radius + particle_length / 2`` (m) from its axis (the z axis);
    ``positions`` (n, 3) m, ``masses`` (n,) kg."""
    total = float(np.sum(masses))
    if total <= 0:
        return 0.0
    rho = np.hypot(positions[:, 0], positions[:, 1])
    return float(np.sum(masses[rho > tube_radius + 0.5 * particle_length])) / total


def classify_settled(positions: np.ndarray, masses: np.ndarray, *, fill_height: float,
                     material_top: float, tube_radius: float, particle_length: float,
                     criteria: OutcomeCriteria) -> tuple[Outcome, str | None]:
    """``column`` if the settled material still stands inside the cylinder's footprint.

    The material is a column when less than ``criteria.column_outside_fraction`` of its mass lies
    farther from the axis than ``tube_radius + particle_length / 2`` and its top is at least
    ``criteria.column_height_fraction`` of the fill height; otherwise a pile.

    Parameters
    ----------
    positions, masses : ndarray
        Clump centres (m) and masses (kg) of the settled material.
    fill_height : float
        Height of the settled fill before the lift, m.
    material_top : float
        Height of the highest sphere surface now, m.
    tube_radius : float
        Inner radius of the cylinder, m.
    particle_length : float
        Largest particle length, m.
    criteria : OutcomeCriteria
        Thresholds.
    """
    if float(np.sum(masses)) <= 0:
        return Outcome.SCATTERED, "no material left on the plate"
    outside = mass_outside(positions, masses, tube_radius=tube_radius,
                           particle_length=particle_length)
    standing = fill_height > 0 and material_top >= criteria.column_height_fraction * fill_height
    if outside < criteria.column_outside_fraction and standing:
        return Outcome.COLUMN, (
            f"the material still stands after the cylinder cleared it: {outside:.0%} of the mass "
            f"outside the cylinder's footprint (column threshold "
            f"{criteria.column_outside_fraction:.0%}), top at {material_top / fill_height:.0%} "
            "of the fill height")
    return Outcome.PILE, None
