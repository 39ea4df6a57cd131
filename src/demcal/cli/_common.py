"""Shared CLI plumbing: the console, and turning demcal errors into one line + exit code 2."""

from __future__ import annotations

import functools
import logging
from collections.abc import Callable
from typing import Any, TypeVar

import typer
from rich.console import Console

from demcal.errors import DemcalError, InputError, SimulationUnstable, StudyError

console = Console()
err_console = Console(stderr=True)
log = logging.getLogger("demcal")

F = TypeVar("F", bound=Callable[..., Any])

EXIT_INPUT = 2
EXIT_FAILURE = 3


def format_validation_error(exc: Exception) -> str:
    """One line per bad field of a pydantic ``ValidationError``: ``a.b.c: message``."""
    lines = []
    for err in exc.errors():  # type: ignore[attr-defined]
        loc = ".".join(str(p) for p in err.get("loc", ()))
        msg = str(err.get("msg", "invalid value")).removeprefix("Value error, ")
        lines.append(f"{loc}: {msg}" if loc else msg)
    return "\n".join(lines)


def cli_errors(func: F) -> F:
    """Decorate a command: demcal errors become a red one-line message and an exit code.

    InputError and pydantic validation errors exit with 2; a failed simulation or study
    exits with 3. Anything else is a bug and keeps its traceback.
    """

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except InputError as exc:
            err_console.print(f"[red]error:[/red] {exc}", soft_wrap=True, highlight=False)
            raise typer.Exit(EXIT_INPUT) from None
        except (SimulationUnstable, StudyError, DemcalError) as exc:
            err_console.print(f"[red]failed:[/red] {exc}", soft_wrap=True, highlight=False)
            raise typer.Exit(EXIT_FAILURE) from None
        except Exception as exc:
            if type(exc).__name__ == "ValidationError" and hasattr(exc, "errors"):
                err_console.print(
                    "[red]error:[/red] " + format_validation_error(exc),
                    soft_wrap=True,
                    highlight=False,
                )
                raise typer.Exit(EXIT_INPUT) from None
            raise

    return wrapper  # type: ignore[return-value]
