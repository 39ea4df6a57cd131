"""``demcal store salvage``: copy what can still be read of a damaged run store."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from demcal.cli import app
from demcal.cli._common import check_output_file, cli_errors, console
from demcal.cli._outputs import refuse_overwrites, store_files
from demcal.store import STORE_NAME, salvage

store_app = typer.Typer(help="Inspect and repair a study's run store.", no_args_is_help=True)
app.add_typer(store_app, name="store")


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
