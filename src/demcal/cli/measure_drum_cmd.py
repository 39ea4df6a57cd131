"""``demcal measure-drum``: the dynamic angle of repose from frames of a rotating drum.

(A command of its own: ``demcal measure PHOTOS...`` takes pile photos as its arguments, so a
``drum`` word there would be read as a photo.)
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from demcal.cli import app
from demcal.cli._common import EXIT_FAILURE, check_output_file, cli_errors, console
from demcal.cli._outputs import refuse_overwrites
from demcal.cli.measure_cmd import parse_threshold
from demcal.errors import InputError
from demcal.safety import photo_too_large


def _fmt(x: float | None) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:.2f}"


@app.command("measure-drum")
@cli_errors
def measure_drum(
    frames: Annotated[list[Path], typer.Argument(
        help="Frames of the turning drum seen through its end wall (JPEG/PNG/TIFF/BMP).")],
    circle: Annotated[tuple[float, float, float] | None, typer.Option(
        "--circle", help="The drum's inner circle: ROW COL RADIUS (pixels); default: found "
        "in each frame.")] = None,
    threshold: Annotated[str, typer.Option(
        "--threshold", "-t", help="otsu (inside the circle), adaptive (lighting falling "
        "off across the frame) or a grey level in (0, 1).")] = "otsu",
    central: Annotated[float, typer.Option(
        "--central", help="Central part of the surface's chord fitted, in (0, 1].")] = 0.6,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write results as JSON.")]
    = None,
) -> None:
    """Measure the dynamic angle of repose of each frame, their mean and standard error
    (deg, positive when the surface rises to the right); refused frames are named with the
    reason. Exits with 3 when no frame gives an angle."""
    from demcal.measure.drum import DrumCircle, drum_frames

    check_output_file(json_out, "--json")
    refuse_overwrites({"--json": json_out}, [(f, "an input frame") for f in frames])
    if circle is not None and not (circle[2] > 0 and all(map(math.isfinite, circle))):
        raise InputError(f"--circle: RADIUS must be > 0 and every number finite; got {circle}")
    if not 0 < central <= 1:
        raise InputError(f"--central must be in (0, 1]; got {central}")
    for f in frames:
        if why := photo_too_large(f):
            raise InputError(f"frame {f}: {why}")
    result = drum_frames([str(f) for f in frames],
                         circle=None if circle is None else DrumCircle(*circle),
                         threshold=parse_threshold(threshold), central_fraction=central)
    if json_out is not None:
        json_out.write_text(json.dumps(result.to_dict(), indent=1))
    table = Table(title="rotating drum frames")
    for col in ("frame", "angle (deg)", "refused"):
        table.add_column(col)
    for f in result.frames:
        table.add_row(f.source, _fmt(f.angle_deg), f.refused or "")
    console.print(table)
    if result.mean_deg is None:
        console.print("no frame gave an angle")
        raise typer.Exit(EXIT_FAILURE)
    console.print(f"dynamic angle = {result.mean_deg:.2f} deg"
                  + ("" if result.sem_deg is None else
                     f" +/- {result.sem_deg:.2f} (standard error; std {result.std_deg:.2f})")
                  + f" over {len(result.angles)} of {len(result.frames)} frames",
                  highlight=False)
