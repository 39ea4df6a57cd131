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
import inspect
import logging
import os
import re
import sqlite3
import typing
from collections.abc import Callable, Iterable
from dataclasses import MISSING, fields
from pathlib import Path
from typing import Any, TypeVar

import typer
from rich.console import Console
from rich.segment import Segment
from rich.text import Text

from demcal.cli._stdout import EXIT_STDOUT_GONE, guarded_stdout, reset, stdout_gone
from demcal.errors import (
    DemcalError,
    InputError,
    SimulationUnstable,
    StudyError,
    validation_message,
)

#: characters of user text never sent to a terminal raw: C0 controls but line break and tab
#: (ESC starts a terminal sequence: colours, "set window title"), DEL, C1 controls, and the
#: bidirectional overrides that make a file name read backwards
_UNSAFE_CHARS = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")


def printable(text: str) -> str:
    """``text`` with every terminal control character written as an escape (``\\x1b``)."""
    return _UNSAFE_CHARS.sub(lambda m: f"\\x{ord(m.group()):02x}" if ord(m.group()) < 256
                             else f"\\u{ord(m.group()):04x}", text)


class SafeConsole(Console):
    """A console that escapes control characters in the text it prints (study names, file
    names, messages), never in rich's own control output (cursor moves, styles)."""

    def _render_buffer(self, buffer: Iterable[Segment]) -> str:
        return super()._render_buffer(
            seg if seg.control else Segment(printable(seg.text), seg.style, seg.control)
            for seg in buffer)


# stdout through a guard: a closed pipe or a hung-up terminal ends no command midway
console = SafeConsole(file=guarded_stdout, markup=False, highlight=False)
err_console = SafeConsole(stderr=True, markup=False, highlight=False)
log = logging.getLogger("demcal")

F = TypeVar("F", bound=Callable[..., Any])

EXIT_INPUT = 2
EXIT_FAILURE = 3
EXIT_INTERRUPTED = 130
#: the exit status of a command stopped by SIGTERM (128 + 15: the ``SystemExit`` that
#: :func:`demcal.execute.signals.sigterm_raises` raises around every command)
EXIT_TERMINATED = 143


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


#: longest error line printed (a screenful): a message quoting a 9 MB value is cut here
MAX_LINE_CHARS = 2000


def one_line(text: object, limit: int = MAX_LINE_CHARS) -> str:
    """``text`` on one line, at most ``limit`` characters: line breaks and other control
    characters (ESC of a terminal sequence included) become spaces."""
    s = str(text)
    if len(s) > limit:
        s = s[:limit] + f"... ({len(s) - limit:,} more characters)"
    return "".join(" " if (ord(c) < 32 or 0x7f <= ord(c) < 0xa0) else c for c in s).strip()


def format_validation_error(exc: Exception) -> str:
    """One line for a pydantic ``ValidationError``: ``a.b.c: message; d: message``."""
    return validation_message(exc)


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


def _os_message(exc: OSError) -> str:
    where = f"{exc.filename}: " if exc.filename else ""
    return f"{where}{exc.strerror or exc}"


#: expected errors: (types, prefix, message, exit code), the first match wins
_ERRORS: tuple[tuple[Any, str, Callable[[Any], str], int], ...] = (
    (InputError, "error:", str, EXIT_INPUT),
    ((SimulationUnstable, StudyError, DemcalError), "failed:", str, EXIT_FAILURE),
    ((FileNotFoundError, IsADirectoryError, NotADirectoryError, PermissionError), "error:",
     _os_message, EXIT_INPUT),
    (UnicodeDecodeError, "error:", lambda e: f"an input file is not text (UTF-8): {e.reason} "
     f"at byte {e.start}", EXIT_INPUT),
    # a structure nested too deeply, wherever it was read: one line, not a traceback
    (RecursionError, "error:", lambda e: "an input is nested too deeply (thousands of "
     "levels) to be read", EXIT_INPUT),
    (MemoryError, "failed:", lambda e: "out of memory; reduce the problem size", EXIT_FAILURE),
    (sqlite3.DatabaseError, "failed:", lambda e: f"run store: {e}", EXIT_FAILURE),
    (OSError, "failed:", str, EXIT_FAILURE),
)


def _as_exit(exc: Exception) -> typer.Exit | None:
    """The exit (after its one line) of an expected error; None: a bug, keep its traceback."""
    for types, prefix, message, code in _ERRORS:
        if isinstance(exc, types):
            return _fail(prefix, message(exc), code)
    if type(exc).__name__ == "ValidationError" and hasattr(exc, "errors"):
        return _fail("error:", format_validation_error(exc), EXIT_INPUT)
    return None


def cli_errors(func: F) -> F:
    """Decorate a command: expected errors become one red line and an exit code.

    InputError, pydantic validation errors, unreadable input files (missing, a folder,
    not text, no permission) and inputs nested too deeply exit with 2; a failed simulation or
    study, a damaged store or a full disk exit with 3; Ctrl-C exits with 130, SIGTERM with
    143 (:func:`demcal.execute.signals.sigterm_raises`); a standard
    output that went away during a command that ran to its end exits with 141. Anything else
    is a bug and keeps its traceback.
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
        except KeyboardInterrupt:
            raise _fail("interrupted", "", EXIT_INTERRUPTED) from None
        except SystemExit as stop:
            if stop.code != EXIT_TERMINATED:
                raise
            raise _fail("terminated", "(SIGTERM)", EXIT_TERMINATED) from None
        except Exception as exc:
            if (exit_ := _as_exit(exc)) is None:
                raise
            raise exit_ from None
        _check_stdout()
        return out

    return wrapper  # type: ignore[return-value]


def with_options(options: type) -> Callable[[Callable[[Any], None]], Callable[..., None]]:
    """A command taking one ``options`` object, shown to typer as the dataclass' fields (a
    command's option list is a table, not a function's complexity: it is read as one)."""
    hints = typing.get_type_hints(options, include_extras=True)

    def wrap(func: Callable[[Any], None]) -> Callable[..., None]:
        @functools.wraps(func)
        def command(**kwargs: Any) -> None:
            func(options(**kwargs))

        command.__signature__ = inspect.Signature([  # type: ignore[attr-defined]
            inspect.Parameter(f.name, inspect.Parameter.KEYWORD_ONLY, default=(
                inspect.Parameter.empty if f.default is MISSING else f.default),
                              annotation=hints[f.name]) for f in fields(options)])
        del command.__wrapped__  # typer must read the signature above, not func's
        # resolved here: typer evaluates string annotations in this module's globals
        command.__annotations__ = {f.name: hints[f.name] for f in fields(options)}
        return command
    return wrap
