"""`demcal import` checks every row first and stores all or nothing, in one line on error."""

from __future__ import annotations

import pandas as pd
import pytest
from typer.testing import CliRunner

from demcal.calibrate import load_study
from demcal.cli import app
from demcal.execute.analytic import analytic_aor
from demcal.store import RunStore
from demcal.virtual import PARAMETERS


@pytest.fixture
def sheet(study_file):
    """The rangefind run sheet of the analytic study, filled by the stand-in."""
    res = CliRunner().invoke(app, ["calibrate", str(study_file), "--external", "--no-report"])
    assert res.exit_code == 0, res.output
    path = study_file.parent / "runsheet_rangefind.csv"
    frame = pd.read_csv(path, dtype={"outcome": object})
    options = load_study(study_file).test.analytic
    for i, row in frame.iterrows():
        params = {n: float(row[n]) for n in PARAMETERS if n in frame.columns}
        r = analytic_aor(params, int(row["seed"]), options)
        frame.loc[i, "aor_deg"] = r["aor_deg"]
        frame.loc[i, "outcome"] = r["outcome"]
    frame.to_csv(path, index=False)
    return path


def _import(sheet, study_file):
    return CliRunner().invoke(app, ["import", str(sheet), "--study", str(study_file)])


def _stored(study_file) -> int:
    with RunStore(study_file.parent, readonly=True) as store:
        return store.count()


def _refused(res) -> str:
    assert res.exit_code == 2, res.output
    assert res.exception is None or isinstance(res.exception, SystemExit), res.exception
    lines = res.output.strip().splitlines()
    assert len(lines) == 1, res.output
    return lines[0]


def test_a_bad_row_stores_nothing(sheet, study_file):
    frame = pd.read_csv(sheet, dtype={"outcome": object})
    frame.loc[len(frame) - 1, "outcome"] = "exploded"
    frame.to_csv(sheet, index=False)
    assert "outcome must be one of" in _refused(_import(sheet, study_file))
    assert _stored(study_file) == 0


def test_a_duplicated_run_is_refused(sheet, study_file):
    frame = pd.read_csv(sheet)
    pd.concat([frame, frame.iloc[[0]]]).to_csv(sheet, index=False)
    assert "the same run" in _refused(_import(sheet, study_file))
    assert _stored(study_file) == 0
    frame.to_csv(sheet, index=False)
    res = _import(sheet, study_file)
    assert res.exit_code == 0 and f"stored {len(frame)} runs" in res.output


@pytest.mark.parametrize("content", [b"", b"\x00\xff\xfe" * 100, b"key,stage\n",
                                     b'"unterminated\n1,2'])
def test_empty_binary_or_broken_sheets(tmp_path, sheet, study_file, content):
    bad = tmp_path / "bad.csv"
    bad.write_bytes(content)
    line = _refused(_import(bad, study_file))
    assert "run store" not in line
    assert _stored(study_file) == 0


def test_nan_point_is_one_line(sheet, study_file):
    frame = pd.read_csv(sheet)
    frame["point"] = frame["point"].astype(float)
    frame.loc[0, "point"] = float("nan")
    frame.to_csv(sheet, index=False)
    assert "point must be an integer" in _refused(_import(sheet, study_file))


def test_import_without_a_store_makes_none(tmp_path, study_file):
    bad = tmp_path / "sheet.csv"
    bad.write_text("key,stage\n")
    assert "--external" in _refused(_import(bad, study_file))
    assert not (study_file.parent / "demcal.sqlite").exists()
