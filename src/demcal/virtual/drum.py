"""The rotating-drum test: the dynamic angle of a bed in a turning drum, as a camera sees it.

Each run goes through the test's phases: **fill** (the preset's particles placed at random
in the drum as a loose packing and dropped from rest), **settle**, **spin-up** (the speed ramps
from rest to its set rpm), **steady** (frames are taken until the running mean of the angle
no longer drifts) and **frames** (the set number of frames averaged). The drum's axis is
horizontal (the y axis), gravity along -z; the drum turns about +y, so its wall carries the
bed up on the -x side. Each frame is the view through the end wall
(:mod:`demcal.virtual.drum_surface`): the free surface's angle, the centre of mass' angle, the
flowing and airborne fractions. Every run ends in one typed
:class:`~demcal.virtual.drum_surface.DrumOutcome`.

One run is one engine (:class:`~demcal.dem.simulation.Simulation`) of one world, run alone:
a run's result is its seed's and its parameters', whatever else runs beside it.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from demcal.dem.output import VtkSeries
from demcal.dem.simulation import Simulation
from demcal.dem.state import ClumpGroup, World
from demcal.dem.walls import Drum
from demcal.errors import InputError
from demcal.limits import check_time_step
from demcal.virtual.aor import material_table
from demcal.virtual.drum_frames import (
    AXIS,
    RESPONSES,
    SETTLE_MAX,
    SETTLE_RMS,
    DrumResult,
    FrameLog,
    FrameState,
    RunInfo,
    frame_angle,
    steady_drift,
    summarise,
)
from demcal.virtual.drum_settings import DrumSettings
from demcal.virtual.drum_surface import DrumOutcome, classify_frames
from demcal.virtual.factory import SphereGrid, draw_scales, make_template, place_in_cylinder
from demcal.virtual.parameters import check_parameter_sets
from demcal.virtual.settle import settle_state

__all__ = ["RESPONSES", "DrumReporting", "DrumResult", "run_drum"]

#: progress callback: (run index, phase name, simulated time s, wall time s)
Progress = Callable[[int, str, float, float], None]


@dataclass(frozen=True)
class DrumReporting:
    """What a caller of :func:`run_drum` gets besides the results (none of it changes a run).

    Attributes
    ----------
    progress : callable, optional
        Called as ``progress(run, phase, sim_time_s, wall_time_s)`` at every frame.
    vtk_dir : path, optional
        A folder for VTK snapshots: per run a ParaView series ``drum_seed<seed>.pvd`` with
        the bed once settled, once spun up, once steady and at every averaged frame (spheres
        and the drum's walls).
    """

    progress: Progress | None = None
    vtk_dir: str | Path | None = None

#: a quarter turn about x: the placement frame's axis (z) onto the drum's (y)
_Q_FIX = np.array([math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0])
#: rounds of the fill: what did not fit falls for FILL_FALL_S, then is tried again
FILL_ROUNDS = 12
FILL_FALL_S = 0.04


@dataclass
class _Run:
    """One run's engine and its record."""

    sim: Simulation
    settings: DrumSettings
    t0: float  #: wall clock at the start, s
    phase_times: dict[str, float] = field(default_factory=dict)
    frames: FrameLog = field(default_factory=FrameLog)
    vtk: VtkSeries | None = None  #: the run's VTK snapshots, if asked for

    def snapshot(self, label: str) -> None:
        """Write the bed and the walls now, if snapshots are asked for."""
        if self.vtk is not None:
            self.vtk.add(self.sim, 0, label=label)

    @property
    def t(self) -> float:
        return float(self.sim.time[0])


class _Stop(Exception):
    """A run ends before its frames: its outcome and reason."""

    def __init__(self, outcome: DrumOutcome, reason: str):
        super().__init__(reason)
        self.outcome, self.reason = outcome, reason


def run_drum(parameter_sets: Sequence[Mapping[str, float]], *, settings: DrumSettings,
             seeds: Sequence[int], backend: str = "auto",
             reporting: DrumReporting | None = None) -> list[DrumResult]:
    """Run rotating-drum tests, one after the other.

    Parameters
    ----------
    parameter_sets : sequence of mapping
        Complete parameter sets (every name of :data:`demcal.virtual.parameters.PARAMETERS`,
        SI units), one per run; see :func:`demcal.virtual.presets.preset_parameters`.
    settings : DrumSettings
        The test (:func:`demcal.virtual.drum_settings.drum_settings`).
    seeds : sequence of int
        One seed per run (particle sizes, orientations and positions).
    backend : {"auto", "cpu", "cuda"}
        Engine backend.
    reporting : DrumReporting, optional
        Progress calls and VTK snapshots.

    Returns
    -------
    list of DrumResult
        One per run, in order.
    """
    checked = check_parameter_sets(parameter_sets, seeds)
    out = []
    for i, (params, seed) in enumerate(zip(checked, seeds, strict=True)):
        def report(phase: str, t: float, wall: float, i=i) -> None:
            if reporting is not None and reporting.progress is not None:
                reporting.progress(i, phase, t, wall)
        vtk = None if reporting is None or reporting.vtk_dir is None else \
            VtkSeries(reporting.vtk_dir, f"drum_seed{int(seed)}")
        out.append(_one_run(params, (int(seed), vtk), settings, backend, report))
    return out


def particle_count(settings: DrumSettings) -> int:
    """The particles of a test: ``count``, or the fill's bed volume (``fill_fraction`` of the
    drum's) at ``bed_solid_fraction`` over the mean particle volume (at least 10)."""
    if settings.count is not None:
        return settings.count
    p = settings.particle
    lo, hi = p.size_min, p.size_max
    mean_s3 = (hi**4 - lo**4) / (4 * (hi - lo)) if hi > lo else lo**3
    volume = math.pi * settings.radius**2 * settings.width
    solid = settings.fill_fraction * volume * settings.bed_solid_fraction
    return max(10, round(solid / (make_template(p).volume * mean_s3)))


def _one_run(params: dict[str, float], run_of: tuple[int, VtkSeries | None], s: DrumSettings,
             backend: str, report: Callable[[str, float, float], None]) -> DrumResult:
    seed, vtk = run_of
    params = {**params, **s.wall_overrides()}  # the drum's own lining, if set
    template = make_template(s.particle)
    n = particle_count(s)
    rng = np.random.default_rng(seed)
    scales = draw_scales(n, s.particle, rng)
    lim = s.radius + 0.05
    drum = Drum(centre=np.zeros(3), axis=AXIS, radius=s.radius, width=s.width)
    world = World(material_table(params), [ClumpGroup(template, "particle", n, scales=scales)],
                  drum.walls(), domain_lo=(-lim, -0.5 * s.width - 0.05, -lim),
                  domain_hi=(lim, 0.5 * s.width + 0.05, lim))
    sim = Simulation([world], backend=backend, dt_fraction=s.dt_fraction,
                     rolling_friction=s.rolling_model, raise_on_unstable=False)
    try:
        check_time_step(float(sim.dt[0]))
    except ValueError as exc:
        raise InputError(str(exc)) from None
    run = _Run(sim, s, time.perf_counter(), vtk=vtk)
    try:
        _fill(run, template, scales, rng)
        _settle(run, report)
        _spin_up(run, drum, report)
        _steady(run, report)
        _frames(run, report)
    except _Stop as stop:
        return _result(run, (params, seed), stop.outcome, stop.reason)
    outcome, reason = classify_frames(run.frames.stats(), s.fill_fraction)
    return _result(run, (params, seed), outcome, reason)


def to_world(pos: np.ndarray, quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Placement frame (the drum's axis along z) to the world's (its axis along y): a
    quarter turn about x, ``(x, y, z) -> (x, -z, y)``; orientations turned with it."""
    world = np.column_stack([pos[:, 0], -pos[:, 2], pos[:, 1]])
    w0, x0 = _Q_FIX[0], _Q_FIX[1]
    w, x, y, z = quat.T
    # the Hamilton product q_fix * q for q_fix = (w0, x0, 0, 0)
    turned = np.column_stack([w0 * w - x0 * x, w0 * x + x0 * w, w0 * y - x0 * z,
                              w0 * z + x0 * y])
    return world, turned


def _fill(run: _Run, template, scales: np.ndarray, rng: np.random.Generator) -> None:
    """Place every particle at random in the drum without overlap; what does not fit falls
    with the rest for a moment and is tried again above it (a full drum holds the loose
    fill only once part of it has fallen)."""
    s, sim = run.settings, run.sim
    margin = float(scales.max() * template.bounding_radius)
    todo = np.arange(len(scales))
    for _ in range(FILL_ROUNDS):
        centres, radii, _ = sim.spheres(0)
        grid = SphereGrid(2.0 * float(template.radii.max() * scales.max()))
        # the world's spheres in the placement frame: (x, y, z) -> (x, z, -y)
        grid.add(np.column_stack([centres[:, 0], centres[:, 2], -centres[:, 1]]), radii)
        idx, pos, quat = place_in_cylinder(template, scales[todo], radius=s.radius,
                                           z_low=-0.5 * s.width + margin,
                                           z_high=0.5 * s.width - margin, rng=rng, grid=grid,
                                           attempts=30)
        if len(idx):
            world, turned = to_world(pos, quat)
            sim.place_clumps(0, todo[idx], world, turned)
            todo = np.delete(todo, idx)
        if len(todo) == 0:
            return
        _advance(run, FILL_FALL_S)
    raise InputError(f"could not place {len(todo)} of {len(scales)} particles in the drum; "
                     "lower drum.fill_fraction or drum.bed_solid_fraction")


def _advance(run: _Run, duration: float) -> None:
    """Advance by ``duration`` (s, whole steps); a numerical failure stops the run."""
    sim = run.sim
    sim.advance(max(1, round(duration / float(sim.dt[0]))))
    if sim.world_errors[0] is not None:
        raise _Stop(DrumOutcome.UNSTABLE, sim.world_errors[0])


def _settle(run: _Run, report) -> None:
    s, sim = run.settings, run.sim
    tol = 0.05 * s.particle.diameter * s.particle.size_min
    start = run.t

    def spheres():
        centres, radii, sphere_clump = sim.spheres(0)
        return np.unique(sphere_clump), centres, radii, sphere_clump

    while True:
        _advance(run, s.frame_interval_s)
        report("settle", run.t, time.perf_counter() - run.t0)
        state = settle_state(sim.clump_velocities(0), spheres, rms_limit=SETTLE_RMS,
                             max_limit=SETTLE_MAX, tolerance=tol)
        if state.settled:
            run.phase_times["settled"] = run.t
            run.snapshot("settled")
            return
        if run.t - start > s.settle_max_s:
            raise _Stop(DrumOutcome.UNSETTLED,
                        f"the fill did not settle within {s.settle_max_s} s (rms speed "
                        f"{state.rms_speed:.3g} m/s, max {state.max_speed:.3g} m/s)")


def _spin_up(run: _Run, drum: Drum, report) -> None:
    """Ramp the speed linearly to ``rpm`` over ``spin_up_s`` in 20 steps (a sudden start
    would throw the bed against the wall)."""
    s = run.settings
    ramp = 20 if s.spin_up_s > 0 else 1
    for k in range(1, ramp + 1):
        drum.set_speed(run.sim, 0, 0, s.omega * k / ramp)
        if s.spin_up_s > 0:
            _advance(run, s.spin_up_s / ramp)
    report("spin-up", run.t, time.perf_counter() - run.t0)
    run.phase_times["spun_up"] = run.t
    run.snapshot("spun_up")


def _steady(run: _Run, report) -> None:
    """Take frames until the running mean of the angle over the last ``steady_window``
    frames is within ``steady_tolerance_deg`` of the one over the window before."""
    s = run.settings
    k = s.steady_window
    start = run.t
    angles: list[float] = []
    while True:
        _advance(run, s.frame_interval_s)
        report("steady", run.t, time.perf_counter() - run.t0)
        centres, radii, _ = run.sim.spheres(0)
        angle = frame_angle(centres, radii, s)
        if angle is not None:
            angles.append(angle)
        drift = steady_drift(angles, k)
        if drift is not None and drift < s.steady_tolerance_deg:
            run.phase_times["steady"] = run.t
            run.snapshot("steady")
            return
        if run.t - start > s.steady_max_s:
            tail = "" if len(angles) < 2 * k else f" (its running mean still drifts by " \
                f"{drift:.2f} deg over {k} frames)"
            raise _Stop(DrumOutcome.UNSETTLED,
                        f"the angle did not become steady within {s.steady_max_s} s" + tail)


def _frames(run: _Run, report) -> None:
    """The averaged frames: each one's angle, centre-of-mass angle, flowing and airborne
    fractions and wall coverage. A frame without a surface is skipped; fewer than half
    measured ends the run as ``unsettled``."""
    s, sim = run.settings, run.sim
    for _ in range(s.frames):
        _advance(run, s.frame_interval_s)
        report("frames", run.t, time.perf_counter() - run.t0)
        centres, radii, _ = sim.spheres(0)
        run.frames.add(FrameState(centres, radii, sim.clump_positions(0),
                                  sim.clump_velocities(0), sim.clump_masses(0)), s)
        run.snapshot("frame")
    missing = s.frames - len(run.frames.angles)
    if 2 * len(run.frames.angles) < s.frames:
        raise _Stop(DrumOutcome.UNSETTLED, f"no free surface found in {missing} of {s.frames} "
                    "frames")


def _result(run: _Run, what: tuple[dict[str, float], int], outcome: DrumOutcome,
            reason: str | None) -> DrumResult:
    sim = run.sim
    params, seed = what
    info = RunInfo(params=params, seed=seed, n_particles=sim.n_active(0),
                   settled="settled" in run.phase_times, time_step_s=float(sim.dt[0]),
                   sim_time_s=run.t, wall_time_s=time.perf_counter() - run.t0,
                   phase_times_s=run.phase_times)
    return summarise(run.frames, outcome, reason, info, run.settings)
