"""A quick-fidelity study ends by saying what its answer is worth (issue 42)."""

from __future__ import annotations

from pathlib import Path

import pytest

from demcal.calibrate.study import load_study
from demcal.cli import _common
from demcal.cli.calibrate_cmd import _is_quick_demonstration, _print_demonstration_worth
from demcal.summaries import CalibrationResult

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "corn_stalk"


@pytest.mark.parametrize(("name", "quick"), [("study.toml", True),
                                             ("study_small.toml", False),
                                             ("study_standard.toml", False),
                                             ("study_standard_lean.toml", False),
                                             ("study_lammps.toml", True),
                                             ("study_lammps_small.toml", False),
                                             ("study_lammps_standard.toml", False),
                                             ("study_bayes_standard.toml", False)])
def test_only_the_quick_study_is_a_demonstration(name, quick):
    assert _is_quick_demonstration(load_study(EXAMPLE / name)) is quick


def test_the_bayesian_study_marks_every_committed_doe_optimum():
    """study_bayes_standard.toml reads each committed result's optimum as a marked point, with
    a value for each of its three factors."""
    study = load_study(EXAMPLE / "study_bayes_standard.toml")
    marks = study.strategy.marks
    assert len(marks) == 6 and all(m.values for m in marks)
    assert {m.result.rsplit("/", 1)[-1] for m in marks} == {
        "result_standard.json", "result_standard_h100.json", "result_standard_lean.json",
        "result_standard_lean_seed2.json", "result_standard_lean_seed3.json",
        "result_small.json"}
    first = marks[0].values
    assert 0.35 <= first["pp.static_friction"] <= 0.75 and first["pp.surface_energy"] < 5e-4


def _printed(result: dict) -> str:
    """What the note prints for the result JSON ``result`` (read as the command reads it)."""
    with _common.console.capture() as cap:
        _print_demonstration_worth(CalibrationResult.from_summary(result))
    return " ".join(cap.get().split())


def test_the_note_gives_the_measured_interval_and_the_study_to_use():
    # the quick demonstration's verification as examples/corn_stalk/README.md records it
    result = {"verification": {"n": 3, "ci_low_deg": 31.9, "ci_high_deg": 53.8}}
    text = _printed(result)
    assert "this is a demonstration:" in text
    assert "95 % interval is 31.9-53.8 deg (+/- 10.9 deg on 3 piles)" in text
    assert "not a calibration to use" in text
    assert 'fidelity = "standard"' in text and "study_standard.toml" in text


def test_the_note_without_an_interval():
    text = _printed({"verification": {"n": 1, "ci_low_deg": None, "ci_high_deg": None}})
    assert "no interval" in text and "not a calibration to use" in text
