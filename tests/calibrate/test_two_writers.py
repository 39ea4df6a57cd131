"""One writer per study: a second `demcal calibrate` is refused, `demcal report` reads."""

from __future__ import annotations

import os
import re
import subprocess
import sys

from typer.testing import CliRunner

from demcal.cli import app
from demcal.store import RunStore


def _calibrate(study_file):
    return subprocess.Popen([sys.executable, "-m", "demcal", "calibrate", str(study_file),
                             "--no-report", "--workers", "1"], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True,
                            env={**os.environ, "COLUMNS": "200"})


def test_two_calibrations_at_once_run_each_point_once(study_file):
    procs = [_calibrate(study_file), _calibrate(study_file)]
    outs = [p.communicate(timeout=300)[0] for p in procs]
    codes = [p.returncode for p in procs]
    assert "Traceback" not in "".join(outs)
    executed = 0
    for code, out in zip(codes, outs, strict=True):
        if code == 0:
            executed += int(re.search(r"\((\d+) run now\)", out).group(1))
        else:  # refused at once, naming the holder
            assert code == 2, out
            assert re.search(r"being written by pid \d+ on host", out), out
            assert len(out.strip().splitlines()) == 1, out
    assert 0 in codes
    assert executed == 40
    with RunStore(study_file.parent, readonly=True) as store:
        assert store.count() == 40 and store.lock_holder() is None


def test_calibrate_refused_while_locked_and_report_reads(study_file):
    from demcal.calibrate import calibrate

    calibrate(study_file)
    with RunStore(study_file.parent, lock=True):
        res = CliRunner().invoke(app, ["calibrate", str(study_file), "--no-report"])
        assert res.exit_code == 2
        assert f"pid {os.getpid()}" in res.output and "one writer per study" in res.output
        res = CliRunner().invoke(app, ["report", str(study_file.parent)])
        assert res.exit_code == 0, res.output
        res = CliRunner().invoke(app, ["import", str(study_file), "--study", str(study_file)])
        assert res.exit_code == 2 and "one writer per study" in res.output
    res = CliRunner().invoke(app, ["calibrate", str(study_file), "--no-report"])
    assert res.exit_code == 0, res.output


def test_break_lock_takes_a_foreign_hosts_lock(study_file):
    with RunStore(study_file.parent) as store:
        store.set_meta("writer", {"pid": 1, "host": "gone.example", "started": 0.0})
    res = CliRunner().invoke(app, ["calibrate", str(study_file), "--no-report"])
    assert res.exit_code == 2 and "--break-lock" in res.output
    res = CliRunner().invoke(app, ["calibrate", str(study_file), "--no-report",
                                   "--break-lock"])
    assert res.exit_code == 0, res.output
