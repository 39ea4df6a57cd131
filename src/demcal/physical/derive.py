"""From raw measurements to model parameters: fixed values, factor ranges, particle template.

:func:`derive_parameters` applies these rules (each overridable, each recorded in the
``source`` text of what it derives):

- ``particle.density``: mean of the density repeats (overflow method).
- ``particle.shear_modulus``: mean of the shear-modulus repeats (from G, or E and v).
- ``particle.poisson``: a factor range drawn from its spread when it has >= 2 distinct
  repeats, else fixed at its mean (the paper measured 0.3 and took 0.2-0.4 from the
  literature: give that in ``factor_ranges``).
- ``pp.static_friction`` / ``pw.static_friction``: ``mu = tan(angle)`` of every repeat,
  then a factor range by the range rule (``minmax`` by default: tan of the smallest and
  largest angle). Range-only records support ``minmax`` alone; with another rule they fall
  back to it, with a note. A zero spread gives a fixed value.
- ``wall.*``: means of the wall's values.
- ``factor_ranges`` and ``fixed`` of the file add what was not measured and override derived
  values (the override is recorded).
- The particle template: :func:`demcal.dem.shapes.cylinder_template` for the mean caliper
  length and diameter, with its volume error against that cylinder.
- The Rayleigh time step, conservatively for the smallest sphere at the smallest size scale,
  the lowest density and shear modulus and the highest Poisson ratio of the ranges.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from demcal.dem.shapes import ClumpTemplate, cylinder_template, cylinder_volume_error
from demcal.errors import InputError
from demcal.physical.conversions import friction_from_angle, rayleigh_time_step
from demcal.physical.parameters import PARAMETERS, Parameter
from demcal.physical.schema import InclinedPlane, Measurements, Shape, parse_measurements
from demcal.physical.stats import (
    RANGE_RULES,
    RepeatSummary,
    suggest_range,
    summarize,
    summarize_range,
)

__all__ = [
    "DT_FRACTION",
    "FactorRange",
    "FixedParameter",
    "PhysicalResult",
    "RayleighStep",
    "TemplateChoice",
    "derive_parameters",
]

#: Fraction of the Rayleigh time step suggested as the DEM time step (the paper's 20 %).
DT_FRACTION: float = 0.2


@dataclass(frozen=True)
class FixedParameter:
    """A parameter fixed at one value (SI units)."""

    name: str
    value: float
    source: str
    measured: RepeatSummary | None = None

    @property
    def info(self) -> Parameter:
        """The parameter's description (symbol, unit, bounds)."""
        return PARAMETERS[self.name]

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON form (SI units)."""
        return {
            "name": self.name,
            "symbol": self.info.symbol,
            "value": self.value,
            "unit": self.info.unit_text,
            "source": self.source,
        }


@dataclass(frozen=True)
class FactorRange:
    """A calibration factor with its range (SI units)."""

    name: str
    low: float
    high: float
    source: str
    measured: RepeatSummary | None = None
    rule: str | None = None

    @property
    def info(self) -> Parameter:
        """The parameter's description (symbol, unit, bounds)."""
        return PARAMETERS[self.name]

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON form (SI units)."""
        return {
            "name": self.name,
            "symbol": self.info.symbol,
            "low": self.low,
            "high": self.high,
            "unit": self.info.unit_text,
            "source": self.source,
            "rule": self.rule,
        }


@dataclass(frozen=True)
class TemplateChoice:
    """The clump template chosen for the measured particle and how well it fits.

    Attributes
    ----------
    template : ClumpTemplate
        The chain of spheres (body x along the particle axis).
    length, diameter : float
        Mean measured length and diameter, m.
    automatic : bool
        Whether the number of spheres was chosen automatically.
    max_volume_error : float
        Ridge-loss tolerance of the automatic choice.
    cylinder_volume : float
        Volume of the measured cylinder, m^3.
    volume_error : float
        ``(V_template - V_cylinder) / V_cylinder`` (negative: the template is smaller).
    density_for_equal_mass : float or None
        Density that would give the template the mass of the measured cylinder at the
        measured density, kg/m^3 (information only; not applied).
    """

    template: ClumpTemplate
    length: float
    diameter: float
    automatic: bool
    max_volume_error: float
    cylinder_volume: float
    volume_error: float
    density_for_equal_mass: float | None

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON form (SI units), with the template itself under ``"template"``."""
        meta = self.template.metadata
        return {
            "name": self.template.name,
            "n_spheres": self.template.n_spheres,
            "automatic": self.automatic,
            "max_volume_error": self.max_volume_error,
            "length_m": self.length,
            "diameter_m": self.diameter,
            "sphere_diameter_m": float(2.0 * self.template.radii[0]),
            "spacing_m": meta.get("spacing_m"),
            "overlap": meta.get("overlap"),
            "ridge_loss": meta.get("ridge_loss"),
            "template_volume_m3": self.template.volume,
            "cylinder_volume_m3": self.cylinder_volume,
            "volume_error": self.volume_error,
            "density_for_equal_mass_kg_m3": self.density_for_equal_mass,
            "template": self.template.to_dict(),
        }


@dataclass(frozen=True)
class RayleighStep:
    """Rayleigh time step of the smallest particle and the suggested DEM step."""

    time_step: float
    radius: float
    density: float
    shear_modulus: float
    poisson: float
    fraction: float
    note: str

    @property
    def suggested_step(self) -> float:
        """``fraction * time_step``, s."""
        return self.fraction * self.time_step

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON form (SI units)."""
        return {
            "rayleigh_time_step_s": self.time_step,
            "suggested_time_step_s": self.suggested_step,
            "fraction": self.fraction,
            "radius_m": self.radius,
            "density_kg_m3": self.density,
            "shear_modulus_pa": self.shear_modulus,
            "poisson": self.poisson,
            "note": self.note,
        }


@dataclass(frozen=True)
class PhysicalResult:
    """Raw measurements and everything derived from them.

    Attributes
    ----------
    measurements : Measurements
        The validated raw data.
    summaries : dict of str to RepeatSummary
        Statistics of every measured quantity (SI, or degrees / percent where named so).
    fixed : dict of str to FixedParameter
        Parameters fixed at one value.
    factors : dict of str to FactorRange
        Calibration factors with their ranges.
    template : TemplateChoice or None
        The particle template (None without shape measurements).
    rayleigh : RayleighStep or None
        The Rayleigh time step (None when density, shear modulus, Poisson ratio or shape is
        missing).
    target_aor : RepeatSummary or None
        The measured angle of repose, degrees.
    missing : tuple of str
        Parameters with neither a value nor a range yet.
    notes : tuple of str
        Fallbacks and overrides applied.
    settings : dict
        ``ci_level``, ``range_rule``, ``range_k`` used.
    """

    measurements: Measurements
    summaries: dict[str, RepeatSummary]
    fixed: dict[str, FixedParameter]
    factors: dict[str, FactorRange]
    template: TemplateChoice | None
    rayleigh: RayleighStep | None
    target_aor: RepeatSummary | None
    missing: tuple[str, ...]
    notes: tuple[str, ...]
    settings: dict[str, Any] = field(default_factory=dict)

    def fixed_values(self) -> dict[str, float]:
        """Fixed parameter values by name, SI."""
        return {k: v.value for k, v in self.fixed.items()}

    def factor_bounds(self) -> dict[str, tuple[float, float]]:
        """Factor ranges by name, ``(low, high)``, SI."""
        return {k: (v.low, v.high) for k, v in self.factors.items()}

    def table_rows(self) -> list[dict[str, Any]]:
        """Rows of the parameter table (the paper's Table 1), in its order.

        Each row: ``symbol``, ``name``, ``label``, ``kind`` ("fixed" or "factor"), ``value``
        (SI float, fixed) or ``low``/``high`` (SI, factor), ``unit`` (SI), ``display``
        (value or range in ``display_unit``), ``display_unit``, ``source``.
        """
        rows = []
        for name, info in PARAMETERS.items():
            if name in self.factors:
                f = self.factors[name]
                rows.append(
                    {
                        "symbol": info.symbol,
                        "name": name,
                        "label": info.label,
                        "kind": "factor",
                        "low": f.low,
                        "high": f.high,
                        "unit": info.unit_text,
                        "display": f"{_fmt(f.low * info.display_scale)}"
                        f"-{_fmt(f.high * info.display_scale)}",
                        "display_unit": info.display_unit,
                        "source": f.source,
                    }
                )
            elif name in self.fixed:
                p = self.fixed[name]
                rows.append(
                    {
                        "symbol": info.symbol,
                        "name": name,
                        "label": info.label,
                        "kind": "fixed",
                        "value": p.value,
                        "unit": info.unit_text,
                        "display": _fmt(p.value * info.display_scale),
                        "display_unit": info.display_unit,
                        "source": p.source,
                    }
                )
        return rows

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON record of the raw data and what was derived (SI units), for the store."""
        return {
            "raw": self.measurements.model_dump(mode="json", exclude_none=True),
            "derived": {
                "settings": dict(self.settings),
                "fixed": {k: v.to_dict() for k, v in self.fixed.items()},
                "factors": {k: v.to_dict() for k, v in self.factors.items()},
                "table": self.table_rows(),
                "summaries": {k: v.to_dict() for k, v in self.summaries.items()},
                "template": self.template.to_dict() if self.template else None,
                "rayleigh": self.rayleigh.to_dict() if self.rayleigh else None,
                "target_aor_deg": self.target_aor.to_dict() if self.target_aor else None,
                "missing": list(self.missing),
                "notes": list(self.notes),
            },
        }


def _fmt(x: float) -> str:
    """Compact number for tables: 3 significant digits below 10, up to 6 above."""
    if x == 0:
        return "0"
    return f"{x:.6g}" if abs(x) >= 10 else f"{x:.3g}"


def _repeats_text(s: RepeatSummary) -> str:
    if s.range_only:
        return f"range of {s.n_repeats} repeats" if s.n_repeats else "range only"
    return "1 value" if s.n_repeats == 1 else f"{s.n_repeats} repeats"


def _angle_summary(plane: InclinedPlane, name: str, level: float) -> RepeatSummary:
    if plane.angle_deg is not None:
        return summarize(plane.angle_deg, name=name, unit="deg", level=level)
    return summarize_range(
        plane.angle_min_deg,  # type: ignore[arg-type]
        plane.angle_max_deg,  # type: ignore[arg-type]
        name=name,
        unit="deg",
        n_repeats=plane.n_repeats,
        level=level,
    )


def _check_settings(ci_level: Any, range_rule: Any, range_k: Any) -> None:
    if not (isinstance(ci_level, (int, float)) and 0.0 < float(ci_level) < 1.0):
        raise InputError(f"ci_level must be in (0, 1); got {ci_level!r}")
    if range_rule not in RANGE_RULES:
        raise InputError(f"range_rule must be one of {', '.join(RANGE_RULES)}; got {range_rule!r}")
    if not (isinstance(range_k, (int, float)) and math.isfinite(range_k) and range_k > 0):
        raise InputError(f"range_k must be a number > 0; got {range_k!r}")


@dataclass
class _Derived:
    """What :func:`derive_parameters` has found so far, and the range settings it uses:
    every measurement's summary, the fixed parameters, the factor ranges and the notes."""

    level: float
    rule: str
    k: float
    summaries: dict[str, RepeatSummary] = field(default_factory=dict)
    fixed: dict[str, FixedParameter] = field(default_factory=dict)
    factors: dict[str, FactorRange] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def summary(self, values: Any, name: str, unit: str) -> RepeatSummary:
        """The repeats ``values`` summarised (and kept) as ``name`` in ``unit``."""
        s = summarize(values, name=name, unit=unit, level=self.level)
        self.summaries[s.name] = s
        return s

    def add_fixed(self, name: str, s: RepeatSummary, what: str) -> None:
        """``name`` fixed at the measured central value of ``s`` (measured by ``what``)."""
        how = "mean of " if (s.n_repeats or 0) > 1 and not s.range_only else ""
        if s.range_only:
            how = "midpoint of the "
        self.fixed[name] = FixedParameter(
            name, s.central, f"measured ({what}; {how}{_repeats_text(s)})", s
        )

    def add_factor(self, name: str, s: RepeatSummary, what: str) -> None:
        """``name`` a factor over the range the rule gives ``s`` (fixed where it is one
        value); a rule that needs repeats falls back to min-max, with a note."""
        info = PARAMETERS[name]
        used = self.rule
        if self.rule != "minmax" and s.std is None:
            used = "minmax"
            self.notes.append(
                f"{name}: range rule {self.rule!r} needs >= 2 repeats, got "
                f"{'a range only' if s.range_only else 'one value'}: used 'minmax'"
            )
        low, high = suggest_range(s, rule=used, k=self.k, bounds=info.clip_bounds())  # type: ignore[arg-type]
        if low == high:
            self.add_fixed(name, s, what)
            return
        rule_text = {
            "minmax": "min-max",
            "mean_std": f"mean +- {self.k:g} sd",
            "ci": f"{self.level:.0%} CI of the mean",
        }[used]
        how = _repeats_text(s) if s.range_only else f"{rule_text} of {_repeats_text(s)}"
        self.factors[name] = FactorRange(name, low, high, f"measured ({what}; {how})", s, used)


def _density(m: Measurements, out: _Derived) -> None:
    """The particle density, fixed."""
    if m.density is not None:
        s = out.summary(m.density.densities(), "particle.density", "kg/m^3")
        out.add_fixed("particle.density", s, f"{m.density.method} method")


def _elasticity(m: Measurements, out: _Derived) -> None:
    """The particle's shear modulus, fixed, and its Poisson ratio: a factor where repeats
    differ."""
    if m.elasticity is None:
        return
    g, e, nu = m.elasticity.moduli()
    sg = out.summary(g, "particle.shear_modulus", "Pa")
    out.summary(e, "particle.youngs_modulus", "Pa")
    sv = out.summary(nu, "particle.poisson", "-")
    what = m.elasticity.method or (
        "compression test" if m.elasticity.compression else "elastic constants"
    )
    out.add_fixed("particle.shear_modulus", sg, what)
    if sv.n_repeats and sv.n_repeats >= 2 and sv.maximum > sv.minimum:
        out.add_factor("particle.poisson", sv, what)
    else:
        out.add_fixed("particle.poisson", sv, what)


def _wall(m: Measurements, out: _Derived) -> None:
    """The wall's density, shear modulus and Poisson ratio, fixed."""
    if m.wall is None:
        return
    g, e, nu = m.wall.moduli()
    rho = out.summary(m.wall.density_kg_m3, "wall.density", "kg/m^3")
    sg = out.summary(g, "wall.shear_modulus", "Pa")
    out.summary(e, "wall.youngs_modulus", "Pa")
    sv = out.summary(nu, "wall.poisson", "-")
    out.add_fixed("wall.density", rho, m.wall.name)
    out.add_fixed("wall.shear_modulus", sg, m.wall.name)
    out.add_fixed("wall.poisson", sv, m.wall.name)


def _friction(m: Measurements, out: _Derived) -> None:
    """The static frictions from inclined-plane angles: factors over their tangents."""
    for key, plane in (("pp", m.friction.particle_particle), ("pw", m.friction.particle_wall)):
        if plane is None:
            continue
        angles = _angle_summary(plane, f"{key}.inclination_deg", out.level)
        mu = angles.map(friction_from_angle, name=f"{key}.static_friction", unit="-")
        out.summaries[angles.name] = angles
        out.summaries[mu.name] = mu
        what = f"inclined plane, tan of {_fmt(angles.minimum)}-{_fmt(angles.maximum)} deg"
        out.add_factor(f"{key}.static_friction", mu, what)


def derive_parameters(
    measurements: Measurements | Mapping[str, Any],
    *,
    ci_level: float | None = None,
    range_rule: str | None = None,
    range_k: float | None = None,
) -> PhysicalResult:
    """Derive fixed parameters, factor ranges and the particle template from measurements.

    Parameters
    ----------
    measurements : Measurements or Mapping
        Validated measurements, or the ``[measurements]`` table as a dict.
    ci_level : float or None, keyword-only
        Confidence level of the intervals; overrides the file's ``ci_level``.
    range_rule : {"minmax", "mean_std", "ci"} or None, keyword-only
        Rule for factor ranges from measured spreads; overrides the file's ``range_rule``.
    range_k : float or None, keyword-only
        ``k`` of the ``mean_std`` rule; overrides the file's ``range_k``.

    Returns
    -------
    PhysicalResult

    Raises
    ------
    InputError
        Invalid measurements (naming the field), or settings out of range.
    """
    if isinstance(measurements, Mapping):
        measurements = dict(measurements)
    m = parse_measurements(measurements)
    level = m.ci_level if ci_level is None else ci_level
    rule = m.range_rule if range_rule is None else range_rule
    k = m.range_k if range_k is None else range_k
    _check_settings(level, rule, k)
    level = float(level)
    k = float(k)

    found = _Derived(level=level, rule=rule, k=k)
    for derive in (_density, _elasticity, _wall, _friction):
        derive(m, found)
    summaries, fixed, factors, notes = found.summaries, found.fixed, found.factors, found.notes

    template_choice, target = _shape_and_target(m, level, summaries, fixed)
    _apply_given(m, fixed, factors, notes)

    rayleigh = _rayleigh(m, template_choice, fixed, factors)
    order = list(PARAMETERS)
    fixed = dict(sorted(fixed.items(), key=lambda kv: order.index(kv[0])))
    factors = dict(sorted(factors.items(), key=lambda kv: order.index(kv[0])))
    missing = tuple(n for n in PARAMETERS if n not in fixed and n not in factors)
    return PhysicalResult(
        measurements=m,
        summaries=summaries,
        fixed=fixed,
        factors=factors,
        template=template_choice,
        rayleigh=rayleigh,
        target_aor=target,
        missing=missing,
        notes=tuple(notes),
        settings={"ci_level": level, "range_rule": rule, "range_k": k},
    )


def _shape_and_target(
    m: Measurements, level: float, summaries: dict[str, RepeatSummary],
    fixed: dict[str, FixedParameter],
) -> tuple[TemplateChoice | None, RepeatSummary | None]:
    """Shape (the particle template), moisture, the loose bulk density and the target AoR;
    their summaries are added to ``summaries``."""
    template_choice = None
    if m.shape is not None:
        sl = summarize(np.asarray(m.shape.length_mm) * 1e-3, name="particle.length", unit="m",
                       level=level)
        sd = summarize(np.asarray(m.shape.diameter_mm) * 1e-3, name="particle.diameter",
                       unit="m", level=level)
        summaries.update({sl.name: sl, sd.name: sd})
        template_choice = _choose_template(m.shape, m.material, sl.central, sd.central, fixed)
    if m.moisture_percent is not None:
        s = summarize(m.moisture_percent, name="moisture_percent", unit="%", level=level)
        summaries[s.name] = s
    if m.bulk_density is not None:  # a response to calibrate against, not a parameter
        s = summarize(m.bulk_density.densities(), name="bulk_density_kg_m3", unit="kg/m^3",
                      level=level)
        summaries[s.name] = s
    target = None
    if m.aor is not None and m.aor.angle_deg is not None:
        target = summarize(m.aor.angle_deg, name="aor_deg", unit="deg", level=level)
        summaries[target.name] = target
    return template_choice, target


def _measured_text(old: FactorRange | FixedParameter) -> str:
    """A measured range or value as the note of a user-given value that overrides it."""
    if isinstance(old, FactorRange):
        return f"{_fmt(old.low)}-{_fmt(old.high)}"
    return _fmt(old.value)


def _apply_given(
    m: Measurements, fixed: dict[str, FixedParameter], factors: dict[str, FactorRange],
    notes: list[str],
) -> None:
    """User-given ranges and values override what was measured, or complete it (in place)."""
    for name, spec in m.factor_ranges.items():
        old = factors.pop(name, None) or fixed.pop(name, None)
        src = spec.source
        if old is not None:
            was = _measured_text(old)
            notes.append(f"{name}: given range {spec.low:g}-{spec.high:g} overrides measured {was}")
            src = f"{spec.source} (measured {was})"
        factors[name] = FactorRange(name, spec.low, spec.high, src, old.measured if old else None,
                                    None)
    for name, spec in m.fixed.items():
        old = factors.pop(name, None) or fixed.pop(name, None)
        src = spec.source
        if old is not None:
            was = _measured_text(old)
            notes.append(f"{name}: given value {spec.value:g} overrides measured {was}")
            src = f"{spec.source} (measured {was})"
        fixed[name] = FixedParameter(name, spec.value, src, old.measured if old else None)


def _choose_template(
    shape: Shape, material: str, length: float, diameter: float,
    fixed: dict[str, FixedParameter],
) -> TemplateChoice:
    try:
        template = cylinder_template(
            length,
            diameter,
            shape.n_spheres,
            max_volume_error=shape.max_volume_error,
            name=material,
        )
    except InputError as exc:
        raise InputError(
            f"measurements.shape: {exc} (mean length_mm={length * 1e3:g}, "
            f"mean diameter_mm={diameter * 1e3:g})"
        ) from None
    v_cyl = math.pi * diameter**2 / 4.0 * length
    rho = fixed.get("particle.density")
    return TemplateChoice(
        template=template,
        length=length,
        diameter=diameter,
        automatic=shape.n_spheres is None,
        max_volume_error=shape.max_volume_error,
        cylinder_volume=v_cyl,
        volume_error=cylinder_volume_error(template, length, diameter),
        density_for_equal_mass=(rho.value * v_cyl / template.volume) if rho else None,
    )


def _conservative(
    name: str, fixed: dict[str, FixedParameter], factors: dict[str, FactorRange], *, high: bool
) -> float | None:
    if name in fixed:
        return fixed[name].value
    if name in factors:
        return factors[name].high if high else factors[name].low
    return None


def _rayleigh(
    m: Measurements,
    choice: TemplateChoice | None,
    fixed: dict[str, FixedParameter],
    factors: dict[str, FactorRange],
) -> RayleighStep | None:
    if choice is None:
        return None
    rho = _conservative("particle.density", fixed, factors, high=False)
    g = _conservative("particle.shear_modulus", fixed, factors, high=False)
    nu = _conservative("particle.poisson", fixed, factors, high=True)
    if rho is None or g is None or nu is None:
        return None
    scale = m.shape.size_scale[0] if m.shape and m.shape.size_scale else 1.0
    radius = choice.template.min_radius * scale
    t_r = rayleigh_time_step(radius, density=rho, shear_modulus=g, poisson=nu)
    note = (
        f"smallest sphere radius {radius * 1e3:g} mm"
        + (f" (size scale {scale:g})" if scale != 1.0 else "")
        + "; lowest density and shear modulus, highest Poisson ratio of their ranges"
    )
    return RayleighStep(t_r, radius, rho, g, nu, DT_FRACTION, note)
