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
import time

import pytest

from demcal.execute.signals import RESEND_S, sigterm_raises

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")


class _SignalledInFinalizer:
    """An object whose finalizer sends SIGTERM: the handler runs (and raises) at the next line,
    inside ``__del__``."""

    def __del__(self) -> None:
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(10_000):
            pass


def _drop_a_stop() -> None:
    """SIGTERM this process and drop the SystemExit the handler raises, as C code that clears
    any error (``PyDict_GetItem`` calling a Python ``__eq__``) does."""
    try:
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(5.0)  # the handler raises here
    except SystemExit:
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


def test_a_sigterm_swallowed_by_any_code_still_stops_the_block():
    # C code that clears any error (PyDict_GetItem calling a Python __eq__, for one) drops the
    # SystemExit as this except does: a CI `simulate` killed while numba compiled ran to its end
    reached_end = False
    with pytest.raises(SystemExit) as stopped, sigterm_raises():
        _drop_a_stop()
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline:  # the signal sent again lands here
            time.sleep(0.01)
        reached_end = True
    assert stopped.value.code == 143 and not reached_end


def test_the_signals_sent_again_do_not_cut_a_clean_up_short():
    cleaned = False
    with pytest.raises(SystemExit) as stopped, sigterm_raises():
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(5.0)
        finally:  # a clean-up longer than several resends (a process group's grace period)
            deadline = time.monotonic() + 4 * RESEND_S
            while time.monotonic() < deadline:
                time.sleep(0.01)
            with sigterm_raises():  # a nested block (the CLI's around a pool's) stays quiet too
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(2 * RESEND_S)
            cleaned = True
    assert stopped.value.code == 143 and cleaned
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


def test_a_block_that_ends_before_the_signal_comes_again_still_stops():
    # the stop dropped and the block's work done at once: SIGTERM still ends it with 143
    reached_end = False
    with pytest.raises(SystemExit) as stopped, sigterm_raises():
        _drop_a_stop()
        reached_end = True
    assert stopped.value.code == 143 and reached_end
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


def test_a_block_without_sigterm_ends_as_it_would():
    with sigterm_raises():
        pass
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


def test_the_cli_says_a_stop_that_came_as_the_command_ended(monkeypatch, capsys):
    import demcal.cli
    import demcal.cli._stdout

    def a_command_that_drops_the_stop(standalone_mode: bool) -> int:
        _drop_a_stop()
        return 0

    monkeypatch.setattr(demcal.cli, "app", a_command_that_drops_the_stop)
    monkeypatch.setattr(demcal.cli._stdout, "survive_hangup", lambda: None)
    with pytest.raises(SystemExit) as stopped:
        demcal.cli.main()
    assert stopped.value.code == 143
    assert capsys.readouterr().err == "terminated (SIGTERM)\n"
