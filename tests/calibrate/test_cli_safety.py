"""`demcal calibrate`: user text is printed as text, output paths are checked first."""

from __future__ import annotations

import json

import typer
from typer.testing import CliRunner

from demcal.cli import app
from demcal.cli._common import cli_errors
from demcal.errors import InputError
from demcal.store import STORE_NAME

NAME = "a[/]b [factors] [bold]x[/bold] [/red]"


def _rename(study_file, name):
    text = study_file.read_text().replace('name = "analytic stand-in"',
                                          f"name = {json.dumps(name)}", 1)
    study_file.write_text(text)


def test_study_name_with_markup_keeps_the_result(study_file, tmp_path):
    _rename(study_file, NAME)
    out = tmp_path / "result.json"
    res = CliRunner().invoke(app, ["calibrate", str(study_file), "--json", str(out),
                                   "--no-report"])
    assert res.exit_code == 0, res.output
    assert json.loads(out.read_text())["study"] == NAME
    assert "[factors]" in res.output and "[/]" in res.output
    # and again: a rerun reads the stored runs and prints the same
    res = CliRunner().invoke(app, ["calibrate", str(study_file), "--no-report"])
    assert res.exit_code == 0, res.output
    assert "(40 run now)" not in res.output


def test_error_handler_prints_brackets_as_text():
    @cli_errors
    def boom():
        raise InputError("bad [/x] value in [factors]\nsecond line")

    cmd = typer.Typer()
    cmd.command()(boom)
    res = CliRunner().invoke(cmd, [])
    assert res.exit_code == 2
    assert res.output.strip() == "error: bad [/x] value in [factors] second line"
    assert "Traceback" not in res.output


def _no_run_started(study_file):
    assert not (study_file.parent / STORE_NAME).exists()


def test_json_into_missing_folder_refused_before_any_run(study_file, tmp_path):
    res = CliRunner().invoke(app, ["calibrate", str(study_file), "--json",
                                   str(tmp_path / "nope" / "r.json")])
    assert res.exit_code == 2
    assert "--json" in res.output and "does not exist" in res.output
    assert len(res.output.strip().splitlines()) == 1
    _no_run_started(study_file)


def test_json_onto_a_directory_refused_before_any_run(study_file, tmp_path):
    (tmp_path / "adir").mkdir()
    res = CliRunner().invoke(app, ["calibrate", str(study_file), "--json",
                                   str(tmp_path / "adir")])
    assert res.exit_code == 2 and "is a directory" in res.output
    _no_run_started(study_file)


def test_report_folder_that_is_a_file_refused_before_any_run(study_file):
    (study_file.parent / "report").write_text("not a folder")
    res = CliRunner().invoke(app, ["calibrate", str(study_file)])
    assert res.exit_code == 2 and "report" in res.output
    _no_run_started(study_file)
    res = CliRunner().invoke(app, ["calibrate", str(study_file), "--no-report"])
    assert res.exit_code == 0, res.output


def test_failed_target_leaves_no_store_behind(study_file):
    text = study_file.read_text().replace("aor_deg = 40.0\nstd_deg = 1.0\nn = 5",
                                          'photos = ["missing.png"]')
    study_file.write_text(text)
    res = CliRunner().invoke(app, ["calibrate", str(study_file)])
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output
    _no_run_started(study_file)


def test_directory_as_study_file(tmp_path):
    res = CliRunner().invoke(app, ["calibrate", str(tmp_path)])
    assert res.exit_code == 2 and len(res.output.strip().splitlines()) == 1


def test_binary_study_file(tmp_path):
    path = tmp_path / "study.toml"
    path.write_bytes(bytes(range(256)) * 4)
    res = CliRunner().invoke(app, ["calibrate", str(path)])
    assert res.exit_code == 2, res.output
    assert len(res.output.strip().splitlines()) == 1
