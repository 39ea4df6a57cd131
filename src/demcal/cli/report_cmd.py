"""``demcal report STUDY_DIR``: rebuild a study's HTML report from its run store."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from demcal import report as study_report  # lazy: matplotlib loads when the report is built
from demcal.cli import app
from demcal.cli._common import (
    check_output_dir,
    check_report_problems,
    cli_errors,
    console,
    styled,
)


@app.command("report")
@cli_errors
def report(
    study_dir: Annotated[Path, typer.Argument(
        help="Study folder holding demcal.sqlite (the run store).")],
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Output folder (default STUDY_DIR/report).")] = None,
) -> None:
    """Build the calibration report (HTML, JSON, CSV tables, PNG figures) from the store."""
    check_output_dir(out, "--out")
    path = study_report.build_report(study_dir, out)
    data = study_report.load_report_data(study_dir)
    for view in data.stages.values():
        colour = {"done": "green", "failed": "red", "running": "yellow"}.get(view.status, "dim")
        line = styled(f"  {view.title}: ", (str(view.status), colour))
        if view.error:
            line.append(f" ({view.error})")
        console.print(line, soft_wrap=True)
    console.print(f"report: {path}", highlight=False, soft_wrap=True)
    card = path.parent / "material.toml"
    if card.is_file():
        console.print(f"material card: {card} (run it: demcal simulate aor --material {card})",
                      highlight=False, soft_wrap=True)
    check_report_problems(path)
