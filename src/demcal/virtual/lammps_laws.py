"""demcal's contact parameters as LAMMPS ``pair_style granular`` coefficients (pure functions).

The mapping (SI units; see docs/lammps.md for what differs between the engines' laws):

- **moduli**: LAMMPS ``hertz/material`` takes (E, nu) per atom type and mixes a pair of
  identical types as E* = E / (2 (1 - nu^2)); a ``wall/gran`` wall is treated the same way (the
  wall's coefficients stand for both bodies). So every contact gets the (E, nu) that reproduces
  demcal's E* and G* of that pair of materials (:func:`equivalent_moduli`): particle-particle
  is the particle's own (E, nu); particle-steel is an (E, nu) with the particle-steel E*, G*.
- **damping**: ``damping coeff_restitution`` is demcal's (EDEM's) law exactly: normal damping
  2 sqrt(5/6) |beta| sqrt(S_n m*) with S_n = 2 E* a; the tangential damping is
  ``x_gamma_t`` = sqrt(4 G*/E*) times it, which is demcal's 2 sqrt(5/6) |beta| sqrt(S_t m*)
  with S_t = 8 G* a. LAMMPS refuses that damping with ``jkr``: a cohesive pair uses
  ``damping viscoelastic`` (eta = eta0 m* a) with eta0 chosen to give demcal's damping at a
  typical contact (:func:`typical_contact`).
- **tangential**: ``tangential mindlin NULL`` (k_t = 8 G* a), history kept, Coulomb limit
  mu_s |F_n| (LAMMPS: elastic + damping force; demcal: elastic only).
- **rolling**: ``rolling sds`` (spring-dashpot-slider) with mu_roll = mu_r: torque limit
  mu_r R* F_n, the lever arm R* of demcal's model C; the spring k_roll (N/m, torque
  k_roll R*^2 per radian) is demcal's model-C spring 2.25 (2 E* a) mu_r^2 R*^2 at a typical
  contact (LAMMPS' spring is constant, demcal's grows with a), no rolling damping (demcal's
  model C has none). demcal's model A (EDEM's constant torque with the centre-of-mass lever
  arm) has no LAMMPS counterpart; this mapping is model C's.
- **cohesion**: ``jkr`` with the surface energy gamma (LAMMPS' JKR is the hysteretic version 2
  of docs/physics.md, friction limited by |F_ne + 2 F_pulloff|; demcal's is version 1).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import NamedTuple

__all__ = [
    "LAWS_VERSION",
    "ContactLaw",
    "contact_laws",
    "equivalent_moduli",
    "model_string",
    "typical_contact",
]

#: Version of this mapping: part of a LAMMPS run's identity in a study's store (a changed
#: mapping gives other results, so its runs are not mixed with older ones).
LAWS_VERSION = 1

#: 2 sqrt(5/6), EDEM's damping prefactor
_DF = 2.0 * math.sqrt(5.0 / 6.0)


@dataclass(frozen=True)
class ContactLaw:
    """LAMMPS coefficients of one kind of contact (particle-particle or particle-wall)."""

    young: float  #: E given to LAMMPS, Pa
    poisson: float  #: nu given to LAMMPS
    restitution: float  #: e
    friction: float  #: mu_s
    x_gamma_t: float  #: tangential / normal damping ratio
    rolling: float  #: mu_roll
    k_roll: float  #: rolling spring, N/m
    gamma: float  #: surface energy, J/m^2 (jkr when > 0)
    eta0: float  #: viscoelastic damping for jkr, 1/(m s)


class Elastic(NamedTuple):
    """A material's elastic constants."""

    young: float  #: Young's modulus E, Pa
    poisson: float  #: Poisson's ratio nu
    shear: float  #: shear modulus G, Pa


def _pair_moduli(one: Elastic, other: Elastic) -> tuple[float, float]:
    """demcal's equivalent moduli (E*, G*) of a contact between two materials, Pa."""
    estar = 1.0 / ((1.0 - one.poisson * one.poisson) / one.young
                   + (1.0 - other.poisson * other.poisson) / other.young)
    gstar = 1.0 / ((2.0 - one.poisson) / one.shear + (2.0 - other.poisson) / other.shear)
    return estar, gstar


def equivalent_moduli(estar: float, gstar: float) -> tuple[float, float]:
    """The (E, nu) for which LAMMPS' same-material mixing gives E* and G*.

    LAMMPS: E* = E / (2 (1 - nu^2)), G* = E / (4 (2 - nu)(1 + nu)), so
    G*/E* = (1 - nu) / (2 (2 - nu)), i.e. nu = (4 q - 1) / (2 q - 1) with q = G*/E*.

    Parameters
    ----------
    estar, gstar : float
        demcal's equivalent Young's and shear moduli of the pair, Pa.

    Returns
    -------
    (E, nu) : tuple of float
        Pa and dimensionless.
    """
    q = gstar / estar
    nu = (4.0 * q - 1.0) / (2.0 * q - 1.0)
    if not 0.0 <= nu < 0.5:
        raise ValueError(f"G*/E* = {q:.4g} has no LAMMPS (E, nu) with 0 <= nu < 0.5")
    return 2.0 * (1.0 - nu * nu) * estar, nu


def typical_contact(estar: float, eff_radius: float, load: float) -> float:
    """Hertz contact radius a = (3 F R* / (4 E*))^(1/3) under a load F (N), m."""
    return (3.0 * load * eff_radius / (4.0 * estar)) ** (1.0 / 3.0)


def _beta(e: float) -> float:
    if e >= 1.0:
        return 0.0
    le = math.log(e)
    return le / math.sqrt(le * le + math.pi * math.pi)


def contact_laws(params: Mapping[str, float], *, sphere_radius: float, clump_mass: float,
                 rolling: bool = True) -> dict[str, ContactLaw]:
    """The LAMMPS coefficients of the particle-particle (``pp``) and particle-wall (``pw``)
    contacts of a demcal parameter set.

    Parameters
    ----------
    params : mapping
        A complete demcal parameter set (SI).
    sphere_radius : float
        A typical sphere radius, m (sets the typical contact of the rolling spring and of the
        cohesive damping).
    clump_mass : float
        A typical clump mass, kg (its weight is the typical contact load).
    rolling : bool
        False gives no rolling resistance (demcal's ``rolling_model = "none"``).
    """
    p = params
    gp, nup = p["particle.shear_modulus"], p["particle.poisson"]
    gw, nuw = p["wall.shear_modulus"], p["wall.poisson"]
    particle = Elastic(2.0 * gp * (1.0 + nup), nup, gp)
    wall = Elastic(2.0 * gw * (1.0 + nuw), nuw, gw)
    out = {}
    for kind, other, reff, meff in (
            ("pp", particle, 0.5 * sphere_radius, 0.5 * clump_mass),
            ("pw", wall, sphere_radius, clump_mass)):
        estar, gstar = _pair_moduli(particle, other)
        young, nu = equivalent_moduli(estar, gstar)
        mu_r = p[f"{kind}.rolling_friction"] if rolling else 0.0
        a = typical_contact(estar, reff, 9.81 * clump_mass)
        beta = _beta(p[f"{kind}.restitution"])
        out[kind] = ContactLaw(
            young=young, poisson=nu, restitution=p[f"{kind}.restitution"],
            friction=p[f"{kind}.static_friction"], x_gamma_t=math.sqrt(4.0 * gstar / estar),
            rolling=mu_r, k_roll=2.25 * 2.0 * estar * a * mu_r * mu_r,
            gamma=p[f"{kind}.surface_energy"],
            eta0=_DF * abs(beta) * math.sqrt(2.0 * estar / (a * meff)))
    return out


def model_string(law: ContactLaw) -> str:
    """The ``pair_coeff`` / ``wall/gran granular`` model text of a contact law."""
    if law.gamma > 0.0:
        # the normal model's second coefficient is the damping's: eta0 for viscoelastic
        normal = (f"jkr {law.young!r} {law.eta0!r} {law.poisson!r} {law.gamma!r} "
                  "damping viscoelastic")
    else:
        normal = (f"hertz/material {law.young!r} {law.restitution!r} {law.poisson!r} "
                  "damping coeff_restitution")
    text = f"{normal} tangential mindlin NULL {law.x_gamma_t!r} {law.friction!r}"
    if law.rolling > 0.0:
        text += f" rolling sds {law.k_roll!r} 0.0 {law.rolling!r}"
    return text
