"""The model parameters a measurement can set, with the virtual test's names and units.

Names are those of the virtual test (``demcal simulate aor``); ``symbol`` is the paper's
(x1-x8 for the calibration factors of its Table 1). Values are SI; ``display_unit`` and
``display_scale`` are for tables only (moduli in MPa, as in the paper).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["PARAMETERS", "ParameterInfo", "parameter_info"]


@dataclass(frozen=True)
class ParameterInfo:
    """Description of one model parameter.

    Attributes
    ----------
    name : str
        Parameter name in the virtual test (``"pp.static_friction"``).
    symbol : str
        The paper's symbol (``"x3"``, ``"G1"``...).
    label : str
        Human-readable description.
    unit : str
        SI unit of the value (``"-"`` for dimensionless).
    lower, upper : float
        Physical bounds of the value; ``upper_inclusive`` tells whether ``upper`` itself is
        allowed (the Poisson ratio must stay below 0.5).
    display_unit : str
        Unit used in printed tables.
    display_scale : float
        Multiply the SI value by this to print it in ``display_unit``.
    """

    name: str
    symbol: str
    label: str
    unit: str
    lower: float
    upper: float
    upper_inclusive: bool = True
    lower_inclusive: bool = True
    display_unit: str = ""
    display_scale: float = 1.0

    def contains(self, value: float) -> bool:
        """Whether ``value`` lies within the physical bounds."""
        if not math.isfinite(value):
            return False
        lo_ok = value >= self.lower if self.lower_inclusive else value > self.lower
        hi_ok = value <= self.upper if self.upper_inclusive else value < self.upper
        return lo_ok and hi_ok

    def bounds_text(self) -> str:
        """The allowed interval, e.g. ``[0, 0.5)``."""
        lo = "[" if self.lower_inclusive else "("
        hi = "]" if self.upper_inclusive else ")"
        return f"{lo}{self.lower:g}, {self.upper:g}{hi}"

    def clip_bounds(self) -> tuple[float, float]:
        """Closed bounds to clip a suggested range to.

        An open end is pulled in by 1e-3 (a Poisson ratio is clipped to 0.499), or to the
        next float above an open lower bound of 0.
        """
        lo = self.lower if self.lower_inclusive else math.nextafter(self.lower, math.inf)
        hi = self.upper if self.upper_inclusive else self.upper - 1e-3
        return lo, hi


_INF = math.inf

#: Every parameter demcal.physical can fix or give a range to, in the order of the paper's
#: Table 1 (then the rest).
PARAMETERS: dict[str, ParameterInfo] = {
    p.name: p
    for p in (
        ParameterInfo("particle.poisson", "x1", "Poisson's ratio of the particle", "-",
                      0.0, 0.5, upper_inclusive=False, display_unit="-"),
        ParameterInfo("particle.shear_modulus", "G1", "Shear modulus of the particle", "Pa",
                      0.0, _INF, lower_inclusive=False, display_unit="MPa",
                      display_scale=1e-6),
        ParameterInfo("particle.density", "rho1", "Particle density", "kg/m^3",
                      0.0, _INF, lower_inclusive=False, display_unit="kg/m^3"),
        ParameterInfo("wall.poisson", "v2", "Poisson's ratio of the wall", "-",
                      0.0, 0.5, upper_inclusive=False, display_unit="-"),
        ParameterInfo("wall.shear_modulus", "G2", "Shear modulus of the wall", "Pa",
                      0.0, _INF, lower_inclusive=False, display_unit="MPa",
                      display_scale=1e-6),
        ParameterInfo("wall.density", "rho2", "Wall density", "kg/m^3",
                      0.0, _INF, lower_inclusive=False, display_unit="kg/m^3"),
        ParameterInfo("pp.restitution", "x2", "Particle-particle coefficient of restitution",
                      "-", 0.0, 1.0, lower_inclusive=False, display_unit="-"),
        ParameterInfo("pp.static_friction", "x3", "Particle-particle static friction "
                      "coefficient", "-", 0.0, _INF, display_unit="-"),
        ParameterInfo("pp.rolling_friction", "x4", "Particle-particle rolling friction "
                      "coefficient", "-", 0.0, _INF, display_unit="-"),
        ParameterInfo("pw.restitution", "x5", "Particle-wall coefficient of restitution",
                      "-", 0.0, 1.0, lower_inclusive=False, display_unit="-"),
        ParameterInfo("pw.static_friction", "x6", "Particle-wall static friction coefficient",
                      "-", 0.0, _INF, display_unit="-"),
        ParameterInfo("pw.rolling_friction", "x7", "Particle-wall rolling friction "
                      "coefficient", "-", 0.0, _INF, display_unit="-"),
        ParameterInfo("pp.surface_energy", "x8", "Particle-particle JKR surface energy",
                      "J/m^2", 0.0, _INF, display_unit="J/m^2"),
        ParameterInfo("pw.surface_energy", "", "Particle-wall JKR surface energy", "J/m^2",
                      0.0, _INF, display_unit="J/m^2"),
    )
}


def parameter_info(name: str) -> ParameterInfo:
    """The :class:`ParameterInfo` of ``name``; KeyError lists the known names."""
    try:
        return PARAMETERS[name]
    except KeyError:
        raise KeyError(f"unknown parameter {name!r}; known: {', '.join(PARAMETERS)}") from None
