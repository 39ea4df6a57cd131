"""Shared CLI plumbing: the consoles, output-path checks, and one-line errors.

Every message that may hold user text (a study name, a path, an error message) is printed
as plain text: both consoles are built with ``markup=False`` and ``highlight=False``, so a
``[/]`` or ``[factors]`` in user text is printed as it is and can never crash the console.
Colour comes from :func:`styled` (a :class:`rich.text.Text` built from ``(text, style)``
parts), never from markup in an f-string.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import os
import sqlite3
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import typer
from rich.console import Console
from rich.text import Text

from demcal.cli._stdout import EXIT_STDOUT_GONE, guarded_stdout, reset, stdout_gone
from demcal.errors import DemcalError, InputError, SimulationUnstable, StudyError

# stdout through a guard: a closed pipe or a hung-up terminal ends no command midway
console = Console(file=guarded_stdout, markup=False, highlight=False)
err_console = Console(stderr=True, markup=False, highlight=False)
log = logging.getLogger("demcal")

F = TypeVar("F", bound=Callable[..., Any])

EXIT_INPUT = 2
EXIT_FAILURE = 3
EXIT_INTERRUPTED = 130


def styled(*parts: str | tuple[str, str]) -> Text:
    """A line from plain parts and ``(text, style)`` pairs; no markup is ever parsed.

    Parameters
    ----------
    *parts : str or (str, str)
        Plain text, or text with a rich style such as ``"yellow"`` or ``"bold"``.

    Returns
    -------
    rich.text.Text
        The assembled line, safe for any user text.
    """
    return Text.assemble(*parts)


def one_line(text: object) -> str:
    """``text`` on one line: line breaks (and other control characters) become spaces."""
    s = str(text)
    return "".join(" " if (c in "\r\n\t" or ord(c) < 32) else c for c in s).strip()


def format_validation_error(exc: Exception) -> str:
    """One line for a pydantic ``ValidationError``: ``a.b.c: message; d: message``."""
    parts = []
    for err in exc.errors():  # type: ignore[attr-defined]
        loc = ".".join(str(p) for p in err.get("loc", ()))
        msg = str(err.get("msg", "invalid value")).removeprefix("Value error, ")
        parts.append(f"{loc}: {msg}" if loc else msg)
    return "; ".join(parts)


def check_output_file(path: Path | None, option: str, *,
                      make_parents: bool = False) -> Path | None:
    """Refuse an output file that cannot be written, before any work starts.

    Parameters
    ----------
    path : Path or None
        The file the command will write (None: nothing to check).
    option : str
        The option that named it (for the message), e.g. ``"--json"``.
    make_parents : bool
        The command creates missing folders: then only the nearest existing one must be a
        writable folder.

    Returns
    -------
    Path or None
        ``path`` unchanged.

    Raises
    ------
    InputError
        ``path`` is a directory, its folder does not exist, or is not writable.
    """
    if path is None:
        return None
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{option}: {path} is a directory; give a file name")
    parent = path.parent if str(path.parent) else Path(".")
    if make_parents and not parent.exists():
        check_output_dir(parent, option)
        return path
    if not parent.is_dir():
        raise InputError(f"{option}: folder {parent} does not exist (create it first)")
    if path.exists() and not os.access(path, os.W_OK):
        raise InputError(f"{option}: {path} is not writable")
    if not path.exists() and not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{option}: folder {parent} is not writable")
    return path


def check_output_dir(path: Path | None, option: str) -> Path | None:
    """Refuse an output folder that cannot be made or written, before any work starts.

    The folder may not exist yet (it is created later), but its nearest existing ancestor
    must be a writable folder.

    Parameters
    ----------
    path : Path or None
        The folder the command will write into (None: nothing to check).
    option : str
        The option that named it (for the message).

    Returns
    -------
    Path or None
        ``path`` unchanged.

    Raises
    ------
    InputError
        ``path`` is a file, or no writable folder holds it.
    """
    if path is None:
        return None
    path = Path(path)
    probe = path
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if probe.exists() and not probe.is_dir():
        raise InputError(f"{option}: {probe} is a file, not a folder")
    if probe.exists() and not os.access(probe, os.W_OK | os.X_OK):
        raise InputError(f"{option}: folder {probe} is not writable")
    return path


def check_report_problems(html_path: Path) -> None:
    """Refuse to pass quietly a report that was written with problems (exit 3, one line).

    Parameters
    ----------
    html_path : Path
        The written ``report.html``; its ``report.json`` lists the problems (figures that
        could not be drawn, sections that could not be built, images refused).

    Raises
    ------
    StudyError
        When the report has problems; the message names the first and the count.
    """
    import json

    try:
        doc = json.loads((Path(html_path).parent / "report.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return
    problems = [str(p) for p in doc.get("problems") or []]
    if problems:
        more = f" (and {len(problems) - 1} more, see report.json)" if len(problems) > 1 else ""
        raise StudyError(f"report {html_path} written with {len(problems)} problem(s): "
                         f"{problems[0]}{more}")


def _fail(prefix: str, message: object, code: int) -> typer.Exit:
    with contextlib.suppress(OSError):  # stderr gone too: the exit code still says it
        err_console.print(styled((prefix, "red"), " ", one_line(message)), soft_wrap=True)
    return typer.Exit(code)


def _check_stdout() -> None:
    """After a command that ran to its end: if its standard output went away meanwhile,
    say so on stderr and exit with EXIT_STDOUT_GONE (its files are all written)."""
    if stdout_gone():
        raise _fail("failed:", "standard output was closed (a closed pipe or a hung-up "
                    "terminal); the command ran to its end and wrote its files, but not all "
                    "of its output was shown", EXIT_STDOUT_GONE)


def cli_errors(func: F) -> F:
    """Decorate a command: expected errors become one red line and an exit code.

    InputError, pydantic validation errors and unreadable input files (missing, a folder,
    not text, no permission) exit with 2; a failed simulation or study, a damaged store or a
    full disk exit with 3; Ctrl-C exits with 130. Anything else is a bug and keeps its
    traceback.
    """

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        reset()
        try:
            out = func(*args, **kwargs)
        except typer.Exit as done:
            if not done.exit_code:  # a failure's own exit code says more
                _check_stdout()
            raise
        except InputError as exc:
            raise _fail("error:", exc, EXIT_INPUT) from None
        except (SimulationUnstable, StudyError, DemcalError) as exc:
            raise _fail("failed:", exc, EXIT_FAILURE) from None
        except (FileNotFoundError, IsADirectoryError, NotADirectoryError,
                PermissionError) as exc:
            where = f"{exc.filename}: " if exc.filename else ""
            raise _fail("error:", f"{where}{exc.strerror or exc}", EXIT_INPUT) from None
        except UnicodeDecodeError as exc:
            raise _fail("error:", f"an input file is not text (UTF-8): {exc.reason} at byte "
                        f"{exc.start}", EXIT_INPUT) from None
        except MemoryError:
            raise _fail("failed:", "out of memory; reduce the problem size", EXIT_FAILURE) \
                from None
        except sqlite3.DatabaseError as exc:
            raise _fail("failed:", f"run store: {exc}", EXIT_FAILURE) from None
        except OSError as exc:
            raise _fail("failed:", exc, EXIT_FAILURE) from None
        except KeyboardInterrupt:
            raise _fail("interrupted", "", EXIT_INTERRUPTED) from None
        except Exception as exc:
            if type(exc).__name__ == "ValidationError" and hasattr(exc, "errors"):
                raise _fail("error:", format_validation_error(exc), EXIT_INPUT) from None
            raise
        _check_stdout()
        return out

    return wrapper  # type: ignore[return-value]
