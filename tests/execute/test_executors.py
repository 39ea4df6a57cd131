"""Executors: the spawn pool (one thread per worker) and Dask give the inline results."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from demcal.execute import RunTask, TestDef, run_local
from demcal.execute.analytic import analytic_aor
from demcal.results import RunResult

# distributed's scheduler serves its HTTP routes on port 8787 even with no dashboard; when a
# parallel test (pytest -n) or another suite on the host holds it, it moves and warns, and
# warnings are errors here: a free port of the OS's choosing instead
FREE_PORT = "127.0.0.1:0"

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "analytic" / "study.toml"
OPTIONS = {"base_deg": 30.0, "linear": {"pp.static_friction": 20.0}, "noise_deg": 0.5,
           "no_pile_above": {"pp.static_friction": 0.85}}


def _tasks(n: int) -> list[RunTask]:
    test = TestDef(kind="analytic", analytic=OPTIONS)
    return [RunTask(f"k{i}", test, {"pp.static_friction": 0.1 * i}, seed=i) for i in range(n)]


def test_spawn_pool_matches_inline_and_sets_one_thread():
    tasks = _tasks(10)
    got: dict[str, RunResult] = {}
    run_local([[t] for t in tasks], lambda r: got.__setitem__(r.key, r), workers=2)
    assert sorted(got) == sorted(t.key for t in tasks)
    for t in tasks:
        ref = analytic_aor(t.params, t.seed, OPTIONS)
        assert got[t.key].outcome == ref["outcome"]
        assert got[t.key].value("aor_deg") == ref["aor_deg"]
    workers = {r.worker["pid"] for r in got.values()}
    assert os.getpid() not in workers and 1 <= len(workers) <= 2
    assert {r.worker["numba_threads"] for r in got.values()} == {"1"}
    assert got["k9"].outcome == "column" and got["k9"].value("aor_deg") is None


def test_pool_study_equals_inline_study(tmp_path):
    from demcal.calibrate import calibrate

    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    shutil.copy(EXAMPLE, a / "study.toml")
    shutil.copy(EXAMPLE, b / "study.toml")
    ra = calibrate(a / "study.toml", workers=1)
    rb = calibrate(b / "study.toml", workers=2)
    assert ra["optimum"] == rb["optimum"] and ra["verification"] == rb["verification"]


def test_dask_local_cluster_runs_the_study(tmp_path):
    distributed = pytest.importorskip("distributed")
    from demcal.calibrate import calibrate

    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    shutil.copy(EXAMPLE, a / "study.toml")
    shutil.copy(EXAMPLE, b / "study.toml")
    ref = calibrate(a / "study.toml", workers=1)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=FREE_PORT) as cluster:
        res = calibrate(b / "study.toml", dask=cluster.scheduler_address)
    assert res["optimum"] == ref["optimum"]
    assert res["verification"] == ref["verification"]
    assert res["n_runs"] == ref["n_runs"] == 40


def test_dask_worker_killed_mid_run_loses_nothing(tmp_path):
    """SIGKILL one Dask worker process during the screening stage: the scheduler reruns its
    task elsewhere, every run ends up stored once, and the answer is the undisturbed one."""
    distributed = pytest.importorskip("distributed")
    import signal
    import threading
    import time

    from demcal.calibrate import calibrate
    from demcal.store import RunStore

    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    shutil.copy(EXAMPLE, a / "study.toml")
    text = EXAMPLE.read_text().replace("noise_deg = 0.3", "noise_deg = 0.3\ndelay_s = 0.15")
    (b / "study.toml").write_text(text)
    ref = calibrate(a / "study.toml", workers=1)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=FREE_PORT) as cluster, \
            distributed.Client(cluster) as client:
        pids = list(client.run(os.getpid).values())
        killed: list[int] = []

        def killer() -> None:
            deadline = time.monotonic() + 60
            while time.monotonic() < deadline and not killed:
                time.sleep(0.05)
                if (b / "demcal.sqlite").exists():
                    with RunStore(b) as store:
                        if store.count("screening") >= 2:
                            os.kill(pids[0], signal.SIGKILL)
                            killed.append(pids[0])

        thread = threading.Thread(target=killer)
        thread.start()
        res = calibrate(b / "study.toml", dask=cluster.scheduler_address)
        thread.join()
    assert killed
    assert res["optimum"] == ref["optimum"] and res["n_runs"] == 40
    with RunStore(b) as store:
        assert store.count() == 40


@pytest.mark.slow
def test_engine_runs_through_run_chunk_with_a_halved_time_step():
    """The real virtual test behind the executor (tiny fill, ~30 s): typed outcomes, and the
    retry's dt_scale halves the engine's time step."""
    from demcal.virtual import preset_parameters

    test = TestDef(kind="aor", fidelity="quick", overrides={"fill": {"count": 40}})
    p = preset_parameters("corn_stalk", {"pp.surface_energy": 0.0})
    full, half = run_local_results([RunTask("a", test, p, 1),
                                    RunTask("b", test, p, 1, dt_scale=0.5)])
    for r in (full, half):
        assert r.outcome in ("pile", "column", "plug", "scattered", "unsettled", "unstable")
        assert (r.value("aor_deg") is None) == (r.outcome != "pile")
    assert half.detail["time_step_s"] == pytest.approx(0.5 * full.detail["time_step_s"])


def run_local_results(tasks: list[RunTask]) -> list[RunResult]:
    got: dict[str, RunResult] = {}
    run_local([tasks], lambda r: got.__setitem__(r.key, r), workers=1)
    return [got[t.key] for t in tasks]


def test_interrupt_stops_the_pool_and_keeps_finished_results():
    """An exception in the parent (as Ctrl-C) while workers run: results already handed over
    are kept, queued tasks are dropped and no worker process is left running."""
    import multiprocessing

    test = TestDef(kind="analytic", analytic={**OPTIONS, "delay_s": 0.3})
    tasks = [RunTask(f"k{i}", test, {"pp.static_friction": 0.05 * i}, seed=i)
             for i in range(12)]
    got: list[str] = []

    class Stop(BaseException):
        pass

    def on_result(r: RunResult) -> None:
        got.append(r.key)
        if len(got) == 3:
            raise Stop

    with pytest.raises(Stop):
        run_local([[t] for t in tasks], on_result, workers=2)
    assert len(got) == 3
    alive = [c.pid for c in multiprocessing.active_children() if c.is_alive()]
    assert not alive, alive


def test_default_chunk_batches_replicates_on_cpu_and_a_stage_on_a_gpu():
    from demcal.execute.local import GPU_CHUNK, default_chunk

    assert default_chunk("cpu", 3) == 3
    assert default_chunk("cpu", 1) == 1
    assert default_chunk("cuda", 1) == GPU_CHUNK
    # "auto" is resolved (no GPU here, so the CPU rule), not read as a string
    assert default_chunk("auto", 4) == 4
