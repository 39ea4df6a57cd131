"""External mode round trip: run sheets out, results in, the study goes on to the same end."""

from __future__ import annotations

import shutil

import pandas as pd
from typer.testing import CliRunner

from demcal.calibrate import calibrate, load_study
from demcal.cli import app
from demcal.execute.analytic import analytic_aor
from demcal.store import RunStore
from demcal.virtual import PARAMETERS


def _fill(sheet, options) -> None:
    """Do the runs 'externally' with the stand-in and fill the sheet's response columns."""
    frame = pd.read_csv(sheet)
    aor, outcome = [], []
    for _, row in frame.iterrows():
        params = {n: float(row[n]) for n in PARAMETERS if n in frame.columns}
        r = analytic_aor(params, int(row["seed"]), options)
        aor.append(r["aor_deg"])
        outcome.append(r["outcome"])
    frame["aor_deg"] = aor
    frame["outcome"] = outcome
    frame.to_csv(sheet, index=False)


def run_externally(study, fill, rounds: int = 10) -> list[tuple[str, int, str]]:
    """Calibrate ``study`` by run sheets: each stage's sheet written, ``fill(sheet)`` done
    'outside', imported, until the study ends; returns (stage, rows, the calibrate command's
    output) per sheet, in order."""
    cli, done = CliRunner(), []
    for _ in range(rounds):
        out = cli.invoke(app, ["calibrate", str(study), "--external", "--no-report"])
        assert out.exit_code == 0, out.output
        if "runs to do externally" not in out.output:
            return done
        stage = out.output.split(":")[0].strip()
        sheet = study.parent / f"runsheet_{stage}.csv"
        done.append((stage, len(pd.read_csv(sheet)), out.output))
        fill(sheet)
        out = cli.invoke(app, ["import", str(sheet), "--study", str(study)])
        assert out.exit_code == 0 and "stored" in out.output, out.output
    raise AssertionError(f"the study did not end in {rounds} sheets: {[d[:2] for d in done]}")


def test_external_round_trip_matches_internal(study_file, tmp_path):
    other = tmp_path / "internal"
    other.mkdir()
    shutil.copy(study_file, other / "study.toml")
    expected = calibrate(other / "study.toml")

    options = load_study(study_file).test.analytic
    sheets = run_externally(study_file, lambda sheet: _fill(sheet, options))
    assert [s[0] for s in sheets] == ["rangefind", "screening", "steepest", "rsm",
                                      "verification"]
    with RunStore(study_file.parent) as store:
        result = store.meta("result")
        assert store.count() == expected["n_runs"]
    assert result["optimum"] == expected["optimum"]
    assert result["verification"] == expected["verification"]


def test_import_refuses_a_foreign_or_bad_sheet(study_file):
    cli = CliRunner()
    res = cli.invoke(app, ["calibrate", str(study_file), "--external", "--no-report"])
    sheet = study_file.parent / "runsheet_rangefind.csv"
    frame = pd.read_csv(sheet)
    frame.loc[0, "pp.static_friction"] = 0.123  # edited parameters: key no longer matches
    frame.to_csv(sheet, index=False)
    res = cli.invoke(app, ["import", str(sheet), "--study", str(study_file)])
    assert res.exit_code == 2 and "row 2: key does not match" in res.output
    res = cli.invoke(app, ["calibrate", str(study_file), "--external", "--no-report"])
    frame = pd.read_csv(sheet)  # a fresh sheet
    frame["outcome"] = frame["outcome"].astype(object)
    frame.loc[0, "outcome"] = "heap"
    frame.to_csv(sheet, index=False)
    res = cli.invoke(app, ["import", str(sheet), "--study", str(study_file)])
    assert res.exit_code == 2 and "outcome must be one of pile, column" in res.output
