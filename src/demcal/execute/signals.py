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

__all__ = ["die_with_parent", "sigterm_raises"]

#: prctl option: the signal this process gets when its parent thread exits (Linux)
PR_SET_PDEATHSIG = 1


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
    the block runs unchanged), so ``finally``/``except BaseException`` clean-ups run."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    code = 128 + signal.SIGTERM

    def stop(signum: int, frame: Any) -> None:
        raise SystemExit(code)

    hook = sys.unraisablehook

    def again(unraisable: Any) -> None:
        # the handler runs at the next line of Python, which may be a finalizer's (__del__,
        # many of them while numba compiles): Python swallows what a finalizer raises, and
        # the command would run on. Signal again from a thread, so that the handler runs
        # at a line after the finalizer (raised here, it would be swallowed again).
        if isinstance(unraisable.exc_value, SystemExit) and unraisable.exc_value.code == code:
            resend = threading.Timer(0.02, os.kill, (os.getpid(), signal.SIGTERM))
            resend.daemon = True
            resend.start()
            return
        hook(unraisable)

    old = signal.signal(signal.SIGTERM, stop)
    sys.unraisablehook = again
    try:
        yield
    finally:
        sys.unraisablehook = hook
        signal.signal(signal.SIGTERM, old)
