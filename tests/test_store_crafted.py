"""Issue 38, classes 7 and 9 (the store): crafted rows are one line, never a traceback;
`store salvage` never turns a newer-schema store into this demcal's schema in silence."""

from __future__ import annotations

import json
import sqlite3

import pytest

from demcal.errors import StoreError
from demcal.store import STORE_NAME, RunRecord, RunStore, salvage


def _store(tmp_path, n=3):
    with RunStore(tmp_path) as store:
        for i in range(n):
            store.record_run(RunRecord(key=f"screening:{i}", stage="screening", point=i,
                                       replicate=0, params={"pp.static_friction": 0.5 + i},
                                       seed=i, status="done", outcome="pile",
                                       responses={"aor_deg": 40.0},
                                       result={"aor_deg": 40.0}))
    return tmp_path / STORE_NAME


def _sql(path, statement, *args):
    conn = sqlite3.connect(path)
    conn.execute(statement, args)
    conn.commit()
    conn.close()


def test_a_params_list_is_a_damaged_row_not_a_type_error(tmp_path):
    path = _store(tmp_path)
    _sql(path, "UPDATE runs SET params_json = '[1, 2]' WHERE key = 'screening:1'")
    with RunStore(tmp_path, readonly=True) as store, \
            pytest.raises(StoreError, match=r"run 'screening:1': params is a JSON list"):
        store.runs()


def test_a_meta_of_the_wrong_type_is_one_line_in_the_report(tmp_path):
    from demcal.report.data import load_report_data

    path = _store(tmp_path)
    _sql(path, "INSERT OR REPLACE INTO meta VALUES ('study', '[1, 2]')")
    with pytest.raises(StoreError, match=r"meta 'study' is a JSON list"):
        load_report_data(tmp_path)


def test_salvage_refuses_a_newer_schema_and_writes_nothing(tmp_path):
    path = _store(tmp_path)
    _sql(path, "UPDATE meta SET value_json = '99' WHERE key = 'schema_version'")
    with pytest.raises(StoreError, match=r"schema version 99.*upgrade demcal"):
        salvage(tmp_path, tmp_path / "new.sqlite")
    assert not (tmp_path / "new.sqlite").exists()


def test_salvage_skips_a_deeply_nested_cell(tmp_path):
    path = _store(tmp_path)
    deep = "[" * 100_000 + "]" * 100_000
    _sql(path, "UPDATE runs SET result_json = ? WHERE key = 'screening:1'", deep)
    _sql(path, "INSERT OR REPLACE INTO stages VALUES ('x', 'done', ?, NULL, 0)", deep)
    _sql(path, "INSERT OR REPLACE INTO meta VALUES ('deep', ?)", deep)
    counts = salvage(tmp_path, tmp_path / "new.sqlite")
    assert counts["runs"] == 2 and counts["runs_skipped"] == 1
    with RunStore(tmp_path / "new.sqlite", readonly=True) as store:
        assert json.dumps(store.get_run("screening:0").params)


@pytest.mark.parametrize("crafted", [
    "UPDATE runs SET aor_deg = 1e308 WHERE key = 'screening:2'",
    "UPDATE responses SET value = 1e308 WHERE key = 'screening:2' AND name = 'aor_deg'",
])
def test_a_stored_angle_outside_0_90_is_a_damaged_row(tmp_path, crafted):
    path = _store(tmp_path)
    _sql(path, crafted)
    with RunStore(tmp_path, readonly=True) as store, \
            pytest.raises(StoreError, match=r"aor_deg 1e\+308 is not an angle in \(0, 90\)"):
        store.runs()
    counts = salvage(tmp_path, tmp_path / "new.sqlite")
    assert counts["runs"] == 2 and counts["runs_skipped"] == 1
