"""Stores written by the schema-1 release (one response, ``runs.aor_deg``) keep working.

``data/store_v1_analytic.sqlite.gz`` is the store that ``demcal calibrate
examples/analytic/study.toml`` wrote on 2026-11-27 with the schema-1 code (commit ff0194e): 40
runs (38 piles), every stage done.
"""

from __future__ import annotations

import gzip
import hashlib
import json
import shutil
import sqlite3
from pathlib import Path

import pytest

from demcal.store import SCHEMA_VERSION, STORE_NAME, RunRecord, RunStore

DATA = Path(__file__).parent / "data" / "store_v1_analytic.sqlite.gz"
EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "analytic" / "study.toml"


@pytest.fixture
def v1_study(tmp_path: Path) -> Path:
    """The analytic example study beside its schema-1 store."""
    shutil.copy(EXAMPLE, tmp_path / "study.toml")
    with gzip.open(DATA, "rb") as src, (tmp_path / STORE_NAME).open("wb") as dst:
        shutil.copyfileobj(src, dst)
    return tmp_path / "study.toml"


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _v1_angles(path: Path) -> dict[str, float]:
    with sqlite3.connect(path) as conn:
        return dict(conn.execute("SELECT key, aor_deg FROM runs WHERE aor_deg IS NOT NULL"))


def test_a_read_only_open_reads_schema_1_as_it_is(v1_study: Path) -> None:
    store_path = v1_study.parent / STORE_NAME
    before = _digest(store_path)
    angles = _v1_angles(store_path)
    assert len(angles) == 38
    with RunStore(store_path, readonly=True) as store:
        assert store.meta("schema_version") == 1
        runs = store.runs()
        assert len(runs) == 40
        got = {r.key: r.aor_deg for r in runs if r.aor_deg is not None}
        assert got == angles
        one = next(iter(angles))
        assert store.get_run(one).responses == {"aor_deg": angles[one]}
    assert _digest(store_path) == before  # the report never changes a store


def test_a_writable_open_migrates_in_place_keeping_every_angle(v1_study: Path) -> None:
    store_path = v1_study.parent / STORE_NAME
    angles = _v1_angles(store_path)
    with RunStore(store_path) as store:
        assert store.meta("schema_version") == SCHEMA_VERSION == 2
        assert {r.key: r.aor_deg for r in store.runs() if r.aor_deg is not None} == angles
        stages = {s.name: s.summary for s in store.stages()}
    with sqlite3.connect(store_path) as conn:
        rows = conn.execute("SELECT key, name, value FROM responses").fetchall()
    assert {k: v for k, n, v in rows if n == "aor_deg"} == angles
    assert len(rows) == 38
    with RunStore(store_path, readonly=True) as store:  # opened again: nothing to migrate
        assert {s.name: s.summary for s in store.stages()} == stages


def test_a_migrated_study_resumes_with_nothing_run_again(v1_study: Path) -> None:
    from demcal.calibrate import calibrate

    with RunStore(v1_study.parent / STORE_NAME, readonly=True) as store:
        before = store.meta("result")
    res = calibrate(v1_study, workers=1)
    assert res["n_runs_executed"] == 0 and res["n_runs"] == 40
    assert res["optimum"] == before["optimum"]
    assert res["verification"] == before["verification"]
    assert json.dumps(res["optimum_full"], sort_keys=True) == json.dumps(
        before["optimum_full"], sort_keys=True)


def test_several_named_responses_round_trip(tmp_path: Path) -> None:
    run = RunRecord(key="rsm:a", stage="rsm", point=1, replicate=0, params={"x": 1.0}, seed=1,
                    status="done", outcome="pile",
                    responses={"aor_deg": 41.0, "bulk_density_kg_m3": 212.5, "drum_deg": 38.0})
    with RunStore(tmp_path) as store:
        store.record_run(run)
        store.record_run(RunRecord(**{**run.__dict__, "key": "rsm:b",
                                      "responses": {"drum_deg": 36.0}}))
        got = store.get_run("rsm:a")
        assert got.responses == run.responses
        assert got.response("bulk_density_kg_m3") == 212.5 and got.aor_deg == 41.0
        b = store.runs()[1]
        assert b.key == "rsm:b" and b.responses == {"drum_deg": 36.0} and b.aor_deg is None
        # a replaced run keeps no response of its former self
        store.record_run(RunRecord(**{**run.__dict__, "responses": {"aor_deg": 40.0}}))
        assert store.get_run("rsm:a").responses == {"aor_deg": 40.0}


def test_salvage_keeps_every_response(tmp_path: Path, v1_study: Path) -> None:
    from demcal.store import salvage

    run = RunRecord(key="rsm:a", stage="rsm", point=1, replicate=0, params={"x": 1.0}, seed=1,
                    status="done", outcome="pile",
                    responses={"aor_deg": 41.0, "bulk_density_kg_m3": 212.5})
    with RunStore(tmp_path / "new") as store:
        store.record_run(run)
    salvage(tmp_path / "new", tmp_path / "copy.sqlite")
    with RunStore(tmp_path / "copy.sqlite", readonly=True) as store:
        assert store.get_run("rsm:a").responses == run.responses
    # and from a schema-1 store: the angles of its runs
    angles = _v1_angles(v1_study.parent / STORE_NAME)
    salvage(v1_study.parent, tmp_path / "v1copy.sqlite")
    with RunStore(tmp_path / "v1copy.sqlite", readonly=True) as store:
        assert {r.key: r.aor_deg for r in store.runs() if r.aor_deg is not None} == angles
