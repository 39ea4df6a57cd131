"""Issue 38, class 9: silent cases say what they do. A reused store's foreign runs are not
passed off as this study's; a factor range whose levels overflow is refused, not written as
a sheet of inf."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from demcal.cli import app
from demcal.store import RunRecord, RunStore


def test_a_reused_stores_other_runs_are_named(study_file, tmp_path):
    out = tmp_path / "r.json"
    res = CliRunner().invoke(app, ["calibrate", str(study_file), "--no-report"])
    assert res.exit_code == 0, res.output
    with RunStore(study_file.parent) as store:  # another study's runs in the same store
        for i in range(7):
            store.record_run(RunRecord(key=f"other:{i}", stage="screening", point=i,
                                       replicate=0, params={"pp.static_friction": 0.1 * i},
                                       seed=i, status="done", outcome="pile",
                                       responses={"aor_deg": 33.0},
                                       result={}))
    res = CliRunner().invoke(app, ["calibrate", str(study_file), "--no-report", "--json",
                                   str(out)])
    assert res.exit_code == 0, res.output
    result = json.loads(out.read_text())
    assert result["n_runs"] == result["n_runs_used"] + 7
    assert "7 of them not used by this study's stages" in " ".join(res.output.split())


def test_a_design_range_of_1e308_is_refused_not_written_as_inf(tmp_path):
    factors = tmp_path / "f.toml"
    factors.write_text("[factors.a]\nlow = -1e308\nhigh = 1e308\n[factors.b]\nlow = 0\n"
                       "high = 1\n[factors.c]\nlow = 0\nhigh = 1\n")
    out = tmp_path / "sheet.csv"
    res = CliRunner().invoke(app, ["design", "bbd", "--factors", str(factors), "--out",
                                   str(out)])
    assert res.exit_code == 2, res.output
    assert "low and high must lie within" in res.output and not out.exists()
