"""The model parameters, once: each one's name, symbol, description, unit and bounds.

The names are those of the virtual test (``--set``, study files, JSON, the material card);
``pp`` = particle-particle, ``pw`` = particle-wall. The symbols are the paper's (x1-x8 for the
calibration factors of its Table 1). Every value is in SI units (surface energy in J/m^2).

This is the single registry: the virtual test (:mod:`demcal.virtual.parameters`: checking
values, ``--set``) and the bench measurements (:mod:`demcal.physical.parameters`: what a
measurement may set, its table) both read it, so a parameter's label, unit or bounds cannot
differ between the lab side and the engine side. The bounds are the engine's: a value the
engine would refuse is refused where it is first given, a measurements file included.

This module imports nothing of demcal but its errors, so every layer may use it (like
:mod:`demcal.results`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from demcal.errors import InputError

__all__ = ["MAX_DENSITY", "MAX_FRICTION", "MAX_MODULUS", "MAX_SURFACE_ENERGY", "PARAMETERS",
           "Parameter"]


@dataclass(frozen=True)
class Parameter:
    """One named model parameter.

    Attributes
    ----------
    name : str
        The parameter's name (``"pp.static_friction"``).
    symbol : str
        The paper's symbol (``"x3"``, ``"G1"``...), ``""`` where it has none.
    description : str
        What it is, lower case (``"particle-particle static friction coefficient"``).
    unit : str
        SI unit of the value, ``""`` for a dimensionless one.
    low, high : float
        The allowed interval, SI; ``low_open`` / ``high_open`` exclude an end (a Poisson
        ratio stays below 0.5, a density above 0).
    table_row : int
        Its row in the paper's Table 1 (the order of the bench-measurement tables); the
        registry's own order is the engine's.
    display_unit : str
        Unit of printed tables (``""``: the SI unit, ``"-"`` for a dimensionless one).
    display_scale : float
        Multiply the SI value by this to print it in ``display_unit`` (moduli in MPa, as in
        the paper).
    """

    name: str
    symbol: str
    description: str
    unit: str
    low: float
    high: float
    table_row: int
    low_open: bool = False
    high_open: bool = False
    display_unit: str = ""
    display_scale: float = 1.0

    def __post_init__(self) -> None:
        if not self.display_unit:  # frozen: set once, the SI unit's text
            object.__setattr__(self, "display_unit", self.unit_text)

    @property
    def label(self) -> str:
        """The description as a table's label (capitalised)."""
        return self.description[:1].upper() + self.description[1:]

    # The names the two registries this one replaced gave these fields (kept for callers of
    # demcal.physical.parameters.ParameterInfo and demcal.virtual.parameters.ParameterSpec).
    @property
    def paper_symbol(self) -> str:
        """Alias of :attr:`symbol`."""
        return self.symbol

    @property
    def lower(self) -> float:
        """Alias of :attr:`low`."""
        return self.low

    @property
    def upper(self) -> float:
        """Alias of :attr:`high`."""
        return self.high

    @property
    def lower_inclusive(self) -> bool:
        """Whether :attr:`low` is allowed."""
        return not self.low_open

    @property
    def upper_inclusive(self) -> bool:
        """Whether :attr:`high` is allowed."""
        return not self.high_open

    @property
    def unit_text(self) -> str:
        """The SI unit as printed: ``"-"`` for a dimensionless value."""
        return self.unit or "-"

    def contains(self, value: float) -> bool:
        """Whether ``value`` is a finite number within the bounds."""
        if not math.isfinite(value):
            return False
        ok_lo = value > self.low if self.low_open else value >= self.low
        ok_hi = value < self.high if self.high_open else value <= self.high
        return ok_lo and ok_hi

    def bounds_text(self) -> str:
        """The allowed interval, e.g. ``[0, 0.5)``."""
        lb = "(" if self.low_open else "["
        rb = ")" if self.high_open else "]"
        return f"{lb}{self.low:g}, {self.high:g}{rb}"

    def clip_bounds(self) -> tuple[float, float]:
        """Closed bounds to clip a suggested range to.

        An open end is pulled in by 1e-3 (a Poisson ratio is clipped to 0.499), or to the
        next float above an open lower bound of 0.
        """
        lo = math.nextafter(self.low, math.inf) if self.low_open else self.low
        hi = self.high - 1e-3 if self.high_open else self.high
        return lo, hi

    def check(self, value: float) -> float:
        """``value`` as a float, or InputError (one line: the name, bounds and unit)."""
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise InputError(f"{self.name} must be a number; got {value!r}") from None
        if not self.contains(v):
            unit = f" {self.unit}" if self.unit else ""
            raise InputError(f"{self.name} must be in {self.bounds_text()}{unit}; got {value!r}")
        return v


#: physical upper bounds: far above any granular material (osmium 22 590 kg/m^3, diamond's
#: shear modulus 4.8e11 Pa, friction and rolling coefficients of order 1, JKR surface
#: energies below 1 J/m^2); beyond, a typo (1e308) overflowed the models or hung the engine
MAX_DENSITY = 1e5
MAX_MODULUS = 1e12
MAX_FRICTION = 10.0
MAX_SURFACE_ENERGY = 1e3

#: Every parameter, in the engine's order (the material card's, the run sheets' columns).
PARAMETERS: dict[str, Parameter] = {p.name: p for p in [
    Parameter("particle.poisson", "x1", "Poisson's ratio of the particle", "", 0.0, 0.5, 1,
              high_open=True),
    Parameter("particle.density", "rho1", "solid density of the particle", "kg/m^3", 0.0,
              MAX_DENSITY, 3, low_open=True),
    Parameter("particle.shear_modulus", "G1", "shear modulus of the particle", "Pa", 0.0,
              MAX_MODULUS, 2, low_open=True, display_unit="MPa", display_scale=1e-6),
    Parameter("wall.poisson", "v2", "Poisson's ratio of the walls (plate, cylinder)", "", 0.0,
              0.5, 4, high_open=True),
    Parameter("wall.shear_modulus", "G2", "shear modulus of the walls", "Pa", 0.0, MAX_MODULUS,
              5, low_open=True, display_unit="MPa", display_scale=1e-6),
    Parameter("wall.density", "rho2", "density of the walls", "kg/m^3", 0.0, MAX_DENSITY, 6,
              low_open=True),
    Parameter("pp.restitution", "x2", "particle-particle coefficient of restitution", "", 0.0,
              1.0, 7, low_open=True),
    Parameter("pp.static_friction", "x3", "particle-particle static friction coefficient", "",
              0.0, MAX_FRICTION, 8),
    Parameter("pp.rolling_friction", "x4", "particle-particle rolling friction coefficient",
              "", 0.0, MAX_FRICTION, 9),
    Parameter("pw.restitution", "x5", "particle-wall coefficient of restitution", "", 0.0, 1.0,
              10, low_open=True),
    Parameter("pw.static_friction", "x6", "particle-wall static friction coefficient", "", 0.0,
              MAX_FRICTION, 11),
    Parameter("pw.rolling_friction", "x7", "particle-wall rolling friction coefficient", "",
              0.0, MAX_FRICTION, 12),
    Parameter("pp.surface_energy", "x8", "particle-particle JKR surface energy", "J/m^2", 0.0,
              MAX_SURFACE_ENERGY, 13),
    Parameter("pw.surface_energy", "", "particle-wall JKR surface energy", "J/m^2", 0.0,
              MAX_SURFACE_ENERGY, 14),
]}
