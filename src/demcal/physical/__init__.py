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

# The public names, imported on first use (demcal._lazy): scipy.stats loads when measurements
# are reduced, not with every study file that names a parameter.
from demcal._lazy import exports

__getattr__, __dir__, __all__ = exports(__name__, {
    "angle_from_friction": "conversions",
    "compression_test": "conversions",
    "density_from_overflow": "conversions",
    "friction_from_angle": "conversions",
    "poisson_from_moduli": "conversions",
    "rayleigh_time_step": "conversions",
    "shear_modulus_from_youngs": "conversions",
    "youngs_modulus_from_shear": "conversions",
    "DT_FRACTION": "derive",
    "FactorRange": "derive",
    "FixedParameter": "derive",
    "PhysicalResult": "derive",
    "RayleighStep": "derive",
    "TemplateChoice": "derive",
    "derive_parameters": "derive",
    "PARAMETERS": "parameters",
    "Parameter": "parameters",
    "parameter_info": "parameters",
    "Measurements": "schema",
    "load_measurements": "schema",
    "parse_measurements": "schema",
    "RANGE_RULES": "stats",
    "RepeatSummary": "stats",
    "std_interval": "stats",
    "suggest_range": "stats",
    "summarize": "stats",
    "summarize_range": "stats",
})
