"""``demcal store status``: where a study stands; ``demcal store salvage``: copy what can
still be read of a damaged run store."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from demcal.cli import app
from demcal.cli._common import check_output_file, cli_errors, console
from demcal.cli._outputs import refuse_overwrites, store_files
from demcal.errors import InputError
from demcal.store import STORE_NAME, RunStore, salvage

store_app = typer.Typer(help="Inspect and repair a study's run store.", no_args_is_help=True)
app.add_typer(store_app, name="store")


@store_app.command("status")
@cli_errors
def status_cmd(
    study: Annotated[Path, typer.Argument(
        help="The study file (TOML), its folder or its demcal.sqlite.")],
) -> None:
    """Where a study stands, read while it runs: its writer, each stage's status, runs and
    findings, the verification's piles so far and the result once it is finished."""
    from rich.table import Table

    from demcal.calibrate.study import study_folder
    from demcal.report.progress import study_progress

    folder = study_folder(study) if study.suffix == ".toml" else (
        study.parent if study.name == STORE_NAME else study)
    if not (folder / STORE_NAME).is_file():
        raise InputError(f"{folder}: no run store ({STORE_NAME}) yet; `demcal calibrate "
                         "STUDY` creates it")
    with RunStore(folder, readonly=True) as store:
        prog = study_progress(store)
    console.print(f"{prog.name}: {prog.runs} runs stored in {folder / STORE_NAME}",
                  highlight=False)
    if prog.last_run_s is not None:
        console.print(f"last run finished {prog.last_run_s / 60:.0f} min ago", highlight=False)
    console.print("writer: " + ("none (no calibration holds the store)" if prog.writer is None
                                else prog.writer.line()), highlight=False)
    table = Table(show_edge=False)
    for col in ("stage", "status", "runs", "found"):
        table.add_column(col, overflow="fold")
    for st in prog.stages:
        table.add_row(st.name, st.status, str(st.runs), st.found)
    console.print(table)
    running = any(st.name == "verification" and st.status != "done" for st in prog.stages)
    if running and (line := prog.verification_line()) is not None:
        console.print(line, highlight=False)
    console.print("result: " + (prog.result or "not yet (the study has not finished)"),
                  highlight=False)


@store_app.command("salvage")
@cli_errors
def salvage_cmd(
    study_dir: Annotated[Path, typer.Argument(
        help="Study folder holding the damaged demcal.sqlite (or the file itself).")],
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="The new store (default STUDY_DIR/demcal.salvaged.sqlite).")]
    = None,
) -> None:
    """Copy the runs, stages and meta rows that can still be read into a new store.

    The damaged store is only read. Move it away and rename the new one to demcal.sqlite
    to go on with the study (runs that were lost are run again).
    """
    folder = study_dir if study_dir.is_dir() else study_dir.parent
    out = out or folder / "demcal.salvaged.sqlite"
    check_output_file(out, "--out")
    refuse_overwrites({"--out": out}, store_files(folder / STORE_NAME))
    counts = salvage(study_dir, out)
    console.print(f"salvaged {counts['runs']} runs ({counts['runs_skipped']} unreadable), "
                  f"{counts['stages']} stages and {counts['meta']} meta rows into {out}; move "
                  f"{folder / STORE_NAME} away and rename {out.name} to {STORE_NAME} to go on")
