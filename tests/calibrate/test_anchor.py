"""The anchor: the response surface centred where the study's own test crosses the target
when the path of steepest ascent ran at a cheaper fidelity (demcal.calibrate.anchor)."""

from __future__ import annotations

import dataclasses

import pytest

import demcal.execute.tasks as tasks
from demcal.calibrate import anchor, calibrate
from demcal.execute.analytic import true_aor
from demcal.execute.tasks import TestDef

REAL_RUN_CHUNK = tasks.run_chunk


def test_crossing_interpolates_between_the_bracketing_steps():
    assert anchor.crossing({0: 30.0, 2: 50.0}, 40.0) == pytest.approx(1.0)
    assert anchor.crossing({3: 50.0, 1: 30.0}, 35.0) == pytest.approx(1.5)
    assert anchor.crossing({1: 30.0, 2: 35.0, 4: 55.0}, 45.0) == pytest.approx(3.0)
    assert anchor.crossing({0: 30.0, 2: 38.0}, 44.0) is None  # both below: no crossing
    assert anchor.crossing({2: 44.0}, 44.0) == 2.0
    # a falling path (descent) crosses as well
    assert anchor.crossing({0: 50.0, 1: 40.0}, 45.0) == pytest.approx(0.5)


def test_the_first_pair_is_the_best_step_s_neighbours_on_the_path():
    assert anchor.first_pair(1, 5) == (0, 2)
    assert anchor.first_pair(0, 5) == (0, 2)
    assert anchor.first_pair(4, 5) == (2, 4)
    assert anchor.first_pair(0, 2) == (0, 1)


def test_next_pair_follows_the_cheap_path_shifted_by_the_measured_offset():
    path_aor = [30.0, 44.0, 48.0, 58.0, 61.0]  # the cheap test; target 44
    # the study's test reads 6 deg lower: 24 at step 0, 42 at step 2 -> shifted path crosses
    # 44 between steps 2 (42) and 3 (52): anchor 3 (2 is done)
    assert anchor.next_pair(path_aor, {0: 24.0, 2: 42.0}, 44.0) == (3,)
    assert anchor.offset(path_aor, {0: 24.0, 2: 42.0}) == pytest.approx(-6.0)
    # the shifted path never reaches the target: the nearest end
    assert anchor.next_pair(path_aor, {0: 5.0, 2: 23.0}, 44.0) == (3, 4)
    assert anchor.next_pair(path_aor, {3: 58.0, 4: 61.0}, 44.0) == (1, 2)
    assert anchor.next_pair(path_aor, {}, 44.0) is None


def test_path_point_and_surface_centre():
    path = [{"a": 0.0, "b": 1.0}, {"a": 1.0, "b": 3.0}, {"a": 2.0, "b": 5.0}]
    assert anchor.path_point(path, 1.25) == pytest.approx({"a": 1.25, "b": 3.5})
    assert anchor.path_point(path, 2) == path[2]
    with pytest.raises(ValueError, match="outside the path"):
        anchor.path_point(path, 2.5)
    assert anchor.surface_centre(0.3, 5) == 1.0
    assert anchor.surface_centre(3.7, 5) == 3.0
    assert anchor.surface_centre(2.4, 5) == 2.4


class Shifted:
    """The analytic stand-in for every stage; the path's cheap test reads ``shift`` deg
    above the study's (as the small corn-stalk pile reads above the standard one)."""

    def __init__(self, analytic: dict, shift: float):
        self.test = TestDef(kind="analytic", analytic=analytic)
        self.shift = shift
        self.stages: dict[str, int] = {}

    def __call__(self, chunk, on_result=None):
        out = []
        for t in chunk:
            stage = t.key.partition(":")[0]
            self.stages[stage] = self.stages.get(stage, 0) + 1
            for r in REAL_RUN_CHUNK([dataclasses.replace(t, test=self.test)]):
                if stage == "steepest" and r.value("aor_deg") is not None:
                    r = dataclasses.replace(r, responses={
                        **r.responses, "aor_deg": r.value("aor_deg") + self.shift})
                out.append(r)
                if on_result is not None:
                    on_result(r)
        return out


@pytest.fixture
def offset_study(study_file, example_data):
    """The analytic example as a 'standard' study whose path runs at 'small'."""
    text = study_file.read_text()
    for old, new in (('kind = "analytic"', 'kind = "aor"\nfidelity = "standard"'),
                     ("[stages.steepest]\n", '[stages.steepest]\nfidelity = "small"\n')):
        assert old in text
        text = text.replace(old, new)
    study_file.write_text(text)
    return study_file, example_data["test"]["analytic"], example_data["target"]["aor_deg"]


def _centre_truth(path, analytic, res):
    """The study's (noise-free) angle at the response surface's centre."""
    from demcal.store import RunStore

    with RunStore(path.parent) as store:
        s = store.stage("steepest").summary
    full = dict(res["optimum_full"])
    full.update(s["centre"])
    return true_aor(full, analytic), s


@pytest.mark.parametrize("rounds", [0, 2])
def test_the_anchor_centres_the_surface_where_the_study_s_test_meets_the_target(
        offset_study, monkeypatch, rounds):
    path, analytic, target = offset_study
    path.write_text(path.read_text().replace(
        "[stages.steepest]\n", f"[stages.steepest]\nanchor_rounds = {rounds}\n"))
    stand_in = Shifted(analytic, shift=8.0)
    monkeypatch.setattr(tasks, "run_chunk", stand_in)
    res = calibrate(path)
    truth, summary = _centre_truth(path, analytic, res)
    if rounds == 0:  # the cheap path's best step: ~8 deg short of the target
        assert "anchor" not in summary and "steepest_anchor" not in stand_in.stages
        assert truth < target - 4.0
    else:
        a = summary["anchor"]
        assert a["fidelity"] == "standard" and a["crossing_step"] is not None
        assert a["offset_deg"] == pytest.approx(-8.0, abs=1.0)  # the stand-in's noise: 0.3
        assert 2 <= stand_in.stages["steepest_anchor"] <= 4
        assert summary["message"].startswith("the path's best step at its own test (small)")
        assert f"centred at step {a['centre_step']:.2f}" in summary["message"]
        assert abs(truth - target) < 2.0
        # resumed: nothing runs again, the same centre
        again = Shifted(analytic, shift=8.0)
        monkeypatch.setattr(tasks, "run_chunk", again)
        assert _centre_truth(path, analytic, calibrate(path))[1]["centre"] == summary["centre"]
        assert again.stages == {}
        _report_shows_the_anchor(path, a)


def _report_shows_the_anchor(path, anchored):
    """The report's steepest section has the anchor's runs as a table (and its text)."""
    import json

    from demcal.report import build_report

    html = build_report(path.parent)
    doc = json.loads((html.parent / "report.json").read_text("utf-8"))
    stages = doc["tables"]["stages"]
    path_row = next(r for r in stages["rows"] if r[0] == "Path of steepest ascent")
    assert path_row[stages["columns"].index("runs")] == 5 + len(anchored["runs"])
    t = doc["tables"]["steepest_anchor"]
    rows = [dict(zip(t["columns"], row, strict=True)) for row in t["rows"]]
    assert [r["step"] for r in rows] == [r["step"] for r in anchored["runs"]]
    assert [r["AoR, standard (deg)"] for r in rows] == pytest.approx(
        [r["aor_deg"] for r in anchored["runs"]])
    assert "crosses the target" in html.read_text("utf-8")
