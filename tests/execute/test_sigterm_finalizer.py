"""SIGTERM handled inside a finalizer still stops the block (execute.signals.sigterm_raises).

Python runs a signal handler at the next line of Python, which may be a ``__del__``'s; what a
finalizer raises is swallowed (reported as "Exception ignored in ..."), so the SystemExit of
SIGTERM was lost there and the command ran on: once in CI, a ``simulate`` killed while numba
compiled its kernels (it makes and drops many finalized objects) did not stop.
"""

from __future__ import annotations

import os
import signal
import sys

import pytest

from demcal.execute.signals import sigterm_raises

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")


class _SignalledInFinalizer:
    """An object whose finalizer sends SIGTERM: the handler runs (and raises) at the next line,
    inside ``__del__``."""

    def __del__(self) -> None:
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(10_000):
            pass


def test_a_sigterm_swallowed_by_a_finalizer_still_stops_the_block():
    before = sys.unraisablehook
    reached_end = False
    with pytest.raises(SystemExit) as stopped, sigterm_raises():
        _SignalledInFinalizer()  # dropped at once: its __del__ runs here
        for _ in range(10_000_000):  # ~0.3 s: the signal sent again lands here
            pass
        reached_end = True
    assert stopped.value.code == 143 and not reached_end
    assert sys.unraisablehook is before
