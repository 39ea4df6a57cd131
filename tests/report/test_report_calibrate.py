"""The report of a real `demcal calibrate` study (analytic stand-in): the writer's store."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from htmltables import read_tables, section

from demcal.calibrate import calibrate
from demcal.errors import StudyError
from demcal.report import build_report

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "analytic" / "study.toml"


@pytest.mark.slow
def test_report_of_the_analytic_study(tmp_path):
    study = tmp_path / "study.toml"
    shutil.copy(EXAMPLE, study)
    calibrate(study)
    path = build_report(tmp_path, tmp_path / "rep")
    doc = json.loads((path.parent / "report.json").read_text())
    assert doc["problems"] == []
    assert all(s["status"] == "done" for s in doc["stages"].values())
    tables = read_tables(path.read_text("utf-8"))
    ver = doc["summaries"]["verification"]
    row = tables["t-verification_summary"]["rows"][0]
    assert float(row[1]) == pytest.approx(ver["aor_mean_deg"], rel=6e-5)
    assert any(f.startswith("figures/surface_") for f in doc["figures"])


@pytest.mark.slow
def test_report_of_a_study_whose_screening_failed(tmp_path):
    study = tmp_path / "study.toml"
    text = EXAMPLE.read_text().replace("[stages.rangefind]",
                                       "[stages.rangefind]\nenabled = false")
    study.write_text(text)
    with pytest.raises(StudyError):
        calibrate(study)
    path = build_report(tmp_path)
    doc = json.loads((path.parent / "report.json").read_text())
    assert doc["stages"]["screening"]["status"] == "failed"
    assert doc["stages"]["rangefind"]["status"] == "disabled"
    assert doc["problems"] == []
    html = path.read_text("utf-8")
    scr = section(html, "screening")
    assert "Stage failed:" in scr and "excluded" in scr
    assert "Disabled:" in section(html, "rangefind")
    excluded = read_tables(html)["t-excluded_runs"]["rows"]
    assert sum(r[0] == "screening" for r in excluded) == 6
