"""Several LAMMPS runs at once (``LammpsOptions.jobs``, ``simulate aor --jobs``): the runs
overlap, come back in their order, and a stop ends every running LAMMPS group at once.

A stand-in ``lmp`` (a shell script that notes when it starts and ends, then sleeps and fails)
takes LAMMPS' place, so these run where LAMMPS is not installed; each run is then
``unstable`` with the stand-in's exit status, which is all the runner needs to be checked.
"""

from __future__ import annotations

import stat
import sys
import time
from pathlib import Path

import pytest
from process_checks import wait_gone
from typer.testing import CliRunner

from demcal.cli import app
from demcal.virtual import fidelity_config, preset_parameters
from demcal.virtual.lammps_options import LammpsOptions
from demcal.virtual.lammps_run import RunReporting, run_aor_lammps

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="Linux /proc")

PARAMS = preset_parameters("corn_stalk")
#: a test small enough to write in a blink (the stand-in never runs it)
CONFIG = fidelity_config("quick", fill={"count": 20})


def _stand_in(tmp_path: Path, seconds: float) -> Path:
    """An ``lmp`` that appends 'start|end <time> <pid>' to ``tmp_path/times``, sleeps in a
    child of its own (as ranks would be) and exits 3."""
    lmp = tmp_path / "lmp"
    times = tmp_path / "times"
    lmp.write_text(f"""#!/bin/sh
echo "start $(date +%s.%N) $$" >> {times}
sleep {seconds} &
echo $! >> {tmp_path}/children
wait
echo "end $(date +%s.%N) $$" >> {times}
exit 3
""")
    lmp.chmod(lmp.stat().st_mode | stat.S_IXUSR)
    return lmp


def _options(lmp: Path, jobs: int) -> LammpsOptions:
    # a launcher prefix keeps mpirun out of it (not installed without the extra)
    return LammpsOptions(lmp=str(lmp), launcher="env", jobs=jobs)


def _most_at_once(times: Path) -> int:
    events = sorted((float(t), +1 if what == "start" else -1)
                    for what, t, _ in (line.split() for line in times.read_text().splitlines()))
    running = most = 0
    for _, step in events:
        running += step
        most = max(most, running)
    return most


def test_jobs_run_that_many_at_once_and_keep_the_runs_order(tmp_path):
    lmp = _stand_in(tmp_path, 1.0)
    seen: list[int] = []
    results = run_aor_lammps([PARAMS] * 5, config=CONFIG, seeds=[11, 12, 13, 14, 15],
                             options=_options(lmp, 2),
                             reporting=RunReporting(on_result=lambda i, r: seen.append(i)))
    assert [r.seed for r in results] == [11, 12, 13, 14, 15]
    assert all(r.outcome == "unstable" and "exit status 3" in (r.reason or "")
               for r in results)
    assert all(r.engine == "lammps" for r in results)
    assert sorted(seen) == [0, 1, 2, 3, 4]
    assert _most_at_once(tmp_path / "times") == 2


def test_one_job_runs_one_after_another(tmp_path):
    lmp = _stand_in(tmp_path, 0.3)
    results = run_aor_lammps([PARAMS] * 3, config=CONFIG, seeds=[1, 2, 3],
                             options=_options(lmp, 1))
    assert [r.seed for r in results] == [1, 2, 3]
    assert _most_at_once(tmp_path / "times") == 1


def test_a_stop_ends_every_running_lammps_at_once(tmp_path):
    # the first LAMMPS to start ends soon and its result's handler fails (as Ctrl-C or
    # SIGTERM would land in this thread); the others would run a minute: each one running
    # (the second, and the third if its thread took it up before the stop) is ended, with
    # its child, before the stop goes on
    for name in ("fast", "slow"):
        (tmp_path / name).mkdir()
    fast, slow = _stand_in(tmp_path / "fast", 0.2), _stand_in(tmp_path / "slow", 60.0)
    lmp = tmp_path / "lmp"
    lmp.write_text(f"#!/bin/sh\nif mkdir {tmp_path}/first 2>/dev/null; then exec {fast} "
                   f"\"$@\"; fi\nexec {slow} \"$@\"\n")
    lmp.chmod(lmp.stat().st_mode | stat.S_IXUSR)

    class Stop(Exception):
        pass

    def fail(i, res):
        raise Stop

    t0 = time.monotonic()
    with pytest.raises(Stop):
        run_aor_lammps([PARAMS] * 3, config=CONFIG, seeds=[101, 102, 103],
                       options=_options(lmp, 2), reporting=RunReporting(on_result=fail))
    took = time.monotonic() - t0
    assert took < 20.0, f"the stop waited {took:.1f} s for a LAMMPS that should have ended"
    children = [int(p) for p in (tmp_path / "slow" / "children").read_text().split()]
    assert 1 <= len(children) <= 2
    assert wait_gone(children, timeout=5.0), "a running LAMMPS outlived the stop"


def test_simulate_refuses_jobs_for_demcal_s_engine():
    res = CliRunner().invoke(app, ["simulate", "aor", "--jobs", "2"])
    assert res.exit_code == 2
    assert "--jobs is for --engine lammps" in res.output


@pytest.mark.parametrize("jobs", ["0", "257"])
def test_simulate_refuses_jobs_out_of_range(jobs):
    res = CliRunner().invoke(app, ["simulate", "aor", "--engine", "lammps", "--jobs", jobs])
    assert res.exit_code == 2
    assert "--jobs must be in 1..256" in res.output


def test_a_study_refuses_lammps_jobs(tmp_path):
    study = tmp_path / "study.toml"
    study.write_text('name = "x"\n[[factors]]\nname = "pp.static_friction"\nlow = 0.3\n'
                     'high = 0.6\n[target]\naor_deg = 40\n[executor]\nengine = "lammps"\n'
                     '[executor.lammps]\njobs = 2\n')
    res = CliRunner().invoke(app, ["calibrate", str(study)])
    assert res.exit_code == 2
    assert "executor.lammps: jobs = 2: a study runs [executor] workers" in res.output
