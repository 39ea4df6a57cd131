"""Process hygiene for long runs: a worker dies with its parent, and SIGTERM unwinds.

A study's local pool spawns worker processes. Killed with SIGKILL, the parent cannot stop
them, and a ``multiprocessing`` pool even replaces workers that die while its parent still
lives; without care they run on as orphans, each holding a core for the rest of its task (a
1200-stalk task: ~20 minutes). :func:`die_with_parent` makes the kernel kill a worker when
its parent goes (Linux ``PR_SET_PDEATHSIG``); :func:`sigterm_raises` turns SIGTERM into
``SystemExit`` in the main thread, so ``kill PID`` unwinds like Ctrl-C (the pool is
terminated, the store closed) instead of ending the process where it stands.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
import threading
from collections.abc import Iterator
from typing import Any

__all__ = ["RESEND_S", "die_with_parent", "sigterm_raises"]

#: prctl option: the signal this process gets when its parent thread exits (Linux)
PR_SET_PDEATHSIG = 1
#: s between the signals :func:`sigterm_raises` sends itself until a stopped block is left
RESEND_S = 0.5


def die_with_parent(parent_pid: int) -> bool:
    """Ask the kernel to SIGKILL this process when its parent exits (Linux; elsewhere a no-op
    returning False). Exits at once if the parent ``parent_pid`` is already gone."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) != 0:
            return False
    except (OSError, AttributeError):  # pragma: no cover - no libc prctl
        return False
    if os.getppid() != parent_pid:  # the parent died before the request took effect
        os._exit(1)
    return True


@contextlib.contextmanager
def sigterm_raises() -> Iterator[None]:
    """SIGTERM raises ``SystemExit(143)`` inside the block (in the main thread only; elsewhere
    the block runs unchanged), so ``finally``/``except BaseException`` clean-ups run.

    Python runs the handler at the next line of Python, and some places drop what it raises:
    a finalizer (``__del__``, many while numba compiles) and C code that clears any error
    (``PyDict_GetItem`` calling a Python ``__eq__``, for one). The command would run on. So
    once SIGTERM has come, a thread signals again every :data:`RESEND_S` s until the block
    is left; the handler raises only where no such SystemExit is already unwinding (none in
    the exception being handled nor in its ``__context__`` chain), so clean-ups run to their
    end, a second ``kill`` included (SIGKILL still ends the process at once). A block that
    ends as if no SIGTERM had come (every stop dropped before the next one) raises the
    SystemExit as it is left.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    code = 128 + signal.SIGTERM
    raised: list[SystemExit] = []
    left = threading.Event()
    resender = threading.Thread(target=lambda: _resend_until(left), daemon=True)

    def stop(signum: int, frame: Any) -> None:
        if _unwinding(code):  # this block's stop, or a nested block's, is on its way out
            return
        if not raised:
            resender.start()
        raised[:] = [SystemExit(code)]
        raise raised[0]

    hook = sys.unraisablehook

    def quiet(unraisable: Any) -> None:
        # a finalizer swallowed the stop: say nothing ("Exception ignored in ..." and a
        # traceback), and signal again at once, from a thread, so that the handler runs at
        # a line after the finalizer (raised here, it would be swallowed again)
        if unraisable.exc_value is not None and unraisable.exc_value in raised:
            soon = threading.Timer(0.02, _signal_unless, (left,))
            soon.daemon = True
            soon.start()
            return
        hook(unraisable)

    old = signal.signal(signal.SIGTERM, stop)
    sys.unraisablehook = quiet
    try:
        yield
    finally:
        left.set()
        if resender.ident is not None:
            resender.join()  # no signal of its own comes after the handler is restored
        sys.unraisablehook = hook
        signal.signal(signal.SIGTERM, old)
    if raised:  # the block ended as if no SIGTERM had come (every stop dropped): stop now
        raise SystemExit(code)


def _unwinding(code: int) -> bool:
    """Is a ``SystemExit(code)`` the exception being handled here, or in its ``__context__``
    chain?"""
    exc = sys.exc_info()[1]
    while exc is not None:
        if isinstance(exc, SystemExit) and exc.code == code:
            return True
        exc = exc.__context__
    return False


def _resend_until(left: threading.Event) -> None:
    """SIGTERM this process every :data:`RESEND_S` s until ``left`` is set."""
    while not left.wait(RESEND_S):
        os.kill(os.getpid(), signal.SIGTERM)


def _signal_unless(left: threading.Event) -> None:
    """SIGTERM this process, unless ``left`` is set (the block is left: no handler of its
    own would take the signal)."""
    if not left.is_set():
        os.kill(os.getpid(), signal.SIGTERM)
