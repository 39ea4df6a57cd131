"""demcal.physical: bench measurements in, model parameters out.

Pure functions (SI units) for the paper's intrinsic-parameter step - density by the overflow
method, E/G/v conversions, friction from inclined-plane angles, the Rayleigh time step -
summaries of repeats with confidence intervals, a documented rule for factor ranges, the
measurements file (pydantic) and :func:`derive_parameters`, which turns a measurements file
into fixed parameters, factor ranges (the paper's Table 1) and a particle template.

>>> from demcal import physical
>>> res = physical.derive_parameters({"density": {"density_kg_m3": [116.15, 126.14, 101.42,
...                                                                  112.35, 115.74]}})
>>> round(res.fixed["particle.density"].value, 2)
114.36
"""

from demcal.physical.conversions import (
    angle_from_friction,
    compression_test,
    density_from_overflow,
    friction_from_angle,
    poisson_from_moduli,
    rayleigh_time_step,
    shear_modulus_from_youngs,
    youngs_modulus_from_shear,
)
from demcal.physical.derive import (
    DT_FRACTION,
    FactorRange,
    FixedParameter,
    PhysicalResult,
    RayleighStep,
    TemplateChoice,
    derive_parameters,
)
from demcal.physical.parameters import PARAMETERS, Parameter, parameter_info
from demcal.physical.schema import Measurements, load_measurements, parse_measurements
from demcal.physical.stats import (
    RANGE_RULES,
    RepeatSummary,
    std_interval,
    suggest_range,
    summarize,
    summarize_range,
)

__all__ = [
    "DT_FRACTION",
    "PARAMETERS",
    "RANGE_RULES",
    "FactorRange",
    "FixedParameter",
    "Measurements",
    "Parameter",
    "PhysicalResult",
    "RayleighStep",
    "RepeatSummary",
    "TemplateChoice",
    "angle_from_friction",
    "compression_test",
    "density_from_overflow",
    "derive_parameters",
    "friction_from_angle",
    "load_measurements",
    "parameter_info",
    "parse_measurements",
    "poisson_from_moduli",
    "rayleigh_time_step",
    "shear_modulus_from_youngs",
    "std_interval",
    "suggest_range",
    "summarize",
    "summarize_range",
    "youngs_modulus_from_shear",
]
