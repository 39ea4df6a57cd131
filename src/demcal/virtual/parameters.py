"""The parameters of a virtual test, by name (the names used by ``--set``, study files, JSON).

``pp`` = particle-particle, ``pw`` = particle-wall. The paper's symbols x1-x8 are given for the
corn-stalk example. Every value is in SI units (surface energy in J/m^2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from demcal.errors import InputError

__all__ = ["PARAMETERS", "ParameterSpec", "check_parameters", "parse_assignments"]


@dataclass(frozen=True)
class ParameterSpec:
    """A named model parameter with its meaning, unit and allowed interval."""

    name: str
    description: str
    unit: str
    low: float
    high: float
    low_open: bool = False
    high_open: bool = False
    paper_symbol: str = ""

    def check(self, value: float) -> float:
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise InputError(f"{self.name} must be a number; got {value!r}") from None
        ok_lo = v > self.low if self.low_open else v >= self.low
        ok_hi = v < self.high if self.high_open else v <= self.high
        if not (math.isfinite(v) and ok_lo and ok_hi):
            lb = "(" if self.low_open else "["
            rb = ")" if self.high_open else "]"
            hi = "inf" if math.isinf(self.high) else f"{self.high:g}"
            unit = f" {self.unit}" if self.unit else ""
            raise InputError(
                f"{self.name} must be in {lb}{self.low:g}, {hi}{rb}{unit}; got {value!r}")
        return v


#: physical upper bounds: far above any granular material (osmium 22 590 kg/m^3, diamond's
#: shear modulus 4.8e11 Pa, friction and rolling coefficients of order 1, JKR surface
#: energies below 1 J/m^2); beyond, a typo (1e308) overflowed the models or hung the engine
MAX_DENSITY = 1e5
MAX_MODULUS = 1e12
MAX_FRICTION = 10.0
MAX_SURFACE_ENERGY = 1e3
PARAMETERS: dict[str, ParameterSpec] = {p.name: p for p in [
    ParameterSpec("particle.poisson", "Poisson ratio of the particle", "", 0.0, 0.5,
                  high_open=True, paper_symbol="x1"),
    ParameterSpec("particle.density", "solid density of the particle", "kg/m^3", 0.0, MAX_DENSITY,
                  low_open=True, paper_symbol="rho1"),
    ParameterSpec("particle.shear_modulus", "shear modulus of the particle", "Pa", 0.0, MAX_MODULUS,
                  low_open=True, paper_symbol="G1"),
    ParameterSpec("wall.poisson", "Poisson ratio of the walls (plate, cylinder)", "", 0.0, 0.5,
                  high_open=True, paper_symbol="v2"),
    ParameterSpec("wall.shear_modulus", "shear modulus of the walls", "Pa", 0.0, MAX_MODULUS,
                  low_open=True, paper_symbol="G2"),
    ParameterSpec("wall.density", "density of the walls", "kg/m^3", 0.0, MAX_DENSITY,
                  low_open=True,
                  paper_symbol="rho2"),
    ParameterSpec("pp.restitution", "particle-particle coefficient of restitution", "", 0.0,
                  1.0, low_open=True, paper_symbol="x2"),
    ParameterSpec("pp.static_friction", "particle-particle static friction coefficient", "",
                  0.0, MAX_FRICTION, paper_symbol="x3"),
    ParameterSpec("pp.rolling_friction", "particle-particle rolling friction coefficient", "",
                  0.0, MAX_FRICTION, paper_symbol="x4"),
    ParameterSpec("pw.restitution", "particle-wall coefficient of restitution", "", 0.0, 1.0,
                  low_open=True, paper_symbol="x5"),
    ParameterSpec("pw.static_friction", "particle-wall static friction coefficient", "", 0.0,
                  MAX_FRICTION, paper_symbol="x6"),
    ParameterSpec("pw.rolling_friction", "particle-wall rolling friction coefficient", "", 0.0,
                  MAX_FRICTION, paper_symbol="x7"),
    ParameterSpec("pp.surface_energy", "particle-particle JKR surface energy", "J/m^2", 0.0,
                  MAX_SURFACE_ENERGY, paper_symbol="x8"),
    ParameterSpec("pw.surface_energy", "particle-wall JKR surface energy", "J/m^2", 0.0,
                  MAX_SURFACE_ENERGY),
]}


def check_parameters(values: dict[str, float]) -> dict[str, float]:
    """Validate named parameter values; unknown names and out-of-range values are refused."""
    out = {}
    for name, value in values.items():
        if name not in PARAMETERS:
            raise InputError(f"unknown parameter {name!r}; known: {', '.join(PARAMETERS)}")
        out[name] = PARAMETERS[name].check(value)
    return out


def parse_assignments(items: list[str]) -> dict[str, float]:
    """Parse ``NAME=VALUE`` strings (``--set``) into validated parameter values."""
    values: dict[str, float] = {}
    for item in items:
        if "=" not in item:
            raise InputError(f"--set expects NAME=VALUE; got {item!r}")
        name, _, raw = item.partition("=")
        values[name.strip()] = raw.strip()  # type: ignore[assignment]
    return check_parameters(values)
