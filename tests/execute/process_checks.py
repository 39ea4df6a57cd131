"""Process checks shared by the orphan tests (Linux /proc)."""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

PID_FILES = ("engine.pid", "child.pid")


def alive(pid: int) -> bool:
    """Is ``pid`` running (a zombie does not count)?"""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rpartition(")")[2].split()[0] != "Z"


def wait_gone(pids: list[int], timeout: float = 20.0) -> bool:
    """True once none of ``pids`` runs, False if one still does after ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if not any(alive(p) for p in pids):
            return True
        time.sleep(0.1)
    return False


def kill_9_when_started(worker: subprocess.Popen, folder: Path) -> list[int]:
    """Wait until the engine under ``worker`` wrote its and its child's pid into ``folder``
    (``engine.pid``, ``child.pid``), give its watchdog a moment, SIGKILL ``worker`` (no
    clean-up code of demcal runs) and return the two pids."""
    deadline = time.monotonic() + 60
    while not all((folder / f).is_file() and (folder / f).read_text().strip()
                  for f in PID_FILES):
        assert time.monotonic() < deadline and worker.poll() is None
        time.sleep(0.05)
    pids = [int((folder / f).read_text()) for f in PID_FILES]
    time.sleep(0.5)  # the watchdog is up
    worker.kill()
    worker.wait()
    return pids
