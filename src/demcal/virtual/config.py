"""Configuration of the cylinder-lifting angle-of-repose test (validated, SI units).

:class:`AoRTestConfig` holds the geometry, the particle template, the fill, the phases, the
measurement and the outcome criteria; :func:`fidelity_config` gives the fidelities
(``quick``, ``small``, ``standard``, ``paper``). Material parameters are separate (a dict of
named values, see :mod:`demcal.virtual.parameters` and :mod:`demcal.virtual.presets`).
"""

from __future__ import annotations

from typing import Literal, get_args

from pydantic import BaseModel, ConfigDict, Field, model_validator

__all__ = [
    "FIDELITIES",
    "FIDELITY_REPLICATES",
    "ROLLING_MODELS",
    "AoRTestConfig",
    "Fill",
    "Geometry",
    "MeasurementOptions",
    "OutcomeCriteria",
    "ParticleShape",
    "Phases",
    "RollingModel",
    "fidelity_config",
]

#: The engine's rolling-friction models (docs/physics.md): A, EDEM's constant directional
#: torque; C, the elastic-plastic spring; none
RollingModel = Literal["A", "C", "none"]
ROLLING_MODELS: tuple[str, ...] = get_args(RollingModel)


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Geometry(_Model):
    """Cylinder and plate of the test (the paper: 50 mm x 150 mm tube on a 300 mm plate)."""

    cylinder_inner_diameter: float = Field(0.050, gt=0, description="inner diameter, m")
    cylinder_height: float = Field(0.150, gt=0, description="height of the tube, m")
    cylinder_wall_thickness: float = Field(0.002, gt=0, description="tube wall thickness, m")
    plate_size: float = Field(0.300, gt=0, description="side of the square plate, m")


class ParticleShape(_Model):
    """The particle template and its size distribution.

    ``stalk``: spheres of the cylinder's diameter along its axis (the paper's 7 x 4 mm spheres
    over 10 mm); ``cylinder``: an automatic N-sphere cylinder; ``sphere``: one sphere of
    diameter ``diameter``. Each particle is scaled by a factor drawn uniformly from
    [size_min, size_max] (the paper: 0.75-1.25).
    """

    template: Literal["stalk", "cylinder", "sphere"] = "stalk"
    length: float = Field(0.010, gt=0, description="particle length, m")
    diameter: float = Field(0.004, gt=0, description="particle diameter, m")
    n_spheres: int = Field(7, ge=1, le=200, description="spheres per stalk")
    size_min: float = Field(0.75, gt=0, description="smallest size factor")
    size_max: float = Field(1.25, gt=0, description="largest size factor")

    @model_validator(mode="after")
    def _sizes(self):
        if self.size_max < self.size_min:
            raise ValueError(f"size_max ({self.size_max}) must be >= size_min ({self.size_min})")
        if self.template == "stalk" and self.length < self.diameter:
            raise ValueError("a stalk's length must be >= its diameter")
        return self


class Fill(_Model):
    """How the cylinder is filled.

    ``factory``: particles are generated at random positions on a disc at ``factory_height``
    (default: the top of the cylinder), without overlap, at ``rate`` per second during
    ``filling_time``, falling at ``drop_speed`` (the paper: 5000 /s, 0.6 s, 1 m/s); generation
    stops early at ``count`` particles if given. ``packing``: ``count`` particles are placed at
    once in a loose random packing (volume fraction ``packing_fraction``) inside the cylinder
    and dropped from rest (faster; used by the quick fidelity).
    """

    method: Literal["factory", "packing"] = "factory"
    count: int | None = Field(None, ge=1, description="number of particles (required for packing)")
    rate: float = Field(5000.0, gt=0, description="generation rate, 1/s")
    filling_time: float = Field(0.6, gt=0, description="generation time, s")
    drop_speed: float = Field(1.0, ge=0, description="initial downward speed, m/s")
    factory_height: float | None = Field(None, gt=0, description="height of the generation disc, m")
    packing_fraction: float = Field(0.18, gt=0, lt=0.6, description="solid fraction of the packing")

    @model_validator(mode="after")
    def _count(self):
        if self.method == "packing" and self.count is None:
            raise ValueError("fill.count is required when fill.method = 'packing'")
        return self


class Phases(_Model):
    """Lifting and settling.

    A phase is *settled* when the root-mean-square clump speed (i.e. the kinetic energy per
    particle, KE/n = m v_rms^2/2) is below ``settle_rms_speed`` and the largest clump speed is
    below ``settle_max_speed``, both over the clumps that touch another clump (a lone stalk
    rolling away across the plate is not part of the pile; see :mod:`demcal.virtual.settle`);
    a phase that does not settle within its time limit ends the test with the outcome
    ``unsettled``.
    """

    lift_speed: float = Field(0.05, gt=0, description="cylinder lifting speed, m/s")
    lift_height: float | None = Field(
        None, gt=0, description="lift distance, m; default: until the cylinder clears the material"
        " (at most its height)")
    settle_rms_speed: float = Field(0.005, gt=0, description="settled: rms speed of the pile's"
                                    " clumps below, m/s")
    settle_max_speed: float = Field(0.03, gt=0, description="settled: max speed of the pile's "
                                    "clumps below, m/s")
    fill_settle_max_time: float = Field(1.5, gt=0, description="time limit to settle the fill, s")
    pile_settle_max_time: float = Field(1.5, gt=0, description="time limit to settle the pile, s")
    min_settle_time: float = Field(0.02, ge=0, description="shortest settle phase, s")
    check_interval: float = Field(0.005, gt=0, description="time between checks, s")

    def check_steps(self, dt: float) -> int:
        """Time steps between two checks at time step ``dt`` (s): the whole number nearest
        ``check_interval / dt``, >= 1 (both engines check on it)."""
        return max(1, round(self.check_interval / dt))


class MeasurementOptions(_Model):
    """How the settled pile's angle is measured (by demcal.measure, as a photo would be)."""

    n_views: int = Field(8, ge=1, le=360, description="silhouette views around the vertical axis")
    method: Literal["silhouette", "profile"] = "silhouette"
    fit_window: tuple[float, float] | None = Field(
        None, description="flank fit window as fractions of the pile height (default: measure's)")


class OutcomeCriteria(_Model):
    """Thresholds that classify a test that forms no pile.

    - ``plug``: after the lift, at least ``plug_mass_fraction`` of the mass is still inside the
      cylinder (the fill rose with it);
    - ``column``: after the cylinder cleared the material and the material settled, less than
      ``column_outside_fraction`` of the mass lies farther from the axis than the cylinder's
      inner radius plus half a particle length, and the material stands at least
      ``column_height_fraction`` of its fill height.
    """

    plug_mass_fraction: float = Field(0.3, gt=0, le=1)
    column_outside_fraction: float = Field(0.15, gt=0, le=1)
    column_height_fraction: float = Field(0.6, gt=0, le=2)


class AoRTestConfig(_Model):
    """Everything about the virtual cylinder-lifting test except the material parameters."""

    geometry: Geometry = Geometry()
    particle: ParticleShape = ParticleShape()
    fill: Fill = Fill()
    phases: Phases = Phases()
    measurement: MeasurementOptions = MeasurementOptions()
    outcome: OutcomeCriteria = OutcomeCriteria()
    dt_fraction: float = Field(0.2, gt=0, le=1, description="time step / Rayleigh time step")
    rolling_model: RollingModel = "A"

    @model_validator(mode="after")
    def _fits(self):
        g, p = self.geometry, self.particle
        big = max(p.length, p.diameter) * p.size_max if p.template != "sphere" else \
            p.diameter * p.size_max
        if g.cylinder_inner_diameter <= big:
            raise ValueError(
                f"geometry.cylinder_inner_diameter ({g.cylinder_inner_diameter} m) must exceed the"
                f" largest particle ({big:.4g} m)")
        if g.plate_size <= g.cylinder_inner_diameter + 2 * g.cylinder_wall_thickness:
            raise ValueError("geometry.plate_size must exceed the cylinder's outer diameter")
        return self


#: fidelity name -> overrides of the default (paper) configuration
FIDELITIES: dict[str, dict] = {
    # the paper's test: factory 5000 /s for 0.6 s at the top of the 150 mm tube, 1 m/s
    "paper": {},
    # a small fill (150 particles, ~60 mm high) dropped as a loose packing, in the paper's
    # *model* cylinder of 30 mm (its model section; its physical test used 50 mm); same time
    # step, plate, lift speed and phase rules. A 150-particle fill in the 50 mm tube is only
    # ~2.5 particle lengths high and stands as a squat column after the lift (measured), so
    # the quick test keeps the fill taller than wide by using the narrower tube.
    # Cost (2026-11-25, one core): 1050 spheres, dt 6.9 us, 1.1-1.9 s simulated, 25-45 s wall.
    # Seed-to-seed scatter of the angle: 2-9 deg (std) near 45 deg: average replicates.
    "quick": {"geometry": {"cylinder_inner_diameter": 0.030},
              "fill": {"method": "packing", "count": 150}},
    # 300 stalks dropped as a loose packing in a 35 mm tube; a pile ~30-35 mm high: a
    # calibration a 2-core workstation runs in about an hour, with replicates. Seed-to-seed
    # scatter (benchmarks/precision.py): 1.5-2.5 deg without cohesion (mu_s 0.55, mu_r 0.15;
    # 150 stalks: 4.66) but 4.2-4.8 deg at cohesive points (the corn stalk's calibrated point:
    # 4.16 over 10 seeds): its 3 replicates give a design point a standard error of
    # 0.9-2.8 deg, so the study's pure error and adequacy rules decide (docs/precision.md).
    # (Called "standard" before 2026-11-27.)
    "small": {"geometry": {"cylinder_inner_diameter": 0.035},
              "fill": {"method": "packing", "count": 300}},
    # 1200 stalks dropped as a loose packing in a 56 mm tube (the small test's fill aspect,
    # N / D^3): the cheapest pile whose seed-to-seed scatter is near the lab's own (the five
    # photos: 1.74 deg) at cohesive points as well. Measured (benchmarks/precision.py): 1.50
    # deg over 12 seeds at the corn stalk's calibrated point (small: 4.16), 2.64 over 18 at a
    # steeper one (x8 0.0005, x4 0.2, x3 0.6; small: 4.81 over 24), 2.39 over 6 at a third;
    # 2.28 pooled; ~380-450 CPU-s per test (small: ~61-80) before the engine's one-sided
    # pair pass (2026-11-27: ~15 % less on one core, the same piles). Its 4 default
    # replicates give a design point a standard error of <= 1 deg where the scatter is the
    # region's (1.88 pooled at six Latin-hypercube points, 2.01 over every standard pile: 3
    # gave 1.09-1.16); for the same standard error the small test needs ~18-24 replicates,
    # about the same CPU. 9.8 s per test batched on an H100. 1600 stalks
    # (62 mm) at the steep point: 2.16 over 12 (1200: 2.66 over 30), 1.34x the time: not
    # under 2 there either, so not worth it (docs/precision.md). (Called "large" before
    # 2026-11-27.)
    "standard": {"geometry": {"cylinder_inner_diameter": 0.056},
                 "fill": {"method": "packing", "count": 1200}},
}

#: Default replicates (seeds) per design point of each fidelity: ``simulate aor`` runs this
#: many when ``--seeds`` is not given, and a study's ``replicates`` defaults to it.
#: ``standard``: 4, the fewest for a standard error <= 1 deg per design point at the test's
#: measured scatter (1.88-2.01 deg; docs/precision.md).
FIDELITY_REPLICATES: dict[str, int] = {"quick": 1, "small": 3, "standard": 4, "paper": 1}


def fidelity_overrides(name: str, overrides: dict) -> dict:
    """The fidelity's own settings (its tube and fill) with ``overrides`` on top, nested
    tables merged key by key: everything that sets the test apart from the default (paper)
    configuration. An unknown name contributes nothing."""
    data: dict = {}
    for src in (FIDELITIES.get(name, {}), overrides):
        for key, value in src.items():
            if isinstance(value, dict):
                data.setdefault(key, {}).update(value)
            else:
                data[key] = value
    return data


def without_fidelity(overrides: dict, name: str) -> dict:
    """Test overrides less the settings that only repeat the fidelity's own (the tube and
    fill a material card writes out so that it runs the same pile): the inverse of
    :func:`fidelity_overrides` for the settings the overrides did not change."""
    own_all = FIDELITIES.get(name, {})
    out = {}
    for key, value in overrides.items():
        own = own_all.get(key)
        if isinstance(value, dict) and isinstance(own, dict):
            rest = {k: v for k, v in value.items() if k not in own or own[k] != v}
            if rest:
                out[key] = rest
        elif own is None or own != value:
            out[key] = value
    return out


def fidelity_config(name: str, **overrides) -> AoRTestConfig:
    """The test configuration of a fidelity (``quick``, ``small``, ``standard`` or ``paper``),
    with nested overrides."""
    from demcal.errors import InputError

    if name not in FIDELITIES:
        renamed = {"large": " ('large' is now called 'standard')"}.get(name, "")
        raise InputError(f"fidelity must be one of {', '.join(FIDELITIES)}; got {name!r}"
                         + renamed)
    return AoRTestConfig.model_validate(fidelity_overrides(name, overrides))
