"""Fixtures: the analytic example study copied into a fresh folder."""

from __future__ import annotations

import shutil
import tomllib
from pathlib import Path

import pytest

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "analytic" / "study.toml"


@pytest.fixture
def study_file(tmp_path: Path) -> Path:
    """A copy of examples/analytic/study.toml in tmp_path (its store lands there)."""
    dst = tmp_path / "study.toml"
    shutil.copy(EXAMPLE, dst)
    return dst


@pytest.fixture
def example_data() -> dict:
    """The analytic example study as a dict."""
    return tomllib.loads(EXAMPLE.read_text())
