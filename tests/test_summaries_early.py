"""The typed summaries of the stages before the response surface (:class:`RangeFind`,
:class:`Screening`, :class:`Steepest`) and of a designed stage's runs (:class:`DesignRun`):
the keys they store, in order, under their stored names, and what the stores of earlier
releases read back as. The fields have generic names (``value``, ``response``); the stored
keys keep the names of the release where the angle was the only response."""

from __future__ import annotations

import dataclasses
import gzip
import json
import shutil
import sqlite3
from pathlib import Path

import pytest

from demcal.summaries import (
    Anchor,
    AnchorRun,
    DesignRun,
    Effect,
    PathStep,
    RangeFind,
    ScanFactor,
    ScanPoint,
    Screening,
    Steepest,
)

DATA = Path(__file__).parent / "data"

#: stored keys, in order: renaming a field or its stored key must fail here
DESIGN_RUN_KEYS = ["point", "coded", "actual", "aor_deg", "outcome", "aor_runs_deg",
                   "aor_std_deg"]
RANGEFIND_KEYS = ["factors", "response_min_deg", "response_max_deg", "target_in_range",
                  "message"]
SCAN_FACTOR_KEYS = ["name", "symbol", "low", "high", "new_low", "new_high", "points", "reason"]
SCREENING_KEYS = ["design", "n_runs", "alpha", "factors", "dummies", "runs", "excluded_points",
                  "anova", "fit", "effects", "selected", "message"]
STEEPEST_KEYS = ["factors", "direction", "steps", "best_step", "centre", "levels", "message"]
STEP_KEYS = ["step", "actual", "aor_deg", "outcome", "relative_error_percent"]


def _old_store(tmp_path: Path) -> dict[str, str]:
    """The stage summaries (as stored text) of the store the release before several
    responses wrote for examples/analytic."""
    db = tmp_path / "old.sqlite"
    with gzip.open(DATA / "store_v1_analytic.sqlite.gz", "rb") as src, db.open("wb") as dst:
        shutil.copyfileobj(src, dst)
    con = sqlite3.connect(db)
    try:
        return dict(con.execute("SELECT name, summary_json FROM stages"))
    finally:
        con.close()


@pytest.mark.parametrize(("stage", "cls", "keys"), [
    ("rangefind", RangeFind, RANGEFIND_KEYS),
    ("screening", Screening, SCREENING_KEYS),
    ("steepest", Steepest, STEEPEST_KEYS),
])
def test_an_old_store_s_summaries_read_and_write_back_byte_for_byte(tmp_path, stage, cls, keys):
    text = _old_store(tmp_path)[stage]
    stored = json.loads(text)
    typed = cls.from_summary(stored)
    assert list(stored) == keys
    assert json.dumps(typed.to_summary()) == json.dumps(stored)


def test_the_old_store_s_values_read_as_the_generic_fields(tmp_path):
    summaries = {k: json.loads(v) for k, v in _old_store(tmp_path).items()}
    found = RangeFind.from_summary(summaries["rangefind"])
    raw = summaries["rangefind"]["factors"][0]
    assert list(raw) == SCAN_FACTOR_KEYS
    assert [p.response for p in found.factors[0].points] == [p["aor_deg"] for p in raw["points"]]
    assert found.response_min == summaries["rangefind"]["response_min_deg"]
    screening = Screening.from_summary(summaries["screening"])
    assert screening.ran and screening.names == [f.name for f in screening.factors or []]
    first = summaries["screening"]["runs"][0]
    assert list(first) == DESIGN_RUN_KEYS
    assert screening.runs[0].value == first["aor_deg"]  # type: ignore[index]
    assert screening.runs[0].replicates == first["aor_runs_deg"]  # type: ignore[index]
    assert all(isinstance(e, Effect) for e in screening.effects or [])
    path = Steepest.from_summary(summaries["steepest"])
    assert path.ran and list(summaries["steepest"]["steps"][0]) == STEP_KEYS
    assert [s.value for s in path.steps or []] == [
        s["aor_deg"] for s in summaries["steepest"]["steps"]]


def test_a_design_run_stores_its_replicates_only_where_known():
    run = DesignRun(point=3, coded={"a": 1.0}, actual={"a": 0.5}, value=31.0, outcome="pile",
                    replicates=[30.0, 32.0], replicate_std=1.41)
    assert list(run.to_summary()) == DESIGN_RUN_KEYS
    assert DesignRun.from_summary(run.to_summary()) == run
    one = dataclasses.replace(run, replicates=[31.0], replicate_std=None)
    assert one.to_summary()["aor_std_deg"] is None  # one replicate: no spread, key kept
    older = {k: v for k, v in run.to_summary().items() if k not in ("aor_runs_deg",
                                                                    "aor_std_deg")}
    assert DesignRun.from_summary(older).to_summary() == older  # a release without them


def test_a_path_with_several_responses_and_an_anchor_keeps_its_keys():
    steps = [PathStep(step=0, actual={"a": 0.2}, value=30.0, outcome="pile",
                      relative_error_percent=5.0, responses={"aor_deg": 30.0, "drum": None},
                      desirability=None)]
    anchor = Anchor(fidelity="standard", runs=[AnchorRun(step=0, actual={"a": 0.2}, value=31.0,
                                                         outcome="pile", path_value=30.0)],
                    crossing_step=None, centre_step=0.5, offset=1.0, message="m")
    path = Steepest(fidelity="small", factors=["a"], direction={"a": 1}, steps=steps,
                    best_step=0, centre={"a": 0.2}, levels={"a": [0.1, 0.2, 0.3]},
                    message="m", anchor=anchor, followed=["aor_deg", "drum"],
                    climb={"gradient": {"a": 1.0}})
    stored = path.to_summary()
    assert list(stored) == ["fidelity", *STEEPEST_KEYS, "anchor", "followed", "climb"]
    assert list(stored["steps"][0]) == [*STEP_KEYS, "responses", "desirability"]
    assert list(stored["anchor"]) == ["fidelity", "runs", "crossing_step", "centre_step",
                                      "offset_deg", "message"]
    assert list(stored["anchor"]["runs"][0]) == ["step", "actual", "aor_deg", "outcome",
                                                 "path_aor_deg"]
    assert Steepest.from_summary(json.loads(json.dumps(stored))) == path


def test_failed_and_disabled_stages_store_what_they_always_did():
    assert Steepest(error="no pile").to_summary() == {"error": "no pile"}
    failed = Screening(design="plackett_burman", n_runs=12, alpha=0.05, factors=[],
                       dummies=[], runs=[], excluded_points=[], error="cannot fit")
    assert list(failed.to_summary()) == [*SCREENING_KEYS[:7], "error"]
    assert not Screening(selected=["a"]).ran and not Steepest(levels={"a": [0, 1, 2]}).ran
    no_pile = RangeFind(factors=[ScanFactor(name="a", points=[ScanPoint(0.1, "column")])],
                        message="no pile formed in any scan")
    stored = no_pile.to_summary()
    assert list(stored) == RANGEFIND_KEYS and stored["response_min_deg"] is None
    assert not no_pile.factors[0].points[0].measured
    out = dataclasses.replace(no_pile, reach=[20.0, 60.0], error="out of reach").to_summary()
    assert list(out) == [*RANGEFIND_KEYS, "reach_deg", "error"]
