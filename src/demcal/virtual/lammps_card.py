"""A material card as LAMMPS input: the ``pair_style granular`` lines a LAMMPS user pastes.

The coefficients are those demcal's LAMMPS engine writes for the card's parameters
(:func:`demcal.virtual.lammps_laws.contact_laws`, ``docs/lammps.md``): Hertz (or JKR with
cohesion) from the particle's and the wall's moduli, Mindlin tangential friction, the SDS
rolling spring capped at the rolling friction. The rolling spring and the cohesive damping
need a typical contact: the card's particle at its nominal size (the template's mean sphere
radius, the clump's mass) under its own weight. The time step follows demcal's rule: the
test's ``dt_fraction`` of the Rayleigh time step of the smallest sphere at the smallest size.

A card calibrated in demcal's engine with its default rolling model A is written all the same
but says plainly, in the output and to the caller (:attr:`LammpsLines.warning`), that LAMMPS
has no model A: at the same rolling friction its SDS law piles ~9 deg lower (docs/lammps.md),
so the angle the card verified is not what LAMMPS will give.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from demcal.dem.contact import rayleigh_time_step
from demcal.errors import InputError
from demcal.virtual.config import fidelity_config
from demcal.virtual.factory import make_template
from demcal.virtual.lammps_laws import contact_laws, model_string
from demcal.virtual.material_card import MaterialCard

__all__ = ["LammpsLines", "lammps_lines"]


@dataclass(frozen=True)
class LammpsLines:
    """The LAMMPS commands of a material card.

    Attributes
    ----------
    text : str
        The commands with comments, ready to paste (``pair_style``, ``pair_coeff``, a
        ``fix wall/gran`` line for a flat floor, ``timestep``).
    pair_coeff : str
        The particle-particle model text (``pair_coeff * * ...``).
    wall_model : str
        The particle-wall model text (for ``fix ... wall/gran granular ...``).
    timestep_s : float
        The time step, s.
    warning : str or None
        Why the lines may not reproduce the card's verified angle in LAMMPS (None: they do,
        the card's laws are LAMMPS').
    """

    text: str
    pair_coeff: str
    wall_model: str
    timestep_s: float
    warning: str | None


def _warning(card: MaterialCard) -> str | None:
    if card.engine_name == "lammps" or card.rolling_model in ("C", "none"):
        return None
    return (f"this card was calibrated in demcal's engine with rolling model "
            f"{card.rolling_model}; LAMMPS has no such law: these lines use its SDS rolling "
            "spring (demcal's model C), which piles ~9 deg lower at the same rolling friction "
            "(docs/lammps.md). Calibrate with [executor] engine = \"lammps\" (or "
            "rolling_model = \"C\") for parameters to use in LAMMPS")


def lammps_lines(card: MaterialCard) -> LammpsLines:
    """The LAMMPS commands that give a material card's contact laws.

    Raises
    ------
    InputError
        A card calibrated in an external engine (its values mean that engine's laws).
    """
    if card.is_external:
        raise InputError("this card was calibrated in an external engine "
                         f"({card.engine.command or card.engine_name}); its values mean "
                         "that engine's contact laws, not LAMMPS'")
    if card.test.kind == "analytic":
        raise InputError("this card was made on the analytic stand-in, a test double, not a "
                         "simulation: its values are no engine's parameters")
    overrides = dict(card.test.overrides)
    overrides.setdefault("rolling_model", card.rolling_model)
    config = fidelity_config(card.test.fidelity_name, **overrides)
    p = card.parameters
    template = make_template(config.particle)
    radius = float(np.mean(template.radii))
    mass = float(p["particle.density"] * template.volume)
    laws = contact_laws(p, sphere_radius=radius, clump_mass=mass,
                        rolling=config.rolling_model != "none")
    r_min = float(template.radii.min() * config.particle.size_min)
    dt = float(config.dt_fraction * rayleigh_time_step(
        r_min, p["particle.density"], p["particle.shear_modulus"], p["particle.poisson"]))
    pp, pw = model_string(laws["pp"]), model_string(laws["pw"])
    warning = _warning(card)
    lines = [
        f"# demcal material card{f' of {card.study}' if card.study else ''}: the contact "
        "laws as LAMMPS granular coefficients (SI units)",
        "# (LAMMPS 2Aug2023 or newer; demcal's mapping and its measured agreement: "
        "docs/lammps.md)",
        *([f"# calibrated with LAMMPS {card.engine.lammps_version}"]
          if card.engine.lammps_version else []),
        f"# typical contact for the rolling spring and the cohesive damping: a sphere of "
        f"radius {radius!r} m on a clump of {mass!r} kg under its weight",
        *([f"# WARNING: {warning}"] if warning else []),
        "# (the script needs units si and atom_style sphere)",
        "pair_style granular",
        f"pair_coeff * * {pp}",
        "# the walls (here a flat floor at z = 0; use the same model for wall/gran/region):",
        f"fix floor all wall/gran granular {pw} zplane 0.0 NULL",
        f"# time step: {config.dt_fraction!r} of the Rayleigh time step of the smallest sphere "
        f"(radius {r_min!r} m)",
        f"timestep {dt!r}",
    ]
    return LammpsLines("\n".join(lines) + "\n", pp, pw, dt, warning)
