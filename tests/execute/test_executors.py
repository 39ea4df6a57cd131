"""Executors: the spawn pool (one thread per worker) and Dask give the inline results."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from demcal.execute import RunTask, TestDef, run_local
from demcal.execute.analytic import analytic_aor

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "analytic" / "study.toml"
OPTIONS = {"base_deg": 30.0, "linear": {"pp.static_friction": 20.0}, "noise_deg": 0.5,
           "no_pile_above": {"pp.static_friction": 0.85}}


def _tasks(n: int) -> list[RunTask]:
    test = TestDef(kind="analytic", analytic=OPTIONS)
    return [RunTask(f"k{i}", test, {"pp.static_friction": 0.1 * i}, seed=i) for i in range(n)]


def test_spawn_pool_matches_inline_and_sets_one_thread():
    tasks = _tasks(10)
    got: dict[str, dict] = {}
    run_local([[t] for t in tasks], lambda r: got.__setitem__(r["key"], r), workers=2)
    assert sorted(got) == sorted(t.key for t in tasks)
    for t in tasks:
        ref = analytic_aor(t.params, t.seed, OPTIONS)
        assert got[t.key]["outcome"] == ref["outcome"]
        assert got[t.key]["aor_deg"] == ref["aor_deg"]
    workers = {r["worker"]["pid"] for r in got.values()}
    assert os.getpid() not in workers and 1 <= len(workers) <= 2
    assert {r["worker"]["numba_threads"] for r in got.values()} == {"1"}
    assert got["k9"]["outcome"] == "column" and got["k9"]["aor_deg"] is None


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
                                  dashboard_address=None) as cluster:
        res = calibrate(b / "study.toml", dask=cluster.scheduler_address)
    assert res["optimum"] == ref["optimum"]
    assert res["verification"] == ref["verification"]
    assert res["n_runs"] == ref["n_runs"] == 40
