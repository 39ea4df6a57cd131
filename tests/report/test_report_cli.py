"""``demcal report STUDY_DIR [--out DIR]``."""

from __future__ import annotations

import json

from paper_store import build_paper_store
from typer.testing import CliRunner

from demcal.cli import app


def test_report_command_writes_the_report(tmp_path):
    study = build_paper_store(tmp_path / "study", stages=("rangefind", "screening"),
                              fail={"steepest": "no step reached the target"})
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["report", str(study), "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert str(out / "report.html") in res.output.replace("\n", "")
    assert "no step reached the target" in res.output
    doc = json.loads((out / "report.json").read_text())
    assert doc["stages"]["steepest"]["status"] == "failed"
    assert not (study / "report").exists()


def test_report_command_without_a_store_is_an_input_error(tmp_path):
    res = CliRunner().invoke(app, ["report", str(tmp_path / "nowhere")])
    assert res.exit_code == 2
    assert "no run store demcal.sqlite" in res.output
