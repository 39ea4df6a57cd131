"""A whole study on an external engine: the stand-in executable of examples/stand_in_engine,
driven through its input template locally (inline and a process pool) and on a local Dask
cluster; engine failures stop the stage and resume re-runs only them; schema errors are one
line (exit 2)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from demcal.calibrate import calibrate
from demcal.calibrate.runner import Runner
from demcal.calibrate.study import load_study, parse_study
from demcal.errors import InputError, StudyError
from demcal.store import RunStore

# distributed's scheduler serves its HTTP routes on port 8787 even with no dashboard; when a
# parallel test (pytest -n) or another suite on the host holds it, it moves and warns, and
# warnings are errors here: a free port of the OS's choosing instead
FREE_PORT = "127.0.0.1:0"

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "stand_in_engine"
N_RUNS = 29  # screening 8, steepest 3, rsm 15, verification 2 + 1 (sized by the pure error)


@pytest.fixture
def study_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The stand-in study in tmp_path/a; no per-run pile pictures (0.5 s each)."""
    monkeypatch.setattr(Runner, "_plot_path", lambda self, stage, key: None)
    d = tmp_path / "a"
    shutil.copytree(EXAMPLE, d)
    return d


def _set(study: Path, old: str, new: str) -> None:
    text = study.read_text()
    assert old in text
    study.write_text(text.replace(old, new))


def test_study_runs_on_the_stand_in_engine_and_resumes(study_dir):
    res = calibrate(study_dir / "study.toml", workers=1)
    assert res["n_runs"] == N_RUNS and res["n_runs_executed"] == N_RUNS
    assert abs(res["verification"]["aor_mean_deg"] - 33.0) < 1.5
    assert res["rsm_adequate"]
    with RunStore(study_dir, readonly=True) as store:
        runs = store.runs()
        assert {r.status for r in runs} == {"done"} and {r.outcome for r in runs} == {"pile"}
        assert store.meta("engine")["name"].startswith("template: {python}")
        r = runs[0]
        run_dir = Path(r.artefacts["run_dir"])
        assert run_dir.parent == study_dir / "runs" and (run_dir / "engine.log").is_file()
        assert f"seed = {r.seed}\n" in (run_dir / "input.txt").read_text()
        assert "template" in r.engine_version and r.result["engine"]["status"] == "exit code 0"
    # resume: nothing runs again
    again = calibrate(study_dir / "study.toml", workers=1)
    assert again["n_runs_executed"] == 0 and again["optimum"] == res["optimum"]
    # the material card says which engine produced the parameters
    from demcal.report.material import write_material_card

    toml_path, json_path = write_material_card(study_dir)
    card = json.loads(Path(json_path).read_text())
    assert card["engine"]["name"] == "template" and card["test"]["kind"] == "template"
    assert "contact_laws" not in card["engine"]  # demcal's laws are not that engine's
    from demcal.virtual.material_card import read_material_card

    assert read_material_card(toml_path).engine.name == "template"
    assert "engine.py" in card["engine"]["command"]
    # a changed template (or command) is a different test: its runs are made again
    from demcal.calibrate.pipeline import open_study

    ctx = open_study(study_dir / "study.toml")
    old_hash = ctx.runner.test_hash
    ctx.store.close()
    _set(study_dir / "input.txt.template", "sleep_s = 0", "sleep_s = 0.0")
    ctx = open_study(study_dir / "study.toml")
    try:
        assert ctx.runner.test_hash != old_hash
        stored = RunStore(study_dir, readonly=True)
        from demcal.calibrate.runner import Point

        r = stored.runs("screening")[0]
        stored.close()
        assert ctx.runner.missing("screening", [Point(r.point, r.replicate, r.params, r.seed)])
    finally:
        ctx.store.close()


def test_engine_failures_stop_the_stage_and_are_rerun_on_resume(study_dir):
    study = study_dir / "study.toml"
    _set(study_dir / "input.txt.template", "mode = ok",
         "mode = ok\nfail_flag = {template_dir}/FAIL")
    (study_dir / "FAIL").write_text("")
    with pytest.raises(StudyError, match=r"screening: 8 of 8 runs failed in the external "
                       r"engine \(8 engine_error\); first: exit code 3 \(log: .*engine.log"):
        calibrate(study, workers=1)
    with RunStore(study_dir, readonly=True) as store:
        runs = store.runs()
        assert len(runs) == 8 and {(r.status, r.outcome) for r in runs} == \
            {("failed", "engine_error")}
        assert all(Path(r.artefacts["engine_log"]).is_file() for r in runs)
    (study_dir / "FAIL").unlink()
    res = calibrate(study, workers=1)
    assert res["n_runs"] == N_RUNS and res["n_runs_executed"] == N_RUNS
    with RunStore(study_dir, readonly=True) as store:
        assert {r.outcome for r in store.runs()} == {"pile"}


def test_a_timed_out_run_is_stored_and_the_others_kept(study_dir):
    study = study_dir / "study.toml"
    _set(study, "timeout_s = 60", "timeout_s = 2")  # a normal run takes ~0.1 s
    _set(study_dir / "input.txt.template", "mode = ok",
         "mode = ok\nhang_if = {pp.static_friction} > 0.85")
    with pytest.raises(StudyError, match=r"screening: 4 of 8 runs failed .*\(4 timeout\)"):
        calibrate(study, workers=1)
    with RunStore(study_dir, readonly=True) as store:
        outcomes = sorted(r.outcome for r in store.runs())
    assert outcomes == ["pile"] * 4 + ["timeout"] * 4


def test_dask_local_cluster_runs_the_study(study_dir):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=FREE_PORT) as cluster:
        res = calibrate(study_dir / "study.toml", dask=cluster.scheduler_address)
    assert res["n_runs"] == res["n_runs_executed"] == N_RUNS
    assert abs(res["verification"]["aor_mean_deg"] - 33.0) < 1.5
    with RunStore(study_dir, readonly=True) as store:
        assert {r.outcome for r in store.runs()} == {"pile"}
        assert len(list((study_dir / "runs").iterdir())) == N_RUNS == store.count()


@pytest.mark.slow
def test_process_pool_and_dask_give_the_inline_answer(tmp_path, study_dir):
    """Two spawned workers (each imports demcal once per stage: ~1 min on 2 cores) and two
    Dask worker processes find exactly the inline study's answer."""
    distributed = pytest.importorskip("distributed")
    ref = calibrate(study_dir / "study.toml", workers=1)
    b, c = tmp_path / "b", tmp_path / "c"
    shutil.copytree(EXAMPLE, b)
    shutil.copytree(EXAMPLE, c)
    res = calibrate(b / "study.toml", workers=2)
    assert res["optimum"] == ref["optimum"] and res["n_runs_executed"] == N_RUNS
    assert res["verification"] == ref["verification"]
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=FREE_PORT) as cluster:
        res = calibrate(c / "study.toml", dask=cluster.scheduler_address)
    assert res["optimum"] == ref["optimum"] and res["verification"] == ref["verification"]


@pytest.mark.parametrize(("edit", "match"), [
    ({"kind": "edem"}, r"engine.kind: Input should be 'template'"),
    ({"result": {"kind": "image", "file": "a"}}, r"engine.result: Input tag 'image'"),
    ({"timeout_s": 0}, r"engine.timeout_s: Input should be greater than 0"),
    ({"command": []}, r"engine.command: .*give the program to run"),
    ({"input": "../x.in"}, r"engine.input: .*a plain file name"),
    ({"hook": "nofunction"}, r"engine.hook: .*'file.py:function'"),
    ({"template": "missing.in"}, r"engine.template: file not found"),
    ({"result": {"kind": "positions", "file": "p.txt", "format": "table",
                 "columns": {"x": "x"}}}, r"columns.x: a table's columns are 0-based"),
])
def test_bad_engine_tables_are_one_line(edit, match):
    import tomllib

    data = tomllib.loads((EXAMPLE / "study.toml").read_text())
    data["engine"].update(edit)
    with pytest.raises(InputError, match=match) as info:
        parse_study(data, base=EXAMPLE)
    assert "\n" not in str(info.value)


def test_engine_with_the_analytic_test_is_refused():
    study = load_study(EXAMPLE / "study.toml")
    data = study.model_dump(mode="json")
    data["test"]["kind"] = "analytic"
    with pytest.raises(InputError, match="engine: an external engine runs the test"):
        parse_study(data, base=EXAMPLE)


def test_an_engine_table_and_the_lammps_engine_exclude_each_other():
    import tomllib

    data = tomllib.loads((EXAMPLE / "study.toml").read_text())
    data["executor"]["engine"] = "lammps"
    with pytest.raises(InputError, match="an \\[engine\\] table exclude each other"):
        parse_study(data, base=EXAMPLE)


def test_cli_bad_engine_exits_2_with_one_line(tmp_path):
    from typer.testing import CliRunner

    from demcal.cli import app

    shutil.copytree(EXAMPLE, tmp_path / "s")
    _set(tmp_path / "s" / "study.toml", 'kind = "positions"', 'kind = "pixels"')
    out = CliRunner().invoke(app, ["calibrate", str(tmp_path / "s" / "study.toml")])
    assert out.exit_code == 2
    assert "engine.result: Input tag 'pixels'" in out.output
    assert "Traceback" not in out.output


def test_cli_engine_failure_exits_3_with_one_line(study_dir):
    from typer.testing import CliRunner

    from demcal.cli import app

    _set(study_dir / "input.txt.template", "mode = ok", "mode = crash")
    out = CliRunner().invoke(app, ["calibrate", str(study_dir / "study.toml"), "--no-report"])
    assert out.exit_code == 3, out.output
    assert "failed: screening: 8 of 8 runs failed in the external engine" in out.output
    assert "Traceback" not in out.output
