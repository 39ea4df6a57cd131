"""Output paths are checked before the work: a folder given as a file is one line, nothing else."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from demcal.cli import app

CORN = Path(__file__).resolve().parents[1] / "examples" / "corn_stalk"


@pytest.mark.parametrize("args", [
    ["physical", str(CORN / "measurements.toml"), "--json"],
    ["analyze", str(CORN / "table7_bbd.csv"), "--response", "aor_deg", "--json"],
    ["optimize", str(CORN / "table7_bbd.csv"), "--response", "aor_deg", "--target", "44",
     "--json"],
])
def test_json_onto_a_directory_is_refused_first(tmp_path, args):
    res = CliRunner().invoke(app, [*args, str(tmp_path)])
    assert res.exit_code == 2, res.output
    assert res.output.strip().splitlines() == [
        f"error: --json: {tmp_path} is a directory; give a file name"]


def test_report_out_onto_a_file(tmp_path):
    (tmp_path / "f").write_text("x")
    res = CliRunner().invoke(app, ["report", str(tmp_path), "--out", str(tmp_path / "f")])
    assert res.exit_code == 2 and "is a file, not a folder" in res.output


def test_json_into_a_new_folder_is_made(tmp_path):
    out = tmp_path / "new" / "deeper" / "r.json"
    res = CliRunner().invoke(app, ["physical", str(CORN / "measurements.toml"), "--json",
                                   str(out)])
    assert res.exit_code == 0, res.output
    assert out.is_file()
