"""``demcal calibrate``, ``demcal init`` and ``demcal import``: run a calibration study."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from rich.table import Table

from demcal.cli import app
from demcal.cli._common import cli_errors, console
from demcal.errors import InputError


def _print_result(result: dict) -> None:
    table = Table(title=f"calibrated parameters ({result['study']})")
    table.add_column("parameter")
    table.add_column("value", justify="right")
    for name, value in result["optimum"].items():
        table.add_row(name, f"{value:.5g}")
    console.print(table)
    v = result["verification"]
    mean = "n/a" if v["aor_mean_deg"] is None else f"{v['aor_mean_deg']:.2f}"
    std = "n/a" if v["aor_std_deg"] is None else f"{v['aor_std_deg']:.2f}"
    rel = "n/a" if v["relative_error_percent"] is None else \
        f"{v['relative_error_percent']:.2f} %"
    console.print(f"target AoR {result['target_aor_deg']:.2f} deg; predicted "
                  f"{result['predicted_aor_deg']:.2f} deg; verification ({v['n']} runs): "
                  f"{mean} +/- {std} deg, relative error {rel}; {result['n_runs']} runs stored "
                  f"({result['n_runs_executed']} run now)")
    if v.get("p_value") is not None:
        verdict = "consistent with" if v["consistent"] else "[yellow]differs from[/yellow]"
        console.print(f"verification: 95 % interval {v['ci_low_deg']:.2f}-"
                      f"{v['ci_high_deg']:.2f} deg, {verdict} the measurement "
                      f"(p = {v['p_value']:.3g}, {v['test']})")
    if not result.get("rsm_adequate", True):
        console.print("[yellow]warning:[/yellow] the response-surface model is not adequate "
                      "(see the rsm stage's warnings)")


def _build_report(study_dir: Path) -> Path | None:
    try:
        from demcal import report
    except ImportError:  # pragma: no cover
        return None
    build = getattr(report, "build_report", None)
    if build is None:
        console.print("[yellow]note:[/yellow] demcal.report.build_report is not available in "
                      "this version; no report written")
        return None
    return Path(build(study_dir))


@app.command("calibrate")
@cli_errors
def calibrate_cmd(
    study: Annotated[Path, typer.Argument(help="Study file (TOML); see `demcal init`.")],
    json_out: Annotated[Path | None, typer.Option("--json", help="Write the result as JSON.")]
    = None,
    external: Annotated[bool, typer.Option(
        "--external", help="Run nothing: write the next stage's run sheet (CSV) and stop.")]
    = False,
    dask: Annotated[str | None, typer.Option(help="Dask scheduler address (tcp://...).")]
    = None,
    workers: Annotated[int | None, typer.Option(
        min=1, help="Local worker processes (default: the study's, else the CPU count).")]
    = None,
    report: Annotated[bool, typer.Option(help="Build the HTML report at the end.")] = True,
) -> None:
    """Run (or resume) a calibration study; print the calibrated parameters."""
    from demcal.calibrate.external import write_run_sheet
    from demcal.calibrate.pipeline import run_stages
    from demcal.calibrate.runner import ExternalPending

    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
               TimeElapsedColumn(), TextColumn("left"), TimeRemainingColumn())
    with Progress(*columns, console=console, transient=False,
                  disable=external) as progress:
        tasks: dict[str, int] = {}

        def on_progress(stage: str, done: int, total: int) -> None:
            if stage not in tasks:
                tasks[stage] = progress.add_task(stage, total=total)
            progress.update(tasks[stage], completed=done, total=total)

        from demcal.calibrate.pipeline import open_study

        ctx = open_study(study, workers=workers, dask=dask, external=external,
                         progress=on_progress)
        try:
            result = run_stages(ctx)
        except KeyboardInterrupt:
            n = ctx.store.count()
            console.print(f"[yellow]interrupted:[/yellow] {n} finished runs are stored; run "
                          f"`demcal calibrate {study}` again to resume")
            raise typer.Exit(130) from None
        except ExternalPending as pending:
            path = write_run_sheet(pending, ctx.runner, Path(study).resolve().parent)
            console.print(f"{pending.stage}: {len(pending.points)} runs to do externally; run "
                          f"sheet: {path}\nfill aor_deg (or outcome) and run `demcal import "
                          f"{path.name} --study {study}`, then `demcal calibrate` again")
            return
        finally:
            ctx.store.close()
    _print_result(result)
    if json_out is not None:
        json_out.write_text(json.dumps(result, indent=2))
        console.print(f"result: {json_out}")
    if not report:  # the material card all the same (report/material.toml)
        from demcal.report.material import write_material_card

        files = write_material_card(Path(study).resolve().parent)
        if files is not None:
            console.print(f"material card: {files[0]}")
    if report:
        path = _build_report(Path(study).resolve().parent)
        if path is not None:
            console.print(f"report: {path}")
            if (path.parent / "material.toml").is_file():
                console.print(f"material card: {path.parent / 'material.toml'}")


@app.command("init")
@cli_errors
def init_cmd(
    path: Annotated[Path, typer.Argument(help="Where to write the example study.")]
    = Path("study.toml"),
    force: Annotated[bool, typer.Option(help="Overwrite an existing file.")] = False,
) -> None:
    """Write a commented example study file."""
    from demcal.calibrate.study import EXAMPLE_STUDY

    if path.exists() and not force:
        raise InputError(f"{path} exists; use --force to overwrite")
    path.write_text(EXAMPLE_STUDY)
    console.print(f"wrote {path}")


@app.command("import")
@cli_errors
def import_cmd(
    results: Annotated[Path, typer.Argument(help="Filled run sheet (CSV).")],
    study: Annotated[Path, typer.Option(help="The study file the sheet belongs to.")],
) -> None:
    """Store the responses of an externally run sheet; `demcal calibrate` then goes on."""
    from demcal.calibrate.external import import_results
    from demcal.calibrate.pipeline import open_study

    ctx = open_study(study, external=True)
    try:
        n = import_results(results, ctx.runner)
    finally:
        ctx.store.close()
    console.print(f"stored {n} runs from {results}")
