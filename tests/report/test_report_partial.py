"""Failed, running, missing and malformed stages: the report still builds and says so."""

from __future__ import annotations

import json

from htmltables import read_tables, section

from demcal.report import build_report
from demcal.store import RunStore

ERROR = "too few runs for the quadratic model: it has 10 terms but only 8 runs have a response"


def test_failed_stage_is_shown_with_its_error_and_later_stages_missing(report_of):
    _, html, doc = report_of(stages=("rangefind", "screening", "steepest"),
                             fail={"rsm": ERROR})
    assert doc["stages"]["rsm"] == {"status": "failed", "error": ERROR, "n_runs": 15}
    assert doc["stages"]["optimize"]["status"] == "missing"
    assert doc["stages"]["verification"]["status"] == "missing"
    rsm = section(html, "rsm")
    assert "Stage failed:" in rsm and ERROR in rsm
    assert 'class="status failed"' in rsm and "t-rsm_anova" not in html
    for sid in ("optimize", "verification"):
        assert "Not run:" in section(html, sid)
    assert "t-screening_anova" in html and "t-steepest" in html  # earlier stages still there
    runs = read_tables(html)["t-rsm_runs"]  # the runs the failed stage stored are listed
    assert runs["columns"] == ["point", "replicate", "x3", "x4", "x8", "status", "outcome",
                               "AoR (deg)", "reason"]
    assert len(runs["rows"]) == 15 and runs["rows"][0][:5] == ["1", "0", "0.55", "0.09", "0.1"]
    stages = {r[0]: r for r in read_tables(html)["t-stages"]["rows"]}
    assert stages["Response surface"][1] == "failed" and stages["Response surface"][3] == ERROR
    assert stages["Verification"][1] == "missing"
    assert doc["problems"] == []


def test_only_some_stages_and_no_photos(report_of):
    study, html, doc = report_of(stages=("rangefind", "screening"), photos=False)
    assert [doc["stages"][s]["status"] for s in ("steepest", "rsm", "optimize",
                                                 "verification")] == ["missing"] * 4
    assert "figures/pareto.png" in doc["figures"]
    assert not any("photo_" in f or "comparison" in f or "surface" in f
                   for f in doc["figures"])
    assert "t-measurements" not in html  # a target given as a value has no photo table
    assert "t-target" in html
    assert (study / "report" / "report.html").is_file()


def test_running_stage_shows_its_partial_summary(report_of):
    _, html, doc = report_of(stages=("rangefind",), running=("screening",))
    scr = section(html, "screening")
    assert "In progress:" in scr and "t-screening_design" in scr
    assert doc["stages"]["screening"]["status"] == "running"


def test_malformed_summary_is_named_and_the_report_still_builds(report_of, tmp_path):
    study, _, _ = report_of()
    with RunStore(study) as store:
        rsm = store.stage("rsm").summary
        rsm["coefficients_coded"] = {"nonsense*term": 1.0}
        store.set_stage("rsm", "done", rsm)
    path = build_report(study, tmp_path / "again")
    html = path.read_text("utf-8")
    assert "could not be drawn" in section(html, "rsm")
    assert "t-rsm_anova" in html  # the tables are still there
    assert "nonsense" in html


def test_stage_disabled_in_the_study_is_shown_as_disabled(report_of):
    study, _, _ = report_of(stages=("screening",))
    with RunStore(study) as store:
        store.set_meta("study", {"name": "x", "stages": {"rangefind": {"enabled": False}}})
    html = build_report(study).read_text("utf-8")
    assert "Disabled:" in section(html, "rangefind")
    assert "Not run:" in section(html, "steepest")


def test_empty_store_builds_a_report_of_missing_stages(tmp_path):
    RunStore(tmp_path / "s").close()
    html = build_report(tmp_path / "s").read_text("utf-8")
    assert html.count("Not run:") == 6
    assert "No target" in html


def test_a_stage_that_cannot_be_shown_leaves_no_orphan_tables(report_of, tmp_path):
    study, _, _ = report_of()
    with RunStore(study) as store:
        store.set_stage("steepest", "done", {"factors": ["pp.static_friction"],
                                             "steps": [{"step": 1, "actual": "garbage"}]})
    path = build_report(study, tmp_path / "again")
    html = path.read_text("utf-8")
    doc = json.loads((path.parent / "report.json").read_text())
    assert "the stored summary could not be shown" in section(html, "steepest")
    assert "steepest" not in doc["tables"] and "t-steepest" not in html
    assert set(read_tables(html)) == {f"t-{k}" for k in doc["tables"]}
