"""A `demcal calibrate` process killed (SIGKILL) in the middle of a stage and restarted:
nothing finished is lost and every run is done exactly once."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time

from demcal.store import RunStore, StoreError


def test_sigkill_mid_stage_then_resume(study_file):
    text = study_file.read_text().replace("noise_deg = 0.3", "noise_deg = 0.3\ndelay_s = 0.05")
    study_file.write_text(text)
    cmd = [sys.executable, "-m", "demcal", "calibrate", str(study_file), "--workers", "1",
           "--no-report"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        killed_at = 0
        while time.monotonic() < deadline:
            time.sleep(0.1)
            if (study_file.parent / "demcal.sqlite").exists():
                try:
                    store = RunStore(study_file.parent)
                except StoreError:  # caught between the file's creation and its header
                    continue
                with store:
                    if store.count("screening") >= 3:
                        proc.send_signal(signal.SIGKILL)
                        proc.wait(30)
                        killed_at = store.count()
                        break
        assert proc.returncode == -signal.SIGKILL
    finally:
        if proc.poll() is None:
            proc.kill()
    with RunStore(study_file.parent) as store:
        stored = store.count()
        assert stored >= killed_at >= 8 and store.stage("screening").status == "running"
        keys = {r.key for r in store.runs()}
    res = subprocess.run([*cmd, "--json", str(study_file.parent / "r.json")], timeout=300,
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    out = json.loads((study_file.parent / "r.json").read_text())
    assert out["n_runs"] == 40
    assert out["n_runs_executed"] == 40 - stored  # the stored runs were not run again
    with RunStore(study_file.parent) as store:
        assert keys <= {r.key for r in store.runs()}
        assert store.count() == 40
