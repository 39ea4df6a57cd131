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


@pytest.fixture
def another_machine(monkeypatch):
    """``resume(study_file)``: the study run, then resumed on "another machine" (its BLAS and
    numpy move the optimizer's answers in the 9th digit: every solution scaled by 1 + 1e-9;
    it stays so for the rest of the test); returns both results."""
    import demcal.doe as doe_pkg
    from demcal.calibrate import calibrate

    real = doe_pkg.optimize_target

    def perturbed(*args, **kwargs):
        res = real(*args, **kwargs)
        for sol in res.solutions:
            sol.actual.update({k: v * (1 + 1e-9) for k, v in sol.actual.items()})
        return res

    def resume(study_file: Path) -> tuple[dict, dict]:
        first = calibrate(study_file, workers=1)
        monkeypatch.setattr(doe_pkg, "optimize_target", perturbed)
        return first, calibrate(study_file, workers=1)

    return resume
