"""``demcal measure-drum``: the dynamic angle of repose from frames of a rotating drum.

(A command of its own: ``demcal measure PHOTOS...`` takes pile photos as its arguments, so a
``drum`` word there would be read as a photo.)
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from demcal.cli import app
from demcal.cli._common import (
    EXIT_FAILURE,
    check_output_file,
    cli_errors,
    console,
    with_options,
)
from demcal.cli._outputs import refuse_overwrites
from demcal.cli.measure_cmd import parse_threshold
from demcal.errors import InputError
from demcal.safety import photo_too_large


def _fmt(x: float | None) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:.2f}"


@dataclass(frozen=True)
class MeasureDrumOptions:
    """The options of ``demcal measure-drum``, typed (:func:`~demcal.cli._common.with_options`)."""

    frames: Annotated[list[Path], typer.Argument(
        help="Frames of the turning drum seen through its end wall (JPEG/PNG/TIFF/BMP), or "
        "video files of it (MP4, AVI, MOV, MKV, WebM, ...: each stands for its frames).",
        show_default=False)]
    circle: Annotated[tuple[float, float, float] | None, typer.Option(
        "--circle", help="The drum's inner circle: ROW COL RADIUS (pixels); default: found "
        "in each frame.")] = None
    threshold: Annotated[str, typer.Option(
        "--threshold", "-t", help="otsu (inside the circle), adaptive (lighting falling "
        "off across the frame) or a grey level in (0, 1).")] = "otsu"
    central: Annotated[float, typer.Option(
        "--central", help="Central part of the surface's chord fitted, in (0, 1].")] = 0.6
    every: Annotated[int, typer.Option(
        "--every", help="Videos: measure every N-th frame (frames far enough apart to be "
        "independent: the standard error assumes it).")] = 1
    json_out: Annotated[Path | None, typer.Option("--json", help="Write results as JSON.")] \
        = None


@app.command("measure-drum")
@cli_errors
@with_options(MeasureDrumOptions)
def measure_drum(o: MeasureDrumOptions) -> None:
    """Measure the dynamic angle of repose of each frame, their mean and standard error
    (deg, positive when the surface rises to the right); refused frames are named with the
    reason. Exits with 3 when no frame gives an angle."""
    from demcal.measure.drum import DrumCircle, drum_frames
    from demcal.measure.video import is_video

    check_output_file(o.json_out, "--json")
    refuse_overwrites({"--json": o.json_out}, [(f, "an input frame") for f in o.frames])
    circle = o.circle
    if circle is not None and not (circle[2] > 0 and all(map(math.isfinite, circle))):
        raise InputError(f"--circle: RADIUS must be > 0 and every number finite; got {circle}")
    if not 0 < o.central <= 1:
        raise InputError(f"--central must be in (0, 1]; got {o.central}")
    if not 1 <= o.every <= 1_000_000:
        raise InputError(f"--every must be in 1..1000000; got {o.every}")
    for f in o.frames:
        if not is_video(f) and (why := photo_too_large(f)):
            raise InputError(f"frame {f}: {why}")
    result = drum_frames([str(f) for f in o.frames], every=o.every,
                         circle=None if circle is None else DrumCircle(*circle),
                         threshold=parse_threshold(o.threshold), central_fraction=o.central)
    if o.json_out is not None:
        o.json_out.write_text(json.dumps(result.to_dict(), indent=1))
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
