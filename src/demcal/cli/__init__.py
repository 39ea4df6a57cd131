"""The ``demcal`` command line: a thin layer over the Python API.

Each sub-command lives in its own module (``*_cmd.py`` or ``*_cmds.py`` in this package),
which registers itself on :data:`app` when imported; :data:`COMMAND_MODULES` lists them, found
by name so that a new command is one new file.
"""

from __future__ import annotations

import importlib
import logging
import pkgutil

import typer

app = typer.Typer(
    name="demcal",
    help="Calibrate DEM material parameters against physical tests, end to end.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)

COMMAND_MODULES: tuple[str, ...] = tuple(sorted(
    m.name for m in pkgutil.iter_modules(__path__) if m.name.endswith(("_cmd", "_cmds"))
))


@app.callback()
def _root(
    verbose: bool = typer.Option(False, "--verbose", "-v", help="Log progress details."),
) -> None:
    """Calibrate DEM material parameters against physical tests, end to end."""
    logging.basicConfig(level=logging.INFO if verbose else logging.WARNING, format="%(message)s")


for _name in COMMAND_MODULES:
    importlib.import_module(f"demcal.cli.{_name}")


def main() -> None:
    """Entry point of the ``demcal`` console script."""
    app()
