"""The run store refuses what is not a sound demcal store, and has one writer at a time."""

from __future__ import annotations

import hashlib
import os
import socket
import sqlite3
import subprocess
import sys
import time

import pytest

from demcal.errors import StoreError
from demcal.store import LOCK_KEY, STORE_NAME, RunRecord, RunStore, salvage


def _run(i: int) -> RunRecord:
    return RunRecord(key=f"screening:{i}", stage="screening", point=i, replicate=0,
                     params={"pp.static_friction": 0.5 + i}, seed=i, status="done",
                     outcome="pile", responses={"aor_deg": 40.0},
                     result={"aor_deg": 40.0, "pad": "x" * 300})


def _digest(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _store(tmp_path, n=3):
    with RunStore(tmp_path) as store:
        for i in range(n):
            store.record_run(_run(i))
    return tmp_path / STORE_NAME


@pytest.mark.parametrize("readonly", [False, True])
def test_zero_byte_file_refused_and_left_alone(tmp_path, readonly):
    path = tmp_path / STORE_NAME
    path.touch()
    with pytest.raises(StoreError, match="empty file"):
        RunStore(tmp_path, readonly=readonly)
    assert path.stat().st_size == 0


@pytest.mark.parametrize("readonly", [False, True])
def test_garbage_file_refused_and_left_alone(tmp_path, readonly):
    path = tmp_path / STORE_NAME
    path.write_bytes(b"hello, not a database\n" * 100)
    before = _digest(path)
    with pytest.raises(StoreError, match="not an SQLite database"):
        RunStore(tmp_path, readonly=readonly)
    assert _digest(path) == before


def test_foreign_sqlite_database_is_not_written(tmp_path):
    path = tmp_path / STORE_NAME
    conn = sqlite3.connect(path)
    conn.execute("CREATE TABLE photos (id INTEGER)")
    conn.commit()
    conn.close()
    before = _digest(path)
    with pytest.raises(StoreError, match="not a demcal run store"):
        RunStore(tmp_path)
    assert _digest(path) == before
    conn = sqlite3.connect(path)
    assert [r[0] for r in conn.execute("SELECT name FROM sqlite_master")] == ["photos"]
    conn.close()


def test_truncated_store_refused_with_a_way_out(tmp_path):
    path = _store(tmp_path, n=300)
    size = path.stat().st_size
    with path.open("r+b") as fh:
        fh.truncate(size // 2)
    with pytest.raises(StoreError, match=r"damaged run store.*salvage"):
        RunStore(tmp_path)
    counts = salvage(tmp_path, tmp_path / "salvaged.sqlite")
    assert 0 < counts["runs"] < 300
    with RunStore(tmp_path / "salvaged.sqlite") as store:
        assert store.count() == counts["runs"]


def test_bad_json_in_a_row_names_the_row(tmp_path):
    path = _store(tmp_path)
    conn = sqlite3.connect(path)
    conn.execute("UPDATE runs SET result_json = '{oops' WHERE key = 'screening:1'")
    conn.commit()
    conn.close()
    with RunStore(tmp_path, readonly=True) as store:
        assert store.get_run("screening:0").aor_deg == 40.0
        with pytest.raises(StoreError, match="run 'screening:1': unreadable JSON"):
            store.runs()
    counts = salvage(tmp_path, tmp_path / "new.sqlite")
    assert counts["runs"] == 2 and counts["runs_skipped"] == 1


def test_newer_schema_refused_untouched(tmp_path):
    path = _store(tmp_path)
    with RunStore(tmp_path) as store:
        store.set_meta("schema_version", 99)
    before = _digest(path)
    with pytest.raises(StoreError, match="newer demcal"):
        RunStore(tmp_path)
    assert _digest(path) == before


def test_readonly_never_creates(tmp_path):
    with pytest.raises(StoreError, match="no run store"):
        RunStore(tmp_path / "s.sqlite", readonly=True)
    assert list(tmp_path.iterdir()) == []


def test_readonly_cannot_write(tmp_path):
    _store(tmp_path)
    with RunStore(tmp_path, readonly=True) as store, pytest.raises(StoreError):
        store.set_meta("x", 1)


# -- one writer per study --------------------------------------------------------------------
def test_second_writer_refused_naming_the_holder(tmp_path):
    with RunStore(tmp_path, lock=True) as first:
        with pytest.raises(StoreError) as info:
            RunStore(tmp_path, lock=True)
        msg = str(info.value)
        assert f"pid {os.getpid()}" in msg and socket.gethostname() in msg
        assert "\n" not in msg
        with RunStore(tmp_path, readonly=True) as reader:  # the report may read
            assert reader.lock_holder()["pid"] == os.getpid()
        assert first.lock_holder() is not None
    with RunStore(tmp_path, lock=True) as again:  # released on close
        assert again.lock_holder()["pid"] == os.getpid()
    with RunStore(tmp_path) as store:
        assert store.meta(LOCK_KEY) is None


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_lock_of_a_dead_process_is_taken_over(tmp_path):
    with RunStore(tmp_path) as store:
        store.set_meta(LOCK_KEY, {"pid": _dead_pid(), "host": socket.gethostname(),
                                  "started": time.time() - 60})
    with RunStore(tmp_path, lock=True) as store:
        assert store.lock_holder()["pid"] == os.getpid()


def test_lock_from_another_host_needs_break_lock(tmp_path):
    with RunStore(tmp_path) as store:
        store.set_meta(LOCK_KEY, {"pid": 4242, "host": "elsewhere.example",
                                  "started": 0.0, "command": "demcal calibrate s.toml"})
    with pytest.raises(StoreError, match=r"pid 4242 on host elsewhere\.example.*--break-lock"):
        RunStore(tmp_path, lock=True)
    with RunStore(tmp_path, lock=True, break_lock=True) as store:
        assert store.lock_holder()["host"] == socket.gethostname()


def test_live_local_holder_is_not_broken_even_with_break_lock(tmp_path):
    code = ("import sys, time; from demcal.store import RunStore; "
            f"s = RunStore(r'{tmp_path}', lock=True); print('ready', flush=True); "
            "sys.stdin.readline()")
    proc = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "ready"
        with pytest.raises(StoreError, match=f"pid {proc.pid} on host"):
            RunStore(tmp_path, lock=True, break_lock=True)
    finally:
        proc.communicate("\n", timeout=30)
    with RunStore(tmp_path, lock=True):
        pass


def test_a_new_store_appears_whole_with_no_temporary_files_left(tmp_path):
    """Created under a temporary name and linked into place: a second process never sees a
    0-byte store (which it would refuse), and a store created meanwhile is kept."""
    with RunStore(tmp_path) as store:
        store.set_meta("x", 1)
    assert (tmp_path / "demcal.sqlite").read_bytes()[:16] == b"SQLite format 3\x00"
    assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")] == []
    RunStore._create(tmp_path / "demcal.sqlite")  # another creator lost the race
    with RunStore(tmp_path, readonly=True) as store:
        assert store.meta("x") == 1
