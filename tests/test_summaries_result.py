"""The result JSON, typed (demcal.summaries.result.CalibrationResult): both strategies build
it, the console, the material card and the marks read its attributes, and it writes the file
format every release wrote."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from demcal.errors import StoreError
from demcal.lead import LeadName
from demcal.report.data import ReportData
from demcal.summaries import CalibrationResult, ResultRound, Verification

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
RESULTS = sorted(EXAMPLES.glob("**/result*.json"))
#: results written by this release's code: written back key for key, in order
CURRENT = ["corn_stalk/result_standard.json", "corn_stalk/result_bayes_standard.json",
           "corn_stalk/result_lammps_small.json", "corn_stalk/result_lammps_low_cohesion.json",
           "corn_stalk/result_lammps_low_cohesion_standard.json",
           "two_responses/result.json",
           "several_responses/result.json", "aor_and_drum/result.json"]


def _lost(stored: object, again: object, where: str = "") -> list[str]:
    """What ``stored`` holds that ``again`` does not hold the same (keys ``again`` adds are
    allowed: a result of an earlier release lacks the newer keys)."""
    if isinstance(stored, dict):
        if not isinstance(again, dict):
            return [where]
        return [lost for k, v in stored.items()
                for lost in ([f"{where}/{k} (gone)"] if k not in again
                             else _lost(v, again[k], f"{where}/{k}"))]
    if isinstance(stored, list):
        if not isinstance(again, list) or len(stored) != len(again):
            return [f"{where} (length)"]
        return [lost for i, (a, b) in enumerate(zip(stored, again, strict=True))
                for lost in _lost(a, b, f"{where}[{i}]")]
    return [] if stored == again else [f"{where}: {stored!r} -> {again!r}"]


def test_every_example_has_a_result_to_read():
    assert len(RESULTS) >= 10
    assert all((EXAMPLES / name).is_file() for name in CURRENT)


@pytest.mark.parametrize("path", RESULTS, ids=lambda p: str(p.relative_to(EXAMPLES)))
def test_every_committed_result_reads_back_with_all_it_holds(path: Path):
    stored = json.loads(path.read_text())
    assert _lost(stored, CalibrationResult.from_summary(stored).to_summary()) == []


@pytest.mark.parametrize("name", CURRENT)
def test_a_result_of_this_release_is_written_back_exactly(name: str):
    stored = json.loads((EXAMPLES / name).read_text())
    again = CalibrationResult.from_summary(stored).to_summary()
    assert again == stored
    assert list(again) == list(stored)  # the key order too: a re-run's file diffs nothing


def test_the_doe_result_s_fields_are_its_keys():
    stored = json.loads((EXAMPLES / "corn_stalk" / "result_standard.json").read_text())
    r = CalibrationResult.from_summary(stored)
    assert r.strategy == "doe" and r.bayes is None and r.lead is None
    assert r.lead_name == LeadName()
    assert r.optimum == stored["optimum"] and r.optimum_full == stored["optimum_full"]
    assert r.target == stored["target_aor_deg"]
    assert r.predicted_lead == stored["predicted_aor_deg"]
    v = stored["verification"]
    assert (r.verification.mean, r.verification.std, r.verification.n) == (
        v["aor_mean_deg"], v["aor_std_deg"], v["n"])
    assert r.verification.ci_low == v["ci_low_deg"]
    assert r.surface is not None and r.surface.model == stored["rsm_model"]
    assert r.surface.adequate is stored["rsm_adequate"]
    assert r.n_runs == stored["n_runs"] and r.n_runs_used == stored.get("n_runs_used")
    assert [x.round for x in r.rounds] == [x["round"] for x in stored["rounds"]]
    assert r.rounds[-1].mean == stored["rounds"][-1]["aor_mean_deg"]
    assert r.ranges == stored["ranges"]


def test_the_bayesian_result_s_fields_are_its_keys():
    stored = json.loads((EXAMPLES / "corn_stalk" / "result_bayes_standard.json").read_text())
    r = CalibrationResult.from_summary(stored)
    assert r.strategy == "bayes" and r.surface is None and r.stages is None
    b = r.bayes
    assert b is not None and b.identifiable is stored["identifiable"] is False
    assert b.optimum == r.optimum == stored["optimum"]
    # the result's n_runs counts the store; the posterior's, its loop and rounds
    assert r.n_runs == stored["n_runs"]
    assert b.n_runs == stored["n_runs_strategy"] + stored["verification_runs"]
    assert [x.mean for x in r.rounds] == [x["aor_mean_deg"] for x in stored["rounds"]]
    assert not any(x.aimed for x in r.rounds)  # the posterior's rounds: no offset


def test_a_bayesian_result_whose_optimum_is_not_its_posterior_s_is_refused():
    # the result JSON writes the posterior's optimum: another one would be lost silently
    from dataclasses import replace

    stored = json.loads((EXAMPLES / "corn_stalk" / "result_bayes_standard.json").read_text())
    r = CalibrationResult.from_summary(stored)
    moved = {**r.optimum, "pp.static_friction": r.optimum["pp.static_friction"] + 0.01}
    with pytest.raises(ValueError, match="not its posterior's optimum"):
        replace(r, optimum=moved)


def test_a_lead_that_is_not_the_angle_is_named_and_read_back():
    r = CalibrationResult(study="s", optimum={"a": 1.0}, optimum_full={"a": 1.0},
                          predicted_lead=0.5, target=0.52, verification=Verification(n=3),
                          lead=LeadName(name="drum_deg_per_rpm", unit="deg/rpm"),
                          rounds=[ResultRound(round=1, n_piles=3, mean=0.51)])
    stored = r.to_summary()
    assert stored["lead"] == {"name": "drum_deg_per_rpm", "unit": "deg/rpm"}
    assert stored["target_aor_deg"] == 0.52  # the angle's key holds the lead's value
    again = CalibrationResult.from_summary(stored)
    assert again.lead_name.label == "drum_deg_per_rpm"
    assert again.to_summary() == stored
    assert "surface_offset_deg" not in stored["rounds"][0]  # a round aimed by no offset


def test_a_damaged_result_in_a_store_is_one_line(tmp_path: Path):
    data = ReportData(study_dir=tmp_path, meta={"result": {"optimum": 5}}, stages={}, runs=[])
    with pytest.raises(StoreError, match="meta 'result' is not what demcal writes"):
        _ = data.result
    assert ReportData(study_dir=tmp_path, meta={}, stages={}, runs=[]).result is None


def test_the_fit_statistics_are_read_typed_from_a_result_and_a_store():
    from demcal.summaries import FitStatistics, Surface

    stored = json.loads((EXAMPLES / "corn_stalk" / "result_standard.json").read_text())
    facts = CalibrationResult.from_summary(stored).surface
    assert facts is not None
    a = facts.adequacy
    assert (a.p_model, a.lack_of_fit_p, a.adj_r2, a.pred_r2, a.adeq_precision) == tuple(
        stored["rsm_adequacy"][k] for k in ("p_model", "lack_of_fit_p", "adj_r2", "pred_r2",
                                            "adeq_precision"))
    assert a.to_summary() == stored["rsm_adequacy"]  # the stored keys, in their order
    assert list(a.to_summary()) == list(stored["rsm_adequacy"])
    # a store that predates a key, or holds none: None, not an error
    assert Surface.from_summary({"adequacy": {"adj_r2": 0.9}}).adequacy == FitStatistics(
        adj_r2=0.9)
    assert Surface.from_summary(None).adequacy is None
    assert not FitStatistics().known and FitStatistics(adj_r2=0.9).known


def test_the_result_names_the_fidelity_of_its_test_beside_a_stage_s_own():
    # the standard study fitted its surface on the small test: the result must say which
    # test its verification (and card) ran, or it reads as a small-fidelity calibration
    stored = json.loads(
        (EXAMPLES / "corn_stalk" / "result_lammps_low_cohesion_standard.json").read_text())
    r = CalibrationResult.from_summary(stored)
    assert r.fidelity == stored["fidelity"] == "standard"
    assert stored["stages"]["rsm"]["fidelity"] == "small"
    assert list(r.to_summary())[:2] == ["study", "fidelity"]
    earlier = CalibrationResult.from_summary({k: v for k, v in stored.items()
                                              if k != "fidelity"})
    assert earlier.fidelity is None and "fidelity" not in earlier.to_summary()


@pytest.mark.parametrize(("study", "fidelity"), [
    ("corn_stalk/study_lammps_low_cohesion_standard.toml", "standard"),
    ("corn_stalk/study.toml", "quick"),
    ("analytic/study.toml", None),          # the stand-in has no test fidelity
    ("stand_in_engine/study.toml", None),   # an external engine runs its own test
])
def test_the_study_s_test_fidelity_is_what_the_result_is_given(study: str, fidelity):
    from demcal.calibrate.study import load_study

    assert load_study(EXAMPLES / study).test_fidelity == fidelity
