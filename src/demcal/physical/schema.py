"""The measurements file: raw bench repeats, validated with pydantic.

The same model reads the ``[measurements]`` section of a study TOML and a standalone
``MEASUREMENTS.toml`` (with or without the ``[measurements]`` header). Units are bench units,
named by a suffix at this user edge (``_g``, ``_cm3``, ``_mm``, ``_deg``, ``_percent``);
moduli are in Pa and densities in kg/m^3. demcal converts to SI once, in
:mod:`demcal.physical.derive`. Every list of repeats also accepts a single number.

Example (the paper's crushed corn stalk, abridged)::

    [measurements]
    material = "crushed corn stalk"
    moisture_percent = 11.63

    [measurements.density]            # overflow method
    density_kg_m3 = [116.15, 126.14, 101.42, 112.35, 115.74]
    # or the raw readings: mass_g = [...] and volume_cm3 = [...]

    [measurements.elasticity]         # two of G, E, v (or compression-test repeats)
    shear_modulus_pa = 2.5e6
    poisson = 0.3

    [measurements.shape]              # caliper repeats
    length_mm = 10.0
    diameter_mm = 4.0

    [measurements.friction.particle_wall]    # inclined plane
    angle_min_deg = 21.0                     # only the range was published:
    angle_max_deg = 35.0                     # no repeats are invented
    n_repeats = 10
    # or: angle_deg = [23.1, 27.4, ...]

    [measurements.aor]
    angle_deg = [44.62, 45.21, 46.09, 41.89, 42.77]

    [measurements.wall]
    name = "65Mn steel"
    shear_modulus_pa = 79e9
    poisson = 0.3
    density_kg_m3 = 7865

    [measurements.factor_ranges]      # ranges not measured (literature); override derived ones
    "pp.restitution" = [0.2, 0.4]

    [measurements.fixed]              # fixed values not measured
    "pw.surface_energy" = 0.0
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from demcal.errors import InputError, validation_message
from demcal.limits import MAX_TEMPLATE_SPHERES
from demcal.physical.conversions import (
    compression_test,
    density_from_overflow,
    poisson_from_moduli,
    shear_modulus_from_youngs,
    youngs_modulus_from_shear,
)
from demcal.physical.parameters import PARAMETERS
from demcal.safety import regular_input

__all__ = [
    "AngleOfRepose",
    "CompressionRepeat",
    "Density",
    "Elasticity",
    "FactorRangeSpec",
    "FixedSpec",
    "Friction",
    "InclinedPlane",
    "Measurements",
    "Shape",
    "Wall",
    "load_measurements",
    "parse_measurements",
]


def _listify(value: Any) -> Any:
    """Accept a single number where a list of repeats is expected."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return [value]
    return value


def _repeats(**constraints: Any) -> Any:
    item = Annotated[float, Field(allow_inf_nan=False, **constraints)]
    return Annotated[list[item], BeforeValidator(_listify), Field(min_length=1)]  # type: ignore[valid-type]


Positive = _repeats(gt=0)
PoissonRepeats = _repeats(ge=0, lt=0.5)
AngleRepeats = _repeats(ge=0, lt=90)
AoRRepeats = _repeats(gt=0, lt=90)
PercentRepeats = _repeats(ge=0, lt=100)
Angle = Annotated[float, Field(ge=0, lt=90, allow_inf_nan=False)]
PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


# ----------------------------------------------------------------------------- density
class Density(_Model):
    """Density repeats: the overflow method's raw readings, or densities.

    Give either ``density_kg_m3`` or both ``mass_g`` and ``volume_cm3`` (one value per
    repeat, or one of the two a single value shared by all repeats).
    """

    method: str = Field("overflow", description="How the density was measured (free text).")
    mass_g: Positive | None = Field(None, description="Sample mass of each repeat, g.")
    volume_cm3: Positive | None = Field(
        None, description="Displaced water volume of each repeat, cm^3 (= mL)."
    )
    density_kg_m3: Positive | None = Field(None, description="Density of each repeat, kg/m^3.")

    @model_validator(mode="after")
    def _one_form(self) -> Density:
        raw = self.mass_g is not None or self.volume_cm3 is not None
        if self.density_kg_m3 is not None and raw:
            raise ValueError("give either density_kg_m3 or mass_g with volume_cm3, not both")
        if self.density_kg_m3 is None:
            if self.mass_g is None or self.volume_cm3 is None:
                raise ValueError("give density_kg_m3, or both mass_g and volume_cm3")
            nm, nv = len(self.mass_g), len(self.volume_cm3)
            if nm != nv and 1 not in (nm, nv):
                raise ValueError(
                    f"mass_g and volume_cm3 must have the same number of repeats; got {nm} and {nv}"
                )
        return self

    def densities(self) -> np.ndarray:
        """Density of each repeat, (n,) float64 ndarray, kg/m^3."""
        if self.density_kg_m3 is not None:
            return np.asarray(self.density_kg_m3, dtype=float)
        return density_from_overflow(
            np.asarray(self.mass_g) * 1e-3, np.asarray(self.volume_cm3) * 1e-6
        )


class BulkDensity(Density):
    """Loose bulk density repeats: a container of known volume filled loosely (poured, not
    tapped, levelled off) and weighed. Give ``mass_g`` of each repeat with ``volume_cm3``
    (the container's volume, one value for all), or ``density_kg_m3`` (bulk densities)."""

    method: str = Field("loose fill", description="How it was filled (free text).")


# ----------------------------------------------------------------------------- elasticity
class CompressionRepeat(_Model):
    """One axial compression of a cylindrical specimen (see
    :func:`demcal.physical.conversions.compression_test`)."""

    height_before_mm: PositiveFloat
    height_after_mm: PositiveFloat
    diameter_before_mm: PositiveFloat
    diameter_after_mm: PositiveFloat
    force_n: PositiveFloat | None = Field(None, description="Axial force under load, N.")


def _resolve_moduli(
    g: list[float] | None, e: list[float] | None, v: list[float] | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(G, E, v) repeats from any two of them (isotropic elasticity)."""
    given = [x is not None for x in (g, e, v)]
    if sum(given) != 2:
        raise ValueError(
            "give exactly two of shear_modulus_pa, youngs_modulus_pa and poisson "
            f"(E = 2 G (1 + v)); got {sum(given)}"
        )
    try:
        if v is None:
            nu = poisson_from_moduli(e, g)
            gg, ee = np.broadcast_arrays(np.asarray(g, float), np.asarray(e, float))
        elif e is None:
            ee = youngs_modulus_from_shear(g, v)
            gg, nu = np.broadcast_arrays(np.asarray(g, float), np.asarray(v, float))
        else:
            gg = shear_modulus_from_youngs(e, v)
            ee, nu = np.broadcast_arrays(np.asarray(e, float), np.asarray(v, float))
    except InputError as exc:
        raise ValueError(str(exc)) from None
    return np.array(gg, float), np.array(ee, float), np.array(nu, float)


class Elasticity(_Model):
    """Elastic constants of the particle material.

    Either two of ``shear_modulus_pa``, ``youngs_modulus_pa`` and ``poisson`` (repeats, or a
    single value each), or ``compression`` repeats (axial compression of a cylindrical
    specimen: Poisson ratio from the change of height and diameter, Young's modulus from the
    force when every repeat has ``force_n``; without forces add ``shear_modulus_pa`` or
    ``youngs_modulus_pa``).
    """

    method: str | None = Field(None, description="How the constants were measured (free text).")
    shear_modulus_pa: Positive | None = None
    youngs_modulus_pa: Positive | None = None
    poisson: PoissonRepeats | None = None
    compression: Annotated[list[CompressionRepeat], Field(min_length=1)] | None = None

    @model_validator(mode="after")
    def _consistent(self) -> Elasticity:
        self.moduli()
        return self

    def moduli(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Shear modulus (Pa), Young's modulus (Pa) and Poisson ratio repeats, (n,) float64."""
        if self.compression is None:
            return _resolve_moduli(
                self.shear_modulus_pa, self.youngs_modulus_pa, self.poisson
            )
        if self.poisson is not None:
            raise ValueError("give poisson or compression repeats, not both")
        c = self.compression
        forces = [r.force_n for r in c]
        with_force = all(f is not None for f in forces)
        try:
            nu, e_c = compression_test(
                height_before=[r.height_before_mm * 1e-3 for r in c],
                height_after=[r.height_after_mm * 1e-3 for r in c],
                diameter_before=[r.diameter_before_mm * 1e-3 for r in c],
                diameter_after=[r.diameter_after_mm * 1e-3 for r in c],
                force=forces if with_force else None,
            )
        except InputError as exc:
            raise ValueError(f"compression: {exc}") from None
        if e_c is not None and (
            self.youngs_modulus_pa is not None or self.shear_modulus_pa is not None
        ):
            raise ValueError(
                "the compression repeats with force_n already give Young's "
                "modulus; drop shear_modulus_pa / youngs_modulus_pa"
            )
        if e_c is None and self.youngs_modulus_pa is None and self.shear_modulus_pa is None:
            raise ValueError(
                "compression repeats without force_n give only the Poisson ratio; "
                "add force_n to every repeat, or shear_modulus_pa or youngs_modulus_pa"
            )
        if self.youngs_modulus_pa is not None and self.shear_modulus_pa is not None:
            raise ValueError(
                "with compression repeats give one of shear_modulus_pa and youngs_modulus_pa, "
                "not both"
            )
        e_list = list(e_c) if e_c is not None else self.youngs_modulus_pa
        g_list = None if e_c is not None else self.shear_modulus_pa
        if g_list is not None:
            return _resolve_moduli(g_list, None, list(nu))
        return _resolve_moduli(None, e_list, list(nu))


# ----------------------------------------------------------------------------- shape
class Shape(_Model):
    """Caliper repeats of the particle's length and diameter, and template options."""

    length_mm: Positive = Field(description="Particle length of each repeat, mm.")
    diameter_mm: Positive = Field(description="Particle diameter of each repeat, mm.")
    n_spheres: Annotated[int, Field(ge=1, le=MAX_TEMPLATE_SPHERES)] | None = Field(
        None, description="Spheres in the clump template; automatic when omitted."
    )
    max_volume_error: Annotated[float, Field(gt=0, lt=1)] = Field(
        0.02,
        description="Largest ridge loss of the automatic sphere count (see "
        "demcal.dem.shapes.cylinder_template).",
    )
    size_scale: tuple[PositiveFloat, PositiveFloat] | None = Field(
        None,
        description="Range of the particle size scale factor in the virtual test (the "
        "paper: 0.75-1.25); its lower end sets the smallest sphere of the Rayleigh step.",
    )

    @field_validator("size_scale")
    @classmethod
    def _ordered(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
        if v is not None and v[0] > v[1]:
            raise ValueError(f"size_scale must be [low, high] with low <= high; got {list(v)}")
        return v


# ----------------------------------------------------------------------------- friction
class InclinedPlane(_Model):
    """Tilt angles at the onset of sliding (mu = tan(angle)).

    Two forms: ``angle_deg`` with every repeat, or - when a source gives only the range of
    its repeats - ``angle_min_deg`` and ``angle_max_deg`` (with ``n_repeats`` if known).
    The range-only form carries no mean, deviation or confidence interval; demcal does not
    invent repeats.
    """

    surface: str | None = Field(None, description="What the sample slid on (free text).")
    angle_deg: AngleRepeats | None = Field(None, description="Angle of each repeat, degrees.")
    angle_min_deg: Angle | None = Field(None, description="Smallest angle (range-only form).")
    angle_max_deg: Angle | None = Field(None, description="Largest angle (range-only form).")
    n_repeats: Annotated[int, Field(ge=1)] | None = None

    @model_validator(mode="after")
    def _one_form(self) -> InclinedPlane:
        ranged = self.angle_min_deg is not None or self.angle_max_deg is not None
        if self.angle_deg is not None:
            if ranged:
                raise ValueError(
                    "give either angle_deg (every repeat) or angle_min_deg/angle_max_deg "
                    "(range only), not both"
                )
            if self.n_repeats is not None and self.n_repeats != len(self.angle_deg):
                raise ValueError(
                    f"n_repeats={self.n_repeats} does not match the {len(self.angle_deg)} "
                    "values of angle_deg"
                )
            return self
        if self.angle_min_deg is None or self.angle_max_deg is None:
            raise ValueError(
                "give angle_deg (every repeat), or both angle_min_deg and angle_max_deg"
            )
        if self.angle_min_deg > self.angle_max_deg:
            raise ValueError(
                "angle_min_deg must be <= angle_max_deg; got "
                f"angle_min_deg={self.angle_min_deg}, angle_max_deg={self.angle_max_deg}"
            )
        return self


class Friction(_Model):
    """Inclined-plane tests: particle on particles (``pp``) and on the wall material (``pw``)."""

    particle_particle: InclinedPlane | None = None
    particle_wall: InclinedPlane | None = None


# ----------------------------------------------------------------------------- AoR
class AngleOfRepose(_Model):
    """Measured angle of repose: values, and/or photos measured by demcal.measure."""

    method: str | None = Field(None, description="e.g. 'cylinder lifting' (free text).")
    angle_deg: AoRRepeats | None = Field(None, description="AoR of each repeat, degrees.")
    photos: Annotated[list[str], Field(min_length=1)] | None = Field(
        None, description="Photo paths, relative to the measurements file."
    )

    @model_validator(mode="after")
    def _something(self) -> AngleOfRepose:
        if self.angle_deg is None and self.photos is None:
            raise ValueError("give angle_deg values and/or photos")
        return self

    def photo_paths(self, base_dir: str | Path) -> list[Path]:
        """The photos as paths, relative ones resolved against ``base_dir``."""
        base = Path(base_dir)
        return [p if p.is_absolute() else base / p for p in map(Path, self.photos or [])]


# ----------------------------------------------------------------------------- wall
class Wall(_Model):
    """Wall (geometry) material: density and two of G, E, v (handbook values or repeats)."""

    name: str = "wall"
    density_kg_m3: Positive
    shear_modulus_pa: Positive | None = None
    youngs_modulus_pa: Positive | None = None
    poisson: PoissonRepeats | None = None

    @model_validator(mode="after")
    def _consistent(self) -> Wall:
        self.moduli()
        return self

    def moduli(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Shear modulus (Pa), Young's modulus (Pa) and Poisson ratio repeats."""
        return _resolve_moduli(self.shear_modulus_pa, self.youngs_modulus_pa, self.poisson)


# ----------------------------------------------------------------------------- given values
def _range_pair(value: Any) -> Any:
    if isinstance(value, (list, tuple)):
        if len(value) != 2:
            raise ValueError(f"a range is [low, high]; got {list(value)}")
        return {"low": value[0], "high": value[1]}
    return value


def _fixed_number(value: Any) -> Any:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return {"value": value}
    return value


class FactorRangeSpec(_Model):
    """A factor range given by the user (``[low, high]`` or ``{low, high, source}``)."""

    low: Annotated[float, Field(allow_inf_nan=False)]
    high: Annotated[float, Field(allow_inf_nan=False)]
    source: str = "given"


class FixedSpec(_Model):
    """A fixed value given by the user (a number or ``{value, source}``)."""

    value: Annotated[float, Field(allow_inf_nan=False)]
    source: str = "given"


RangeInput = Annotated[FactorRangeSpec, BeforeValidator(_range_pair)]
FixedInput = Annotated[FixedSpec, BeforeValidator(_fixed_number)]


# ----------------------------------------------------------------------------- the file
class Measurements(_Model):
    """Bench measurements of one material and its wall (all sections optional).

    Settings: ``ci_level`` (confidence level of every interval), ``range_rule`` and
    ``range_k`` (how a factor range is drawn from a measured spread; see
    :func:`demcal.physical.stats.suggest_range`). ``factor_ranges`` and ``fixed`` add values
    that were not measured (literature) and override derived ones; their keys are the
    parameter names of :data:`demcal.physical.parameters.PARAMETERS`.
    """

    material: str = "particle"
    notes: str | None = None
    ci_level: Annotated[float, Field(gt=0, lt=1)] = 0.95
    range_rule: Literal["minmax", "mean_std", "ci"] = "minmax"
    range_k: Annotated[float, Field(gt=0, allow_inf_nan=False)] = 2.0
    density: Density | None = None
    bulk_density: BulkDensity | None = Field(
        None, description="loose bulk density repeats: a response the lift test reports")
    elasticity: Elasticity | None = None
    shape: Shape | None = None
    friction: Friction = Field(default_factory=Friction)
    moisture_percent: PercentRepeats | None = Field(
        None, description="Moisture content of each repeat, % (as the tester reports it)."
    )
    aor: AngleOfRepose | None = None
    wall: Wall | None = None
    factor_ranges: dict[str, RangeInput] = Field(default_factory=dict)
    fixed: dict[str, FixedInput] = Field(default_factory=dict)

    @field_validator("factor_ranges")
    @classmethod
    def _check_ranges(cls, ranges: dict[str, FactorRangeSpec]) -> dict[str, FactorRangeSpec]:
        for name, spec in ranges.items():
            info = _known(name)
            if not spec.low < spec.high:
                raise ValueError(
                    f"low must be < high for factor {name}; got low={spec.low:g}, "
                    f"high={spec.high:g}"
                )
            for end, val in (("low", spec.low), ("high", spec.high)):
                if not info.contains(val):
                    raise ValueError(
                        f"{end} of factor {name} must be in {info.bounds_text()}; got {val:g}"
                    )
        return ranges

    @field_validator("fixed")
    @classmethod
    def _check_fixed(cls, fixed: dict[str, FixedSpec]) -> dict[str, FixedSpec]:
        for name, spec in fixed.items():
            info = _known(name)
            if not info.contains(spec.value):
                raise ValueError(f"{name} must be in {info.bounds_text()}; got {spec.value:g}")
        return fixed

    @model_validator(mode="after")
    def _not_both(self) -> Measurements:
        both = sorted(set(self.factor_ranges) & set(self.fixed))
        if both:
            raise ValueError(
                f"{', '.join(both)}: a parameter is either fixed or a factor range, not both"
            )
        return self


def _known(name: str) -> Any:
    if name not in PARAMETERS:
        raise ValueError(f"unknown parameter {name!r}; known: {', '.join(PARAMETERS)}")
    return PARAMETERS[name]


# ----------------------------------------------------------------------------- loading
def _format_errors(exc: ValidationError, prefix: str) -> str:
    return validation_message(exc, prefix, sep="\n", show_input=True)


def parse_measurements(data: Any, *, prefix: str = "measurements") -> Measurements:
    """Validate a measurements mapping (the parsed TOML section).

    Parameters
    ----------
    data : Mapping or Measurements
        The ``[measurements]`` table as a dict (or an already validated model).
    prefix : str, keyword-only
        Printed before each field path in error messages.

    Raises
    ------
    InputError
        One line per bad field, e.g.
        ``measurements.density.mass_g.2: Input should be greater than 0; got -5.0``.
    """
    if isinstance(data, Measurements):
        return data
    if not isinstance(data, dict):
        raise InputError(f"{prefix} must be a table (mapping); got {type(data).__name__}")
    try:
        return Measurements.model_validate(data)
    except ValidationError as exc:
        raise InputError(_format_errors(exc, prefix)) from None


def load_measurements(path: str | Path) -> Measurements:
    """Read and validate a measurements TOML file.

    A file with a ``[measurements]`` table (a study file, or a standalone file written with
    that header) is read from that table; otherwise the whole document is the measurements.

    Parameters
    ----------
    path : str or Path
        The TOML file.

    Raises
    ------
    InputError
        File missing or unreadable, bad TOML, or invalid fields (one line per field).
    """
    p = regular_input(path, "measurements file")  # a named pipe would block the read
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"measurements file not found: {p}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read measurements file {p}: {exc}") from None
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{p}: invalid TOML: {exc}") from None
    except RecursionError:
        raise InputError(f"{p}: invalid TOML: nested too deeply") from None
    if "measurements" in doc:
        return parse_measurements(doc["measurements"], prefix="measurements")
    return parse_measurements(doc, prefix="measurements")
