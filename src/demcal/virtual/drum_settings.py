"""Settings of the rotating-drum test (validated, SI units) and its fidelities.

:class:`DrumSettings` holds the drum (diameter, width), the fill (its fraction of the drum's
volume), the speed (rpm) and the phases (spin-up, the steady-state rule, the frames averaged);
:func:`drum_settings` builds one from a fidelity (``quick``, ``standard``) and ``--test``-style
overrides. Every refusal is one line naming the setting and its allowed range (an
:class:`~demcal.errors.InputError`), raised before any engine is built: a fill of 100 % or
more, a speed at or above the critical one (Froude number ``omega^2 R / g >= 1``: the material
centrifuges, there is no free surface to measure), a drum narrower than two particles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from typing import Any

from pydantic import ValidationError

from demcal.errors import InputError
from demcal.virtual.config import ROLLING_MODELS, ParticleShape

__all__ = ["DRUM_FIDELITIES", "WALL_PARAMETERS", "DrumSettings", "G", "critical_rpm",
           "drum_settings", "froude"]

G = 9.81  #: gravitational acceleration of the test, m/s^2 (along -z)

#: the drum's own lining: setting -> the material parameter it replaces in the drum
WALL_PARAMETERS = {"wall_static_friction": "pw.static_friction",
                   "wall_rolling_friction": "pw.rolling_friction",
                   "wall_restitution": "pw.restitution"}


def froude(rpm: float, diameter: float) -> float:
    """The drum's Froude number ``omega^2 R / g`` (``rpm`` 1/min, ``diameter`` m)."""
    omega = 2.0 * math.pi * rpm / 60.0
    return omega * omega * 0.5 * diameter / G


def critical_rpm(diameter: float) -> float:
    """The speed at which the Froude number reaches 1 (the material centrifuges), 1/min."""
    return 60.0 / (2.0 * math.pi) * math.sqrt(G / (0.5 * diameter))


@dataclass(frozen=True)
class DrumSettings:
    """The rotating-drum test, all but the material parameters (SI units).

    Attributes
    ----------
    diameter, width : float
        Inner diameter and inner width (between the end walls) of the drum, m.
    fill_fraction : float
        Fraction of the drum's volume the settled bed takes, in (0, 1); the particle count is
        this volume times ``bed_solid_fraction`` over the mean particle volume.
    rpm : float
        Turning speed, 1/min (>= 0; 0: a drum at rest, whose bed keeps its settled angle).
    spin_up_s : float
        Time over which the speed ramps linearly from rest to ``rpm``, s.
    frames : int
        Frames averaged once the flow is steady.
    frame_interval_s : float
        Time between frames (and between the steady-state checks), s.
    steady_window : int
        Frames of each of the two running means compared by the steady-state rule.
    steady_tolerance_deg : float
        Steady when the two last running means of the angle differ by less than this, deg.
    steady_max_s : float
        Longest wait for a steady flow after the spin-up, s (then ``unsettled``).
    settle_max_s : float
        Longest wait for the fill to settle before the drum turns, s (then ``unsettled``).
    bed_solid_fraction : float
        Solid fraction assumed for the settled bed when counting the particles.
    count : int or None
        The particle count itself (overrides the fill fraction's count).
    bin_width : float
        Width of the columns across the drum in which the free surface is the highest
        particle, in particle diameters.
    central_fraction : float
        Central part of the surface's chord over which the line is fitted.
    dt_fraction : float
        Time step over the Rayleigh time step.
    rolling_model : {"A", "C", "none"}
        Rolling-friction model of the engine.
    particle : ParticleShape
        The particle template and its size distribution (the lift test's).
    wall_static_friction, wall_rolling_friction, wall_restitution : float or None
        The drum's own lining (its shell and end walls): these replace the material's
        ``pw.static_friction``, ``pw.rolling_friction`` and ``pw.restitution`` in the drum
        only (None: the material's particle-wall values, as the lift test's). A drum is
        often lined rough so that it carries the bed, while the lift test's cylinder is the
        material's steel.
    """

    diameter: float = 0.06
    width: float = 0.03
    fill_fraction: float = 0.4
    rpm: float = 30.0
    spin_up_s: float = 0.1
    frames: int = 20
    frame_interval_s: float = 0.02
    steady_window: int = 5
    steady_tolerance_deg: float = 1.5
    steady_max_s: float = 2.0
    settle_max_s: float = 1.5
    bed_solid_fraction: float = 0.3
    count: int | None = None
    bin_width: float = 1.0
    central_fraction: float = 0.6
    dt_fraction: float = 0.2
    rolling_model: str = "A"
    particle: ParticleShape = field(default_factory=ParticleShape)
    wall_static_friction: float | None = None
    wall_rolling_friction: float | None = None
    wall_restitution: float | None = None

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name in ("particle", "rolling_model", "count") or (
                    f.name in WALL_PARAMETERS and getattr(self, f.name) is None):
                continue
            _finite(f.name, getattr(self, f.name))
        _ranges(self)
        _fits(self)

    def wall_overrides(self) -> dict[str, float]:
        """The material parameters the drum's lining replaces, by name (``pw.*``)."""
        return {WALL_PARAMETERS[name]: float(getattr(self, name)) for name in WALL_PARAMETERS
                if getattr(self, name) is not None}

    @property
    def radius(self) -> float:
        """Inner radius, m."""
        return 0.5 * self.diameter

    @property
    def omega(self) -> float:
        """Angular speed, rad/s."""
        return 2.0 * math.pi * self.rpm / 60.0

    @property
    def froude(self) -> float:
        """Froude number ``omega^2 R / g``."""
        return froude(self.rpm, self.diameter)

    @property
    def particle_size(self) -> float:
        """The largest particle's largest dimension, m (length x size_max for a stalk)."""
        p = self.particle
        big = p.diameter if p.template == "sphere" else max(p.length, p.diameter)
        return big * p.size_max

    @property
    def particle_diameter(self) -> float:
        """The mean particle's diameter (its thickness), m."""
        p = self.particle
        return p.diameter * 0.5 * (p.size_min + p.size_max)


def _finite(name: str, value: Any) -> None:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InputError(f"drum.{name} must be a finite number; got {value!r}")


#: (name, low, high, low included, high included) of every bounded setting
_RANGES = (
    ("diameter", 0.0, 10.0, False, True),
    ("width", 0.0, 10.0, False, True),
    ("fill_fraction", 0.0, 1.0, False, False),
    ("rpm", 0.0, 1e4, True, True),
    ("spin_up_s", 0.0, 100.0, True, True),
    ("frames", 2, 100_000, True, True),
    ("frame_interval_s", 0.0, 10.0, False, True),
    ("steady_window", 1, 1000, True, True),
    ("steady_tolerance_deg", 0.0, 90.0, False, True),
    ("steady_max_s", 0.0, 1000.0, True, True),
    ("settle_max_s", 0.0, 1000.0, False, True),
    ("bed_solid_fraction", 0.0, 0.74, False, True),
    ("bin_width", 0.1, 10.0, True, True),
    ("central_fraction", 0.0, 1.0, False, True),
    ("dt_fraction", 0.0, 1.0, False, True),
)


def _ranges(s: DrumSettings) -> None:
    for name in WALL_PARAMETERS:
        if getattr(s, name) is not None:
            _wall_range(name, getattr(s, name))
    for name, lo, hi, lo_in, hi_in in _RANGES:
        v = getattr(s, name)
        ok = (v >= lo if lo_in else v > lo) and (v <= hi if hi_in else v < hi)
        if not ok:
            span = f"{'[' if lo_in else '('}{lo:g}, {hi:g}{']' if hi_in else ')'}"
            hint = " (a fill of 100 % or more leaves no free surface)" \
                if name == "fill_fraction" else ""
            raise InputError(f"drum.{name} must be in {span}; got {v:g}{hint}")
    for name in ("frames", "steady_window"):
        if int(getattr(s, name)) != getattr(s, name):
            raise InputError(f"drum.{name} must be a whole number; got {getattr(s, name)}")
    if s.count is not None and (isinstance(s.count, bool) or not isinstance(s.count, int)
                                or not 10 <= s.count <= 100_000):
        raise InputError(f"drum.count must be a whole number in [10, 100000]; got {s.count!r}")
    if s.rolling_model not in ROLLING_MODELS:
        raise InputError(f"rolling_model must be A, C or none; got {s.rolling_model!r}")


def _wall_range(name: str, value: float) -> None:
    """The lining's value within its material parameter's bounds (the registry's)."""
    from demcal.parameters import PARAMETERS

    try:
        PARAMETERS[WALL_PARAMETERS[name]].check(value)
    except InputError:
        spec = PARAMETERS[WALL_PARAMETERS[name]]
        raise InputError(f"drum.{name} must be in {spec.bounds_text()} (the drum's "
                         f"{WALL_PARAMETERS[name]}); got {value!r}") from None


def _fits(s: DrumSettings) -> None:
    fr = s.froude
    if fr >= 1.0:
        raise InputError(
            f"drum.rpm {s.rpm:g} gives a Froude number omega^2 R / g = {fr:.3g} >= 1: the "
            f"material centrifuges; the critical speed of a {s.diameter * 1e3:g} mm drum is "
            f"{critical_rpm(s.diameter):.1f} rpm, give less")
    two = 2.0 * s.particle_size
    for name, value in (("width", s.width), ("radius", s.radius)):
        if value < two:
            raise InputError(
                f"drum.{'width' if name == 'width' else 'diameter'}: the drum's {name} "
                f"({value * 1e3:.4g} mm) must be at least 2 particle sizes ({two * 1e3:.4g} mm: "
                "twice the longest particle, its length x size_max)")


#: fidelity name -> settings that differ from :class:`DrumSettings`' defaults
DRUM_FIDELITIES: dict[str, dict[str, Any]] = {
    # a 60 mm x 30 mm drum 40 % full at 30 rpm (Froude 0.030): ~90 stalks, 40 frames over
    # 0.8 s; a demonstration and the tests' physics checks
    "quick": {"frames": 40},
    # a 90 mm x 40 mm drum 40 % full (268 stalks), 100 frames over 3 s. Measured
    # (benchmarks/drum_precision.py, docs/drum.md): seed-to-seed std 0.55 deg over 6 seeds
    # at ~100 CPU-s per run (40 frames: 0.97 deg, ~53 CPU-s)
    "standard": {"diameter": 0.09, "width": 0.04, "frames": 100, "frame_interval_s": 0.03},
}


def drum_settings(fidelity: str = "quick", overrides: dict[str, Any] | None = None
                  ) -> DrumSettings:
    """The settings of a fidelity with ``overrides`` on top.

    Parameters
    ----------
    fidelity : {"quick", "standard"}
        The fidelity.
    overrides : dict, optional
        ``--test``-style nested overrides: ``{"drum": {"rpm": 15}}``, ``{"particle":
        {"n_spheres": 5}}``, ``{"rolling_model": "C"}``, ``{"dt_fraction": 0.1}``.

    Raises
    ------
    InputError
        One line: an unknown fidelity or setting, or a setting out of its range.
    """
    if fidelity not in DRUM_FIDELITIES:
        raise InputError(f"fidelity must be one of {', '.join(DRUM_FIDELITIES)}; "
                         f"got {fidelity!r}")
    over = dict(overrides or {})
    values: dict[str, Any] = dict(DRUM_FIDELITIES[fidelity])
    drum = over.pop("drum", {})
    if not isinstance(drum, dict):
        raise InputError("--test drum.NAME=VALUE sets a drum setting; got drum=" + repr(drum))
    names = {f.name for f in fields(DrumSettings)} - {"particle", "rolling_model",
                                                      "dt_fraction"}
    for key, value in drum.items():
        if key not in names:
            raise InputError(f"drum.{key} is not a drum setting; use one of "
                             f"{', '.join(sorted(names))}")
        values[key] = value
    particle = over.pop("particle", None)
    for key in ("rolling_model", "dt_fraction"):
        if key in over:
            values[key] = over.pop(key)
    if over:
        raise InputError(f"--test {sorted(over)[0]}: not a drum test setting (drum.NAME, "
                         "particle.NAME, rolling_model, dt_fraction)")
    settings = DrumSettings(**values)
    if particle is not None:
        try:
            shape = ParticleShape.model_validate({**settings.particle.model_dump(), **particle})
        except ValidationError as exc:
            err = exc.errors()[0]
            where = "".join(f".{p}" for p in err["loc"])
            msg = str(err["msg"]).removeprefix("Value error, ")
            raise InputError(f"particle{where}: {msg}") from None
        settings = replace(settings, particle=shape)
    return settings
