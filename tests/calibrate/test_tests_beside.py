"""A study runs the rotating drum beside the lift test (``[tests.drum]``).

Each test's run is stored on its own (stage ``<stage>+drum``), resumed on its own, and joined
into the point's run as more responses; a drum run that measures nothing loses no lift run.
"""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from demcal.calibrate.pipeline import beside_tests
from demcal.calibrate.runner import Point, Runner, RunnerOptions, joined
from demcal.calibrate.study import parse_study
from demcal.cli import app
from demcal.errors import InputError
from demcal.execute.tasks import TestDef
from demcal.store import RunRecord, RunStore
from demcal.virtual.presets import preset_parameters

BASE = {
    "name": "beside",
    "target": {"aor_deg": 40.0},
    "factors": [{"name": "pp.static_friction", "low": 0.3, "high": 0.7}],
}
#: the cheapest drum: the quick one with 4 frames and a short steady-state window
SMALL_DRUM = {"frames": 4, "steady_window": 2}


def _rec(stage: str, status: str, responses: dict[str, float]) -> RunRecord:
    return RunRecord(key=f"{stage}:k", stage=stage, point=0, replicate=0, params={}, seed=1,
                     status=status, outcome="pile" if status == "done" else "unstable",
                     responses=responses)


def test_a_drum_response_needs_the_drum_and_bad_drum_settings_are_one_line():
    with_response = {**BASE, "responses": [{"name": "drum_dynamic_aor_deg", "target": 35.0}]}
    with pytest.raises(InputError, match="drum_dynamic_aor_deg"):
        parse_study(with_response)
    study = parse_study({**with_response, "tests": {"drum": {"drum": {"rpm": 20}}}})
    assert study.tests.drum is not None and "drum_dynamic_aor_deg" in study.reported_responses()
    with pytest.raises(InputError, match=r"tests\.drum.*fill_fraction") as exc:
        parse_study({**BASE, "tests": {"drum": {"drum": {"fill_fraction": 1.2}}}})
    assert "\n" not in str(exc.value)
    with pytest.raises(InputError, match="rpm"):  # a speed that centrifuges
        parse_study({**BASE, "tests": {"drum": {"drum": {"rpm": 500}}}})


def test_the_drum_beside_the_lift_test_takes_its_particles_and_rolling_model():
    study = parse_study({**BASE, "test": {"overrides": {"rolling_model": "C"}},
                         "tests": {"drum": {"drum": {"rpm": 20}}}})
    from demcal.calibrate.pipeline import test_def

    drum = beside_tests(study, test_def(study))["drum"]
    assert drum.kind == "drum" and drum.overrides["rolling_model"] == "C"
    assert drum.overrides["drum"] == {"rpm": 20}
    assert beside_tests(parse_study(BASE), test_def(parse_study(BASE))) == {}


def test_a_lammps_study_runs_its_drum_in_lammps_too():
    """With ``executor.engine = "lammps"`` the drum beside the lift test runs in LAMMPS,
    started as the lift test is; its runs are never taken for demcal's (the identity names
    the engine), and demcal's drum identity is what it was."""
    from demcal.calibrate.pipeline import test_def

    study = parse_study({**BASE, "tests": {"drum": {"drum": {"rpm": 20}}},
                         "executor": {"engine": "lammps", "lammps": {"np": 2}}})
    drum = beside_tests(study, test_def(study))["drum"]
    assert drum.engine == "lammps" and drum.lammps.np == 2
    assert drum.identity()["engine"]["name"] == "lammps"
    plain = parse_study({**BASE, "tests": {"drum": {"drum": {"rpm": 20}}}})
    demcal = beside_tests(plain, test_def(plain))["drum"]
    assert "engine" not in demcal.identity()
    assert demcal.identity()["config"] == drum.identity()["config"]


def test_joined_adds_a_done_run_s_responses_and_the_main_test_wins_a_shared_name():
    main = _rec("screening", "done", {"aor_deg": 40.0})
    drum = _rec("screening+drum", "done", {"drum_dynamic_aor_deg": 33.0, "aor_deg": 1.0})
    assert joined(main, drum).responses == {"aor_deg": 40.0, "drum_dynamic_aor_deg": 33.0}
    assert joined(main, _rec("screening+drum", "failed", {})).responses == {"aor_deg": 40.0}
    assert main.responses == {"aor_deg": 40.0}  # joined makes a new record


def test_each_test_is_stored_and_resumed_on_its_own(tmp_path):
    params = preset_parameters("corn_stalk_dry")
    lift = TestDef(kind="analytic")
    drum = TestDef(kind="drum", overrides={"drum": SMALL_DRUM})
    points = [Point(0, 0, params, 11)]
    with RunStore(tmp_path) as store:
        runner = Runner(store, lift, RunnerOptions(beside={"drum": drum}))
        (rec,) = runner.run("screening", points)
        assert runner.executed == 2
        stored = {r.stage: r for r in store.runs()}
        assert set(stored) == {"screening", "screening+drum"}
        assert runner.beside_keys == {stored["screening+drum"].key}  # counted as used
        assert rec.key == stored["screening"].key and rec.aor_deg is not None
        drum_run = stored["screening+drum"]
        assert drum_run.outcome in ("rolling", "slumping") and drum_run.responses
        assert drum_run.result["n_particles"] > 0
        # the drum's responses join the point's run exactly when the drum measured them
        drum_names = {n for n in rec.responses if n.startswith("drum_")}
        assert drum_names == set(drum_run.responses)
        # range finding runs the lift test alone
        runner.run("rangefind", points)
        assert runner.executed == 3
        # any stage runs the drum beside (the Bayesian strategy's "bayes" too)
        assert runner.test_for("bayes+drum") is drum and runner.test_for("bayes") is lift
        assert runner.stage_hash("bayes+drum") == runner.stage_hash("screening+drum")
        # a resumed study re-runs nothing, and gets the same joined run back
        again = Runner(store, lift, RunnerOptions(beside={"drum": drum}))
        assert again.run("screening", points)[0].responses == rec.responses
        assert again.executed == 0



def test_the_drum_is_refused_with_external_runs(tmp_path):
    study = tmp_path / "study.toml"
    study.write_text('name = "beside"\n[target]\naor_deg = 40.0\n'
                     '[[factors]]\nname = "pp.static_friction"\nlow = 0.3\nhigh = 0.7\n'
                     '[tests.drum]\nfidelity = "quick"\n')
    res = CliRunner().invoke(app, ["calibrate", str(study), "--external"])
    assert res.exit_code == 2 and "[tests.drum] runs inside demcal" in res.output
    assert not (tmp_path / "demcal.sqlite").exists()
