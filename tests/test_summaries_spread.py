"""Where else the target is met (demcal.summaries.spread): the optimize stage's distinct
settings that reach the target, and how far apart they lie, read from a committed study."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from demcal.summaries import CalibrationResult, Candidate, Optimum
from demcal.summaries.spread import MIN_FRACTION, TargetSpread, target_spread

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _small() -> tuple[Optimum, dict[str, list[float]]]:
    """The small corn-stalk study's optimize stage (4 candidates, every one at 44.116 deg)
    and the ranges its steepest path gave the surface."""
    stored = json.loads((EXAMPLES / "corn_stalk" / "result_small.json").read_text())
    opt = Optimum(target=stored["target_aor_deg"], candidates=[
        Candidate(params=c["params"], predicted_lead=c["predicted_aor_deg"],
                  desirability=c["desirability"])
        for c in stored["stages"]["optimize"]["candidates"]])
    steepest = stored["stages"]["steepest"]
    levels = steepest["levels"]
    return opt, {n: [lv[0], lv[2]] for n, lv in levels.items()}


def test_the_small_study_s_target_is_met_far_apart():
    opt, ranges = _small()
    spread = target_spread(opt, ranges)
    assert spread is not None and spread.n == 4 and spread.target == 44.116
    by_name = {s.name: s for s in spread.spans}
    mu_s = by_name["pp.static_friction"]
    assert (round(mu_s.low, 4), round(mu_s.high, 4)) == (0.4721, 0.65)
    lo, hi = ranges["pp.static_friction"]
    assert mu_s.fraction == pytest.approx((0.65 - mu_s.low) / (hi - lo), rel=1e-3)
    assert all(s.fraction >= MIN_FRACTION for s in spread.spans)
    assert [s.fraction for s in spread.spans] == sorted((s.fraction for s in spread.spans),
                                                        reverse=True)
    line = spread.line()
    assert line.startswith("the target is met along a surface, not at one point: 4 distinct "
                           "settings predict 44.12 deg, with ")
    assert "pp.static_friction 0.4721-0.65 (" in line and "pin down" in line


def test_one_setting_a_missed_target_or_a_posterior_says_nothing():
    opt, ranges = _small()
    one = Optimum(target=opt.target, candidates=opt.candidates[:1])
    assert target_spread(one, ranges) is None
    missed = Optimum(target=opt.target, candidates=[
        Candidate(params=c.params, desirability=0.5) for c in opt.candidates])
    assert target_spread(missed, ranges) is None
    bayes = Optimum(target=opt.target, candidates=[  # the posterior's: no desirability
        Candidate(params=c.params) for c in opt.candidates])
    assert target_spread(bayes, ranges) is None
    wide = {n: [lo - 100.0, hi + 100.0] for n, (lo, hi) in ranges.items()}
    assert target_spread(opt, wide) is None  # every span a sliver of its range


def test_the_spread_is_a_typed_part_of_the_result():
    opt, ranges = _small()
    spread = target_spread(opt, ranges)
    assert TargetSpread.from_summary(spread.to_summary()) == spread
    stored = json.loads((EXAMPLES / "corn_stalk" / "result_small.json").read_text())
    assert "target_spread" not in stored  # an older result: none, and none written back
    assert "target_spread" not in CalibrationResult.from_summary(stored).to_summary()
    with_it = {**stored, "target_spread": spread.to_summary()}
    back = CalibrationResult.from_summary(with_it)
    assert back.spread == spread and back.to_summary()["target_spread"] == spread.to_summary()
