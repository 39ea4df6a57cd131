"""`demcal store status`: where a study stands, read from its store (demcal.report.progress)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from demcal.calibrate import calibrate
from demcal.cli import app
from demcal.report.progress import study_progress
from demcal.store import LOCK_KEY, RunStore

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "analytic" / "study.toml"


def _status(target: Path) -> tuple[int, str]:
    res = CliRunner().invoke(app, ["store", "status", str(target)], terminal_width=200)
    return res.exit_code, " ".join(res.output.split())


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("status")
    shutil.copy(EXAMPLE, folder / "study.toml")
    calibrate(folder / "study.toml")
    return folder / "study.toml"


def test_a_finished_study_s_stages_runs_and_result(finished):
    with RunStore(finished.parent, readonly=True) as store:
        prog = study_progress(store)
        n_ver = store.count(stage="verification")
    assert [s.name for s in prog.stages] == ["rangefind", "screening", "steepest", "rsm",
                                             "optimize", "verification"]
    assert all(s.status == "done" for s in prog.stages)
    assert sum(s.runs for s in prog.stages) == prog.runs and prog.writer is None
    assert len(prog.verification) == n_ver and prog.result.startswith("verified ")
    code, text = _status(finished)
    assert code == 0, text
    assert f"{prog.runs} runs stored" in text and "writer: none" in text
    assert "rsm │ done │ 15 │ adequate" in text
    assert f"result: {prog.result}" in text
    assert "so far" not in text  # the verification is done: its line is the stage's


def test_a_writer_that_is_gone_and_a_running_stage_are_said(finished, tmp_path):
    shutil.copytree(finished.parent, tmp_path / "s")
    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    import socket

    with RunStore(tmp_path / "s") as store:  # a calibration killed in its verification
        store.set_meta(LOCK_KEY, {"pid": int(gone.stdout), "host": socket.gethostname(),
                                  "started": 1.7e9, "command": "demcal calibrate study.toml"})
        store.set_stage("verification", "running", {})
        store.set_meta("result", None)
    code, text = _status(tmp_path / "s" / "study.toml")
    assert code == 0, text
    assert f"writer: pid {int(gone.stdout)} on host" in text
    assert "no longer running: a resume takes its lock over" in text
    assert "verification │ running │" in text and "verification pile(s) so far" in text
    assert "result: not yet" in text


def test_no_store_is_one_line(tmp_path):
    code, text = _status(tmp_path / "study.toml")
    assert code == 2 and text.startswith("error: ") and "no run store" in text


def test_a_bayesian_stage_says_its_verdict():
    import json

    from demcal.report.progress import _found

    stored = json.loads((EXAMPLE.parents[1] / "corn_stalk" / "result_bayes_standard.json")
                        .read_text())
    assert _found("bayes", stored) == "not identifiable: 2 ridge(s) left"
    assert _found("bayes", {}) == ""  # a stage not finished: nothing to say
