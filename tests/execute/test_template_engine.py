"""The template adapter's pieces: placeholders, result readers, one run of a real executable
(the stand-in engine of examples/stand_in_engine) and its typed failures."""

from __future__ import annotations

import json
import os
import shutil
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from demcal.errors import InputError
from demcal.execute.engine_results import ResultUnreadable, read_positions, read_value
from demcal.execute.engine_spec import PositionsResult, TemplateEngine, load_engine
from demcal.execute.tasks import MEASUREMENT_VERSION, RunTask, TestDef
from demcal.execute.template_engine import LOG_NAME, run_dir_name, run_template
from demcal.execute.template_fill import BUILTINS, fill, placeholders
from demcal.virtual import PARAMETERS, preset_parameters

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "stand_in_engine"
KNOWN = set(PARAMETERS) | {"x3"}


# --- placeholders ------------------------------------------------------------------------

def test_fill_replaces_parameters_and_leaves_other_braces_alone():
    text = ("mu {pp.static_friction} seed {seed}\nvariable v equal ${v}\nd = {'a': 1}\n"
            "literal {{seed}}\n")
    assert placeholders(text) == {"pp.static_friction", "seed"}
    out = fill(text, {"pp.static_friction": 0.65, "seed": 7})
    assert out == ("mu 0.65 seed 7\nvariable v equal ${v}\nd = {'a': 1}\nliteral {seed}\n")
    assert fill("{e}", {"e": 5e7}) == "50000000.0" and fill("{e}", {"e": 1e-5}) == "1e-05"
    assert float(fill("{x}", {"x": 0.1 + 0.2})) == 0.1 + 0.2  # round trip exact


def test_fill_names_a_missing_placeholder_and_its_line():
    with pytest.raises(InputError, match=r"line 2: no value for placeholder \{nope\}"):
        fill("a\n{nope}\n", {"seed": 1})


# --- result readers ----------------------------------------------------------------------

def test_positions_in_table_and_lammps_dump_formats(tmp_path):
    rows = [(0.0, 0.0, 5.0, 1.0), (1.0, 2.0, 7.0, 1.5)]
    (tmp_path / "p.txt").write_text("N time\n# comment\n" + "\n".join(
        f"{x} {y} {z} 9 {r}" for x, y, z, r in rows) + "\n")
    spec = PositionsResult(file="p.txt", format="table", skip_rows=1, columns={"radius": 4},
                           length_scale=0.001, plate_z=0.002).model_dump()
    c, r = read_positions(tmp_path, spec)
    np.testing.assert_allclose(c, [[0, 0, 0.003], [0.001, 0.002, 0.005]])
    np.testing.assert_allclose(r, [0.001, 0.0015])
    dump = ("ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n1\nITEM: ATOMS id x y z radius\n"
            "1 9 9 9 9\nITEM: TIMESTEP\n100\nITEM: NUMBER OF ATOMS\n2\n"
            "ITEM: ATOMS id type x y z radius\n"
            + "\n".join(f"{i} 1 {x} {y} {z} {r}" for i, (x, y, z, r) in enumerate(rows)))
    (tmp_path / "d.liggghts").write_text(dump)
    c, r = read_positions(tmp_path, PositionsResult(file="d.liggghts",
                                                    format="lammps_dump").model_dump())
    np.testing.assert_allclose(c, [[0, 0, 5], [1, 2, 7]])  # the last snapshot
    np.testing.assert_allclose(r, [1.0, 1.5])


@pytest.mark.parametrize(("text", "match"), [
    (None, "not found"), ("x,y,z\n1,2,3\n", "no column radius"),
    ("x,y,z,radius\n1,2,nan,1\n", "not finite"), ("x,y,z,radius\n1,2,3,0\n", "radius is <= 0"),
    ("x,y,z,radius\n1,2,three,4\n", "not a number"), ("x,y,z,radius\n", "no spheres")])
def test_unreadable_positions_say_why(tmp_path, text, match):
    if text is not None:
        (tmp_path / "pile.csv").write_text(text)
    with pytest.raises(ResultUnreadable, match=match):
        read_positions(tmp_path, PositionsResult(file="pile.csv").model_dump())


def test_value_results(tmp_path):
    spec = {"file": "aor.txt", "key": "aor_deg"}
    (tmp_path / "aor.txt").write_text("33.5\n")
    assert read_value(tmp_path, spec)["aor_deg"] == 33.5
    (tmp_path / "aor.txt").write_text(json.dumps({"aor_deg": 31.0, "mass_kg": 2.0}))
    got = read_value(tmp_path, spec)
    assert got["outcome"] == "pile" and got["engine_values"] == {"mass_kg": 2.0}
    (tmp_path / "aor.txt").write_text(json.dumps({"outcome": "column", "reason": "stands"}))
    assert read_value(tmp_path, spec)["outcome"] == "column"
    for bad, match in (('{"outcome": "lava"}', "outcome must be"), ("95", r"\(0, 90\)"),
                       ("hello", "neither a number"), ('{"x": 1}', "no 'aor_deg'")):
        (tmp_path / "aor.txt").write_text(bad)
        with pytest.raises(ResultUnreadable, match=match):
            read_value(tmp_path, spec)


# --- one run of a real executable ---------------------------------------------------------

def _engine(tmp_path: Path, mode: str = "ok", **kw) -> TestDef:
    shutil.copy(EXAMPLE / "engine.py", tmp_path / "engine.py")
    text = (EXAMPLE / "input.txt.template").read_text().replace("mode = ok", f"mode = {mode}")
    text = text.replace("noise_deg = 0.3", "noise_deg = 0")
    (tmp_path / "input.txt.template").write_text(text)
    spec = TemplateEngine.model_validate({
        "template": "input.txt.template",
        "command": ["{python}", "{template_dir}/engine.py", "{input}"],
        "result": {"kind": "positions", "file": "pile.csv"}, **kw})
    engine = load_engine(spec, tmp_path, KNOWN)
    return TestDef(kind="template", external=engine.for_runs(
        tmp_path / "runs", {"x3": "pp.static_friction"}))


def _task(test: TestDef, mu: float = 0.6, seed: int = 3) -> RunTask:
    params = {**preset_parameters("corn_stalk"), "pp.static_friction": mu,
              "pp.rolling_friction": 0.2, "pw.static_friction": 0.55}
    return RunTask("screening:0123456789abcdef", test, params, seed)


def test_a_run_fills_the_template_runs_the_engine_and_measures_its_pile(tmp_path):
    test = _engine(tmp_path)
    res = run_template(_task(test, mu=0.9), str(tmp_path / "fig" / "pile.png"))
    planted = 30 + 15 * 0.3 - 10 * 0.09
    assert res.outcome == "pile" and abs(res.value("aor_deg") - planted) < 1.0, res
    run_dir = tmp_path / "runs" / "screening_0123456789abcdef"
    assert run_dir_name("screening:0123456789abcdef") == run_dir.name
    filled = (run_dir / "input.txt").read_text()
    assert "pp.static_friction = 0.9\n" in filled and "seed = 3\n" in filled
    assert "{" + "seed}" not in filled.split("\n", 3)[-1]
    assert "planted angle" in (run_dir / LOG_NAME).read_text()
    art = res.detail["artefacts"]
    assert art["engine_log"] == str(run_dir / LOG_NAME) and Path(art["pile_png"]).is_file()
    assert res.detail["engine"]["status"] == "exit code 0"
    assert res.detail["measured"]["n_rejected"] == 0
    json.dumps(res.detail)  # JSON-ready for the store
    # the pile demcal measured from the engine's positions: its angle, height and base
    assert set(res.responses) == {"aor_deg", "pile_height_m", "base_diameter_m"}


@pytest.mark.parametrize(("mode", "outcome", "match"), [
    ("crash", "engine_error", "exit code 3"),
    ("silent", "no_result", "result file pile.csv not found"),
    ("garbage", "no_result", "not a number")])
def test_engine_failures_are_typed_with_the_log(tmp_path, mode, outcome, match):
    res = run_template(_task(_engine(tmp_path, mode)))
    assert res.outcome == outcome and res.value("aor_deg") is None
    assert match in res.reason and LOG_NAME in res.reason
    if mode == "crash":
        assert "crashed on purpose" in res.reason  # the log's last lines are quoted


def test_a_missing_program_is_an_engine_error(tmp_path):
    test = _engine(tmp_path)
    engine = replace(test.external, command=("no-such-dem-engine-xyz", "{input}"))
    res = run_template(_task(TestDef(kind="template", external=engine)))
    assert res.outcome == "engine_error" and "command not found" in res.reason


def test_timeout_kills_the_engine_and_its_children(tmp_path):
    test = _engine(tmp_path, timeout_s=3.0)  # time for sh to start on a loaded machine
    engine = replace(test.external, command=("sh", "-c", "sleep 60 & echo $! > child.pid; wait"))
    t0 = time.monotonic()
    res = run_template(_task(TestDef(kind="template", external=engine)))
    assert time.monotonic() - t0 < 30
    assert res.outcome == "timeout" and "3 s" in res.reason
    pid = int((Path(res.detail["engine"]["run_dir"]) / "child.pid").read_text())
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        try:
            os.kill(pid, 0)
            if Path(f"/proc/{pid}/stat").read_text().split()[2] == "Z":
                break  # dead, not yet reaped by init
        except (ProcessLookupError, FileNotFoundError):
            break
        time.sleep(0.1)
    else:
        pytest.fail(f"the engine's child {pid} survived the timeout")


def test_identity_holds_the_template_and_command_not_the_timeout(tmp_path):
    a = _engine(tmp_path)
    b = _engine(tmp_path, timeout_s=5.0)
    assert a.identity() == b.identity()
    (tmp_path / "input.txt.template").write_text(
        (tmp_path / "input.txt.template").read_text() + "# edited\n")
    spec = TemplateEngine.model_validate({
        "template": "input.txt.template", "command": "{python} engine.py {input}",
        "result": {"kind": "positions", "file": "pile.csv"}})
    c = TestDef(kind="template", external=load_engine(spec, tmp_path, KNOWN))
    assert c.identity()["engine"]["template_sha256"] != a.identity()["engine"][
        "template_sha256"]
    assert c.identity()["engine"]["command"] == ["{python}", "engine.py", "{input}"]


def test_the_identity_is_the_stored_runs_file_format(tmp_path):
    """Every stored engine run's key hashes this dict: its keys and values are a file format
    (a study resumed by another release must find its runs), whatever type holds the engine."""
    import hashlib

    test = _engine(tmp_path)
    text = (tmp_path / "input.txt.template").read_text()
    assert test.identity() == {
        "kind": "template", "measurement": MEASUREMENT_VERSION,
        "engine": {"kind": "template", "template_sha256": hashlib.sha256(text.encode()).hexdigest(),
                   "input": "input.txt",
                   "command": ["{python}", "{template_dir}/engine.py", "{input}"], "hook": None,
                   "result": PositionsResult(file="pile.csv").model_dump(mode="json")}}
    moved = test.external.for_runs(tmp_path / "elsewhere", {})  # where runs are kept: not in it
    assert TestDef(kind="template", external=moved).identity() == test.identity()


def test_unknown_placeholder_is_refused_when_the_study_is_read(tmp_path):
    (tmp_path / "t.in").write_text("mu {pp.static_frction}\n")
    spec = TemplateEngine.model_validate({"template": "t.in", "command": "x {input}",
                                          "result": {"kind": "value", "file": "a.txt"}})
    with pytest.raises(InputError, match=r"unknown placeholder\(s\) \{pp.static_frction\}"):
        load_engine(spec, tmp_path, KNOWN)
    assert set(BUILTINS) >= {"seed", "run_dir", "input", "python", "dt_scale"}


def test_a_hook_adds_placeholders(tmp_path):
    (tmp_path / "hook.py").write_text(
        "def fill(params, seed, run_dir):\n"
        "    (run_dir / 'extra.txt').write_text('made by the hook')\n"
        "    return {'prime_seed': 10007 + 2 * seed}\n")
    (tmp_path / "t.in").write_text("seed {prime_seed}\n")
    spec = TemplateEngine.model_validate({
        "template": "t.in", "hook": "hook.py:fill",
        "command": ["{python}", "-c", "print(open('t.in').read())"],
        "result": {"kind": "value", "file": "aor.txt"}})
    engine = load_engine(spec, tmp_path, KNOWN)
    assert engine.hook_sha256 and engine.input == "t.in"
    engine = engine.for_runs(tmp_path / "runs")
    res = run_template(_task(TestDef(kind="template", external=engine), seed=4))
    run_dir = Path(res.detail["engine"]["run_dir"])
    assert (run_dir / "t.in").read_text() == "seed 10015\n"
    assert (run_dir / "extra.txt").is_file() and "seed 10015" in (run_dir / LOG_NAME).read_text()
    assert res.outcome == "no_result"  # it wrote no aor.txt


def test_a_terminated_worker_takes_its_engine_down(tmp_path):
    """SIGTERM to the worker (a pool's terminate on Ctrl-C) kills the engine's process group
    rather than leaving it running as an orphan."""
    import pickle
    import signal
    import subprocess
    import sys

    test = _engine(tmp_path, timeout_s=60.0)
    engine = replace(test.external, command=("sh", "-c", "echo $$ > engine.pid; sleep 60"))
    task = _task(TestDef(kind="template", external=engine))
    (tmp_path / "task.pkl").write_bytes(pickle.dumps(task))
    code = ("import pickle, sys; from demcal.execute.template_engine import run_template; "
            "run_template(pickle.load(open(sys.argv[1], 'rb')))")
    worker = subprocess.Popen([sys.executable, "-c", code, str(tmp_path / "task.pkl")])
    pid_file = tmp_path / "runs" / run_dir_name(task.key) / "engine.pid"
    deadline = time.monotonic() + 30
    while not (pid_file.is_file() and pid_file.read_text().strip()):
        assert time.monotonic() < deadline and worker.poll() is None
        time.sleep(0.05)
    engine_pid = int(pid_file.read_text())
    worker.send_signal(signal.SIGTERM)
    assert worker.wait(timeout=30) != 0
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        try:
            os.kill(engine_pid, 0)
        except ProcessLookupError:
            break
        time.sleep(0.1)
    with pytest.raises(ProcessLookupError):
        os.kill(engine_pid, 0)
