"""Issue 38, class 8 (the terminal): user text (a study name, a file name) never reaches the
terminal with raw control characters; they are printed as escapes (``\\x1b``)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from rich.table import Table
from typer.testing import CliRunner

from demcal.cli import app
from demcal.cli._common import console, printable

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "analytic" / "study.toml"
EVIL = "evil\x1b]0;owned\x07\x1b[31mred\x9b\u202etxt.png"


def test_printable_escapes_every_terminal_control():
    out = printable(EVIL + "\nnext\tline")
    assert "\x1b" not in out and "\x07" not in out and "\x9b" not in out
    assert "\u202e" not in out and "\\x1b]0;owned" in out and "\nnext\tline" in out


def test_a_table_of_user_text_is_printed_escaped(capsys):
    table = Table(title=EVIL)
    table.add_column("photo")
    table.add_row(EVIL)
    console.print(table)
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\\x1b" in out


def test_calibrate_prints_a_study_name_escaped(tmp_path):
    study = tmp_path / "study.toml"
    shutil.copy(EXAMPLE, study)
    study.write_text(study.read_text().replace('name = "analytic stand-in"',
                                               f"name = {json.dumps(EVIL)}", 1))
    res = CliRunner().invoke(app, ["calibrate", str(study), "--no-report"])
    assert res.exit_code == 0, res.output
    assert "\x1b" not in res.output and "\u202e" not in res.output
    assert "evil\\x1b]0;owned" in res.output
