"""``demcal measure``: angle of repose from pile photos (each, mean, standard deviation)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table
from rich.text import Text

from demcal import measure as pile_photos  # lazy: scikit-image loads when a photo is read
from demcal.cli import app
from demcal.cli._common import (
    check_output_dir,
    check_output_file,
    cli_errors,
    console,
    log,
    with_options,
)
from demcal.cli._outputs import refuse_overwrites
from demcal.errors import InputError
from demcal.safety import photo_too_large


def parse_threshold(text: str) -> str | float:
    """``auto``, ``otsu``, ``adaptive`` or a grey level in (0, 1)."""
    if text in ("auto", "otsu", "adaptive"):
        return text
    try:
        return float(text)
    except ValueError:
        raise InputError(
            f"--threshold must be auto, otsu, adaptive or a grey level in (0, 1); got {text!r}"
        ) from None


def _fmt(x: float, digits: int = 2) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:.{digits}f}"


def aor_table(table: pile_photos.AoRTable) -> Table:
    """A rich table: one row per photo, then the mean and standard deviation."""
    out = Table(title="Angle of repose", title_justify="left")
    out.add_column("#", justify="right")
    out.add_column("Photo", overflow="fold")
    for col in ("Left (°)", "± SE", "Right (°)", "± SE", "AoR (°)"):
        out.add_column(col, justify="right")
    for i, r in enumerate(table.results, 1):
        out.add_row(str(i), Path(r.source).name, _fmt(r.left_deg), _fmt(r.left_stderr_deg),
                    _fmt(r.right_deg), _fmt(r.right_stderr_deg),
                    Text(_fmt(r.mean_deg), style="bold"))
    out.add_section()
    out.add_row("", "mean", "", "", "", "", Text(_fmt(table.mean_deg), style="bold"))
    out.add_row("", "standard deviation", "", "", "", "", _fmt(table.std_deg))
    return out


def _write_outputs(table: pile_photos.AoRTable, plot: Path | None, plot_dir: Path | None,
                   csv: Path | None, json_out: Path | None) -> list[Path]:
    """Write the figures, the CSV and the JSON of a measured table; return their paths."""
    targets = [(table.results[0], plot)] if plot is not None else []
    if plot_dir is not None:
        plot_dir.mkdir(parents=True, exist_ok=True)
        names = _figure_names([Path(r.source) for r in table.results], plot_dir)
        targets += list(zip(table.results, names, strict=True))
    for res, path in targets:
        pile_photos.plot_photo_aor(res, path)
    for path in (csv, json_out):
        if path is not None:
            path.parent.mkdir(parents=True, exist_ok=True)
    if csv is not None or json_out is not None:
        pile_photos.save_table(table, csv=csv, json_path=json_out)
    return [path for _, path in targets] + [p for p in (csv, json_out) if p is not None]


def _figure_names(photos: list[Path], plot_dir: Path) -> list[Path]:
    """The diagnostic figure of each photo in ``plot_dir`` (numbered when stems repeat)."""
    stems = [Path(p).stem for p in photos]
    unique = len(set(stems)) == len(stems)
    return [plot_dir / (f"{stem}_aor.png" if unique else f"{i}_{stem}_aor.png")
            for i, stem in enumerate(stems, 1)]


@dataclass(frozen=True)
class MeasureOptions:
    """The options of ``demcal measure``, typed (:func:`~demcal.cli._common.with_options`)."""

    photos: Annotated[
        list[Path],
        typer.Argument(help="Front photos of piles (JPEG/PNG/TIFF/BMP), e.g. repeated tests."),
    ]
    threshold: Annotated[
        str,
        typer.Option("--threshold", "-t",
                     help="auto (Otsu, falling back to adaptive when the base line it gives "
                     "is implausible), otsu, adaptive (uneven lighting) or a grey level in "
                     "(0, 1)."),
    ] = "auto"
    fit_window: Annotated[
        tuple[float, float],
        typer.Option("--fit-window", help="Flank heights fitted, fractions of the pile height "
                     "(LO HI, 0 <= LO < HI <= 1)."),
    ] = pile_photos.DEFAULT_FIT_WINDOW
    fit: Annotated[
        str,
        typer.Option("--fit", help="Line fit: theil_sen, least_squares or ransac."),
    ] = "theil_sen"
    pile: Annotated[
        str, typer.Option("--pile", help="Tone of the pile: auto, dark or light.")
    ] = "auto"
    base_row: Annotated[
        int | None,
        typer.Option("--base-row", help="Image row of the plate surface (default: found)."),
    ] = None
    roi: Annotated[
        tuple[int, int, int, int] | None,
        typer.Option("--roi", help="Region of interest: ROW0 ROW1 COL0 COL1 (pixels)."),
    ] = None
    roll_deg: Annotated[
        float, typer.Option("--roll-deg", help="Camera roll, deg (counter-clockwise).")
    ] = 0.0
    pixel_aspect: Annotated[
        float, typer.Option("--pixel-aspect", help="Pixel height / width.")
    ] = 1.0
    plot: Annotated[
        Path | None,
        typer.Option("--plot", help="Diagnostic figure of the single photo given."),
    ] = None
    plot_dir: Annotated[
        Path | None,
        typer.Option("--plot-dir", help="Write one diagnostic figure per photo here."),
    ] = None
    csv: Annotated[
        Path | None, typer.Option("--csv", help="Write the table as CSV here.")
    ] = None
    json_out: Annotated[
        Path | None, typer.Option("--json", help="Write the table as JSON here.")
    ] = None


@app.command("measure")
@cli_errors
@with_options(MeasureOptions)
def measure(o: MeasureOptions) -> None:
    """Measure the angle of repose of each photo; print each, the mean and the std."""
    if o.plot is not None and len(o.photos) != 1:
        raise InputError(f"--plot takes one photo ({len(o.photos)} given); use --plot-dir")
    check_output_file(o.plot, "--plot", make_parents=True)
    check_output_file(o.csv, "--csv", make_parents=True)
    check_output_file(o.json_out, "--json", make_parents=True)
    check_output_dir(o.plot_dir, "--plot-dir")
    figures = {} if o.plot_dir is None else {
        f"--plot-dir ({f.name})": f for f in _figure_names(o.photos, o.plot_dir)}
    refuse_overwrites({"--plot": o.plot, "--csv": o.csv, "--json": o.json_out, **figures},
                      [(p, "an input photo") for p in o.photos])
    for photo in o.photos:
        if why := photo_too_large(photo):
            raise InputError(f"photo {photo}: {why}")
    log.info("measuring %d photo(s)", len(o.photos))
    table = pile_photos.photos_aor(
        o.photos, threshold=parse_threshold(o.threshold), fit_window=o.fit_window, fit=o.fit,
        pile=o.pile, base_line=o.base_row, roi=o.roi, roll_deg=o.roll_deg,
        pixel_aspect=o.pixel_aspect)
    # every file first, the console last: a console that is gone or blocks costs no file
    written = _write_outputs(table, o.plot, o.plot_dir, o.csv, o.json_out)
    console.print(aor_table(table))
    for r in table.results:
        for note in r.notes:
            console.print(f"note: {Path(r.source).name}: {note}", markup=False,
                          highlight=False)
    for path in written:
        console.print(f"wrote {path}", highlight=False)
