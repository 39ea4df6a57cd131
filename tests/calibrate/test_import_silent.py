"""Issue 38, class 9: `demcal import` says what it does with a row; a typed 'nan' angle or
an angle beside a no-pile outcome is refused, never skipped or dropped in silence."""

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
    frame = pd.read_csv(path, dtype={"outcome": object, "aor_deg": object})
    options = load_study(study_file).test.analytic
    for i, row in frame.iterrows():
        params = {n: float(row[n]) for n in PARAMETERS if n in frame.columns}
        r = analytic_aor(params, int(row["seed"]), options)
        frame.loc[i, "aor_deg"] = "" if r["aor_deg"] is None else str(r["aor_deg"])
        frame.loc[i, "outcome"] = r["outcome"]
    frame.to_csv(path, index=False)
    return path


def _stored(study_file) -> int:
    with RunStore(study_file.parent, readonly=True) as store:
        return store.count()


@pytest.mark.parametrize("angle, outcome, what", [
    ("nan", "", "aor_deg must be in (0, 90) for a pile; got nan"),
    ("NA", "", "aor_deg must be a number; got 'NA'"),
    ("31.0", "column", "aor_deg 31.0 given for a run whose outcome is 'column'"),
])
def test_a_row_that_would_be_skipped_or_dropped_is_refused(sheet, study_file, angle,
                                                           outcome, what):
    frame = pd.read_csv(sheet, dtype=object, keep_default_na=False)
    frame.loc[0, "aor_deg"] = angle
    frame.loc[0, "outcome"] = outcome
    frame.to_csv(sheet, index=False)
    res = CliRunner().invoke(app, ["import", str(sheet), "--study", str(study_file)])
    assert res.exit_code == 2, res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and what in lines[0], lines
    assert _stored(study_file) == 0


def test_an_empty_row_is_still_not_done_yet(sheet, study_file):
    frame = pd.read_csv(sheet, dtype=object, keep_default_na=False)
    frame.loc[0, "aor_deg"] = ""
    frame.loc[0, "outcome"] = ""
    frame.to_csv(sheet, index=False)
    res = CliRunner().invoke(app, ["import", str(sheet), "--study", str(study_file)])
    assert res.exit_code == 0, res.output
    assert _stored(study_file) == len(frame) - 1


def test_a_column_named_twice_is_refused_not_half_read(sheet, study_file):
    # pandas would read the second 'aor_deg' as 'aor_deg.1' and import the first in silence
    text = sheet.read_text(encoding="utf-8").splitlines()
    text[0] = text[0].replace("outcome", "aor_deg", 1)
    sheet.write_text("\n".join(text) + "\n", encoding="utf-8")
    res = CliRunner().invoke(app, ["import", str(sheet), "--study", str(study_file)])
    assert res.exit_code == 2, res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and "the column 'aor_deg' appears twice" in lines[0], lines
    assert _stored(study_file) == 0
