"""Refinement rounds: a verification that disagrees with the surface moves the optimum.

The analytic stand-in plants a cubic in the rolling friction that no quadratic surface can
fit: the Box-Behnken's optimum misses the target by several degrees in truth. Each round
corrects the surface by the offset its piles measured; the truth at the final optimum must
lie closer to the target than at the first, on seeds no other round used.
"""

from __future__ import annotations

import tomllib
from dataclasses import replace

import pytest

from demcal.calibrate import calibrate
from demcal.calibrate.refine import needs_another_round
from demcal.calibrate.study import study_folder
from demcal.execute.analytic import true_aor
from demcal.store import RunStore
from demcal.summaries import Verification

CUBIC = 'cubic = { "pp.rolling_friction" = 20000.0 }'


@pytest.fixture
def curved_study(study_file):
    text = study_file.read_text()
    anchor = 'quadratic = { "pp.static_friction" = -10.0 }'
    assert anchor in text and "[stages.verification]\nn = 3\n" in text
    text = text.replace(anchor, anchor + "\n" + CUBIC)
    text = text.replace("[stages.verification]\nn = 3\n",
                        "[stages.verification]\nn = 3\nmax_rounds = 3\n")
    study_file.write_text(text)
    return study_file


def _truth(study_file, result, row):
    opts = tomllib.loads(study_file.read_text())["test"]["analytic"]
    return true_aor({**result["optimum_full"], **row["optimum"]}, opts)


def test_rounds_move_the_optimum_towards_the_truth_on_fresh_seeds(curved_study):
    res = calibrate(curved_study, workers=1)
    rounds = res["rounds"]
    assert len(rounds) == 3 and [r["round"] for r in rounds] == [1, 2, 3]
    first, last = rounds[0], rounds[-1]
    assert first["confirmed"] is False and first["target_in_interval"] is False
    # after an unconfirmed round the whole measured offset is applied
    assert rounds[1]["offset_weight"] == 1.0
    assert rounds[1]["surface_offset_deg"] == rounds[1]["measured_offset_deg"]
    miss = [abs(_truth(curved_study, res, r) - 40.0) for r in rounds]
    assert miss[0] > 4.0 and miss[2] < 0.5 * miss[0] and miss[1] < miss[0]
    # the study's answer is the last round's
    assert res["optimum"] == last["optimum"]
    assert res["verification"]["aor_mean_deg"] == last["aor_mean_deg"]
    # every round verified on its own seeds
    with RunStore(study_folder(curved_study), readonly=True) as store:
        seeds = sorted(r.seed for r in store.runs("verification"))
    assert seeds == [10_001, 10_002, 10_003, 20_001, 20_002, 20_003, 30_001, 30_002, 30_003]


def test_a_resumed_study_re_runs_no_round_even_on_another_machine(curved_study,
                                                                   another_machine):
    first, again = another_machine(curved_study)
    assert again["n_runs_executed"] == 0
    assert again["rounds"] == first["rounds"] and again["verification"] == first["verification"]


def test_one_round_by_default_and_none_when_the_verification_agrees(study_file, curved_study):
    text = curved_study.read_text().replace("max_rounds = 3\n", "")
    curved_study.write_text(text)
    res = calibrate(curved_study, workers=1)
    assert len(res["rounds"]) == 1 and res["rounds"][0]["confirmed"] is False
    # a straight surface: round 1 confirms and no second round runs despite the budget
    curved_study.write_text(text.replace(CUBIC + "\n", "").replace(
        "[stages.verification]\nn = 3\n", "[stages.verification]\nn = 3\nmax_rounds = 3\n"))
    res = calibrate(curved_study, workers=1)
    assert len(res["rounds"]) == 1 and res["rounds"][0]["confirmed"] is True


def test_a_verification_without_every_pile_is_no_reason_for_a_round():
    base = Verification(values=[40.0, 41.0, 39.0], n_piles=3, confirmed=False,
                        target_in_interval=True)
    assert needs_another_round(base)
    assert needs_another_round(replace(base, confirmed=True, target_in_interval=False))
    assert not needs_another_round(replace(base, confirmed=True))
    assert not needs_another_round(replace(base, confirmed=None, target_in_interval=None))
    assert not needs_another_round(replace(base, values=[40.0, None, 39.0], n_piles=2))
    agreed = replace(base, confirmed=True, relative_error_percent=2.5)
    assert needs_another_round(agreed, tolerance_percent=2.0)
    assert not needs_another_round(agreed, tolerance_percent=3.0)


def test_an_acceptance_tolerance_asks_for_rounds_and_the_result_says_if_it_was_met(
        curved_study):
    # a straight surface confirms round 1, but its mean misses the target by more than a
    # 0.01 % tolerance: a second round runs, and the result says whether it met it
    text = curved_study.read_text().replace(CUBIC + "\n", "").replace(
        "max_rounds = 3\n", "max_rounds = 2\ntolerance_percent = 0.01\n")
    curved_study.write_text(text)
    res = calibrate(curved_study, workers=1)
    first, v = res["rounds"][0], res["verification"]
    assert first["confirmed"] is True and first["within_tolerance"] is False
    assert len(res["rounds"]) == 2 and v["tolerance_percent"] == 0.01
    # round 1 kept the surface's promise: round 2 applies the piles' share of its offset
    second = res["rounds"][1]
    assert 0.0 < second["offset_weight"] < 1.0
    assert second["surface_offset_deg"] == pytest.approx(
        second["offset_weight"] * second["measured_offset_deg"])
    assert v["within_tolerance"] is (v["relative_error_percent"] <= 0.01)
    # 0.01 % of 40 deg is far inside the piles' interval: the command line says so
    from typer.testing import CliRunner

    from demcal.cli import app

    out = CliRunner().invoke(app, ["calibrate", str(curved_study), "--workers", "1",
                                   "--no-report"]).output
    assert "is narrower than the verification's 95 % interval" in " ".join(out.split())


def test_the_command_line_and_the_report_show_every_round(curved_study, tmp_path):
    from typer.testing import CliRunner

    from demcal.cli import app

    res = CliRunner().invoke(app, ["calibrate", str(curved_study), "--workers", "1",
                                   "--report"])
    assert res.exit_code == 0, res.output
    for k in (1, 2, 3):
        assert f"round {k}: " in res.output
    assert "corrected by the last offset" in res.output
    assert "so each aim moved the optimum within the noise" not in res.output  # adequate
    html = next(study_folder(curved_study).glob("report/*.html")).read_text()
    assert "Verification rounds" in html and "surface offset" in html
    card = (study_folder(curved_study) / "report" / "material.toml").read_text()
    assert "round = 3" in card and "surface_offset_deg" in card
