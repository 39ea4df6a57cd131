"""One rotating-drum frame's measures, the steady-state rule and a run's result, whichever
engine turned the drum.

demcal's engine (:mod:`demcal.virtual.drum`) measures its frames as it runs; the LAMMPS
engine (:mod:`demcal.virtual.lammps_drum`) dumps them and demcal measures them afterwards.
Both go through these functions, so a frame means the same in both: the free surface's
angle in the side view (:func:`~demcal.virtual.drum_surface.surface_line`), the centre of
mass' angle, the flowing, airborne and carried fractions and the wall's coverage, and the
same rule says when the flow is steady.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from demcal.results import RunResult, finite_responses
from demcal.virtual.drum_settings import DrumSettings
from demcal.virtual.drum_surface import (
    MEASURED,
    DrumOutcome,
    FrameStats,
    com_angle,
    surface_line,
    wall_coverage,
)

__all__ = ["AXIS", "RESPONSES", "SETTLE_MAX", "SETTLE_RMS", "DrumResult", "FrameLog", "FrameState",
           "RunInfo", "frame_angle", "side_view", "steady_drift", "summarise"]

#: The responses the drum test reports for a rolling or slumping bed: the dynamic angle, the
#: centre of mass' angle and the surface's fluctuation over frames (deg); DrumResult fields
#: without the ``drum_`` prefix.
RESPONSES = ("drum_dynamic_aor_deg", "drum_com_angle_deg", "drum_surface_fluctuation_deg")

#: the drum turns about +y: its bottom moves towards -x, so the bed rises on the -x side
AXIS = np.array([0.0, 1.0, 0.0])
#: the settle criterion of the fill (the lift test's defaults), m/s; also the speed above
#: which a clump counts as moving off the drum's rotation however slowly the drum turns
SETTLE_RMS, SETTLE_MAX = 0.005, 0.03


@dataclass
class DrumResult:
    """What one rotating-drum test measured (SI units, angles in degrees).

    ``dynamic_aor_deg`` (the mean over the steady frames of the free surface's angle),
    ``com_angle_deg`` (the mean centre-of-mass angle from the vertical), ``surface_fluctuation_
    deg`` (the standard deviation of the frames' angles) are None unless the outcome is
    ``rolling`` or ``slumping``.
    """

    outcome: str
    reason: str | None
    dynamic_aor_deg: float | None
    com_angle_deg: float | None
    surface_fluctuation_deg: float | None
    froude: float
    rpm: float
    n_particles: int
    seed: int
    params: dict[str, float]
    frames_deg: list[float] = field(default_factory=list)
    com_frames_deg: list[float] = field(default_factory=list)
    flowing_fraction: float | None = None
    airborne_fraction: float | None = None
    carried_fraction: float | None = None
    settled: bool = False
    time_step_s: float = 0.0
    sim_time_s: float = 0.0
    wall_time_s: float = 0.0
    phase_times_s: dict[str, float] = field(default_factory=dict)
    engine: str = "demcal"

    @property
    def angle_com_difference_deg(self) -> float | None:
        """The dynamic angle less the centre-of-mass angle, deg (None without both)."""
        if self.dynamic_aor_deg is None or self.com_angle_deg is None:
            return None
        return self.dynamic_aor_deg - self.com_angle_deg

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (with ``angle_com_difference_deg``)."""
        out = {k: getattr(self, k) for k in self.__dataclass_fields__}
        out["angle_com_difference_deg"] = self.angle_com_difference_deg
        return out

    def responses(self) -> dict[str, float]:
        """The measured responses by name (:data:`RESPONSES`); none unless the outcome is
        ``rolling`` or ``slumping``."""
        if self.outcome not in MEASURED:
            return {}
        return finite_responses({name: getattr(self, name.removeprefix("drum_"))
                                 for name in RESPONSES})

    def run_result(self, key: str) -> RunResult:
        """This run as the study's typed :class:`~demcal.results.RunResult` under ``key``."""
        return RunResult(key, self.outcome, self.responses(), self.reason, self.wall_time_s,
                         self.to_dict())


@dataclass(frozen=True)
class FrameState:
    """The bed at one frame, in the world frame (the drum's axis along y through the
    origin), SI units."""

    centres: np.ndarray  #: (n, 3) sphere centres, m
    radii: np.ndarray  #: (n,) sphere radii, m
    com: np.ndarray  #: (m, 3) clump centres of mass, m
    velocity: np.ndarray  #: (m, 3) clump centre-of-mass velocities, m/s
    masses: np.ndarray  #: (m,) clump masses, kg


def side_view(points: np.ndarray) -> np.ndarray:
    """World points (n, 3) in the side view: ``(u, v)`` with ``u`` towards the rising side
    (-x) and ``v`` up (z), m."""
    return np.column_stack([-points[:, 0], points[:, 2]])


def frame_angle(centres: np.ndarray, radii: np.ndarray, s: DrumSettings) -> float | None:
    """The free surface's angle of one frame, deg (None: no surface found)."""
    line = surface_line(side_view(centres), radii, bin_width=s.bin_width * s.particle_diameter,
                        central_fraction=s.central_fraction)
    return None if line is None else line.angle_deg


def steady_drift(angles: list[float], window: int) -> float | None:
    """How far the running mean of the last ``window`` angles lies from the one over the
    ``window`` before, deg (None: fewer than ``2 window`` angles). The flow is steady once
    this falls below the settings' ``steady_tolerance_deg``."""
    if len(angles) < 2 * window:
        return None
    return float(abs(np.mean(angles[-window:]) - np.mean(angles[-2 * window:-window])))


@dataclass
class FrameLog:
    """The averaged frames' measures, one entry per frame (a frame without a surface adds
    to the fractions but not to the angles)."""

    angles: list[float] = field(default_factory=list)
    coms: list[float] = field(default_factory=list)
    flowing: list[float] = field(default_factory=list)
    airborne: list[float] = field(default_factory=list)
    coverage: list[float] = field(default_factory=list)
    carried: list[float] = field(default_factory=list)

    def add(self, state: FrameState, s: DrumSettings) -> None:
        """Measure one frame: its angle, centre-of-mass angle, flowing and airborne
        fractions, wall coverage and the fraction of the clumps against the wall carried
        with it."""
        line = surface_line(side_view(state.centres), state.radii,
                            bin_width=s.bin_width * s.particle_diameter,
                            central_fraction=s.central_fraction)
        cuv = side_view(state.com)
        # off the solid-body rotation omega x r (omega along +y): the flowing layer
        off = np.linalg.norm(state.velocity - np.cross(s.omega * AXIS, state.com), axis=1) \
            > max(0.5 * s.omega * s.radius, SETTLE_MAX)
        self.flowing.append(float(np.mean(off)))
        against = np.hypot(cuv[:, 0], cuv[:, 1]) >= s.radius - s.particle_size
        self.carried.append(float(np.mean(~off[against])) if against.any() else math.nan)
        self.coverage.append(wall_coverage(cuv, radius=s.radius, reach=s.particle_size))
        if line is None:
            return
        self.angles.append(line.angle_deg)
        com = com_angle(cuv, state.masses)
        if com is not None:
            self.coms.append(com)
        above = cuv[:, 1] - (line.slope * cuv[:, 0] + line.intercept)
        self.airborne.append(float(np.mean(above > s.particle_size)))

    def stats(self) -> FrameStats:
        """The frames' fractions for :func:`~demcal.virtual.drum_surface.classify_frames`."""
        return FrameStats(np.array(self.flowing), np.array(self.airborne),
                          np.array(self.coverage), np.array(self.carried))


@dataclass(frozen=True)
class RunInfo:
    """What a run's result says besides its frames."""

    params: dict[str, float]
    seed: int
    n_particles: int
    settled: bool
    time_step_s: float
    sim_time_s: float
    wall_time_s: float
    phase_times_s: dict[str, float]
    engine: str = "demcal"


def summarise(log: FrameLog, outcome: DrumOutcome, reason: str | None, info: RunInfo,
              s: DrumSettings) -> DrumResult:
    """A run's :class:`DrumResult` from its frames: the dynamic angle and its fluctuation,
    the centre-of-mass angle (only for a ``rolling`` or ``slumping`` bed) and the mean
    fractions."""
    measured = outcome in MEASURED
    angles = np.array(log.angles)
    return DrumResult(
        outcome=outcome.value, reason=reason,
        dynamic_aor_deg=float(angles.mean()) if measured else None,
        com_angle_deg=float(np.mean(log.coms)) if measured and log.coms else None,
        surface_fluctuation_deg=float(angles.std(ddof=1)) if measured else None,
        froude=s.froude, rpm=s.rpm, n_particles=info.n_particles, seed=info.seed,
        params=dict(info.params), frames_deg=[float(a) for a in angles],
        com_frames_deg=[float(a) for a in log.coms],
        flowing_fraction=float(np.mean(log.flowing)) if log.flowing else None,
        airborne_fraction=float(np.mean(log.airborne)) if log.airborne else None,
        carried_fraction=float(np.nanmean(log.carried)) if np.isfinite(log.carried).any()
        else None,
        settled=info.settled, time_step_s=info.time_step_s, sim_time_s=info.sim_time_s,
        wall_time_s=info.wall_time_s, phase_times_s=dict(info.phase_times_s),
        engine=info.engine)
