"""Issue 38, class 1: an output path that is one of the command's own inputs (the study
file, its run store, a photo, a measurements file) is refused before any run, in one line."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from PIL import Image
from typer.testing import CliRunner

from demcal.cli import app
from demcal.store import STORE_NAME

CORN = Path(__file__).resolve().parents[2] / "examples" / "corn_stalk"


def _refused(res, what: str) -> None:
    assert res.exit_code == 2, res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: --") and what in lines[0], lines


@pytest.mark.parametrize("name, what", [
    (STORE_NAME, "run store"),
    (STORE_NAME + "-wal", "side file"),
    ("study.toml", "the study file"),
])
def test_calibrate_json_onto_its_own_store_or_study_is_refused(study_file, name, what):
    store = study_file.parent / STORE_NAME
    before = study_file.read_bytes()
    res = CliRunner().invoke(app, ["calibrate", str(study_file), "--json",
                                   str(study_file.parent / name), "--no-report"])
    _refused(res, what)
    assert study_file.read_bytes() == before
    assert not store.exists()  # refused before the store was opened: no run


def test_calibrate_json_through_a_symlink_onto_the_study_is_refused(study_file, tmp_path):
    link = tmp_path / "elsewhere.json"
    link.symlink_to(study_file)
    _refused(CliRunner().invoke(app, ["calibrate", str(study_file), "--json", str(link),
                                      "--no-report"]), "the study file")


def test_measure_plot_onto_the_photo_is_refused(tmp_path):
    photo = tmp_path / "pile.png"
    Image.new("L", (40, 30), 200).save(photo)
    before = photo.read_bytes()
    _refused(CliRunner().invoke(app, ["measure", str(photo), "--plot", str(photo)]),
             "an input photo")
    assert photo.read_bytes() == before


def test_physical_json_onto_its_measurements_is_refused(tmp_path):
    m = tmp_path / "m.toml"
    shutil.copy(CORN / "measurements.toml", m)
    _refused(CliRunner().invoke(app, ["physical", str(m), "--json", str(m)]),
             "the measurements file")


def test_analyze_json_onto_the_run_sheet_is_refused(tmp_path):
    runs = tmp_path / "runs.csv"
    shutil.copy(CORN / "table7_bbd.csv", runs)
    _refused(CliRunner().invoke(app, ["analyze", str(runs), "--response", "aor_deg",
                                      "--json", str(runs)]), "the run sheet")


def test_two_outputs_onto_one_file_are_refused(tmp_path):
    photo = tmp_path / "pile.png"
    Image.new("L", (40, 30), 200).save(photo)
    out = tmp_path / "same.out"
    res = CliRunner().invoke(app, ["measure", str(photo), "--csv", str(out), "--json",
                                   str(out)])
    assert res.exit_code == 2 and "name the same file" in res.output, res.output


def test_salvage_out_onto_the_store_is_refused(study_file):
    store = study_file.parent / STORE_NAME
    store.write_bytes(b"x" * 10)
    _refused(CliRunner().invoke(app, ["store", "salvage", str(study_file.parent), "--out",
                                      str(store)]), "run store")
    assert store.read_bytes() == b"x" * 10


def test_measure_plot_dir_onto_another_input_photo_is_refused(tmp_path):
    a, b = tmp_path / "pile.png", tmp_path / "pile_aor.png"
    for p in (a, b):
        Image.new("L", (40, 30), 200).save(p)
    before = b.read_bytes()
    _refused(CliRunner().invoke(app, ["measure", str(a), str(b), "--plot-dir",
                                      str(tmp_path)]), "an input photo")
    assert b.read_bytes() == before
