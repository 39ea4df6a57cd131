"""Issue 38, class 4: a response that does not vary is a clear statement (the rsm stage
stored as failed, one line, exit 3; `analyze` and `optimize` say so), never a traceback."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
from typer.testing import CliRunner

from demcal import doe
from demcal.calibrate.stages import no_variation
from demcal.cli import app
from demcal.store import RunStore

CORN = Path(__file__).resolve().parents[2] / "examples" / "corn_stalk"


def _flat_sheet(tmp_path: Path) -> Path:
    with open(CORN / "table7_bbd.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        r["aor_deg"] = "30.0"
    out = tmp_path / "flat.csv"
    with open(out, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return out


def test_a_constant_response_ends_the_study_with_one_line(study_file):
    text = study_file.read_text()
    for key in ("linear", "quadratic"):
        text = "\n".join(f"{key} = {{}}" if ln.startswith(f"{key} = ") else ln
                         for ln in text.splitlines())
    study_file.write_text(text.replace("noise_deg = 0.3", "noise_deg = 0.0"))
    res = CliRunner().invoke(app, ["calibrate", str(study_file), "--no-report"])
    assert res.exit_code == 3, res.output
    last = res.output.strip().splitlines()[-1]
    assert last.startswith("failed: screening:") and "does not vary" in last, res.output
    store = RunStore(study_file.parent, readonly=True)
    try:
        assert store.stage("screening").status == "failed"  # the report can say it
    finally:
        store.close()


def test_the_doe_model_of_a_constant_response_has_no_division_by_zero():
    space = doe.as_factor_space({"a": (0.0, 1.0), "b": (0.0, 1.0), "c": (0.0, 1.0)})
    design = doe.box_behnken(space, center_points=3, randomize=False)
    model = doe.fit(design, np.full(design.n_runs, 30.0), model="quadratic")
    assert math.isnan(model.f_value) and math.isnan(model.f_pvalue)
    model.anova()  # no ZeroDivisionError
    assert no_variation(np.full(5, 30.0)) is not None
    assert "not finite" in no_variation(np.array([1e308, -1e308, 1.0]))
    assert no_variation(np.array([30.0, 31.0, np.nan])) is None


def test_analyze_and_optimize_say_a_flat_response(tmp_path):
    sheet = _flat_sheet(tmp_path)
    res = CliRunner().invoke(app, ["analyze", str(sheet), "--response", "aor_deg"])
    assert res.exit_code == 0, res.output
    assert "does not vary" in res.output
    res = CliRunner().invoke(app, ["optimize", str(sheet), "--response", "aor_deg",
                                   "--target", "44"])
    assert res.exit_code == 0, res.output
    assert "unreachable" in res.output and "predicted to give" not in res.output


def test_a_screening_of_a_flat_response_has_no_division_warning():
    space = doe.as_factor_space({"a": (0.0, 1.0), "b": (0.0, 1.0), "c": (0.0, 1.0)})
    design = doe.plackett_burman(space, n_runs=8, randomize=False)
    rs = doe.fit(design, np.full(design.n_runs, 30.0), model="linear")
    eff = rs.effects()  # warnings are errors under pytest: no divide-by-zero warning
    assert np.isnan(eff["f"]).all()


def test_a_constant_response_at_the_surface_stores_its_design_rows(study_file):
    """Straight to the response surface: the failed stage stores its design and every run's
    row (plain JSON, readable back), so the report can show what was run."""
    from demcal.summaries import Surface

    text = study_file.read_text()
    for key in ("linear", "quadratic"):
        text = "\n".join(f"{key} = {{}}" if ln.startswith(f"{key} = ") else ln
                         for ln in text.splitlines())
    text = text.replace("noise_deg = 0.3", "noise_deg = 0.0")
    for stage in ("rangefind", "screening", "steepest"):
        text = text.replace(f"[stages.{stage}]\n", f"[stages.{stage}]\nenabled = false\n")
    study_file.write_text(text)
    res = CliRunner().invoke(app, ["calibrate", str(study_file), "--no-report"])
    assert res.exit_code == 3, res.output
    assert res.output.strip().splitlines()[-1].startswith("failed: rsm:"), res.output
    store = RunStore(study_file.parent, readonly=True)
    try:
        stage = store.stage("rsm")
    finally:
        store.close()
    assert stage.status == "failed" and "does not vary" in stage.summary["error"]
    runs = Surface.from_summary(stage.summary).runs
    piles = [r for r in runs if r.outcome == "pile"]
    assert piles and all(r.value == 30.0 and r.replicates == [30.0] for r in piles)
    assert all(r.value is None for r in runs if r.outcome != "pile")  # the columns
