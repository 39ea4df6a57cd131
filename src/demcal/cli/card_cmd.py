"""``demcal card lammps MATERIAL``: a calibrated material card as another engine's input."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from demcal.cli import app
from demcal.cli._common import check_output_file, cli_errors, console, err_console
from demcal.cli._outputs import refuse_overwrites

card_app = typer.Typer(help="A material card as another DEM code's input.",
                       no_args_is_help=True)
app.add_typer(card_app, name="card")


@card_app.command("lammps")
@cli_errors
def card_lammps(
    material: Annotated[Path, typer.Argument(help="Material card (material.toml or "
                                             "material.json written by demcal report).")],
    out: Annotated[Path | None, typer.Option("--out", help="Write the lines to this file "
                                             "(default: print them).")] = None,
) -> None:
    """Print the LAMMPS commands (pair_style granular, pair_coeff, fix wall/gran, timestep)
    of a calibrated material, to paste into a LAMMPS input script (docs/lammps.md)."""
    from demcal.virtual.lammps_card import lammps_lines
    from demcal.virtual.material_card import read_material_card

    check_output_file(out, "--out", make_parents=True)
    refuse_overwrites({"--out": out}, [(material, "the material card")])
    lines = lammps_lines(read_material_card(material))
    if out is not None:
        out.write_text(lines.text)
        console.print(f"LAMMPS lines written to {out}", highlight=False)
    else:
        console.print(lines.text, end="", highlight=False, soft_wrap=True)
    if lines.warning:
        err_console.print(f"warning: {lines.warning}", highlight=False)
