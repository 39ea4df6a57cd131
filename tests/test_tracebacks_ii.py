"""Issue 38, class 7 (the other tracebacks): a hook that raises fails its run (typed), a
factor range beyond its physical bound, an unknown name in [test.analytic] and a 1e308 cell
in a run sheet are one line each."""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from demcal.cli import app
from demcal.execute.engine_spec import TemplateEngine, load_engine
from demcal.execute.tasks import RunTask, TestDef
from demcal.execute.template_engine import run_template
from demcal.virtual import PARAMETERS, preset_parameters

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "analytic" / "study.toml"


@pytest.mark.parametrize("body, what", [
    ("    raise ValueError('hook exploded')\n", "raised ValueError: hook exploded"),
    ("    import sys; sys.exit(3)\n", "raised SystemExit: 3"),
])
def test_a_hook_that_raises_fails_its_run_typed(tmp_path, body, what):
    (tmp_path / "hook.py").write_text("def fill(params, seed, run_dir):\n" + body)
    shutil.copy(ROOT / "examples" / "stand_in_engine" / "input.txt.template",
                tmp_path / "t.in.template")
    spec = TemplateEngine.model_validate({
        "template": "t.in.template", "hook": "hook.py:fill", "command": ["true"],
        "result": {"kind": "value", "file": "aor.txt"}})
    engine = load_engine(spec, tmp_path, set(PARAMETERS))
    engine = engine.for_runs(tmp_path / "runs")
    task = RunTask("screening:0123456789abcdef", TestDef(kind="template", external=engine),
                   preset_parameters("corn_stalk"), 1)
    res = run_template(task)
    assert res.outcome == "engine_error" and what in res.reason, res


def _study(tmp_path: Path, old: str, new: str) -> Path:
    text = EXAMPLE.read_text()
    assert old in text
    path = tmp_path / "study.toml"
    path.write_text(text.replace(old, new, 1))
    return path


@pytest.mark.parametrize("old, new, what", [
    ("low = 0.2\nhigh = 1.0", "low = 0.2\nhigh = 1e308", "pp.static_friction must be in [0, 10]"),
    ('linear = { "pp.static_friction"', 'linear = { "pp.nope" = 1.0, "pp.static_friction"',
     "unknown parameter 'pp.nope'"),
])
def test_a_study_number_or_name_out_of_range_is_one_line(tmp_path, old, new, what):
    study = _study(tmp_path, old, new)
    res = CliRunner().invoke(app, ["calibrate", str(study), "--no-report"])
    assert res.exit_code == 2, res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and what in lines[0], lines
    assert not (tmp_path / "demcal.sqlite").exists()


def test_simulate_refuses_a_friction_of_1e308():
    res = CliRunner().invoke(app, ["simulate", "aor", "--set", "pp.static_friction=1e308"])
    assert res.exit_code == 2 and "must be in [0, 10]" in res.output, res.output


def test_analyze_with_a_1e308_cell_is_one_line(tmp_path):
    with open(ROOT / "examples" / "corn_stalk" / "table7_bbd.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    rows[0]["x3"] = "1e308"
    sheet = tmp_path / "huge.csv"
    with open(sheet, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    res = CliRunner().invoke(app, ["analyze", str(sheet), "--response", "aor_deg"])
    assert res.exit_code == 2, res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and "cannot be fitted" in lines[0], lines
