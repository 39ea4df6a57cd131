"""Fixtures: the paper's study in a real RunStore, and its report built once per process."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from paper_store import build_paper_store

from demcal.report import build_report


@pytest.fixture(scope="session")
def paper_report(tmp_path_factory) -> dict:
    """The full paper study and its report: paths, HTML text and report.json.

    Built once per test process (a report draws ~17 figures, several seconds) and shared by
    every module that only reads it: a test that changes the study builds its own.
    """
    study = build_paper_store(tmp_path_factory.mktemp("paper") / "study")
    html_path = build_report(study)
    return {"study": study, "html_path": html_path, "html": html_path.read_text("utf-8"),
            "json": json.loads((html_path.parent / "report.json").read_text("utf-8"))}


@pytest.fixture()
def report_of(tmp_path):
    """Build a study with build_paper_store(**kw) and its report; return (study, html, json)."""

    def make(**kw) -> tuple[Path, str, dict]:
        study = build_paper_store(tmp_path / "study", **kw)
        path = build_report(study)
        return study, path.read_text("utf-8"), json.loads(
            (path.parent / "report.json").read_text("utf-8"))

    return make
