"""The rotating-drum test in LAMMPS: the same drum, laws and frames, measured by demcal.

:func:`run_drum_lammps` is :func:`demcal.virtual.run_drum` on the LAMMPS engine. For every
parameter set and seed it writes the case, runs LAMMPS in a subprocess (``mpirun -np <np>
lmp -in in.drum``, or the user's launcher) and measures the frames LAMMPS dumps with the
functions demcal's own drum uses (:mod:`demcal.virtual.drum_frames`), so a frame, the
steady-state rule and the outcome mean the same in both engines.

What is written:

- ``drum.data`` and ``bodies.txt`` (:mod:`demcal.virtual.lammps_clumps`): the particles with
  demcal's masses and union inertia, from the same seed's sizes as demcal's drum. They are
  placed at random in the drum all at once (demcal's engine places them in rounds, letting
  each round fall before the next): the bed settles and the drum turns until the flow is
  steady before any frame counts, so how it was poured is forgotten;
- ``in.drum``: ``pair_style granular`` (:mod:`demcal.virtual.lammps_laws`); the drum as one
  closed ``cylinder`` region along y (its side and both end walls) under ``fix
  wall/gran/region``, turned about its axis by ``rotate v_theta``: LAMMPS takes the region's
  surface velocity at each contact into the tangential motion, as demcal's drum does. The
  phases: the bed settles (demcal's settle rule, checked every frame interval), the speed
  ramps linearly to the set rpm over ``spin_up_s``, then a frame is dumped every frame
  interval until demcal, reading the frames as they come, writes a ``STOP`` file: once the
  steady-state rule holds and the set number of frames has followed it, or once the flow
  failed to become steady within ``steady_max_s``.

Differences in the test itself (docs/lammps.md): LAMMPS' wall contacts have no spin, so its
rolling resistance against the turning wall acts on a particle's spin relative to the
ground, demcal's on its spin relative to the wall (the same when the wall's rolling
friction is zero); the speed ramp is continuous (demcal's is 20 steps).
"""

from __future__ import annotations

import math
import tempfile
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from demcal.errors import InputError
from demcal.virtual.drum import Progress, particle_count, to_world
from demcal.virtual.drum_frames import (
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
from demcal.virtual.lammps_clumps import (
    Box,
    ClumpSet,
    settle_block,
    step_and_laws,
    write_clumps,
)
from demcal.virtual.lammps_laws import model_string
from demcal.virtual.lammps_options import LammpsOptions
from demcal.virtual.lammps_run import (
    clump_means,
    lammps_command,
    launch,
    log_events,
    read_dump_step,
)
from demcal.virtual.parameters import check_parameter_sets

__all__ = ["DrumCase", "read_frame", "run_drum_lammps", "write_drum_case"]

#: files of a case
DATA, BODIES, INPUT, STOP = "drum.data", "bodies.txt", "in.drum", "STOP"
#: random placements tried per particle before the fill gives up (all placed at once)
FILL_ATTEMPTS = 500


@dataclass(frozen=True)
class DrumCase:
    """A written drum case: where, and what reading its frames needs."""

    folder: Path
    n_clumps: int
    n_spheres: int
    time_step_s: float
    seed: int
    params: dict[str, float]


def _fill(s: DrumSettings, seed: int, density: float) -> ClumpSet:
    """The particles (the seed's sizes, as demcal's drum draws them) placed at random in
    the drum without overlap, in the world frame."""
    template = make_template(s.particle)
    n = particle_count(s)
    rng = np.random.default_rng(seed)
    scales = draw_scales(n, s.particle, rng)
    margin = float(scales.max() * template.bounding_radius)
    grid = SphereGrid(2.0 * float(template.radii.max() * scales.max()))
    idx, pos, quat = place_in_cylinder(template, scales, radius=s.radius,
                                       z_low=-0.5 * s.width + margin,
                                       z_high=0.5 * s.width - margin, rng=rng, grid=grid,
                                       attempts=FILL_ATTEMPTS)
    if len(idx) < n:
        raise InputError(f"could not place {n - len(idx)} of {n} particles in the drum; "
                         "lower drum.fill_fraction or drum.bed_solid_fraction")
    world, turned = to_world(pos, quat)
    return ClumpSet(template, scales[idx], world, turned, density)


def write_drum_case(params: Mapping[str, float], settings: DrumSettings, seed: int,
                    folder: str | Path) -> DrumCase:
    """Write the LAMMPS files of one drum run into ``folder`` (created).

    Parameters
    ----------
    params : mapping
        A complete demcal parameter set (SI units).
    settings : DrumSettings
        The drum test.
    seed : int
        The run's seed (the particles' sizes, positions and orientations).
    folder : path
        Where to write ``drum.data``, ``bodies.txt`` and ``in.drum``.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rho = float(params["particle.density"])
    clumps = _fill(settings, int(seed), rho)
    lim, half = settings.radius + 0.05, 0.5 * settings.width + 0.05
    written = write_clumps(clumps, Box((-lim, -half, -lim), (lim, half, lim)), folder / DATA,
                           folder / BODIES, title="demcal rotating-drum test")
    dt, laws = step_and_laws(params, written, dt_fraction=settings.dt_fraction,
                             rolling=settings.rolling_model != "none")
    n_frame = max(1, round(settings.frame_interval_s / dt))
    body = _script(settings, dt, (model_string(laws["pp"]), model_string(laws["pw"])), n_frame)
    head = (f"comm_modify vel yes cutoff {2.0 * written.reach + 0.5 * written.r_min!r}\n"
            f"neighbor {0.5 * written.r_min!r} bin\n")
    (folder / INPUT).write_text(body.replace("#HEAD\n", head))
    return DrumCase(folder, written.n_clumps, written.n_spheres, float(dt), int(seed),
                    dict(params))


def _theta(s: DrumSettings) -> str:
    """The drum's turn (rad) since the spin-up began, ``v_tau`` s: a linear ramp of the speed
    to ``omega`` over ``spin_up_s``, then a steady turn."""
    w, ramp = repr(s.omega), repr(float(s.spin_up_s))
    if s.spin_up_s <= 0:
        return f"{w}*v_tau"
    return f"(v_tau < {ramp})*0.5*{w}*v_tau*v_tau/{ramp} + (v_tau >= {ramp})*{w}*(v_tau - " \
           f"0.5*{ramp})"


def max_frames(s: DrumSettings) -> int:
    """Frames LAMMPS may dump at most: the steady-state wait's, then the averaged ones."""
    return math.ceil(s.steady_max_s / s.frame_interval_s) + 1 + s.frames + 1


def _script(s: DrumSettings, dt: float, models: tuple[str, str], n_frame: int) -> str:
    """The phase script ``in.drum`` (``#HEAD`` stands for the ghost cutoff and skin lines).

    Parameters
    ----------
    s : DrumSettings
        The drum test.
    dt : float
        Time step, s.
    models : (str, str)
        The particle-particle and particle-wall ``granular`` model texts.
    n_frame : int
        Steps per frame interval.
    """
    pp, pw = models
    n_spin = max(1, round(s.spin_up_s / dt))
    return f"""# demcal: the rotating-drum test (written by demcal.virtual.lammps_drum)
units si
atom_style sphere
atom_modify map array
boundary f f f
#HEAD
fix pmol all property/atom mol ghost yes
read_data {DATA} fix pmol NULL Molecules
neigh_modify delay 0 every 1 check yes exclude molecule/intra all
pair_style granular
pair_coeff * * {pp}
timestep {dt!r}
fix grav all gravity 9.81 vector 0 0 -1
fix rig all rigid/small molecule infile {BODIES}
# the drum: its side and both end walls, turning about +y (the bed rises on the -x side)
variable tau equal 0.0
variable theta equal 0.0
region drum cylinder y 0 0 {s.radius!r} {-0.5 * s.width!r} {0.5 * s.width!r} side in \
rotate v_theta 0 0 0 0 1 0 units box
fix drum all wall/gran/region granular {pw} region drum

{settle_block(SETTLE_RMS, SETTLE_MAX)}thermo_style custom step time atoms v_rms v_vmax
thermo {n_frame}
thermo_modify lost ignore norm no

print "DEMCAL start 0 {n_frame}"
label settle_loop
run {n_frame} post no
if "${{still}}" then "jump SELF settled"
if "$(time) > {float(s.settle_max_s)!r}" then &
  "print 'DEMCAL unsettled_fill $(time) ${{rms}} ${{vmax}}'" "jump SELF finish"
jump SELF settle_loop
label settled
print "DEMCAL settled $(time)"
variable ts equal $(time)
variable tau equal "time - v_ts"
variable theta equal "{_theta(s)}"
run {n_spin} post no
print "DEMCAL spun_up $(time)"
variable k loop {max_frames(s)}
label frame_loop
run {n_frame} post no
write_dump all custom frame.${{k}} id mol mass radius x y z vx vy vz modify sort id
if "$(is_file({STOP}))" then "jump SELF finish"
next k
jump SELF frame_loop
label finish
print "DEMCAL end $(time)"
"""


def read_frame(path: str | Path) -> tuple[int, FrameState]:
    """One dumped frame: its time step and the bed (sphere centres and radii, the clumps'
    centres of mass, velocities and masses)."""
    step, dump = read_dump_step(path)
    centres = np.column_stack([dump["x"], dump["y"], dump["z"]])
    mass, means = clump_means(dump, ("x", "y", "z", "vx", "vy", "vz"))
    return step, FrameState(centres, dump["radius"], means[:, :3], means[:, 3:], mass)


@dataclass
class _Watch:
    """Reads the frames as LAMMPS dumps them and applies demcal's drum rules: the steady
    state, then the averaged frames; writes ``STOP`` when it has what it needs."""

    case: DrumCase
    settings: DrumSettings
    seen: int = 0  #: frames read
    steady_angles: list[float] = field(default_factory=list)
    steady_at: int | None = None  #: the frame after which the flow was steady
    log: FrameLog = field(default_factory=FrameLog)
    verdict: tuple[DrumOutcome, str] | None = None  #: an outcome decided before the frames
    last_step: int = 0
    n_clumps: int = 0
    done: bool = False

    def __call__(self, final: bool = False) -> None:
        """Read every complete frame (one is complete once the next exists, or LAMMPS
        ended)."""
        folder = self.case.folder
        while not self.done:
            path, after = folder / f"frame.{self.seen + 1}", folder / f"frame.{self.seen + 2}"
            if not path.exists() or not (final or after.exists()):
                return
            self.seen += 1
            self.last_step, state = read_frame(path)
            self.n_clumps = len(state.masses)
            self._feed(state)
            path.unlink()
            if self.done:
                (folder / STOP).touch()

    def _feed(self, state: FrameState) -> None:
        s = self.settings
        if self.steady_at is None:
            angle = frame_angle(state.centres, state.radii, s)
            if angle is not None:
                self.steady_angles.append(angle)
            drift = steady_drift(self.steady_angles, s.steady_window)
            if drift is not None and drift < s.steady_tolerance_deg:
                self.steady_at = self.seen
            elif self.seen * s.frame_interval_s > s.steady_max_s:
                tail = "" if drift is None else f" (its running mean still drifts by " \
                    f"{drift:.2f} deg over {s.steady_window} frames)"
                self.verdict = (DrumOutcome.UNSETTLED, "the angle did not become steady "
                                f"within {s.steady_max_s} s" + tail)
                self.done = True
            return
        self.log.add(state, s)
        self.done = self.seen - self.steady_at >= s.frames


def _outcome(watch: _Watch, events: dict[str, list[float]], failure: str | None,
             log_tail: str) -> tuple[DrumOutcome, str | None]:
    s = watch.settings
    if failure is not None or "end" not in events:
        return DrumOutcome.UNSTABLE, f"LAMMPS failed: {failure or 'no end event'}; log " \
                                     f"tail: {log_tail}"
    if "unsettled_fill" in events:
        _t, rms, vmax = events["unsettled_fill"][:3]
        return DrumOutcome.UNSETTLED, (f"the fill did not settle within {s.settle_max_s} s "
                                       f"(rms speed {rms:.3g} m/s, max {vmax:.3g} m/s)")
    if watch.verdict is not None:
        return watch.verdict
    if watch.steady_at is None or not watch.done:
        return DrumOutcome.UNSETTLED, f"LAMMPS ended after {watch.seen} frames, before the " \
                                      "steady frames were taken"
    measured = len(watch.log.angles)
    if 2 * measured < s.frames:
        return DrumOutcome.UNSETTLED, f"no free surface found in {s.frames - measured} of " \
                                      f"{s.frames} frames"
    return classify_frames(watch.log.stats(), s.fill_fraction)


def _run_one(params: dict[str, float], seed: int, settings: DrumSettings,
             options: LammpsOptions, folder: Path) -> DrumResult:
    cmd = lammps_command(options, INPUT)
    t0 = time.perf_counter()
    params = {**params, **settings.wall_overrides()}  # the drum's own lining, if set
    case = write_drum_case(params, settings, seed, folder)
    watch = _Watch(case, settings)
    failure = launch(cmd, folder, options.timeout_s, watch=watch)
    watch(final=True)
    text = (folder / "log.lammps").read_text() if (folder / "log.lammps").exists() else ""
    events = log_events(text)
    outcome, reason = _outcome(watch, events, failure, "\n".join(text.splitlines()[-5:]))
    phases = {k: events[k][0] for k in ("settled", "spun_up") if k in events}
    if watch.steady_at is not None and "spun_up" in events:
        phases["steady"] = phases["spun_up"] + watch.steady_at * settings.frame_interval_s
    info = RunInfo(params=params, seed=seed, n_particles=watch.n_clumps or case.n_clumps,
                   settled="settled" in events, time_step_s=case.time_step_s,
                   sim_time_s=events.get("end", [watch.last_step * case.time_step_s])[0],
                   wall_time_s=time.perf_counter() - t0, phase_times_s=phases,
                   engine="lammps")
    return summarise(watch.log, outcome, reason, info, settings)


def run_drum_lammps(parameter_sets: Sequence[Mapping[str, float]], *, settings: DrumSettings,
                    seeds: Sequence[int], options: LammpsOptions | None = None,
                    progress: Progress | None = None) -> list[DrumResult]:
    """Run rotating-drum tests in LAMMPS, one after another (each on ``options.np`` ranks).

    Parameters
    ----------
    parameter_sets : sequence of mapping
        Complete demcal parameter sets (SI units), one per run.
    settings : DrumSettings
        The test (:func:`demcal.virtual.drum_settings.drum_settings`).
    seeds : sequence of int
        One seed per run.
    options : LammpsOptions, optional
        How LAMMPS is started.
    progress : callable, optional
        Called as ``progress(run, phase, sim_time_s, wall_time_s)`` as each run starts and
        ends.

    Returns
    -------
    list of DrumResult
        One per run, in order, with ``engine = "lammps"``; ``unstable`` when LAMMPS failed
        (with its log's tail).
    """
    checked = check_parameter_sets(parameter_sets, seeds)
    options = options or LammpsOptions()
    lammps_command(options, INPUT)  # fail before any work when LAMMPS is missing
    out = []
    for i, (params, seed) in enumerate(zip(checked, seeds, strict=True)):
        if progress is not None:
            progress(i, "lammps", 0.0, 0.0)
        if options.work_dir is not None:
            Path(options.work_dir).mkdir(parents=True, exist_ok=True)
            folder = Path(tempfile.mkdtemp(prefix=f"drum-seed{seed}-", dir=options.work_dir))
            res = _run_one(params, int(seed), settings, options, folder)
        else:
            with tempfile.TemporaryDirectory(prefix="demcal-lammps-drum-") as tmp:
                res = _run_one(params, int(seed), settings, options, Path(tmp))
        out.append(res)
        if progress is not None:
            progress(i, res.outcome, res.sim_time_s, res.wall_time_s)
    return out
