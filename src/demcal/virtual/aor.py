"""The cylinder-lifting angle-of-repose test, many runs at once as batched engine worlds.

Each run goes through the phases of the paper's test: **fill** (a dynamic factory at the top of
the tube, or a loose packing dropped from rest), **settle**, **lift** the tube at constant speed
until it clears the material, **settle**, **measure**. Every run ends in one typed
:class:`~demcal.virtual.outcome.Outcome`: ``pile`` (with the angle), ``column``, ``plug``,
``unsettled`` or ``unstable`` (see :mod:`demcal.virtual.outcome` for the criteria).

All runs of a batch share one :class:`~demcal.dem.simulation.Simulation` (one world each, with
its own parameters, seed and time step); a finished world is paused, so the batch costs what
its live runs cost.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from demcal.dem.materials import Interaction, Material, MaterialTable
from demcal.dem.output import VtkSeries
from demcal.dem.simulation import Simulation
from demcal.dem.state import ClumpGroup, World
from demcal.dem.walls import PlaneWall, TubeWall
from demcal.errors import InputError
from demcal.limits import check_time_step
from demcal.results import finite_responses
from demcal.virtual.config import AoRTestConfig
from demcal.virtual.factory import (
    SphereGrid,
    draw_scales,
    fill_capacity,
    make_template,
    pack_cylinder,
    place_in_cylinder,
)
from demcal.virtual.fill import bulk_density, fill_level
from demcal.virtual.outcome import (
    Outcome,
    classify_after_lift,
    classify_settled,
    footprint,
    mass_in_tube,
    mass_outside,
)
from demcal.virtual.parameters import check_parameter_sets
from demcal.virtual.pile import measure_pile
from demcal.virtual.settle import settle_state

__all__ = ["RESPONSES", "AoRResult", "material_table", "run_aor"]

#: The responses the lift test reports for a pile: the angle (deg), the pile's height and base
#: diameter (m), the fill's loose bulk density (kg/m^3), the mass the lifted cylinder retained
#: (kg); each is an AoRResult field.
RESPONSES = ("aor_deg", "pile_height_m", "base_diameter_m", "bulk_density_kg_m3",
             "mass_left_kg")

log = logging.getLogger("demcal.virtual")

TUBE = 1  #: index of the cylinder among a world's walls (the plate is 0)

#: progress callback: (run index, phase name, simulated time s, wall time s)
Progress = Callable[[int, str, float, float], None]


@dataclass
class AoRResult:
    """What one virtual angle-of-repose test measured (SI units, angles in degrees)."""

    outcome: str
    aor_deg: float | None
    aor_left_deg: float | None
    aor_right_deg: float | None
    aor_std_deg: float | None
    aor_profile_deg: float | None
    n_particles: int
    particles_lost: int
    mass_on_plate_kg: float
    pile_height_m: float | None
    base_diameter_m: float | None
    fill_height_m: float | None
    settled: bool
    time_step_s: float
    sim_time_s: float
    wall_time_s: float
    seed: int
    params: dict[str, float]
    reason: str | None = None
    sphere_steps: int = 0
    views_deg: list[dict[str, float]] = field(default_factory=list)
    phase_times_s: dict[str, float] = field(default_factory=dict)
    artefacts: dict[str, str] = field(default_factory=dict)
    engine: str = "demcal"  #: the DEM engine that ran the test: "demcal" or "lammps"
    #: the settled fill's level read as a lab reads it (:mod:`demcal.virtual.fill`), m
    fill_level_m: float | None = None
    #: its loose bulk density: the fill's mass over the cylinder's volume to that level, kg/m^3
    bulk_density_kg_m3: float | None = None
    #: the mass still inside the lifted cylinder at the end (above its bottom rim, within its
    #: inner radius: :func:`~demcal.virtual.outcome.mass_in_tube`), kg; None before a lift
    mass_left_kg: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (``aor_deg`` is None unless the outcome is ``pile``)."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}

    def responses(self) -> dict[str, float]:
        """What the test measured, by response name: the angle (deg), the pile's height and
        base diameter (m), the fill's loose bulk density (kg/m^3), the mass the lifted
        cylinder retained (kg); none unless the outcome is ``pile``."""
        if self.outcome != "pile":
            return {}
        return finite_responses({name: getattr(self, name) for name in RESPONSES})


def material_table(p: Mapping[str, float]) -> MaterialTable:
    """The engine's materials (``particle``, ``wall``) and their pairs from a parameter set
    (the names of :data:`demcal.virtual.parameters.PARAMETERS`, SI units); the lift test's
    and the drum's."""
    particle = Material("particle", p["particle.density"], p["particle.shear_modulus"],
                        p["particle.poisson"])
    wall = Material("wall", p["wall.density"], p["wall.shear_modulus"], p["wall.poisson"])
    return MaterialTable([particle, wall], {
        ("particle", "particle"): Interaction(p["pp.restitution"], p["pp.static_friction"],
                                             p["pp.rolling_friction"], p["pp.surface_energy"]),
        ("particle", "wall"): Interaction(p["pw.restitution"], p["pw.static_friction"],
                                          p["pw.rolling_friction"], p["pw.surface_energy"]),
    })


@dataclass
class _Run:
    """Host-side state of one run (world) during the batch."""

    index: int
    params: dict[str, float]
    seed: int
    rng: np.random.Generator
    scales: np.ndarray
    capacity: int
    phase: str = "fill"
    phase_start: float = 0.0
    inserted: int = 0
    fill_height: float | None = None
    fill_level: float | None = None
    fill_mass: float | None = None
    done: bool = False
    result: AoRResult | None = None
    phase_times: dict[str, float] = field(default_factory=dict)
    wall_time: float = 0.0
    sphere_steps: int = 0
    steps: int = 0  #: engine steps of this world so far
    check_every: int = 1  #: steps between its checks (the check interval in its own steps)
    next_check: int = 1  #: step count of its next check
    plot_path: str | Path | None = None
    pile_path: str | Path | None = None


def run_aor(parameter_sets: Sequence[Mapping[str, float]], *, config: AoRTestConfig,
            seeds: Sequence[int], backend: str = "auto", progress: Progress | None = None,
            vtk_dir: str | Path | None = None,
            plot_paths: Sequence[str | Path | None] | None = None,
            pile_paths: Sequence[str | Path | None] | None = None,
            on_result: Callable[[int, AoRResult], None] | None = None) -> list[AoRResult]:
    """Run a batch of cylinder-lifting tests as worlds of one engine.

    Parameters
    ----------
    parameter_sets : sequence of mapping
        Complete parameter sets (every name of :data:`demcal.virtual.parameters.PARAMETERS`,
        SI units), one per run; see :func:`demcal.virtual.presets.preset_parameters`.
    config : AoRTestConfig
        The test (geometry, particles, fill, phases, measurement, outcome criteria).
    seeds : sequence of int
        One seed per run (particle sizes, orientations and positions).
    backend : {"auto", "cpu", "cuda"}
        Engine backend.
    progress : callable, optional
        Called as ``progress(run, phase, sim_time_s, wall_time_s)`` at every check.
    vtk_dir : path, optional
        If given, VTK snapshots of every run at the end of each phase are written there.
    plot_paths : sequence of path or None, optional
        One entry per run: where to save a side view of its pile with the fitted flank lines
        (PNG; only for a ``pile`` outcome; the path is in ``artefacts["pile_png"]``).
    pile_paths : sequence of path or None, optional
        One entry per run: where to save the final spheres (``.npz`` with ``centres`` (n, 3) m
        and ``radii`` (n,) m, plate at z = 0), whatever the outcome, so that a pile can be
        measured again later (path in ``artefacts["pile_npz"]``).
    on_result : callable, optional
        Called as ``on_result(run, result)`` the moment a run ends (before the batch ends), so
        a caller can store it at once.

    Returns
    -------
    list of AoRResult
        One per run, in order.
    """
    checked = check_parameter_sets(parameter_sets, seeds)
    if not parameter_sets:
        return []
    plots, piles = _per_run(len(checked), plot_paths=plot_paths, pile_paths=pile_paths)
    template = make_template(config.particle)
    runs = [_new_run(i, params, int(seed), config, template)
            for i, (params, seed) in enumerate(zip(checked, seeds, strict=True))]
    for run, plot, pile in zip(runs, plots, piles, strict=True):
        run.plot_path, run.pile_path = plot, pile
    sim = Simulation([_world(run, config, template) for run in runs], backend=backend,
                     dt_fraction=config.dt_fraction, rolling_friction=config.rolling_model,
                     raise_on_unstable=False)
    try:  # a run of 1e150 steps would hang, not fail: refused before the first step
        check_time_step(float(np.min(sim.dt)))
    except ValueError as exc:
        raise InputError(str(exc)) from None
    batch = _Batch(sim, config, template, _Snapshots(vtk_dir) if vtk_dir is not None else None)
    t_start = time.perf_counter()
    for run in runs:
        _start_fill(batch, run)
    for run in runs:  # each world is checked every interval of its own time step
        run.check_every = config.phases.check_steps(float(sim.dt[run.index]))
        run.next_check = run.check_every
    while not all(r.done for r in runs):
        live = [r for r in runs if not r.done]
        _advance_to_next_check(sim, live, len(template.radii))
        times = sim.time
        for run in live:
            if run.steps < run.next_check:
                continue  # not this world's check yet: its run goes on as if it ran alone
            run.next_check += run.check_every
            _check(batch, run, float(times[run.index]), t_start, on_result)
            if progress is not None:
                progress(run.index, run.phase, float(times[run.index]), run.wall_time)
    return [r.result for r in runs]  # type: ignore[misc]


@dataclass(frozen=True)
class _Batch:
    """What every run of a batch shares: the engine, the test, the particle template and
    the VTK snapshots (None: none written)."""

    sim: Simulation
    config: AoRTestConfig
    template: Any
    snap: _Snapshots | None


def _per_run(n: int, **paths: Sequence[str | Path | None] | None
             ) -> list[list[str | Path | None]]:
    """Each of ``paths`` (by argument name) as one entry per run (all None where not
    given); InputError naming it where its length is not ``n``."""
    out = []
    for name, given in paths.items():
        if given is not None and len(given) != n:
            raise InputError(f"{name} needs one entry per parameter set; got {len(given)} "
                             f"for {n} sets")
        out.append([None] * n if given is None else list(given))
    return out


def _new_run(i: int, params: dict[str, float], seed: int, config: AoRTestConfig,
             template) -> _Run:
    """Run ``i``'s host state: its generator (seeded) and its particles' drawn sizes."""
    cap = fill_capacity(config, template)
    rng = np.random.default_rng(seed)
    return _Run(i, params, seed, rng, draw_scales(cap, config.particle, rng), cap)


def _world(run: _Run, config: AoRTestConfig, template) -> World:
    """Run ``run``'s world: the plate, the cylinder on it and room for its particles."""
    g = config.geometry
    half = 0.5 * g.plate_size
    z_top = g.cylinder_height + (config.phases.lift_height or g.cylinder_height) + 0.1
    walls = [
        PlaneWall(origin=[0.0, 0.0, 0.0], normal=[0.0, 0.0, 1.0], half_size=(half, half),
                  material="wall", name="plate"),
        TubeWall(base=[0.0, 0.0, 0.0], axis=[0.0, 0.0, 1.0],
                 inner_radius=0.5 * g.cylinder_inner_diameter,
                 thickness=g.cylinder_wall_thickness, length=g.cylinder_height,
                 material="wall", name="cylinder"),
    ]
    return World(material_table(run.params),
                 [ClumpGroup(template, "particle", run.capacity, scales=run.scales)], walls,
                 domain_lo=(-half - 0.02, -half - 0.02, -0.05),
                 domain_hi=(half + 0.02, half + 0.02, z_top))


def _check(b: _Batch, run: _Run, t: float, t_start: float,
           on_result: Callable[[int, AoRResult], None] | None) -> None:
    """A run's check at its time ``t``: the next phase (or its end, with ``on_result``);
    a world the engine found unstable ends there. ``t_start``: the batch's start on
    :func:`time.perf_counter` (the run's wall time counts from it)."""
    w = run.index
    error = b.sim.world_errors[w]
    if error is not None:
        _finish(b, run, Outcome.UNSTABLE, t, reason=error)
    else:
        _PHASES[run.phase](b, run, t)
    run.wall_time = time.perf_counter() - t_start
    if not run.done:
        return
    if b.snap is not None:
        run.result.artefacts["vtk_series"] = b.snap.close(b.sim, run)
    b.sim.set_world_enabled(w, False)
    run.result.wall_time_s = run.wall_time
    run.result.sphere_steps = run.sphere_steps
    if on_result is not None:
        on_result(w, run.result)


def _advance_to_next_check(sim: Simulation, live: list[_Run], n_template: int) -> None:
    """Advance the live worlds to the nearest of their next checks.

    Each world is checked (settle detection, the lift's start and end, ...) every
    ``check_every`` of its own steps, as it would be if it ran alone: the worlds of a batch
    have their own time steps (their particle sizes are drawn per seed), and checking all of
    them at the interval of the smallest step made a run's pile depend on the runs batched
    with it (a study's results on its worker count, a resumed run on what ended before).
    """
    n = min(r.next_check - r.steps for r in live)
    sim.advance(n)
    for run in live:
        run.steps += n
        run.sphere_steps += n * sim.n_active(run.index) * n_template


def _start_fill(b: _Batch, run: _Run) -> None:
    """A packed fill placed at once (then it settles); a factory's starts empty."""
    if b.config.fill.method == "packing":
        idx, pos, quat = pack_cylinder(b.template, run.scales, b.config, run.rng)
        b.sim.place_clumps(run.index, idx, pos, quat)
        run.inserted = run.capacity
        _enter(run, "fill_settle", 0.0)


def _enter(run: _Run, phase: str, t: float) -> None:
    run.phase_times[run.phase] = t
    run.phase = phase
    run.phase_start = t


def _settled(sim: Simulation, w: int, config: AoRTestConfig) -> tuple[bool, float, float]:
    """The phase's settle criterion (:mod:`demcal.virtual.settle`): (settled, rms, max)."""
    def spheres():
        centres, radii, sphere_clump = sim.spheres(w)
        # velocity rows are the world's active clumps in index order, as np.unique gives them
        return np.unique(sphere_clump), centres, radii, sphere_clump

    ph, p = config.phases, config.particle
    state = settle_state(sim.clump_velocities(w), spheres, rms_limit=ph.settle_rms_speed,
                         max_limit=ph.settle_max_speed, tolerance=0.05 * p.diameter * p.size_min)
    return state.settled, state.rms_speed, state.max_speed


def _material_top(sim: Simulation, w: int) -> float:
    centres, radii, _ = sim.spheres(w)
    if len(radii) == 0:
        return 0.0
    return float(np.max(centres[:, 2] + radii))


def _fill_step(b: _Batch, run: _Run, t: float) -> None:
    """The factory fills until its time is up or the cylinder's capacity is in."""
    _factory_insert_slots(b.sim, run, b.config, b.template, t)
    if t >= b.config.fill.filling_time or run.inserted >= run.capacity:
        _enter(run, "fill_settle", t)


def _fill_settle_step(b: _Batch, run: _Run, t: float) -> None:
    """Once the fill has settled: its height, level and mass, then the lift starts."""
    sim, config, w = b.sim, b.config, run.index
    ph = config.phases
    elapsed = t - run.phase_start
    ok, rms, vmax = _settled(sim, w, config)
    if ok and elapsed >= ph.min_settle_time:
        run.fill_height = _material_top(sim, w)
        centres, radii, _ = sim.spheres(w)
        run.fill_level = fill_level(centres, radii, cell=config.particle.diameter,
                                    tube_radius=0.5 * config.geometry.cylinder_inner_diameter)
        run.fill_mass = float(sim.clump_masses(w).sum())
        if b.snap is not None:
            b.snap.write(sim, run, "filled")
        sim.set_wall_velocity(w, TUBE, [0.0, 0.0, ph.lift_speed])
        _enter(run, "lift", t)
    elif elapsed > ph.fill_settle_max_time:
        _finish(b, run, Outcome.UNSETTLED, t,
                reason=f"the fill did not settle within {ph.fill_settle_max_time} s "
                       f"(rms speed {rms:.3g} m/s, max {vmax:.3g} m/s)")


def _lift_step(b: _Batch, run: _Run, t: float) -> None:
    """The cylinder rises until it clears the material (or reaches its lift height); then
    what stands is classified, and a pile goes on to settle."""
    sim, config, w = b.sim, b.config, run.index
    ph, g = config.phases, config.geometry
    z_b = float(sim.wall_origin(w, TUBE)[2])
    limit = ph.lift_height if ph.lift_height is not None else g.cylinder_height
    clearance = 0.5 * config.particle.diameter
    cleared = ph.lift_height is None and z_b > _material_top(sim, w) + clearance
    if not (cleared or z_b >= limit):
        return
    sim.set_wall_velocity(w, TUBE, [0.0, 0.0, 0.0])
    if b.snap is not None:
        b.snap.write(sim, run, "lifted")
    outcome, reason = classify_after_lift(sim.clump_positions(w), sim.clump_masses(w),
                                          tube_bottom=z_b, tube_height=g.cylinder_height,
                                          tube_radius=0.5 * g.cylinder_inner_diameter,
                                          criteria=config.outcome)
    if outcome is not None:
        _finish(b, run, outcome, t, reason=reason)
        return
    _enter(run, "pile_settle", t)


def _pile_settle_step(b: _Batch, run: _Run, t: float) -> None:
    """Once the pile has settled it is measured; one that keeps moving ends unsettled."""
    ph = b.config.phases
    elapsed = t - run.phase_start
    ok, rms, vmax = _settled(b.sim, run.index, b.config)
    if ok and elapsed >= ph.min_settle_time:
        if b.snap is not None:
            b.snap.write(b.sim, run, "settled")
        _finish(b, run, None, t)
    elif elapsed > ph.pile_settle_max_time:
        _finish(b, run, Outcome.UNSETTLED, t,
                reason=f"the pile did not settle within {ph.pile_settle_max_time} s "
                       f"(rms speed {rms:.3g} m/s, max {vmax:.3g} m/s)"
                       + _column_hint(b.sim, run, b.config))


#: what a run's check does in each phase
_PHASES: dict[str, Callable[[_Batch, _Run, float], None]] = {
    "fill": _fill_step, "fill_settle": _fill_settle_step, "lift": _lift_step,
    "pile_settle": _pile_settle_step}


def _column_hint(sim: Simulation, run: _Run, config: AoRTestConfig) -> str:
    """For a pile that did not settle: a clause saying what the moving material is (its
    height against the fill's, its mass outside the cylinder's footprint) and, when it meets
    :func:`~demcal.virtual.outcome.classify_settled`'s column rule, that it is a column
    creeping on, or ``""``. Strong cohesion can hold a light material up as a mound or
    column that creeps on and never settles (the paper's EDEM surface energies on this
    engine), so the reason must say what the test built, not only that it kept moving."""
    w = run.index
    centres, radii, _ = sim.spheres(w)
    if len(radii) == 0 or not run.fill_height:
        return ""
    top = float(np.max(centres[:, 2] + radii))
    pos, mass = sim.clump_positions(w), sim.clump_masses(w)
    rule = footprint(config)
    outside = mass_outside(pos, mass, **rule)
    outcome, _ = classify_settled(pos, mass, fill_height=run.fill_height, material_top=top,
                                  criteria=config.outcome, **rule)
    what = ("it still stands as a column, creeping (cohesion holds the material up)"
            if outcome == Outcome.COLUMN else "the material is still moving")
    return (f"; {what}: {top * 1e3:.0f} mm high ({top / run.fill_height:.0%} of the fill "
            f"height), {outside:.0%} of the mass outside the cylinder's footprint")


def _factory_insert_slots(sim: Simulation, run: _Run, config: AoRTestConfig, template,
                          t: float) -> None:
    """Dynamic factory: generate the particles due by time t into free world slots."""
    fill = config.fill
    due = min(run.capacity, math.floor(fill.rate * min(t, fill.filling_time)))
    n_want = due - run.inserted
    if n_want <= 0:
        return
    g = config.geometry
    r_in = 0.5 * g.cylinder_inner_diameter
    z_f = fill.factory_height if fill.factory_height is not None else g.cylinder_height
    reach = float(run.scales.max() * template.bounding_radius)
    centres, radii, _ = sim.spheres(run.index)
    near = np.abs(centres[:, 2] - z_f) < 4 * reach
    grid = SphereGrid(2.0 * float(template.radii.max() * run.scales.max()))
    grid.add(centres[near], radii[near])
    # world slots are used in order; each slot keeps the size drawn for it
    slots = np.arange(run.inserted, run.inserted + n_want)
    idx, pos, quat = place_in_cylinder(template, run.scales[slots], radius=r_in,
                                       z_low=z_f - reach, z_high=z_f, rng=run.rng, grid=grid,
                                       attempts=5)
    if len(idx) == 0:
        return
    # a slot that did not fit now is tried again at the next event: place the ones that did,
    # in slot order, and leave the rest for later
    placed_slots = slots[idx]
    order = np.argsort(placed_slots)
    placed_slots = placed_slots[order]
    # keep slots contiguous: only the leading run of placed slots is committed
    lead = 0
    while lead < len(placed_slots) and placed_slots[lead] == run.inserted + lead:
        lead += 1
    if lead == 0:
        return
    sel = order[:lead]
    sim.place_clumps(run.index, placed_slots[:lead], pos[sel], quat[sel],
                     velocities=np.tile([0.0, 0.0, -fill.drop_speed], (lead, 1)))
    run.inserted += lead


def _finish(b: _Batch, run: _Run, outcome: Outcome | None, t: float,
            reason: str | None = None) -> None:
    """Classify (if not yet), measure a pile, and store the result."""
    sim, config, w = b.sim, b.config, run.index
    run.phase_times[run.phase] = t
    centres, radii, _clump_ids = sim.spheres(w)
    pos = sim.clump_positions(w)
    mass = sim.clump_masses(w)
    settled = outcome is None
    if outcome is None:
        outcome, reason = classify_settled(
            pos, mass, fill_height=run.fill_height or 0.0,
            material_top=float(np.max(centres[:, 2] + radii)) if len(radii) else 0.0,
            criteria=config.outcome, **footprint(config))
    measured: dict[str, Any] = {}
    if outcome == Outcome.PILE:
        figure = run.plot_path
        if figure is not None:
            try:
                Path(figure).parent.mkdir(parents=True, exist_ok=True)
            except OSError as exc:  # the run's result matters more than its picture
                log.warning("no pile picture at %s: %s", figure, exc.strerror)
                figure = None
        measured = measure_pile(centres, radii, config.measurement, figure=figure)
        if measured.get("figure_error"):
            log.warning("no pile picture: %s", measured["figure_error"])
        if measured.get("error"):
            outcome = Outcome.SCATTERED
            reason = measured["error"]
    artefacts: dict[str, str] = {}
    if measured.get("figure"):
        artefacts["pile_png"] = measured["figure"]
    if run.pile_path is not None:
        saved = _save_pile(run.pile_path, centres, radii)
        if saved is not None:
            artefacts["pile_npz"] = saved
    lost = sim.n_removed(w)
    run.result = AoRResult(
        outcome=outcome.value,
        aor_deg=measured.get("aor_deg") if outcome == Outcome.PILE else None,
        aor_left_deg=measured.get("aor_left_deg") if outcome == Outcome.PILE else None,
        aor_right_deg=measured.get("aor_right_deg") if outcome == Outcome.PILE else None,
        aor_std_deg=measured.get("aor_std_deg") if outcome == Outcome.PILE else None,
        aor_profile_deg=measured.get("aor_profile_deg") if outcome == Outcome.PILE else None,
        n_particles=run.inserted,
        particles_lost=lost,
        mass_on_plate_kg=float(mass.sum()),
        pile_height_m=measured.get("pile_height_m",
                                   float(np.max(centres[:, 2] + radii)) if len(radii) else None),
        base_diameter_m=measured.get("base_diameter_m"),
        fill_height_m=run.fill_height,
        fill_level_m=run.fill_level,
        bulk_density_kg_m3=bulk_density(run.fill_mass or 0.0, run.fill_level,
                                        0.5 * config.geometry.cylinder_inner_diameter),
        mass_left_kg=_mass_left(sim, run, config, pos, mass),
        settled=settled and outcome in (Outcome.PILE, Outcome.COLUMN, Outcome.SCATTERED),
        time_step_s=float(sim.dt[w]),
        sim_time_s=t,
        wall_time_s=0.0,
        seed=run.seed,
        params=dict(run.params),
        reason=reason,
        views_deg=measured.get("views", []),
        phase_times_s=dict(run.phase_times),
        artefacts=artefacts,
    )
    run.done = True


def _mass_left(sim: Simulation, run: _Run, config: AoRTestConfig, pos: np.ndarray,
               mass: np.ndarray) -> float | None:
    """The mass the lifted cylinder still holds, kg (None for a run that ended before its
    lift: the whole fill is in the tube, nothing was retained)."""
    if "lift" not in run.phase_times:
        return None
    g = config.geometry
    return mass_in_tube(pos, mass, tube_bottom=float(sim.wall_origin(run.index, TUBE)[2]),
                        tube_height=g.cylinder_height,
                        tube_radius=0.5 * g.cylinder_inner_diameter)


def _save_pile(path: str | Path, centres: np.ndarray, radii: np.ndarray) -> str | None:
    """Save a run's final spheres (``centres`` m, ``radii`` m) as ``.npz``; None if it fails."""
    try:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        with open(path, "wb") as fh:
            np.savez_compressed(fh, centres=centres, radii=radii)
    except OSError as exc:  # the run's result matters more than its spheres
        log.warning("no pile file at %s: %s", path, exc.strerror)
        return None
    return str(path)


class _Snapshots:
    """VTK snapshots of runs at the end of phases: one :class:`~demcal.dem.output.VtkSeries`
    (``run<k>.pvd`` and its ``.vtp`` files) per run."""

    def __init__(self, folder: str | Path):
        self.folder = Path(folder)
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError(f"vtk_dir {str(folder)!r}: {exc.strerror}") from None
        self.series: dict[int, VtkSeries] = {}

    def write(self, sim: Simulation, run: _Run, label: str) -> None:
        if run.index not in self.series:
            self.series[run.index] = VtkSeries(self.folder, f"run{run.index:03d}")
        self.series[run.index].add(sim, run.index, label=label)

    def close(self, sim: Simulation, run: _Run) -> str:
        """Write the final state of a finished run (if not just written); the .pvd path."""
        t = float(sim.time[run.index])
        series = self.series.get(run.index)
        if series is None or series.entries[-1][0] != t:
            self.write(sim, run, "end")
        return str(self.series[run.index].close())
