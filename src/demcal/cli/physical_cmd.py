"""``demcal physical``: bench measurements in, model parameters out (the paper's Table 1)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from demcal import physical as bench  # lazy: scipy.stats loads when measurements are reduced
from demcal.cli import app
from demcal.cli._common import check_output_file, cli_errors, console, log, styled
from demcal.cli._outputs import refuse_overwrites


def _num(x: float | None, digits: int = 4) -> str:
    """Compact number: ``digits`` significant digits below 1, up to 6 above."""
    if x is None:
        return "-"
    return f"{x:.6g}" if abs(x) >= 1 else f"{x:.{digits}g}"


def _display(s: bench.RepeatSummary) -> tuple[str, float]:
    """Display unit and scale of a summary (moduli in MPa, lengths in mm)."""
    if s.name in bench.PARAMETERS:
        info = bench.PARAMETERS[s.name]
        return info.display_unit, info.display_scale
    if s.unit == "Pa":
        return "MPa", 1e-6
    if s.unit == "m":
        return "mm", 1e3
    return s.unit, 1.0


def _parameter_table(result: bench.PhysicalResult) -> Table:
    table = Table(title=f"Model parameters of {result.measurements.material}", title_justify="left")
    table.add_column("Symbol")
    table.add_column("Parameter")
    table.add_column("Name", style="cyan")
    table.add_column("Value", justify="right")
    table.add_column("Unit")
    table.add_column("Source", overflow="fold")
    for row in result.table_rows():
        value = row["display"].replace("-", " - ") if row["kind"] == "factor" else row["display"]
        table.add_row(
            row["symbol"],
            row["label"],
            row["name"],
            value,
            row["display_unit"],
            row["source"],
        )
    return table


def _summary_table(result: bench.PhysicalResult) -> Table:
    level = result.settings.get("ci_level", 0.95)
    table = Table(title="Measured repeats", title_justify="left")
    table.add_column("Quantity", style="cyan")
    table.add_column("Unit")
    table.add_column("n", justify="right")
    table.add_column("Mean", justify="right")
    table.add_column("SD", justify="right")
    table.add_column("Min - max", justify="right")
    table.add_column(f"{level:.0%} CI of mean", justify="right")
    for s in result.summaries.values():
        unit, scale = _display(s)

        def sc(x: float | None, scale: float = scale) -> float | None:
            return None if x is None else x * scale

        ci = "-" if s.ci_low is None else f"{_num(sc(s.ci_low))} - {_num(sc(s.ci_high))}"
        n = "-" if s.n_repeats is None else str(s.n_repeats)
        if s.range_only:
            n += " (range only)"
        table.add_row(
            s.name,
            unit,
            n,
            _num(sc(s.mean)),
            _num(sc(s.std), 3),
            f"{_num(sc(s.minimum))} - {_num(sc(s.maximum))}",
            ci,
        )
    return table


def _template_lines(result: bench.PhysicalResult) -> list[str]:
    lines = []
    t = result.template
    if t is not None:
        d = t.to_dict()
        how = "automatic" if t.automatic else "given"
        lines.append(
            f"Particle template: {d['n_spheres']} spheres ({how}) of "
            f"{d['sphere_diameter_m'] * 1e3:.3g} mm along {t.length * 1e3:.3g} mm, spacing "
            f"{(d['spacing_m'] or 0.0) * 1e3:.3g} mm, overlap {d['overlap']:.0%} of a diameter"
        )
        lines.append(
            f"  volume {t.template.volume * 1e9:.4g} mm^3 vs cylinder "
            f"{t.cylinder_volume * 1e9:.4g} mm^3: volume error {t.volume_error:+.1%} "
            f"(ridges {-(d['ridge_loss'] or 0.0):+.1%} of the capsule; rounded ends "
            f"{-t.diameter / (3 * t.length):+.1%} of the cylinder)"
        )
        if t.density_for_equal_mass is not None:
            lines.append(
                f"  equal-mass density would be {t.density_for_equal_mass:.5g} kg/m^3 "
                "(information only; not applied)"
            )
    r = result.rayleigh
    if r is not None:
        lines.append(
            f"Rayleigh time step {r.time_step:.4g} s; {r.fraction:.0%} of it: "
            f"{r.suggested_step:.4g} s ({r.note})"
        )
    a = result.target_aor
    if a is not None:
        ci = "" if a.ci_low is None else f", {a.level:.0%} CI {a.ci_low:.2f}-{a.ci_high:.2f}"
        sd = "" if a.std is None else f" +- {a.std:.2f} (sd)"
        lines.append(f"Target angle of repose {a.mean:.2f}{sd} deg, n={a.n_repeats}{ci}")
    photos = result.measurements.aor.photos if result.measurements.aor else None
    if photos:
        lines.append(f"AoR photos to measure: {len(photos)}")
    return lines


@app.command("physical")
@cli_errors
def physical(
    measurements: Annotated[
        Path,
        typer.Argument(
            help="Measurements TOML (standalone, or a study file with a \\[measurements] table)."
        ),
    ],
    json_out: Annotated[
        Path | None,
        typer.Option("--json", help="Write the raw data and everything derived as JSON here."),
    ] = None,
    range_rule: Annotated[
        str | None,
        typer.Option(
            "--range-rule",
            help="Factor range from a measured spread: minmax, mean_std or ci "
            "(overrides the file).",
        ),
    ] = None,
    k: Annotated[
        float | None,
        typer.Option("--k", help="Standard deviations of the mean_std rule (overrides the file)."),
    ] = None,
    ci_level: Annotated[
        float | None,
        typer.Option("--ci-level", help="Confidence level of the intervals (overrides the file)."),
    ] = None,
) -> None:
    """Derive fixed parameters, factor ranges and the particle template from measurements."""
    check_output_file(json_out, "--json", make_parents=True)
    refuse_overwrites({"--json": json_out}, [(measurements, "the measurements file")])
    log.info("reading %s", measurements)
    result = bench.derive_parameters(
        bench.load_measurements(measurements), ci_level=ci_level, range_rule=range_rule, range_k=k
    )
    if json_out is not None:  # first: a console that is gone or blocks costs no file
        json_out.parent.mkdir(parents=True, exist_ok=True)
        json_out.write_text(json.dumps(result.to_dict(), indent=2) + "\n", encoding="utf-8")
    console.print(_parameter_table(result))
    if result.missing:
        console.print(
            styled(("not set yet:", "yellow"), " " + ", ".join(result.missing))
        )
    for note in result.notes:
        console.print(styled((f"note: {note}", "dim")))
    console.print(_summary_table(result))
    for line in _template_lines(result):
        console.print(line, highlight=False)
    if json_out is not None:
        console.print(f"wrote {json_out}", highlight=False)
