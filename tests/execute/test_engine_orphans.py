"""Issue 38, class 3: an external engine dies with the demcal process that started it,
whatever kills that one (SIGKILL included), and a resumed run never runs beside it."""

from __future__ import annotations

import pickle
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from process_checks import PID_FILES, kill_9_when_started, wait_gone

from demcal.engine_guard import PID_FILE, note_engine
from demcal.execute.engine_spec import TemplateEngine, load_engine
from demcal.execute.tasks import RunTask, TestDef
from demcal.execute.template_engine import run_dir_name, run_template
from demcal.virtual import PARAMETERS, preset_parameters

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="Linux /proc")

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "stand_in_engine"


def _task(tmp_path: Path, command: list[str]) -> RunTask:
    shutil.copy(EXAMPLE / "engine.py", tmp_path / "engine.py")
    shutil.copy(EXAMPLE / "input.txt.template", tmp_path / "input.txt.template")
    spec = TemplateEngine.model_validate({
        "template": "input.txt.template", "command": command, "timeout_s": 120.0,
        "result": {"kind": "positions", "file": "pile.csv"}})
    engine = load_engine(spec, tmp_path, set(PARAMETERS))
    engine = engine.for_runs(tmp_path / "runs")
    params = {**preset_parameters("corn_stalk"), "pp.static_friction": 0.6}
    return RunTask("screening:0123456789abcdef", TestDef(kind="template", external=engine),
                   params, 3)


def test_kill_9_of_demcal_takes_the_engine_and_its_children_down(tmp_path):
    # the engine (sh) starts a child of its own: a parent-death signal would miss that one
    task = _task(tmp_path, ["sh", "-c", "sleep 120 & echo $! > child.pid; echo $$ > "
                            "engine.pid; wait"])
    (tmp_path / "task.pkl").write_bytes(pickle.dumps(task))
    code = ("import pickle, sys; from demcal.execute.template_engine import run_template; "
            "run_template(pickle.load(open(sys.argv[1], 'rb')))")
    worker = subprocess.Popen([sys.executable, "-c", code, str(tmp_path / "task.pkl")])
    pids = kill_9_when_started(worker, tmp_path / "runs" / run_dir_name(task.key))
    assert wait_gone(pids), f"the engine's processes {pids} outlived demcal"


def test_a_resumed_run_ends_the_killed_studys_engine_first(tmp_path):
    task = _task(tmp_path, ["{python}", "{template_dir}/engine.py", "{input}"])
    run_dir = tmp_path / "runs" / run_dir_name(task.key)
    run_dir.mkdir(parents=True)
    # a killed study's engine, still running in the run's folder (its watchdog gone too)
    orphan = subprocess.Popen(["sleep", "120"], cwd=run_dir, start_new_session=True)
    try:
        note_engine(run_dir, orphan.pid)
        assert (run_dir / PID_FILE).is_file()
        res = run_template(task)
        assert res.outcome == "pile", res
        assert orphan.wait(timeout=20) == -signal.SIGTERM
    finally:
        if orphan.poll() is None:
            orphan.kill()


def test_a_pid_file_naming_another_process_touches_nothing(tmp_path):
    task = _task(tmp_path, ["{python}", "{template_dir}/engine.py", "{input}"])
    run_dir = tmp_path / "runs" / run_dir_name(task.key)
    run_dir.mkdir(parents=True)
    other = subprocess.Popen(["sleep", "120"], start_new_session=True)
    try:  # the pid was reused: its start time differs from the one noted
        (run_dir / PID_FILE).write_text(f"{other.pid} 1\n")
        assert run_template(task).outcome == "pile"
        assert other.poll() is None
    finally:
        other.kill()
        other.wait()


# ------------------------------------------------------------------------------ LAMMPS
_RANKS = "sleep 60 & echo $! > child.pid; echo $$ > engine.pid; wait"


def test_lammps_ranks_end_with_their_time_limit(tmp_path):
    """A LAMMPS run past its limit: its whole group (the launcher and the ranks it started)
    is ended, not only the first process."""
    from demcal.virtual.lammps_run import launch

    why = launch(["sh", "-c", _RANKS], tmp_path, 2.0)
    assert why is not None and "time limit of 2 s" in why
    pids = [int((tmp_path / f).read_text()) for f in PID_FILES]
    assert wait_gone(pids), f"LAMMPS' processes {pids} outlived their time limit"


def test_lammps_ranks_die_with_a_killed_demcal(tmp_path):
    """kill -9 of the process running LAMMPS: the watchdog ends the ranks."""
    code = ("import sys; from pathlib import Path; from demcal.virtual.lammps_run import "
            f"launch; launch(['sh', '-c', {_RANKS!r}], Path(sys.argv[1]), 600.0)")
    worker = subprocess.Popen([sys.executable, "-c", code, str(tmp_path)])
    pids = kill_9_when_started(worker, tmp_path)
    assert wait_gone(pids), f"LAMMPS' processes {pids} outlived demcal"
