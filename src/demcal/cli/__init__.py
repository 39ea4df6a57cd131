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
    """Entry point of the ``demcal`` console script.

    A usage error (an unknown option, a value out of its range, a missing argument) is one
    line on stderr naming the option, and exit code 2, like every other input error.
    """
    import contextlib
    import signal
    import sys

    from demcal.cli._stdout import survive_hangup
    from demcal.execute.signals import sigterm_raises

    survive_hangup()  # a dropped terminal ends no study midway (its output is guarded)
    # the click exceptions typer raises (typer may vendor its own click)
    errors = importlib.import_module(typer.BadParameter.__module__)
    try:
        # SIGTERM (kill, a scheduler's time limit) unwinds the command as Ctrl-C does,
        # exit 143: its finished runs are stored and its clean-ups run
        with sigterm_raises():
            code = app(standalone_mode=False)
    except errors.NoArgsIsHelpError:  # the help is printed already
        sys.exit(0)
    except errors.UsageError as exc:
        where = f" (see `{exc.ctx.command_path} --help`)" if exc.ctx is not None else ""
        print(f"error: {exc.format_message()}{where}", file=sys.stderr)
        sys.exit(2)
    except errors.ClickException as exc:
        print(f"error: {exc.format_message()}", file=sys.stderr)
        sys.exit(exc.exit_code)
    except typer.Abort:
        sys.exit(130)
    except SystemExit as stop:
        # a SIGTERM whose every stop was dropped ends the command as the block is left,
        # past the command's own one line (sigterm_raises): say it here
        if stop.code == 128 + signal.SIGTERM:
            with contextlib.suppress(OSError):
                print("terminated (SIGTERM)", file=sys.stderr)
        raise
    sys.exit(code if isinstance(code, int) else 0)
