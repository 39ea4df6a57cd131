"""The report reads only images the study wrote, writes safe file names and CSV cells."""

from __future__ import annotations

import json

from paper_store import build_paper_store
from typer.testing import CliRunner

from demcal.cli import app
from demcal.report import build_report
from demcal.safety import csv_cell, safe_filename
from demcal.store import RunStore


def _edit_meta(study, key, change):
    with RunStore(study) as store:
        value = store.meta(key)
        change(value)
        store.set_meta(key, value)


def test_report_does_not_read_files_outside_the_study(tmp_path):
    study = build_paper_store(tmp_path / "study")
    secret = tmp_path / "secret.txt"
    secret.write_text("root:x:0:0:secret\n")
    not_png = study / "fake.png"
    not_png.write_text("root:x:0:0:not an image\n")

    def point_away(target):
        target["photos"][0]["figure"] = str(secret)
        target["photos"][1]["figure"] = "../secret.txt"
        target["photos"][2]["figure"] = str(not_png)

    _edit_meta(study, "target", point_away)
    html = build_report(study)
    doc = json.loads((html.parent / "report.json").read_text())
    assert "root:x" not in html.read_text()
    for png in (html.parent / "figures").iterdir():
        assert b"root:x" not in png.read_bytes()
    assert sum("outside the study folder" in p for p in doc["problems"]) == 2
    assert any("not a PNG or JPEG" in p for p in doc["problems"])
    res = CliRunner().invoke(app, ["report", str(study)])
    assert res.exit_code == 3 and "problem(s)" in res.output
    assert "Traceback" not in res.output


def test_symbols_with_slashes_and_formulas(tmp_path, paper_report):
    study = build_paper_store(tmp_path / "study")
    evil = {"x3": "=cmd|' /C calc'!A0", "x4": "a/b", "x8": "../x8"}

    def rename(factors):
        for f in factors:
            f["symbol"] = evil.get(f["symbol"], f["symbol"])

    _edit_meta(study, "factors", rename)
    html = build_report(study)
    doc = json.loads((html.parent / "report.json").read_text())
    assert doc["problems"] == []
    n_clean = len(paper_report["json"]["figures"])  # the same study, its own symbols
    assert len(doc["figures"]) == n_clean
    assert any("surface" in f for f in doc["figures"])
    assert all((html.parent / f).is_file() for f in doc["figures"])
    assert not list(tmp_path.glob("**/x8*.png"))  # nothing outside figures/
    for csv in (html.parent / "tables").glob("*.csv"):
        for line in csv.read_text().splitlines():
            for cell in line.split(","):
                assert not cell.lstrip('"').startswith("="), (csv.name, line)
    texts = "".join(c.read_text() for c in (html.parent / "tables").glob("*.csv"))
    assert "'=cmd|" in texts


def test_helpers():
    assert csv_cell("=1+2") == "'=1+2" and csv_cell("@SUM(A1)") == "'@SUM(A1)"
    assert csv_cell("-1.5") == "-1.5" and csv_cell(-1.5) == -1.5 and csv_cell("x") == "x"
    assert safe_filename("../a/b c") == "a_b_c" and safe_filename("..") == "_"


def test_report_refuses_empty_and_damaged_stores_untouched(tmp_path):
    store = tmp_path / "demcal.sqlite"
    store.touch()
    res = CliRunner().invoke(app, ["report", str(tmp_path)])
    assert res.exit_code == 2 and "empty file" in res.output
    assert len(res.output.strip().splitlines()) == 1
    assert store.stat().st_size == 0 and not (tmp_path / "report").exists()
    store.write_bytes(b"SQLite format 3\x00" + b"\xff" * 5000)
    res = CliRunner().invoke(app, ["report", str(tmp_path)])
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output and len(res.output.strip().splitlines()) == 1
    assert store.read_bytes() == b"SQLite format 3\x00" + b"\xff" * 5000
