"""An external engine dies with the demcal process that started it, however that one ends.

An engine (an external engine through :mod:`demcal.execute.template_engine`, or LAMMPS through
:mod:`demcal.virtual.lammps_run`) runs in its own session, so Ctrl-C at the
terminal does not reach it and demcal can kill its whole process group. The price: when
demcal itself is killed with SIGKILL (``kill -9``, the OOM killer), nothing kills the engine;
before 2026-11-27 it ran on, reparented to init, holding its cores for hours, and a resumed
study ran beside it.

:func:`engine_watchdog` starts a tiny watchdog process beside each engine. It holds the read
end of a pipe whose only write end is held by demcal: when demcal ends by any means, the
kernel closes that end and the watchdog reads EOF. Unless demcal said ``done`` first (the
engine ended, or demcal killed it itself), the watchdog then ends the engine's process group
(SIGTERM; SIGKILL after :data:`GRACE_S`): every process the engine started, not only its
first (``PR_SET_PDEATHSIG`` would reach only that one). The watchdog runs in its own session,
so the signals of a terminal or of demcal's group do not end it first.

:func:`stop_leftover_engine` is the second line, for a resumed run: an engine still running
in the run folder that is about to be emptied (its watchdog was killed too) is ended first,
so a resume never runs beside it; :func:`note_engine` names it there (group id and start
time, so a reused pid is never taken for it). Linux only (``/proc``); elsewhere a no-op.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

__all__ = ["GRACE_S", "PID_FILE", "engine_watchdog", "kill_group", "note_engine",
           "stop_leftover_engine"]

#: seconds between the watchdog's SIGTERM and SIGKILL of an orphaned engine's group
GRACE_S = 5.0

_WATCHDOG = r"""
import os, signal, sys, time
for s in (signal.SIGINT, signal.SIGHUP, signal.SIGPIPE):
    signal.signal(s, signal.SIG_IGN)
pgid, grace = int(sys.argv[1]), float(sys.argv[2])
said = b""
while True:
    try:
        chunk = os.read(0, 64)
    except InterruptedError:
        continue
    if not chunk:
        break
    said += chunk
if b"done" not in said:
    def alive():
        try:
            os.killpg(pgid, 0)
            return True
        except OSError:
            return False
    try:
        os.killpg(pgid, signal.SIGTERM)
    except OSError:
        sys.exit(0)
    end = time.monotonic() + grace
    while alive() and time.monotonic() < end:
        time.sleep(0.05)
    try:
        os.killpg(pgid, signal.SIGKILL)
    except OSError:
        pass
"""


@contextlib.contextmanager
def engine_watchdog(pgid: int) -> Iterator[None]:
    """Keep a watchdog on the engine's process group ``pgid`` while the block runs.

    Leaving the block (normally or by an exception, after the engine was waited for or
    killed) tells the watchdog ``done``; demcal's death before that makes it kill the group.
    Where no watchdog can be started (no ``os.killpg``, no process), the block runs
    unguarded: a missing watchdog must not fail a run.
    """
    if not hasattr(os, "killpg"):  # pragma: no cover - not POSIX
        yield
        return
    read_end, write_end = os.pipe()
    try:
        dog = subprocess.Popen([sys.executable, "-c", _WATCHDOG, str(pgid), str(GRACE_S)],
                               stdin=read_end, stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL, start_new_session=True)
    except OSError:  # pragma: no cover - cannot start a process: run unguarded
        os.close(write_end)
        yield
        return
    finally:
        os.close(read_end)
    try:
        yield
    finally:
        with contextlib.suppress(OSError):
            os.write(write_end, b"done")
        os.close(write_end)
        with contextlib.suppress(subprocess.TimeoutExpired):
            dog.wait(timeout=10)


#: the engine's process-group id and start time, in its run folder while it runs
PID_FILE = "demcal-engine.pid"


def _start_time(pid: int) -> str | None:
    """Process ``pid``'s start time (clock ticks since boot; Linux), None when it is gone
    or a zombie. With the pid it names one process for good: a reused pid starts later."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()
    except (OSError, IndexError):
        return None
    if not fields or fields[0] == "Z":
        return None
    return fields[19] if len(fields) > 19 else None


def note_engine(run_dir: Path, pgid: int) -> None:
    """Write the engine's group id and start time into its run folder (for a resume)."""
    with contextlib.suppress(OSError):
        (run_dir / PID_FILE).write_text(f"{pgid} {_start_time(pgid) or ''}\n")


def stop_leftover_engine(run_dir: Path) -> bool:
    """End a killed study's engine still running in ``run_dir`` (its watchdog was killed
    too) before the folder is emptied for a new run; return whether one was running.

    The engine is named by :data:`PID_FILE` (group id and start time), so a reused pid is
    never touched.
    """
    try:
        pgid_text, _, started = (run_dir / PID_FILE).read_text().strip().partition(" ")
        pgid = int(pgid_text)
    except (OSError, ValueError):
        return False
    if pgid <= 1 or not started or _start_time(pgid) != started:
        return False
    for sig in (signal.SIGTERM, signal.SIGKILL):
        with contextlib.suppress(OSError):
            os.killpg(pgid, sig)
        end = time.monotonic() + GRACE_S
        while sig == signal.SIGTERM and _start_time(pgid) == started \
                and time.monotonic() < end:
            time.sleep(0.05)
    return True


def kill_group(proc: subprocess.Popen, grace_s: float = GRACE_S) -> None:
    """SIGTERM the engine's process group, SIGKILL it after ``grace_s`` s (and wait for it)."""
    killpg = getattr(os, "killpg", None)
    try:
        if killpg is not None:
            killpg(proc.pid, signal.SIGTERM)
        else:  # pragma: no cover - not POSIX
            proc.terminate()
        proc.wait(timeout=grace_s)
    except subprocess.TimeoutExpired:
        pass
    except ProcessLookupError:
        return
    with contextlib.suppress(ProcessLookupError, PermissionError):
        if killpg is not None:
            killpg(proc.pid, signal.SIGKILL)  # also children the engine started
        else:  # pragma: no cover
            proc.kill()
    proc.wait()
