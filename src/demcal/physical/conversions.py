"""Pure conversions from bench readings to material parameters (SI units).

Every function takes a scalar or a 1-D array of repeats and returns float64 values of the
same length (a float for scalar input where stated), after checking the input and raising
:class:`~demcal.errors.InputError` that names the argument and the allowed range.

- density by the overflow method: ``rho = m / V`` (the paper's Eq. 1);
- isotropic elasticity: ``E = 2 G (1 + v)`` (Eq. 2) and its inverses;
- static friction from the tilt angle of an inclined plane at the onset of sliding:
  ``mu = tan(alpha)`` (Eq. 3);
- uniaxial compression of a cylindrical specimen: Poisson ratio and Young's modulus;
- the Rayleigh time step ``T_R = pi R sqrt(rho / G) / (0.1631 v + 0.8766)``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from demcal.errors import InputError
from demcal.physical._validate import as_scalar, as_values

__all__ = [
    "angle_from_friction",
    "compression_test",
    "density_from_overflow",
    "friction_from_angle",
    "poisson_from_moduli",
    "rayleigh_time_step",
    "shear_modulus_from_youngs",
    "youngs_modulus_from_shear",
]

_POISSON = {"low": 0.0, "high": 0.5, "high_inclusive": False}
_POSITIVE = {"low": 0.0, "low_inclusive": False}


def _pair(a: np.ndarray, b: np.ndarray, na: str, nb: str) -> tuple[np.ndarray, np.ndarray]:
    if a.size != b.size and a.size != 1 and b.size != 1:
        raise InputError(
            f"{na} and {nb} must have the same number of repeats (or one of them a single "
            f"value); got {a.size} and {b.size}"
        )
    return np.broadcast_arrays(a, b)


def density_from_overflow(mass: Any, volume: Any) -> np.ndarray:
    """Bulk density of each repeat of the overflow (water displacement) method.

    Parameters
    ----------
    mass : float or (n,) array_like
        Mass of the sample, kg (> 0).
    volume : float or (n,) array_like
        Volume of the displaced (overflowed) water, m^3 (> 0); same length as ``mass`` or
        a single value.

    Returns
    -------
    (n,) float64 ndarray
        Densities ``mass / volume``, kg/m^3.

    Examples
    --------
    >>> density_from_overflow(5e-3, 43.72e-6).round(2).tolist()
    [114.36]
    """
    m = as_values(mass, "mass", "kg", **_POSITIVE)
    v = as_values(volume, "volume", "m^3", **_POSITIVE)
    m, v = _pair(m, v, "mass", "volume")
    return m / v


def youngs_modulus_from_shear(shear_modulus: Any, poisson: Any) -> np.ndarray:
    """Young's modulus of an isotropic solid, ``E = 2 G (1 + v)``.

    Parameters
    ----------
    shear_modulus : float or (n,) array_like
        Shear modulus G, Pa (> 0).
    poisson : float or (n,) array_like
        Poisson ratio v, in [0, 0.5).

    Returns
    -------
    (n,) float64 ndarray
        Young's modulus E, Pa.

    Examples
    --------
    >>> youngs_modulus_from_shear(2.5e6, 0.3).tolist()
    [6500000.0]
    """
    g = as_values(shear_modulus, "shear_modulus", "Pa", **_POSITIVE)
    nu = as_values(poisson, "poisson", "dimensionless", **_POISSON)
    g, nu = _pair(g, nu, "shear_modulus", "poisson")
    return 2.0 * g * (1.0 + nu)


def shear_modulus_from_youngs(youngs_modulus: Any, poisson: Any) -> np.ndarray:
    """Shear modulus of an isotropic solid, ``G = E / (2 (1 + v))``.

    Parameters
    ----------
    youngs_modulus : float or (n,) array_like
        Young's modulus E, Pa (> 0).
    poisson : float or (n,) array_like
        Poisson ratio v, in [0, 0.5).

    Returns
    -------
    (n,) float64 ndarray
        Shear modulus G, Pa.
    """
    e = as_values(youngs_modulus, "youngs_modulus", "Pa", **_POSITIVE)
    nu = as_values(poisson, "poisson", "dimensionless", **_POISSON)
    e, nu = _pair(e, nu, "youngs_modulus", "poisson")
    return e / (2.0 * (1.0 + nu))


def poisson_from_moduli(youngs_modulus: Any, shear_modulus: Any) -> np.ndarray:
    """Poisson ratio of an isotropic solid, ``v = E / (2 G) - 1``.

    Parameters
    ----------
    youngs_modulus : float or (n,) array_like
        Young's modulus E, Pa (> 0).
    shear_modulus : float or (n,) array_like
        Shear modulus G, Pa (> 0).

    Returns
    -------
    (n,) float64 ndarray
        Poisson ratio v.

    Raises
    ------
    InputError
        If a resulting ratio lies outside [0, 0.5), i.e. ``2 G <= E < 3 G`` is violated.
    """
    e = as_values(youngs_modulus, "youngs_modulus", "Pa", **_POSITIVE)
    g = as_values(shear_modulus, "shear_modulus", "Pa", **_POSITIVE)
    e, g = _pair(e, g, "youngs_modulus", "shear_modulus")
    nu = e / (2.0 * g) - 1.0
    bad = np.flatnonzero((nu < 0.0) | (nu >= 0.5))
    if bad.size:
        i = int(bad[0])
        raise InputError(
            "poisson (from youngs_modulus / (2 shear_modulus) - 1) must be in [0, 0.5); got "
            f"{nu[i]:.4g} for youngs_modulus={e[i]:g} Pa, shear_modulus={g[i]:g} Pa (repeat {i})"
        )
    return nu


def friction_from_angle(angle_deg: Any) -> np.ndarray:
    """Static friction coefficient from the inclined-plane angle at the onset of sliding.

    ``mu = tan(alpha)``: at the onset of sliding the tangential component of the weight,
    ``W sin(alpha)``, equals ``mu W cos(alpha)``.

    Parameters
    ----------
    angle_deg : float or (n,) array_like
        Tilt angle of the plane when the sample starts to slide, degrees, in [0, 90).

    Returns
    -------
    (n,) float64 ndarray
        Static friction coefficients (dimensionless).

    Examples
    --------
    >>> friction_from_angle([21.0, 35.0]).round(2).tolist()
    [0.38, 0.7]
    """
    a = as_values(angle_deg, "angle_deg", "degrees", low=0.0, high=90.0, high_inclusive=False)
    return np.tan(np.radians(a))


def angle_from_friction(mu: Any) -> np.ndarray:
    """Inclined-plane angle (degrees) at which a sample with friction ``mu`` starts to slide.

    Parameters
    ----------
    mu : float or (n,) array_like
        Static friction coefficient (>= 0).

    Returns
    -------
    (n,) float64 ndarray
        ``degrees(arctan(mu))``, in [0, 90).
    """
    m = as_values(mu, "mu", "dimensionless", low=0.0)
    return np.degrees(np.arctan(m))


def compression_test(
    *,
    height_before: Any,
    height_after: Any,
    diameter_before: Any,
    diameter_after: Any,
    force: Any | None = None,
) -> tuple[np.ndarray, np.ndarray | None]:
    """Poisson ratio (and Young's modulus) from an axial compression of a cylinder.

    The specimen (a cylinder of diameter ``d0`` and height ``h0``) is compressed along its
    axis within its linear-elastic range to ``h1`` while its diameter grows to ``d1``.
    Engineering (small) strains: axial ``e_a = (h0 - h1) / h0``, lateral
    ``e_l = (d1 - d0) / d0``; ``v = e_l / e_a``; with the axial force ``F`` at that
    deformation, ``E = (F / (pi d0^2 / 4)) / e_a``. The relations hold for uniaxial stress in
    an isotropic, linear-elastic specimen; for a strongly anisotropic or plastic material
    (most stalks) the values are effective ones, as in the paper.

    Parameters
    ----------
    height_before, height_after : float or (n,) array_like, keyword-only
        Specimen height before and under load, m (0 < after < before).
    diameter_before, diameter_after : float or (n,) array_like, keyword-only
        Specimen diameter before and under load, m (0 < before <= after).
    force : float or (n,) array_like or None, keyword-only
        Axial force at the loaded state, N (> 0); None to skip E.

    Returns
    -------
    poisson : (n,) float64 ndarray
        Poisson ratio of each repeat.
    youngs_modulus : (n,) float64 ndarray or None
        Young's modulus of each repeat, Pa, or None without ``force``.

    Raises
    ------
    InputError
        Bad geometry, or a Poisson ratio outside [0, 0.5) (naming the repeat).
    """
    h0 = as_values(height_before, "height_before", "m", **_POSITIVE)
    h1 = as_values(height_after, "height_after", "m", **_POSITIVE)
    d0 = as_values(diameter_before, "diameter_before", "m", **_POSITIVE)
    d1 = as_values(diameter_after, "diameter_after", "m", **_POSITIVE)
    sizes = {a.size for a in (h0, h1, d0, d1)} - {1}
    if len(sizes) > 1:
        raise InputError(
            "height_before, height_after, diameter_before and diameter_after must have the "
            f"same number of repeats; got {h0.size}, {h1.size}, {d0.size}, {d1.size}"
        )
    h0, h1, d0, d1 = np.broadcast_arrays(h0, h1, d0, d1)
    for i in range(h0.size):
        if not h1[i] < h0[i]:
            raise InputError(
                f"height_after must be < height_before (a compression); repeat {i}: "
                f"height_before={h0[i]:g} m, height_after={h1[i]:g} m"
            )
        if d1[i] < d0[i]:
            raise InputError(
                f"diameter_after must be >= diameter_before under compression; repeat {i}: "
                f"diameter_before={d0[i]:g} m, diameter_after={d1[i]:g} m"
            )
    axial = (h0 - h1) / h0
    lateral = (d1 - d0) / d0
    nu = lateral / axial
    bad = np.flatnonzero(nu >= 0.5)
    if bad.size:
        i = int(bad[0])
        raise InputError(
            f"poisson from the compression test must be < 0.5; repeat {i} gives {nu[i]:.4g} "
            f"(lateral strain {lateral[i]:.4g}, axial strain {axial[i]:.4g})"
        )
    youngs = None
    if force is not None:
        f = as_values(force, "force", "N", **_POSITIVE)
        if f.size not in (1, h0.size):
            raise InputError(
                f"force must have one value per repeat ({h0.size}) or a single value; "
                f"got {f.size}"
            )
        youngs = (f / (math.pi * d0**2 / 4.0)) / axial
    return nu, youngs


def rayleigh_time_step(
    radius: float,
    *,
    density: float,
    shear_modulus: float,
    poisson: float,
) -> float:
    """Rayleigh time step of the smallest particle, s.

    ``T_R = pi R sqrt(rho / G) / (0.1631 v + 0.8766)``: the time a Rayleigh surface wave
    takes to cross a sphere of radius R. DEM codes use a fraction of it as the time step
    (the paper: 20 %).

    Parameters
    ----------
    radius : float
        Radius of the smallest sphere, m (> 0).
    density : float, keyword-only
        Particle density, kg/m^3 (> 0).
    shear_modulus : float, keyword-only
        Particle shear modulus, Pa (> 0).
    poisson : float, keyword-only
        Particle Poisson ratio, in [0, 0.5).

    Returns
    -------
    float
        T_R, s.

    Examples
    --------
    >>> round(rayleigh_time_step(2e-3, density=114.36, shear_modulus=2.5e6, poisson=0.3), 9)
    4.5915e-05
    """
    r = as_scalar(radius, "radius", "m", **_POSITIVE)
    rho = as_scalar(density, "density", "kg/m^3", **_POSITIVE)
    g = as_scalar(shear_modulus, "shear_modulus", "Pa", **_POSITIVE)
    nu = as_scalar(poisson, "poisson", "dimensionless", **_POISSON)
    return math.pi * r * math.sqrt(rho / g) / (0.1631 * nu + 0.8766)
