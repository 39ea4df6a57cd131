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


def test_sigterm_stops_a_study_as_ctrl_c_does(study_file):
    """SIGTERM (a batch scheduler's time limit) mid-stage: the study stops as an interrupted
    one (the finished runs counted and stored, exit 143), not killed where it stood (-15)."""
    text = study_file.read_text().replace("noise_deg = 0.3", "noise_deg = 0.3\ndelay_s = 0.05")
    study_file.write_text(text)
    cmd = [sys.executable, "-m", "demcal", "calibrate", str(study_file), "--workers", "1",
           "--no-report"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.1)
            try:
                with RunStore(study_file.parent) as store:
                    if store.count("screening") >= 3:
                        break
            except StoreError:  # not there yet, or caught between its creation and header
                continue
        proc.send_signal(signal.SIGTERM)
        out, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 143, out
    assert "terminated (SIGTERM)" in out and "finished runs are stored" in out, out
    with RunStore(study_file.parent) as store:
        assert store.count() >= 3
