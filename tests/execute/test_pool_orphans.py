"""A local pool's workers do not outlive a killed study: SIGKILL of the parent (the kernel
kills them: PR_SET_PDEATHSIG) and SIGTERM (it unwinds like Ctrl-C and terminates the pool)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from process_checks import wait_gone

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="Linux /proc")

SCRIPT = textwrap.dedent("""
    from demcal.execute.local import run_local
    from demcal.execute.tasks import RunTask, TestDef

    test = TestDef(kind="analytic", analytic={"delay_s": 30.0})
    chunks = [[RunTask(f"s:{i}", test, {"pp.static_friction": 0.5}, i)] for i in range(4)]
    run_local(chunks, lambda r: None, workers=2)
""")


def _children(pid: int) -> list[int]:
    """Live (not zombie) processes whose parent is ``pid``."""
    out = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        state, ppid = stat.rpartition(")")[2].split()[:2]
        if int(ppid) == pid and state != "Z":
            out.append(int(entry.name))
    return out


def _start() -> tuple[subprocess.Popen, list[int]]:
    proc = subprocess.Popen([sys.executable, "-c", SCRIPT], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    workers: list[int] = []
    while time.monotonic() < deadline and len(workers) < 2:
        time.sleep(0.2)
        # the spawn pool's workers (and its resource tracker) are the parent's children
        workers = [c for c in _children(proc.pid)
                   if "spawn_main" in Path(f"/proc/{c}/cmdline").read_bytes().decode(
                       errors="replace")]
    assert len(workers) == 2, "the pool did not start"
    time.sleep(2.0)  # the workers are inside their 30 s runs
    return proc, workers


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_killing_the_parent_stops_its_workers(sig):
    proc, workers = _start()
    try:
        proc.send_signal(sig)
        proc.wait(20)
        assert wait_gone(workers, timeout=10.0), \
            f"workers {workers} outlived a parent killed by {sig!r}"
        if sig == signal.SIGTERM:
            assert proc.returncode == 128 + signal.SIGTERM  # unwound, not cut off
    finally:
        for p in [proc.pid, *workers]:
            try:
                os.kill(p, signal.SIGKILL)
            except ProcessLookupError:
                pass
