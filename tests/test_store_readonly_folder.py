"""Issue 38, class 9: `demcal report` reads a healthy store in a read-only folder (an
archived study) instead of calling it damaged, and creates no file there."""

from __future__ import annotations

import os
import shutil
import subprocess
from contextlib import contextmanager

import pytest

from demcal.store import STORE_NAME, RunRecord, RunStore


@contextmanager
def _read_only(folder):
    """``folder`` read-only for this process (root ignores permissions: chattr +i)."""
    if os.geteuid() == 0:
        if shutil.which("chattr") is None or subprocess.run(
                ["chattr", "+i", str(folder)], capture_output=True).returncode != 0:
            pytest.skip("chattr +i is not available here")
        try:
            yield
        finally:
            subprocess.run(["chattr", "-i", str(folder)], check=True)
    else:
        os.chmod(folder, 0o555)
        try:
            yield
        finally:
            os.chmod(folder, 0o755)


def test_a_store_in_a_read_only_folder_is_read(tmp_path):
    folder = tmp_path / "study"
    with RunStore(folder) as store:
        for i in range(3):
            store.record_run(RunRecord(key=f"screening:{i}", stage="screening", point=i,
                                       replicate=0, params={"pp.static_friction": 0.5},
                                       seed=i, status="done", outcome="pile",
                                       responses={"aor_deg": 40.0},
                                       result={}))
    before = sorted(p.name for p in folder.iterdir())
    assert before == [STORE_NAME]  # a closed store leaves no side file
    with _read_only(folder):
        with RunStore(folder, readonly=True) as store:
            assert store.count() == 3
        assert sorted(p.name for p in folder.iterdir()) == before
