"""The typed optimize summary (:class:`demcal.summaries.Optimum`): the keys each of its three
producers stores, in order, and what stores of earlier releases read back as."""

from __future__ import annotations

import gzip
import json
import shutil
import sqlite3
from pathlib import Path

from demcal.summaries import Candidate, Goal, Optimum, ResponsesOptimum

DATA = Path(__file__).parent / "data"

#: The keys each producer's optimize summary stores, in order. The result JSON, the report,
#: the material card and old stores read these names: renaming a field must fail here.
#: The angle's response surface (demcal.calibrate.stages.optimize), round 1:
SURFACE_KEYS = ["target_aor_deg", "candidates", "chosen", "predicted_aor_deg", "classifier",
                "opts"]
#: ... a refinement round's adds (demcal.calibrate.refine):
ROUND_KEYS = ["round", "surface_offset_deg", "offset_from_rounds", "measured_offset_deg",
              "offset_weight", "rounds"]
#: several responses (demcal.calibrate.several.optimize_summary):
SEVERAL_KEYS = [*SURFACE_KEYS, "responses"]
RESPONSES_KEYS = ["goals", "desirability", "reachable", "unmet"]
GOAL_KEYS = ["name", "goal", "low", "high", "target", "weight", "importance"]
#: the Bayesian strategy (demcal.calibrate.bayes_strategy), in the order it always wrote:
POSTERIOR_KEYS = ["target_aor_deg", "chosen", "predicted_aor_deg", "candidates", "opts",
                  "source"]
#: each candidate: the surface's, several responses' and the posterior's
CANDIDATE_KEYS = ["params", "predicted_aor_deg", "pi_low_deg", "pi_high_deg", "p_pile",
                  "desirability"]
SEVERAL_CANDIDATE_KEYS = [*CANDIDATE_KEYS, "predicted", "individual"]
POSTERIOR_CANDIDATE_KEYS = CANDIDATE_KEYS[:-1]

X = {"pp.static_friction": 0.61, "pp.rolling_friction": 0.2}
OPTS = {"n_solutions": 5, "n_starts": 8, "min_p_pile": 0.5}


def _surface_optimum(**extra) -> Optimum:
    """As :func:`demcal.calibrate.stages.optimize` builds it."""
    cands = [Candidate(params=dict(X), predicted_lead=40.0, pi_low=38.9,
                       pi_high=41.1, p_pile=0.98, desirability=1.0),
             Candidate(params={k: v + 0.01 for k, v in X.items()}, predicted_lead=40.0,
                       pi_low=None, pi_high=None, p_pile=0.97, desirability=0.99)]
    return Optimum(target=40.0, candidates=cands, chosen=cands[0].params,
                   predicted_lead=40.0, classifier={"n_runs": 37, "constant": None},
                   opts=dict(OPTS), **extra)


def _several_optimum(unmet: list[str]) -> Optimum:
    """As :func:`demcal.calibrate.several.optimize_summary` builds it."""
    cand = Candidate(params=dict(X), predicted_lead=30.4, pi_low=30.0, pi_high=30.8,
                     p_pile=1.0, desirability=0.97,
                     predicted={"aor_deg": 30.4, "drum_deg": 32.6},
                     individual={"aor_deg": 0.98, "drum_deg": 0.96})
    goals = [Goal(name="aor_deg", goal="target", low=28.0, high=33.0, target=30.45,
                  weight=1.0, importance=3),
             Goal(name="drum_deg", goal="target", low=30.0, high=35.0, target=32.6, weight=1.0,
                  importance=3)]
    return Optimum(target=30.45, candidates=[cand], chosen=cand.params,
                   predicted_lead=30.4, classifier={"n_runs": 15}, opts=dict(OPTS),
                   responses=ResponsesOptimum(goals=goals, desirability=0.97,
                                              reachable=not unmet, unmet=unmet),
                   warnings=[f"no setting meets the limits of {u}" for u in unmet])


def _posterior_optimum() -> Optimum:
    """As :mod:`demcal.calibrate.bayes_strategy` builds it."""
    return Optimum(target=30.45, chosen=dict(X), predicted_lead=30.46,
                   candidates=[Candidate(params=dict(X), predicted_lead=30.46,
                                         pi_low=None, pi_high=None, p_pile=None)],
                   opts="bayes", source="the posterior's best sample (strategy bayes)")


def test_the_angle_s_optimum_stores_the_keys_it_always_stored():
    opt = _surface_optimum()
    stored = opt.to_summary()
    assert list(stored) == SURFACE_KEYS
    assert [list(c) for c in stored["candidates"]] == [CANDIDATE_KEYS] * 2
    assert stored["chosen"] == X and stored["opts"] == OPTS
    assert Optimum.from_summary(stored) == opt and opt.round_number == 1 and opt.done


def test_a_refinement_round_stores_its_offset_and_the_earlier_rounds():
    first = _surface_optimum()
    second = _surface_optimum(round=2, surface_offset=-0.7, offset_from_rounds=[1],
                              measured_offset=-1.0, offset_weight=0.7)
    stored = second.in_round([first.in_round([])]).to_summary()
    assert list(stored) == SURFACE_KEYS + ROUND_KEYS
    assert list(stored["rounds"][0]) == SURFACE_KEYS  # round 1 as it was stored
    back = Optimum.from_summary(stored)
    assert back.round_number == 2 and back.rounds[0].round_number == 1
    assert back.rounds == [first] and back.offset_weight == 0.7
    # a round's history is the earlier rounds' alone, whatever it carried before
    assert back.in_round([]).rounds == [] and back.in_round([first]).rounds == [first]


def test_several_responses_store_the_goals_and_the_desirability():
    stored = _several_optimum([]).to_summary()
    assert list(stored) == SEVERAL_KEYS
    assert list(stored["candidates"][0]) == SEVERAL_CANDIDATE_KEYS
    assert list(stored["responses"]) == RESPONSES_KEYS
    assert [list(g) for g in stored["responses"]["goals"]] == [GOAL_KEYS] * 2
    assert Optimum.from_summary(stored) == _several_optimum([])
    # a limit out of reach: its warning, after the responses
    unmet = _several_optimum(["drum_deg"]).to_summary()
    assert list(unmet) == [*SEVERAL_KEYS, "warnings"] and unmet["responses"]["unmet"] == [
        "drum_deg"]
    assert Optimum.from_summary(unmet).responses.unmet == ["drum_deg"]


def test_the_bayesian_strategy_s_optimum_keeps_its_own_key_order():
    # the store keeps a summary's key order: the posterior's optimum always began with the
    # chosen point, before its one candidate
    opt = _posterior_optimum()
    stored = opt.to_summary()
    assert list(stored) == POSTERIOR_KEYS
    assert list(stored["candidates"][0]) == POSTERIOR_CANDIDATE_KEYS
    assert stored["opts"] == "bayes" and "classifier" not in stored
    back = Optimum.from_summary(stored)
    assert back == opt and back.best.desirability is None and back.responses is None


def test_an_old_store_s_optimum_reads_and_writes_back_byte_for_byte(tmp_path):
    # the optimum a schema-1 store (the release before several responses) holds
    db = tmp_path / "old.sqlite"
    with gzip.open(DATA / "store_v1_analytic.sqlite.gz", "rb") as src, db.open("wb") as dst:
        shutil.copyfileobj(src, dst)
    con = sqlite3.connect(db)
    try:
        text = con.execute("SELECT summary_json FROM stages WHERE name = 'optimize'").fetchone()[0]
    finally:
        con.close()
    stored = json.loads(text)
    opt = Optimum.from_summary(stored)
    assert opt.chosen == stored["chosen"] and len(opt.candidates) == len(stored["candidates"])
    assert opt.best.params == opt.chosen and opt.responses is None
    assert json.dumps(opt.to_summary()) == json.dumps(stored)


def test_missing_keys_take_their_defaults_and_unknown_keys_are_left_out():
    for empty in (None, {}, {"error": "optimize: no setting inside the pile region"}):
        opt = Optimum.from_summary(empty)
        assert not opt.done and opt.best == Candidate() and opt.round_number == 1
    # a store written before "opts" and each candidate's "desirability" were stored
    old = {"target_aor_deg": 40.0, "candidates": [{"params": X, "predicted_aor_deg": 40.0,
                                                   "pi_low_deg": None, "pi_high_deg": None,
                                                   "p_pile": None}],
           "chosen": X, "predicted_aor_deg": 40.0, "some_future_key": 1}
    opt = Optimum.from_summary(old)
    assert opt.opts is None and opt.best.desirability is None
    assert opt.to_summary() == {k: v for k, v in old.items() if k != "some_future_key"}
    assert Optimum.from_summary({"responses": {}}).responses is None
