"""Material presets: named parameter sets for virtual tests.

``corn_stalk`` is the paper's crushed corn stalk with the mid values of its Table 1 (fixed values
where the table gives one). Note on surface energy: with demcal's JKR law (the documented EDEM
version-1 force law) this light material forms no pile at the paper's 0.04-0.12 J/m^2 (see
docs/physics.md, "Measured"), so the preset's particle-particle surface energy is the mid
value of the paper's range and a test at it is expected to end as a ``column`` or ``plug``;
calibrations of this material use lower ranges (see examples/corn_stalk).
"""

from __future__ import annotations

from demcal.errors import InputError
from demcal.virtual.parameters import check_parameters

__all__ = ["PRESETS", "preset_parameters"]

PRESETS: dict[str, dict[str, float]] = {
    "corn_stalk": {
        "particle.poisson": 0.3,          # x1, Table 1: 0.2-0.4 (measured 0.3)
        "particle.density": 114.36,       # kg/m^3, overflow method
        "particle.shear_modulus": 2.5e6,  # Pa
        "wall.poisson": 0.3,              # 65Mn steel
        "wall.shear_modulus": 7.9e10,     # Pa
        "wall.density": 7865.0,           # kg/m^3
        "pp.restitution": 0.3,            # x2, 0.2-0.4
        "pp.static_friction": 0.55,       # x3, 0.35-0.75
        "pp.rolling_friction": 0.09,      # x4, 0.03-0.15
        "pw.restitution": 0.45,           # x5, 0.3-0.6
        "pw.static_friction": 0.55,       # x6, 0.4-0.7
        "pw.rolling_friction": 0.155,     # x7, 0.01-0.3
        "pp.surface_energy": 0.08,        # x8, 0.04-0.12 J/m^2
        "pw.surface_energy": 0.0,         # no adhesion to steel in the paper
    },
    # a cohesionless reference material (glass-bead-like spheres are not the default template;
    # this is the corn stalk without cohesion, handy for checks)
    "corn_stalk_dry": {},
}
PRESETS["corn_stalk_dry"] = {**PRESETS["corn_stalk"], "pp.surface_energy": 0.0}


def preset_parameters(name: str, overrides: dict[str, float] | None = None) -> dict[str, float]:
    """A preset's parameters with validated overrides applied."""
    if name not in PRESETS:
        raise InputError(f"preset must be one of {', '.join(PRESETS)}; got {name!r}")
    params = dict(PRESETS[name])
    if overrides:
        params.update(check_parameters(overrides))
    return check_parameters(params)
