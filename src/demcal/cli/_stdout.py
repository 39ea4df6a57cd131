"""A standard output that may go away: a closed pipe or a hung-up terminal costs no result.

``demcal calibrate STUDY | head``, a dropped ssh session or a parent that stops reading: a
print then fails with EPIPE (pipe closed) or EIO (terminal hung up). Before 2026-11-27 that
error ended the command where it stood, after a simulation of minutes or a study of hours:
``simulate aor`` exited 1 with no JSON, ``calibrate`` wrote no JSON and no report.

:class:`GuardedStdout` is the file of demcal's console: it writes to whatever
``sys.stdout`` is at the time (so test runners that swap it still capture), and when that
write fails because the reader is gone it sends every later write to ``/dev/null`` and
remembers it. The command therefore runs to its end and writes its files; the CLI then
ends with :data:`EXIT_STDOUT_GONE` and one line on stderr (:func:`stdout_gone`).
A hung-up terminal would also send SIGHUP, whose default ends the process at once;
:func:`survive_hangup` ignores it, as ``nohup`` does, so the work finishes.
"""

from __future__ import annotations

import contextlib
import errno
import io
import os
import signal
import sys

__all__ = ["EXIT_STDOUT_GONE", "GuardedStdout", "guarded_stdout", "reset", "stdout_gone",
           "survive_hangup"]

#: exit status when standard output went away during the command (128 + SIGPIPE, as a
#: shell reports a process that SIGPIPE ended); every file the command writes is written
EXIT_STDOUT_GONE = 141
#: write errors meaning "the reader is gone": a closed pipe, a hung-up terminal
_GONE = (errno.EPIPE, errno.EIO)


class GuardedStdout(io.TextIOBase):
    """``sys.stdout`` as it is at each write; once its reader is gone, a silent sink."""

    def __init__(self) -> None:
        super().__init__()
        self.gone = False

    @staticmethod
    def _target() -> object:
        """The stream to write to: ``sys.stdout``, or the file under rich's own proxy of it.

        While a progress display runs, rich replaces ``sys.stdout`` by a proxy that prints
        through this console; writing to the proxy would come back here for ever.
        """
        out: object = sys.stdout
        while (inner := getattr(out, "rich_proxied_file", None)) is not None:
            out = inner
        return out

    def _lost(self) -> None:
        """Remember the loss; point fd 1 at /dev/null so no later write (the interpreter's
        last flush included) fails again."""
        self.gone = True
        with contextlib.suppress(OSError, ValueError, io.UnsupportedOperation,
                                 AttributeError):
            fd = self._target().fileno()  # type: ignore[attr-defined]
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, fd)
            os.close(null)

    def write(self, text: str) -> int:
        if self.gone:
            return len(text)
        try:
            return self._target().write(text)  # type: ignore[attr-defined]
        except OSError as exc:
            if exc.errno not in _GONE:
                raise
            self._lost()
            return len(text)

    def flush(self) -> None:
        if self.gone:
            return
        try:
            self._target().flush()  # type: ignore[attr-defined]
        except OSError as exc:
            if exc.errno not in _GONE:
                raise
            self._lost()

    def isatty(self) -> bool:
        try:
            return not self.gone and self._target().isatty()  # type: ignore[attr-defined]
        except (OSError, ValueError):
            return False

    def fileno(self) -> int:
        return self._target().fileno()  # type: ignore[attr-defined]

    def writable(self) -> bool:
        return True

    @property
    def encoding(self) -> str:  # type: ignore[override]
        """The encoding of the current ``sys.stdout`` (utf-8 when it has none)."""
        return getattr(self._target(), "encoding", None) or "utf-8"


#: the one guarded stream behind :data:`demcal.cli._common.console`
guarded_stdout = GuardedStdout()


def stdout_gone() -> bool:
    """Whether a write to standard output found its reader gone during this command."""
    return guarded_stdout.gone


def reset() -> None:
    """Forget an earlier loss (a new command in the same process, as in tests)."""
    guarded_stdout.gone = False


def survive_hangup() -> None:
    """Ignore SIGHUP (a hung-up terminal), so a running study or simulation finishes and
    writes its results; SIGTERM and Ctrl-C still stop it."""
    with contextlib.suppress(ValueError, OSError, AttributeError):  # not the main thread
        signal.signal(signal.SIGHUP, signal.SIG_IGN)
