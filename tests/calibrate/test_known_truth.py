"""Known truth: on the analytic stand-in (planted surface, no-pile region above
pp.surface_energy = 0.03 J/m^2) the range finding cuts the no-pile part and the whole study
recovers a setting whose TRUE angle is the target."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from demcal.calibrate import calibrate
from demcal.calibrate.study import load_study
from demcal.errors import StudyError
from demcal.execute.analytic import true_aor
from demcal.store import RunStore

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "analytic" / "study.toml"

BOUNDARY = 0.03  # planted: no pile where pp.surface_energy > 0.03


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    path = tmp_path_factory.mktemp("truth") / "study.toml"
    shutil.copy(EXAMPLE, path)
    return calibrate(path), path


def test_rangefind_finds_the_pile_region(result):
    res, path = result
    with RunStore(path.parent) as store:
        rf = store.stage("rangefind")
        assert rf.status == "done"
        (x8,) = rf.summary["factors"]
        assert x8["name"] == "pp.surface_energy"
        # grid 0, 0.0125, ..., 0.05: the last pile point lies within one step of the truth
        assert x8["new_low"] == 0.0
        assert BOUNDARY - 0.0125 <= x8["new_high"] <= BOUNDARY
        assert "column" in x8["reason"]
        outcomes = [p["outcome"] for p in x8["points"]]
        assert outcomes == ["pile", "pile", "pile", "column", "column"]
        assert [p["aor_deg"] is None for p in x8["points"]] == [False] * 3 + [True] * 2
        # the scan of x8 alone (others at their centre) reaches 30..35 deg < 40: say so
        assert rf.summary["target_in_range"] is False
        assert 34 < rf.summary["response_max_deg"] < 36
        assert "raise the AoR: pp.surface_energy (up)" in rf.summary["message"]
        # the no-pile runs are stored with their outcome and no angle
        cols = [r for r in store.runs(stage="rangefind") if r.outcome == "column"]
        assert len(cols) == 2 and all(r.aor_deg is None and r.status == "done" for r in cols)
    assert res["ranges"]["pp.surface_energy"] == [0.0, x8["new_high"]]


def test_study_recovers_the_planted_target(result):
    res, path = result
    study = load_study(path)
    opts = study.test.analytic
    target = res["target_aor_deg"]
    # screening picks the three planted strong factors, not restitution (no effect)
    assert set(res["stages"]["screening"]["selected"]) == {
        "pp.static_friction", "pp.rolling_friction", "pp.surface_energy"}
    # the chosen setting's noise-free angle is the target within 1 deg, in the pile region
    truth = true_aor(res["optimum_full"], opts)
    assert abs(truth - target) < 1.0, truth
    assert res["optimum"]["pp.surface_energy"] < BOUNDARY
    assert abs(res["predicted_aor_deg"] - target) < 0.05
    v = res["verification"]
    assert v["n"] == 3 and abs(v["aor_mean_deg"] - target) < 1.0
    assert v["relative_error_percent"] < 2.5
    assert res["n_runs"] == 5 + 12 + 5 + 15 + 3
    with RunStore(path.parent) as store:
        rsm = store.stage("rsm").summary
        assert rsm["adequate"] and rsm["lack_of_fit_p"] is not None
        # the keys the response surface always stored (demcal.summaries.Surface writes them)
        assert list(rsm) == ["design", "factors", "runs", "excluded_points", "replicates",
                             "anova", "fit", "lack_of_fit_p", "adequacy", "rounds", "model",
                             "removed_terms", "anova_full", "adequacy_full",
                             "coefficients_coded", "coefficients_actual", "equation_coded",
                             "equation_actual", "adequate", "warnings"]
        opt = store.stage("optimize").summary
        # the keys the angle's optimum always stored (demcal.summaries.Optimum writes them)
        assert list(opt) == ["target_aor_deg", "candidates", "chosen", "predicted_aor_deg",
                             "classifier", "opts"]
        assert list(opt["candidates"][0]) == ["params", "predicted_aor_deg", "pi_low_deg",
                                              "pi_high_deg", "p_pile", "desirability"]
        for c in opt["candidates"]:  # never a point predicted outside the pile region
            assert c["p_pile"] >= 0.5 and c["params"]["pp.surface_energy"] < BOUNDARY
        assert store.meta("result")["optimum"] == res["optimum"]
        assert {s.name for s in store.stages()} == {"rangefind", "screening", "steepest", "rsm",
                                                     "optimize", "verification"}


def test_without_rangefind_the_no_pile_points_are_excluded_and_named(study_file):
    text = study_file.read_text().replace("[stages.rangefind]", "[stages.rangefind]\nenabled "
                                          "= false")
    study_file.write_text(text)
    with pytest.raises(StudyError, match=r"formed no pile \(column\): points"):
        calibrate(study_file)
    with RunStore(study_file.parent) as store:
        sc = store.stage("screening")
        assert sc.status == "failed" and "excluded" in sc.summary["error"]
        assert len(sc.summary["excluded_points"]) == 6  # x8 high in half the PB runs


def test_steepest_path_goes_on_while_the_error_falls(study_file):
    """3 steps end still falling toward 43 deg: the path grows by 2 steps and stops at the
    first no-pile step (x8 > 0.03); the best step is the last pile."""
    text = study_file.read_text().replace("aor_deg = 40.0", "aor_deg = 43.0").replace(
        "[stages.steepest]\nsteps = 5", "[stages.steepest]\nsteps = 3\nmax_steps = 9")
    study_file.write_text(text)
    calibrate(study_file)
    with RunStore(study_file.parent) as store:
        s = store.stage("steepest").summary
        assert store.count("steepest") == 5
    assert [x["outcome"] for x in s["steps"]] == ["pile", "pile", "pile", "column", "column"]
    errs = [x["relative_error_percent"] for x in s["steps"][:3]]
    assert errs[0] > errs[1] > errs[2]
    assert s["best_step"] == 2 and "no pile" in s["message"]
