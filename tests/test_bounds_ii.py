"""Issue 38, classes 6-8: nothing unbounded inside the bounds (designs, logs, echoed values,
error lines), every input format parsed with a depth bound, and result files and templates
that stay inside their folders."""

from __future__ import annotations

import json
import os
import shutil
import tracemalloc
from pathlib import Path

import pytest
from typer.testing import CliRunner

from demcal import doe
from demcal.cli import app
from demcal.cli._common import MAX_LINE_CHARS, one_line
from demcal.errors import InputError, StoreError
from demcal.execute.engine_results import ResultUnreadable, read_positions, read_value
from demcal.execute.engine_spec import TemplateEngine, load_engine
from demcal.execute.template_engine import _tail
from demcal.virtual import PARAMETERS

ROOT = Path(__file__).resolve().parents[1]
DEEP = 100_000


# --- class 6: sizes ----------------------------------------------------------------------

def test_a_full_factorial_over_the_run_bound_is_refused_before_it_is_built(tmp_path):
    with pytest.raises(InputError, match=r"2\^\(20-0\) factorial has 1,048,576 runs"):
        doe.factorial(20)
    factors = tmp_path / "f.toml"
    factors.write_text("".join(f"[factors.f{i}]\nlow = 0\nhigh = 1\n" for i in range(20)))
    res = CliRunner().invoke(app, ["design", "factorial", "--factors", str(factors)])
    assert res.exit_code == 2 and "at most 100,000" in res.output, res.output


def test_the_engine_log_is_read_from_its_end(tmp_path):
    log = tmp_path / "engine.log"
    with open(log, "wb") as fh:  # 64 MB of (sparse) zeros, then the lines to quote
        fh.truncate(64 * 2**20)
        fh.seek(0, os.SEEK_END)
        fh.write(b"step 1\nstep 2\nexploded at step 3\n")
    tracemalloc.start()
    try:
        tail = _tail(log)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert tail.endswith("step 1 | step 2 | exploded at step 3")
    assert peak < 4 * 2**20, f"{peak:,} bytes to quote 3 lines"


def test_an_error_line_is_cut_to_a_screen_and_loses_its_escapes():
    line = one_line("x" * 10_000_000 + "\x1b]0;owned\x07\x1b[31m")
    assert len(line) < MAX_LINE_CHARS + 100 and "\x1b" not in line
    assert "\x1b" not in one_line("name \x1b[31mred\x9b")


def test_a_huge_engine_value_is_quoted_not_echoed(tmp_path):
    (tmp_path / "aor.json").write_text(json.dumps({"aor_deg": list(range(3_000_000))}))
    with pytest.raises(ResultUnreadable) as err:
        read_value(tmp_path, {"file": "aor.json", "key": "aor_deg"})
    assert len(str(err.value)) < 300
    extra = {"aor_deg": 31.0, "trace": list(range(100_000)), "ok": 1}
    (tmp_path / "aor.json").write_text(json.dumps(extra))
    read = read_value(tmp_path, {"file": "aor.json", "key": "aor_deg"})
    assert read["aor_deg"] == 31.0 and read["engine_values"]["ok"] == 1
    assert len(json.dumps(read["engine_values"])) < 70_000  # kept with the run, per run


def test_a_value_file_is_bounded_and_a_sparse_result_refused_before_parsing(tmp_path):
    (tmp_path / "aor.json").write_text(" " * (2 * 2**20) + "31.0")
    with pytest.raises(ResultUnreadable, match="larger than 1 MB"):
        read_value(tmp_path, {"file": "aor.json", "key": "aor_deg"})
    with open(tmp_path / "pile.csv", "wb") as fh:  # a sparse file: NUL bytes, no text
        fh.write(b"x,y,z,radius\n")
        fh.truncate(64 * 2**20)
    with pytest.raises(ResultUnreadable, match="NUL bytes"):
        read_positions(tmp_path, {"file": "pile.csv", "format": "csv", "columns": {
            "x": "x", "y": "y", "z": "z", "radius": "radius"}})


# --- class 7: depth ---------------------------------------------------------------------

def test_an_engines_deeply_nested_json_fails_that_run(tmp_path):
    (tmp_path / "aor.json").write_text("[" * DEEP + "]" * DEEP)
    with pytest.raises(ResultUnreadable, match="nested too deeply"):
        read_value(tmp_path, {"file": "aor.json", "key": "aor_deg"})


@pytest.mark.parametrize("args, name", [
    (["calibrate", "{f}", "--no-report"], "study.toml"),
    (["physical", "{f}"], "m.toml"),
    (["design", "bbd", "--factors", "{f}"], "f.toml"),
    (["simulate", "aor", "--material", "{f}"], "material.toml"),
])
def test_a_deeply_nested_toml_is_one_line(tmp_path, args, name):
    path = tmp_path / name
    path.write_text("x = " + "[" * DEEP + "]" * DEEP + "\n")
    res = CliRunner().invoke(app, [a.format(f=path) for a in args])
    assert res.exit_code == 2, res.output
    assert len(res.output.strip().splitlines()) == 1 and "Traceback" not in res.output


def test_a_deeply_nested_store_cell_is_a_damaged_store():
    from demcal.store import _loads

    with pytest.raises(StoreError, match="nested too deeply"):
        _loads("[" * DEEP + "]" * DEEP, "run 'x'")


# --- class 8: foreign files -------------------------------------------------------------

@pytest.mark.parametrize("name", ["/etc/passwd", "../../../../../../etc/passwd"])
def test_a_result_file_outside_the_run_folder_is_refused_by_the_study(name):
    with pytest.raises(ValueError, match="inside the run folder"):
        TemplateEngine.model_validate({"template": "t", "command": ["x"],
                                       "result": {"kind": "value", "file": name}})


def test_a_symlink_out_of_the_run_folder_is_not_read(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    (tmp_path / "secret.csv").write_text("x,y,z,radius\n0,0,0,1\n")
    (run / "pile.csv").symlink_to(tmp_path / "secret.csv")
    (run / "aor.txt").symlink_to("/etc/hostname")
    with pytest.raises(ResultUnreadable, match="outside the run folder"):
        read_positions(run, {"file": "pile.csv", "format": "csv", "columns": {
            "x": "x", "y": "y", "z": "z", "radius": "radius"}})
    with pytest.raises(ResultUnreadable, match="outside the run folder"):
        read_value(run, {"file": "aor.txt", "key": "aor_deg"})


def test_a_template_outside_the_study_folder_is_refused(tmp_path):
    study = tmp_path / "study"
    study.mkdir()
    shutil.copy(ROOT / "examples" / "stand_in_engine" / "input.txt.template", tmp_path / "t")
    spec = TemplateEngine.model_validate({"template": "../t", "command": ["x", "{input}"],
                                          "result": {"kind": "value", "file": "aor.txt"}})
    with pytest.raises(InputError, match="outside the study folder"):
        load_engine(spec, study, set(PARAMETERS))


def test_calibrate_workers_has_the_studys_upper_bound(tmp_path):
    res = CliRunner().invoke(app, ["calibrate", str(tmp_path / "study.toml"), "--workers",
                                   "100000"])
    assert res.exit_code == 2 and "less than or equal to 1024" in res.output, res.output


def test_a_positions_header_naming_a_column_twice_is_refused(tmp_path):
    (tmp_path / "pile.csv").write_text("x,x,y,z,radius\n0,1,0,0,0.01\n")
    with pytest.raises(ResultUnreadable, match="x named twice"):
        read_positions(tmp_path, {"file": "pile.csv", "format": "csv", "columns": {
            "x": "x", "y": "y", "z": "z", "radius": "radius"}})


def test_a_lone_minus_is_no_formula_in_a_csv_cell():
    from demcal.safety import csv_cell

    assert csv_cell("-") == "-" and csv_cell("-x") == "'-x"


def test_an_engine_number_with_an_underscore_is_no_number(tmp_path):
    (tmp_path / "aor.txt").write_text("3_0\n")
    with pytest.raises(ResultUnreadable, match="neither a number nor a JSON object"):
        read_value(tmp_path, {"file": "aor.txt", "key": "aor_deg"})
