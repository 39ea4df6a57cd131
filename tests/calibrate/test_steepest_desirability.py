"""With several responses the steepest path climbs their overall desirability (issue 37).

The analytic stand-in plants two responses that pull the rolling friction apart: the angle
(target above the centre's angle) rises with every factor, so alone it climbs all three; the
drum angle rises steeply with the rolling friction and its lab value lies below the centre's,
so it wants less rolling friction, and with equal importance it outweighs the angle on that
factor. The path must go the overall desirability's way (less rolling friction), say which
responses it followed, and come closer to both lab values than the angle's own path.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from demcal import doe
from demcal.calibrate import calibrate
from demcal.execute.analytic import AnalyticOptions, true_aor, true_responses
from demcal.store import RunStore

A, B, C = "pp.static_friction", "pp.rolling_friction", "pw.static_friction"
FACTORS = {A: ("x3", 0.2, 1.0), B: ("x4", 0.0, 0.4), C: ("x6", 0.3, 0.8)}
ANALYTIC = {
    "base_deg": 30.0, "centre": {A: 0.6, B: 0.2, C: 0.55}, "noise_deg": 0.1,
    "linear": {A: 15.0, B: 25.0, C: 2.0},
    "responses": {"drum_deg": {"base": 35.0, "noise": 0.1, "linear": {B: 60.0}}},
}
#: where the lab values were made (noise-free): the angle 33 deg needs more of everything,
#: the drum angle 29 deg less rolling friction
PLANTED = {A: 0.9667, B: 0.1, C: 0.55}


def _value(v) -> str:
    if isinstance(v, dict):
        return "{ " + ", ".join(f'"{k}" = {_value(x)}' for k, x in v.items()) + " }"
    return repr(v)


def _study(folder: Path, *, drum: bool) -> Path:
    opts = AnalyticOptions(**ANALYTIC)
    lines = ['name = "the path follows D"', "seed = 5", "replicates = 1", "",
             "[material]", 'preset = "corn_stalk"', "",
             "[target]", f"aor_deg = {true_aor(PLANTED, opts)!r}", "std_deg = 0.5", "n = 5", ""]
    for name, (sym, lo, hi) in FACTORS.items():
        lines += ["[[factors]]", f'name = "{name}"', f'symbol = "{sym}"', f"low = {lo}",
                  f"high = {hi}", ""]
    if drum:
        lines += ["[[responses]]", 'name = "drum_deg"',
                  f"target = {true_responses(PLANTED, opts)['drum_deg']!r}", "std = 0.5",
                  "n = 5", ""]
    lines += ["[test]", 'kind = "analytic"', "", "[test.analytic]"]
    lines += [f"{k} = {_value(v)}" for k, v in ANALYTIC.items()]
    lines += ["", "[stages.rangefind]", "enabled = false", "",
              "[stages.screening]", "runs = 8", "min_factors = 3", "",
              "[stages.steepest]", "steps = 5", "anchor_rounds = 0", "",
              "[stages.optimize]", "n_starts = 8", "", "[stages.verification]", "n = 3", "",
              "[executor]", "workers = 1", ""]
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "study.toml"
    path.write_text("\n".join(lines))
    return path


@pytest.fixture(scope="module")
def both(tmp_path_factory) -> dict[str, dict]:
    root = tmp_path_factory.mktemp("climb")
    out = {}
    for name, drum in (("angle", False), ("two", True)):
        result = calibrate(_study(root / name, drum=drum), workers=1)
        with RunStore(root / name) as store:  # the stage's own summary (the result's is less)
            out[name] = {**result, "steepest": store.stage("steepest").summary}
    return out


def test_the_angle_alone_and_the_desirability_point_different_ways(both) -> None:
    angle = both["angle"]["steepest"]
    two = both["two"]["steepest"]
    # alone the angle climbs every factor (its target lies above the centre's angle)
    assert angle["direction"] == {A: 1, B: 1, C: 1}
    assert "followed" not in angle and "climb" not in angle
    # with the drum angle the path lowers the rolling friction: D's way, not the angle's
    assert two["followed"] == ["aor_deg", "drum_deg"]
    assert two["climb"]["gradient"][B] < 0 < two["climb"]["gradient"][A]
    assert two["direction"][B] == -1 and two["direction"][A] == 1
    alone = two["climb"]["alone"]
    assert alone["aor_deg"][B] == 1 and alone["drum_deg"][B] == -1


def test_the_path_s_steps_carry_every_response_and_d(both) -> None:
    two = both["two"]["steepest"]
    assert both["two"]["stages"]["steepest"]["followed"] == two["followed"]  # the result's
    steps = two["steps"]
    assert all(set(s["responses"]) == {"aor_deg", "drum_deg"} for s in steps)
    d = [s["desirability"] for s in steps]
    best = two["best_step"]
    # the best step is the last before the measured D falls (or the path's end)
    assert all(d[i] <= d[i + 1] for i in range(best))
    assert best == len(d) - 1 or d[best + 1] < d[best]
    assert d[best] > 0.5


def test_the_desirability_path_centres_the_surface_nearer_both_lab_values(both) -> None:
    """The angle's path centres the response surface where the angle is hit, with the drum
    angle far off; the desirability's path where both are near."""
    opts = AnalyticOptions(**ANALYTIC)
    want = true_responses(PLANTED, opts)["drum_deg"]
    drum_at = {}
    for name, r in both.items():
        centre = {n: v[1] for n, v in r["stages"]["steepest"]["levels"].items()}
        assert set(centre) == set(FACTORS)
        drum_at[name] = true_responses(centre, opts)["drum_deg"]
    assert abs(drum_at["two"] - want) < abs(drum_at["angle"] - want)


def test_climb_is_d_where_d_is_positive_else_minus_the_shortfall() -> None:
    goals = [doe.ResponseGoal("a", "target", 0.0, 10.0, target=5.0),
             doe.ResponseGoal("b", "maximize", 0.0, 1.0, importance=1)]
    y = np.array([[5.0, 1.0], [2.5, 0.25], [12.0, 0.5], [-2.0, -1.0]])
    d = doe.overall_desirability([[1.0, 1.0], [0.5, 0.25], [0.0, 0.5], [0.0, 0.0]], [3, 1])
    got = doe.climb(goals, y)
    np.testing.assert_allclose(got[:2], d[:2])
    assert got[2] == pytest.approx(-0.2)  # 2 above the window of 10
    assert got[3] == pytest.approx(-(0.2 + 1.0))


def test_the_report_shows_what_the_path_climbed(both) -> None:
    from demcal.report.tables import steepest_table
    from demcal.summaries import Steepest

    table = steepest_table(Steepest.from_summary(both["two"]["steepest"]), {})
    assert {"drum_deg", "D"} <= set(table.frame.columns)
    angle = steepest_table(Steepest.from_summary(both["angle"]["steepest"]), {})
    assert "D" not in angle.frame.columns
