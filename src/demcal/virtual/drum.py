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

All runs of a call are worlds of one engine (:class:`~demcal.dem.simulation.Simulation`),
as the lift test's are: each world has its own parameters, seed, time step and phases and
ends at its own time, so one GPU can turn a whole design's drums at once. A run's result is
its seed's and its parameters', bit for bit what it gives alone, whatever else runs beside it
(:func:`_drive` says why, and the one exception: the time in an unstable run's reason).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Generator, Mapping, Sequence
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
        Called as ``progress(run, phase, sim_time_s, wall_time_s)`` at every frame of every
        run (``run``: its index in the call; ``wall_time_s``: since the batch started, s).
    vtk_dir : path, optional
        A folder for VTK snapshots: per run a ParaView series ``drum_seed<seed>.pvd`` with
        the bed once settled, once spun up, once steady and at every averaged frame (spheres
        and the drum's walls); ``drum_run<k>_seed<seed>.pvd`` when a call repeats a seed.
    on_result : callable, optional
        Called as ``on_result(run, result)`` the moment a run ends, before the batch does,
        so that a caller can store it at once (a study stopped midway keeps it).
    """

    progress: Progress | None = None
    vtk_dir: str | Path | None = None
    on_result: Callable[[int, DrumResult], None] | None = None


#: a quarter turn about x: the placement frame's axis (z) onto the drum's (y)
_Q_FIX = np.array([math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0])
#: rounds of the fill: what did not fit falls for FILL_FALL_S, then is tried again
FILL_ROUNDS = 12
FILL_FALL_S = 0.04


@dataclass(frozen=True)
class _Bed:
    """What one run brings to the batch: its parameters (the drum's lining over the
    material's), seed, drawn particle sizes, the random stream its fill goes on with, and its
    world."""

    params: dict[str, float]
    seed: int
    scales: np.ndarray  #: (n,) particle scale factors
    rng: np.random.Generator  #: the seed's stream, after the sizes were drawn
    world: World


@dataclass
class _Run:
    """One run's world in the batched engine and its record."""

    sim: Simulation
    world: int  #: its world index in ``sim`` (and its run index in ``run_drum``)
    settings: DrumSettings
    bed: _Bed
    t0: float  #: wall clock at the start of the batch, s
    reporting: DrumReporting
    phase_times: dict[str, float] = field(default_factory=dict)
    frames: FrameLog = field(default_factory=FrameLog)
    vtk: VtkSeries | None = None  #: the run's VTK snapshots, if asked for

    def snapshot(self, label: str) -> None:
        """Write the bed and the walls now, if snapshots are asked for."""
        if self.vtk is not None:
            self.vtk.add(self.sim, self.world, label=label)

    def report(self, phase: str) -> None:
        """Tell the caller's progress callback where this run is."""
        if self.reporting.progress is not None:
            self.reporting.progress(self.world, phase, self.t, time.perf_counter() - self.t0)

    @property
    def t(self) -> float:
        """The world's simulated time, s."""
        return float(self.sim.time[self.world])

    @property
    def dt(self) -> float:
        """The world's time step, s."""
        return float(self.sim.dt[self.world])


class _Stop(Exception):
    """A run ends before its frames: its outcome and reason."""

    def __init__(self, outcome: DrumOutcome, reason: str):
        super().__init__(reason)
        self.outcome, self.reason = outcome, reason


#: a run's script: a generator that yields the steps its world must advance before it goes
#: on, and returns the run's result
Script = Generator[int, None, DrumResult]


def run_drum(parameter_sets: Sequence[Mapping[str, float]], *, settings: DrumSettings,
             seeds: Sequence[int], backend: str = "auto",
             reporting: DrumReporting | None = None) -> list[DrumResult]:
    """Run rotating-drum tests as worlds of one engine.

    Every run is one world of one :class:`~demcal.dem.simulation.Simulation` (its own
    parameters, seed and time step; no contact across worlds); each goes through its phases
    on its own and ends at its own time, and a world that ended is paused. A run's result is
    the one it gives alone (bit for bit; see :func:`_drive`).

    Parameters
    ----------
    parameter_sets : sequence of mapping
        Complete parameter sets (every name of :data:`demcal.virtual.parameters.PARAMETERS`,
        SI units), one per run; see :func:`demcal.virtual.presets.preset_parameters`.
    settings : DrumSettings
        The test (:func:`demcal.virtual.drum_settings.drum_settings`), the same for every
        run (one engine has one time-step fraction).
    seeds : sequence of int
        One seed per run (particle sizes, orientations and positions).
    backend : {"auto", "cpu", "cuda"}
        Engine backend.
    reporting : DrumReporting, optional
        Progress calls, VTK snapshots and the call made as each run ends.

    Returns
    -------
    list of DrumResult
        One per run, in order.
    """
    checked = check_parameter_sets(parameter_sets, seeds)
    if not checked:
        return []
    reporting = reporting or DrumReporting()
    beds = [_draw_bed(params, int(seed), settings) for params, seed in zip(checked, seeds,
                                                                           strict=True)]
    sim = Simulation([b.world for b in beds], backend=backend, dt_fraction=settings.dt_fraction,
                     rolling_friction=settings.rolling_model, raise_on_unstable=False)
    try:  # a run of 1e150 steps would hang, not fail: refused before the first step
        check_time_step(float(np.min(sim.dt)))
    except ValueError as exc:
        raise InputError(str(exc)) from None
    t0 = time.perf_counter()
    names = _series_names([b.seed for b in beds])
    runs = [_Run(sim, w, settings, bed, t0, reporting,
                 vtk=None if reporting.vtk_dir is None else VtkSeries(reporting.vtk_dir,
                                                                      names[w]))
            for w, bed in enumerate(beds)]
    return _drive(sim, runs, reporting.on_result)


def _series_names(seeds: list[int]) -> list[str]:
    """Each run's VTK series: ``drum_seed<seed>``, or ``drum_run<k>_seed<seed>`` when seeds
    repeat in the batch (two runs' snapshots must not write the same files)."""
    if len(set(seeds)) == len(seeds):
        return [f"drum_seed{s}" for s in seeds]
    return [f"drum_run{k:03d}_seed{s}" for k, s in enumerate(seeds)]


def _drive(sim: Simulation, runs: list[_Run],
           on_result: Callable[[int, DrumResult], None] | None) -> list[DrumResult]:
    """Run every run's script to its end, all worlds stepping together.

    Each script asks for the steps its world must take before it next looks at it (a frame,
    a fall of the fill, a step of the spin-up); the engine advances the live worlds to the
    nearest of these points, so every world is looked at, changed and measured after exactly
    the steps it would take alone. Worlds share no contact, and the engine's per-world sums
    are gathers in a fixed order (no atomics), so a world's state is bit for bit its state
    alone. What the batch does share changes only which candidates are looked at, not what
    they add: the skin, grid cell and contact margin are the batch's largest (a cohesive
    world's margin reaches a dry world's pairs, which add nothing out of reach), and a
    neighbour rebuild that one world needs rebuilds all (the lists are sorted). The engine
    checks health (NaN, overlap, speed) after every call and every ``_config.CHUNK_STEPS``
    steps, and the other worlds' points move these checks: a world that goes NaN or overlaps
    too far (flags that stay set until checked) is caught by the frame at which it would be
    caught alone, with the same outcome, but the time in its reason and its ``sim_time_s``
    are those of the check that caught it (less than ``CHUNK_STEPS`` steps apart). A speed
    above ``_config.MAX_SPEED`` is seen only at a check: a spike that falls back between two
    checks can be caught in one schedule and missed in the other (a blow-up that goes on is
    caught in both).

    A run that ends (its frames done, or stopped early: unsettled, unstable) is paused
    (:meth:`Simulation.set_world_enabled`): the engine's force and integration passes skip a
    paused world (only a neighbour rebuild still bins its spheres), so the batch costs about
    what its live runs cost and the ended world's bed stays as it ended. Its result goes to
    ``on_result`` at once. A fill that cannot be placed is a setting's fault
    (:class:`~demcal.errors.InputError`, one line) and ends the call, as it did when the
    runs ran one by one.
    """
    scripts = {run.world: _script(run) for run in runs}
    left: dict[int, int] = {}  #: live world -> steps before its script goes on
    results: dict[int, DrumResult] = {}

    def resume(w: int) -> None:
        try:
            left[w] = scripts[w].send(None)
        except StopIteration as end:
            left.pop(w, None)
            sim.set_world_enabled(w, False)
            results[w] = end.value
            if on_result is not None:
                on_result(w, end.value)

    for w in scripts:
        resume(w)
    while left:
        n = min(left.values())
        sim.advance(n)
        for w in list(left):
            left[w] -= n
            if left[w] == 0:
                resume(w)
    return [results[run.world] for run in runs]


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


def _draw_bed(params: dict[str, float], seed: int, s: DrumSettings) -> _Bed:
    """A run's world: the drum (at rest) and its particles (sizes drawn from the seed, not
    yet placed)."""
    params = {**params, **s.wall_overrides()}  # the drum's own lining, if set
    rng = np.random.default_rng(seed)
    scales = draw_scales(particle_count(s), s.particle, rng)
    lim = s.radius + 0.05
    world = World(material_table(params),
                  [ClumpGroup(make_template(s.particle), "particle", len(scales),
                              scales=scales)],
                  _drum(s).walls(), domain_lo=(-lim, -0.5 * s.width - 0.05, -lim),
                  domain_hi=(lim, 0.5 * s.width + 0.05, lim))
    return _Bed(params, seed, scales, rng, world)


def _drum(s: DrumSettings) -> Drum:
    """The test's drum: its axis along y through the origin (walls 0 to 2 of a world)."""
    return Drum(centre=np.zeros(3), axis=AXIS, radius=s.radius, width=s.width)


def _script(run: _Run) -> Script:
    """One run's phases in order; its result (the steps it asks for go through
    :func:`_advance`)."""
    try:
        yield from _fill(run, make_template(run.settings.particle))
        yield from _settle(run)
        yield from _spin_up(run)
        yield from _steady(run)
        yield from _frames(run)
    except _Stop as stop:
        return _result(run, stop.outcome, stop.reason)
    outcome, reason = classify_frames(run.frames.stats(), run.settings.fill_fraction)
    return _result(run, outcome, reason)


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


def _fill(run: _Run, template) -> Generator[int, None, None]:
    """Place every particle at random in the drum without overlap; what does not fit falls
    with the rest for a moment and is tried again above it (a full drum holds the loose
    fill only once part of it has fallen)."""
    s, sim, w = run.settings, run.sim, run.world
    scales = run.bed.scales
    margin = float(scales.max() * template.bounding_radius)
    todo = np.arange(len(scales))
    for _ in range(FILL_ROUNDS):
        centres, radii, _ = sim.spheres(w)
        grid = SphereGrid(2.0 * float(template.radii.max() * scales.max()))
        # the world's spheres in the placement frame: (x, y, z) -> (x, z, -y)
        grid.add(np.column_stack([centres[:, 0], centres[:, 2], -centres[:, 1]]), radii)
        idx, pos, quat = place_in_cylinder(template, scales[todo], radius=s.radius,
                                           z_low=-0.5 * s.width + margin,
                                           z_high=0.5 * s.width - margin, rng=run.bed.rng,
                                           grid=grid, attempts=30)
        if len(idx):
            world, turned = to_world(pos, quat)
            sim.place_clumps(w, todo[idx], world, turned)
            todo = np.delete(todo, idx)
        if len(todo) == 0:
            return
        yield from _advance(run, FILL_FALL_S)
    raise InputError(f"could not place {len(todo)} of {len(scales)} particles in the drum; "
                     "lower drum.fill_fraction or drum.bed_solid_fraction")


def _advance(run: _Run, duration: float) -> Generator[int, None, None]:
    """Advance the run's world by ``duration`` (s, whole steps of its own time step); a
    numerical failure stops the run."""
    yield max(1, round(duration / run.dt))
    error = run.sim.world_errors[run.world]
    if error is not None:  # without the engine's "world <k>: ": k is the run's place in a batch
        raise _Stop(DrumOutcome.UNSTABLE, error.removeprefix(f"world {run.world}: "))


def _settle(run: _Run) -> Generator[int, None, None]:
    s, sim, w = run.settings, run.sim, run.world
    tol = 0.05 * s.particle.diameter * s.particle.size_min
    start = run.t

    def spheres():
        centres, radii, sphere_clump = sim.spheres(w)
        return np.unique(sphere_clump), centres, radii, sphere_clump

    while True:
        yield from _advance(run, s.frame_interval_s)
        run.report("settle")
        state = settle_state(sim.clump_velocities(w), spheres, rms_limit=SETTLE_RMS,
                             max_limit=SETTLE_MAX, tolerance=tol)
        if state.settled:
            run.phase_times["settled"] = run.t
            run.snapshot("settled")
            return
        if run.t - start > s.settle_max_s:
            raise _Stop(DrumOutcome.UNSETTLED,
                        f"the fill did not settle within {s.settle_max_s} s (rms speed "
                        f"{state.rms_speed:.3g} m/s, max {state.max_speed:.3g} m/s)")


def _spin_up(run: _Run) -> Generator[int, None, None]:
    """Ramp the speed linearly to ``rpm`` over ``spin_up_s`` in 20 steps (a sudden start
    would throw the bed against the wall)."""
    s = run.settings
    ramp = 20 if s.spin_up_s > 0 else 1
    drum = _drum(s)
    for k in range(1, ramp + 1):
        drum.set_speed(run.sim, run.world, 0, s.omega * k / ramp)
        if s.spin_up_s > 0:
            yield from _advance(run, s.spin_up_s / ramp)
    run.report("spin-up")
    run.phase_times["spun_up"] = run.t
    run.snapshot("spun_up")


def _steady(run: _Run) -> Generator[int, None, None]:
    """Take frames until the running mean of the angle over the last ``steady_window``
    frames is within ``steady_tolerance_deg`` of the one over the window before."""
    s = run.settings
    k = s.steady_window
    start = run.t
    angles: list[float] = []
    while True:
        yield from _advance(run, s.frame_interval_s)
        run.report("steady")
        centres, radii, _ = run.sim.spheres(run.world)
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


def _frames(run: _Run) -> Generator[int, None, None]:
    """The averaged frames: each one's angle, centre-of-mass angle, flowing and airborne
    fractions and wall coverage. A frame without a surface is skipped; fewer than half
    measured ends the run as ``unsettled``."""
    s, sim, w = run.settings, run.sim, run.world
    for _ in range(s.frames):
        yield from _advance(run, s.frame_interval_s)
        run.report("frames")
        centres, radii, _ = sim.spheres(w)
        run.frames.add(FrameState(centres, radii, sim.clump_positions(w),
                                  sim.clump_velocities(w), sim.clump_masses(w)), s)
        run.snapshot("frame")
    missing = s.frames - len(run.frames.angles)
    if 2 * len(run.frames.angles) < s.frames:
        raise _Stop(DrumOutcome.UNSETTLED, f"no free surface found in {missing} of {s.frames} "
                    "frames")


def _result(run: _Run, outcome: DrumOutcome, reason: str | None) -> DrumResult:
    sim, w = run.sim, run.world
    info = RunInfo(params=run.bed.params, seed=run.bed.seed, n_particles=sim.n_active(w),
                   settled="settled" in run.phase_times, time_step_s=run.dt,
                   sim_time_s=run.t, wall_time_s=time.perf_counter() - run.t0,
                   phase_times_s=run.phase_times)
    return summarise(run.frames, outcome, reason, info, run.settings)
