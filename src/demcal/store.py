"""SQLite run store of a study: one row per simulation, written the moment a run ends.

The store is the single source of truth of a study (``<study_dir>/demcal.sqlite``): the
calibration writes every finished run and every finished stage into it, and the report is
rebuilt from it alone. Each write is its own transaction, so a crash, a killed process or
Ctrl-C loses no finished run; SQLite's write-ahead log keeps readers (a report being built
while the study runs) consistent.

Tables
------
``runs``
    one row per simulation attempt group, keyed by :func:`run_key` (stage, parameters, seed and
    the virtual test's configuration hash): status ``done`` or ``failed``, the typed outcome,
    the whole result as JSON, the reason of a failure, the attempts made, timings and
    artefact paths. (Its ``aor_deg`` column is schema 1's; it mirrors the ``aor_deg``
    response for SQL readers.)
``responses``
    one row per measured response of a run: ``(key, name, value)``, indexed by name, so a run
    holds any number of named responses (the lift test's angle, pile height and base
    diameter; every number an external engine reports).
``stages``
    one row per stage (``rangefind``, ``screening``, ``steepest``, ``rsm``, ``optimize``,
    ``verification``): status ``running``, ``done`` or ``failed``, and a JSON summary whose keys
    are documented in ``demcal.calibrate`` (the report reads them).
``meta``
    key -> JSON value: the validated study, the target, the physical measurements, versions;
    ``writer`` holds the study's writer lock while a calibration runs (see below).

Schema versions
---------------
1 (until 2026-11-27) kept one response, the angle, in ``runs.aor_deg``; 2 adds the
``responses`` table. A schema-1 store opened for writing is migrated in place in one
transaction (its angles copied into ``responses``; nothing else changes, so every run key and
stage summary stays as it was and a resumed study re-runs nothing); opened read-only (the
report) it is read as it is.

Safety
------
Opening checks that the file is a demcal store before anything is written: a 0-byte file,
a file that is not SQLite, a damaged database (``PRAGMA quick_check``), an SQLite database of
something else, or a store of a newer schema is refused with a :class:`demcal.errors.StoreError`
(one line, saying how to recover; :func:`salvage` copies the runs that can still be read into
a new store). A row whose JSON cannot be read is refused the same way. ``readonly=True`` opens
a store for reading only (the report): it never creates or changes a file.

One writer per study: ``lock=True`` (``demcal calibrate`` and ``demcal import``) takes the
writer lock, the meta row ``writer`` = ``{pid, host, started, command}``, in one immediate
transaction, and :meth:`RunStore.close` gives it back. A second writer is refused with one line
naming the holder. A lock whose process is gone (same host, pid no longer running) is taken
over at once; a lock held from another host is broken only with ``break_lock=True``
(``--break-lock``). Readers never look at the lock.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import shutil
import socket
import sqlite3
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from demcal.errors import StoreError

__all__ = ["STAGES", "STORE_NAME", "RunRecord", "RunStore", "StageRecord", "describe_holder",
           "holder_alive", "params_hash", "run_key", "salvage"]

STORE_NAME = "demcal.sqlite"
#: The calibration's stages, in the order they run, with their titles: the names the
#: ``stages`` table holds (the calibration writes them, the report reads them).
STAGES: dict[str, str] = {
    "rangefind": "Range finding",
    "screening": "Screening (Plackett-Burman)",
    "steepest": "Path of steepest ascent",
    "rsm": "Response surface",
    "optimize": "Optimum",
    "verification": "Verification",
}
SCHEMA_VERSION = 2
LOCK_KEY = "writer"
_SQLITE_HEADER = b"SQLite format 3\x00"
_TABLES = {"runs", "stages", "meta"}
log = logging.getLogger("demcal")

#: schema 2's table of responses (also what a schema-1 store gains when it is migrated)
_RESPONSES_TABLE = ("CREATE TABLE IF NOT EXISTS responses (key TEXT NOT NULL, name TEXT NOT "
                    "NULL, value REAL NOT NULL, PRIMARY KEY (key, name))")
_RESPONSES_INDEX = "CREATE INDEX IF NOT EXISTS responses_name ON responses (name)"

_SCHEMA = f"""
CREATE TABLE IF NOT EXISTS runs (
    key TEXT PRIMARY KEY,
    stage TEXT NOT NULL,
    point INTEGER NOT NULL,
    replicate INTEGER NOT NULL,
    params_json TEXT NOT NULL,
    params_hash TEXT NOT NULL,
    seed INTEGER NOT NULL,
    engine_version TEXT NOT NULL,
    status TEXT NOT NULL CHECK (status IN ('done', 'failed')),
    outcome TEXT,
    aor_deg REAL,
    result_json TEXT NOT NULL,
    reason TEXT,
    attempts INTEGER NOT NULL,
    started_at REAL,
    finished_at REAL NOT NULL,
    wall_time_s REAL,
    artefacts_json TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS runs_stage ON runs (stage, point, replicate);
CREATE TABLE IF NOT EXISTS stages (
    name TEXT PRIMARY KEY,
    status TEXT NOT NULL CHECK (status IN ('running', 'done', 'failed')),
    summary_json TEXT NOT NULL,
    inputs_hash TEXT,
    updated_at REAL NOT NULL
);
{_RESPONSES_TABLE};
{_RESPONSES_INDEX};
CREATE TABLE IF NOT EXISTS meta (
    key TEXT PRIMARY KEY,
    value_json TEXT NOT NULL
);
"""


def _canonical(value: Any) -> Any:
    """JSON-stable form: floats by repr (exact), dict keys sorted by json.dumps."""
    if isinstance(value, Mapping):
        return {str(k): _canonical(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_canonical(v) for v in value]
    if isinstance(value, float):
        return repr(value)
    if hasattr(value, "item"):  # numpy scalar
        return _canonical(value.item())
    return value


def params_hash(params: Mapping[str, Any], extra: Any = None) -> str:
    """Short SHA-256 of a parameter set (and anything else that defines a run), order-free."""
    text = json.dumps({"params": _canonical(params), "extra": _canonical(extra)},
                      sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def run_key(stage: str, params: Mapping[str, Any], seed: int, test_hash: str = "") -> str:
    """Identity of one run: the same key means the same simulation, already done if stored."""
    return f"{stage}:{params_hash(params, {'seed': int(seed), 'test': test_hash})}"


def _dumps(value: Any) -> str:
    def default(o: Any) -> Any:
        if hasattr(o, "item"):
            return o.item()
        if hasattr(o, "tolist"):
            return o.tolist()
        if isinstance(o, Path):
            return str(o)
        raise TypeError(f"not JSON serialisable: {type(o).__name__}")

    def clean(v: Any) -> Any:
        if isinstance(v, float) and not math.isfinite(v):
            return None
        if isinstance(v, Mapping):
            return {str(k): clean(x) for k, x in v.items()}
        if isinstance(v, list | tuple):
            return [clean(x) for x in v]
        return v

    return json.dumps(clean(value), default=default, allow_nan=False)


@dataclass
class RunRecord:
    """One stored simulation (angles in degrees, times in seconds, wall clock as Unix time)."""

    key: str
    stage: str
    point: int
    replicate: int
    params: dict[str, float]
    seed: int
    status: str
    outcome: str | None = None
    responses: dict[str, float] = field(default_factory=dict)
    result: dict[str, Any] = field(default_factory=dict)
    reason: str | None = None
    attempts: int = 1
    engine_version: str = ""
    started_at: float | None = None
    finished_at: float = 0.0
    wall_time_s: float | None = None
    artefacts: dict[str, str] = field(default_factory=dict)

    @property
    def params_hash(self) -> str:
        """Hash of the parameter set alone (equal for replicates of one design point)."""
        return params_hash(self.params)

    @property
    def aor_deg(self) -> float | None:
        """The lift test's angle of repose (deg), if the run measured one."""
        return self.responses.get("aor_deg")

    def response(self, name: str) -> float | None:
        """The response ``name``, or None if the run did not measure it."""
        return self.responses.get(name)


@dataclass
class StageRecord:
    """One stage's status and summary (the JSON documented in ``demcal.calibrate``)."""

    name: str
    status: str
    summary: dict[str, Any]
    inputs_hash: str | None
    updated_at: float


def _loads(text: Any, where: str) -> Any:
    """``json.loads`` of a stored cell; a damaged cell is a StoreError naming ``where``."""
    try:
        return json.loads(text)
    except RecursionError:  # a crafted cell: refused like any damaged one
        raise StoreError(f"{where}: unreadable JSON (nested too deeply); the store is damaged "
                         "(`demcal store salvage` copies the readable runs into a new "
                         "store)") from None
    except (TypeError, ValueError) as exc:
        raise StoreError(f"{where}: unreadable JSON ({exc}); the store is damaged (`demcal "
                         "store salvage` copies the readable runs into a new store)") from None


def _connect_readonly(path: Path) -> sqlite3.Connection:
    """A read-only connection to the store ``path``.

    SQLite reads a WAL-mode database by creating its ``-shm`` file beside it; in a read-only
    folder (a finished study archived, a colleague's share) it cannot, and a healthy store
    was called damaged. No writer can work in such a folder, so the file is then read as it
    is (``immutable``: no ``-shm``, no lock) unless its write-ahead log still holds changes,
    which only a writable folder lets SQLite merge: that is said in one line.
    """
    uri = path.resolve().as_uri()
    if os.access(path.parent, os.W_OK | os.X_OK):  # a writer may run: the usual reader
        return sqlite3.connect(f"{uri}?mode=ro", uri=True, timeout=60.0, isolation_level=None)
    wal = path.with_name(path.name + "-wal")
    if wal.is_file() and wal.stat().st_size > 0:
        raise StoreError(f"{path}: its folder is read-only and its write-ahead log "
                         f"{wal.name} holds changes SQLite must merge into the store first; "
                         "copy the study folder somewhere writable to read it")
    return sqlite3.connect(f"{uri}?mode=ro&immutable=1", uri=True, timeout=60.0,
                           isolation_level=None)


def _loads_object(text: Any, where: str, what: str, *, none: bool = False) -> Any:
    """:func:`_loads` of a cell that must hold a JSON object (or null when ``none``): a
    crafted list there was a TypeError deep in a resumed study."""
    value = _loads(text, where)
    if isinstance(value, dict) or (none and value is None):
        return value
    raise StoreError(f"{where}: {what} is a JSON {type(value).__name__}, not an object; the "
                     "store is damaged (`demcal store salvage` copies the readable runs into "
                     "a new store)")


def _proc_start(pid: int) -> str | None:
    """Start time of process ``pid`` (Linux clock ticks since boot), or None if unknown."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
        return stat.rsplit(")", 1)[1].split()[19]
    except (OSError, IndexError):
        return None


def holder_alive(holder: Mapping[str, Any]) -> bool | None:
    """Whether the lock holder still runs: True, False, or None (another host: unknown)."""
    if holder.get("host") != socket.gethostname():
        return None
    try:
        pid = int(holder.get("pid"))  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return False
    if not _pid_alive(pid):
        return False
    # a live pid of another process than the holder's (the pid was reused)
    start = _proc_start(pid)
    recorded = holder.get("proc_start")
    return not (start is not None and recorded is not None and start != recorded)


def _pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` exists on this host (one of another user's counts)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except PermissionError:
        return True
    except OSError:  # ProcessLookupError among them
        return False
    return True


def describe_holder(holder: Mapping[str, Any]) -> str:
    """``pid 123 on host h since 2026-01-01 12:00:00 UTC (demcal calibrate s.toml)``."""
    when = holder.get("started")
    since = "" if not isinstance(when, int | float) else \
        time.strftime(" since %Y-%m-%d %H:%M:%S UTC", time.gmtime(when))
    cmd = holder.get("command")
    return (f"pid {holder.get('pid')} on host {holder.get('host')}{since}"
            + (f" ({cmd})" if cmd else ""))


class RunStore:
    """The study's SQLite store at ``path`` (a file, or a study folder holding STORE_NAME).

    Safe to open from several processes; every method commits before returning.

    Parameters
    ----------
    path : str or Path
        The store file, or the study folder (then ``<path>/demcal.sqlite``).
    readonly : bool
        Open for reading only: the store must exist, and nothing is ever written (the
        report). Default False: a missing store is created.
    lock : bool
        Take the study's writer lock (refused while another writer holds it).
    break_lock : bool
        With ``lock``: take the lock even when it is held from another host (its process
        cannot be checked from here).

    Raises
    ------
    StoreError
        The file is empty, not SQLite, damaged, not a demcal store, of another schema
        version, or (with ``lock``) held by another writer.
    """

    def __init__(self, path: str | Path, *, readonly: bool = False, lock: bool = False,
                 break_lock: bool = False) -> None:
        path = Path(path)
        if path.is_dir() or path.suffix == "":
            path = path / STORE_NAME
        self.path = path
        self.readonly = readonly
        #: a schema-1 store opened read-only: responses come from ``runs.aor_deg``
        self._legacy = False
        self._lock_value: str | None = None
        self._conn: sqlite3.Connection | None = None
        exists = path.exists()
        if not exists and readonly:
            raise StoreError(f"{path}: no run store there (run `demcal calibrate` first)")
        if not exists:
            path.parent.mkdir(parents=True, exist_ok=True)
            self._create(path)
            exists = True
        self._check_file(path)
        try:
            if readonly:
                self._conn = _connect_readonly(path)
            else:
                self._conn = sqlite3.connect(path, timeout=60.0, isolation_level=None)
            self._open(exists)
        except sqlite3.DatabaseError as exc:
            self.close()
            raise StoreError(f"{path}: damaged run store ({exc}); {self._recovery()}") \
                from None
        except BaseException:
            self.close()
            raise
        if lock:
            try:
                self.acquire_lock(break_lock=break_lock)
            except BaseException:
                self.close()
                raise

    @staticmethod
    def _create(path: Path) -> None:
        """Create an empty store at ``path`` atomically: built under a temporary name, then
        linked into place, so that no other process ever sees a half-made (0-byte) file; if
        another process created it first, its store is kept."""
        tmp = path.with_name(f".{path.name}.{os.getpid()}.{time.monotonic_ns()}.tmp")
        conn = sqlite3.connect(tmp, isolation_level=None)
        try:
            conn.execute("PRAGMA journal_mode=WAL")
            conn.executescript(_SCHEMA)
            conn.execute("INSERT INTO meta VALUES (?, ?)",
                         ("schema_version", _dumps(SCHEMA_VERSION)))
        finally:
            conn.close()
        try:
            os.link(tmp, path)
        except FileExistsError:
            pass
        finally:
            for leftover in (tmp, tmp.with_name(tmp.name + "-wal"),
                             tmp.with_name(tmp.name + "-shm")):
                leftover.unlink(missing_ok=True)

    @staticmethod
    def _check_file(path: Path) -> None:
        """Refuse, before SQLite touches it, a file that cannot be a demcal store."""
        if not path.is_file():
            raise StoreError(f"{path}: not a file; a run store is an SQLite file")
        size = path.stat().st_size
        if size == 0:
            raise StoreError(f"{path}: empty file (0 bytes), not a demcal run store; delete "
                             "it to start the study over")
        with path.open("rb") as fh:
            head = fh.read(len(_SQLITE_HEADER))
        if head != _SQLITE_HEADER:
            raise StoreError(f"{path}: not a demcal run store (not an SQLite database); move "
                             "it away to start the study over")

    def _recovery(self) -> str:
        return (f"`demcal store salvage {self.path.parent}` copies the runs that can still be "
                "read into a new store")

    def _open(self, existed: bool) -> None:
        conn = self._conn
        assert conn is not None
        if existed:
            check = conn.execute("PRAGMA quick_check").fetchall()
            if [tuple(r) for r in check] != [("ok",)]:
                raise StoreError(f"{self.path}: damaged run store (integrity check: "
                                 f"{check[0][0]}); {self._recovery()}")
            tables = {r[0] for r in conn.execute(
                "SELECT name FROM sqlite_master WHERE type = 'table'")}
        else:
            tables = set()
        if tables and not _TABLES <= tables:
            raise StoreError(f"{self.path}: an SQLite database but not a demcal run store "
                             f"(tables: {', '.join(sorted(tables))}); nothing was written")
        if not tables:
            if self.readonly:
                raise StoreError(f"{self.path}: an empty database, no run stored yet")
            conn.execute("PRAGMA journal_mode=WAL")
            conn.execute("PRAGMA synchronous=NORMAL")
            conn.executescript(_SCHEMA)
            self.set_meta("schema_version", SCHEMA_VERSION)
            return
        if not self.readonly:
            conn.execute("PRAGMA synchronous=NORMAL")
        self._check_version(self.meta("schema_version"), tables)

    def _check_version(self, version: Any, tables: set[str]) -> None:
        """Refuse a store of another schema; a schema-1 store is read as it is, or migrated
        when opened for writing."""
        if version is None:
            raise StoreError(f"{self.path}: not a demcal run store (no schema_version); "
                             "nothing was written")
        if version == 1 and "responses" not in tables:
            self._legacy = True
            if not self.readonly:
                self._migrate_v1()
            return
        if version != SCHEMA_VERSION:
            newer = isinstance(version, int) and version > SCHEMA_VERSION
            raise StoreError(f"{self.path}: store schema version {version!r}, this demcal "
                             f"reads {SCHEMA_VERSION}"
                             + ("; it was written by a newer demcal: upgrade demcal"
                                if newer else ""))

    def _migrate_v1(self) -> None:
        """Schema 1 -> 2 in one transaction: the angles of ``runs.aor_deg`` become
        ``aor_deg`` responses; a crash leaves the store as it was."""
        conn = self._conn
        assert conn is not None
        conn.execute("BEGIN IMMEDIATE")
        try:
            conn.execute(_RESPONSES_TABLE)
            conn.execute(_RESPONSES_INDEX)
            conn.execute("INSERT OR REPLACE INTO responses SELECT key, 'aor_deg', aor_deg "
                         "FROM runs WHERE aor_deg IS NOT NULL")
            conn.execute("UPDATE meta SET value_json = ? WHERE key = 'schema_version'",
                         (_dumps(SCHEMA_VERSION),))
            conn.execute("COMMIT")
        except BaseException:
            conn.execute("ROLLBACK")
            raise
        self._legacy = False
        log.info("%s: run store migrated from schema 1 to %d (responses by name)", self.path,
                 SCHEMA_VERSION)

    # -- the writer lock -------------------------------------------------------------------
    def lock_holder(self) -> dict[str, Any] | None:
        """The writer lock's holder ``{pid, host, started, command}``, or None if free."""
        holder = self.meta(LOCK_KEY)
        return holder if isinstance(holder, dict) else None

    def acquire_lock(self, *, break_lock: bool = False) -> None:
        """Take the study's writer lock (one immediate transaction: check, then write).

        Parameters
        ----------
        break_lock : bool
            Take a lock held from another host too (its process cannot be checked here).

        Raises
        ------
        StoreError
            Another live writer holds the lock (the message names its pid and host).
        """
        if self._lock_value is not None:
            return
        if self.readonly:
            raise StoreError(f"{self.path}: opened read-only; cannot take the writer lock")
        me = {"pid": os.getpid(), "host": socket.gethostname(), "started": time.time(),
              "proc_start": _proc_start(os.getpid()),
              "command": " ".join(["demcal", *sys.argv[1:]])[:200]}
        value = _dumps(me)
        with self._tx() as c:
            row = c.execute("SELECT value_json FROM meta WHERE key = ?",
                            (LOCK_KEY,)).fetchone()
            holder = None
            if row is not None:
                try:
                    holder = json.loads(row[0])
                except ValueError:
                    holder = None
            if isinstance(holder, dict):
                alive = holder_alive(holder)
                who = describe_holder(holder)
                if alive is True:
                    raise StoreError(f"{self.path.parent}: study is being written by {who}; "
                                     "one writer per study: wait for it or stop it "
                                     "(`demcal report` can read meanwhile)")
                if alive is None and not break_lock:
                    raise StoreError(f"{self.path.parent}: study is locked by {who}; if that "
                                     "process is gone, run again with --break-lock")
                log.warning("taking over the writer lock of %s (%s)", who,
                            "no longer running" if alive is False else "--break-lock")
            c.execute("INSERT OR REPLACE INTO meta VALUES (?, ?)", (LOCK_KEY, value))
        self._lock_value = value

    def release_lock(self) -> None:
        """Give the writer lock back (only if this store still holds it)."""
        if self._lock_value is None or self._conn is None:
            return
        value, self._lock_value = self._lock_value, None
        try:
            with self._tx() as c:
                c.execute("DELETE FROM meta WHERE key = ? AND value_json = ?",
                          (LOCK_KEY, value))
        except sqlite3.Error:  # a store gone bad: the lock is stale, taken over later
            pass

    # -- plumbing -------------------------------------------------------------------------
    @contextmanager
    def batch(self) -> Iterator[RunStore]:
        """Group writes into one transaction: all of them are stored, or none.

        Examples
        --------
        >>> with store.batch():  # doctest: +SKIP
        ...     for run in runs:
        ...         store.record_run(run)
        """
        if getattr(self, "_in_batch", False):
            yield self
            return
        with self._tx():
            self._in_batch = True
            try:
                yield self
            finally:
                self._in_batch = False

    @contextmanager
    def _tx(self) -> Iterator[sqlite3.Connection]:
        if self.readonly:
            raise StoreError(f"{self.path}: opened read-only")
        assert self._conn is not None
        if getattr(self, "_in_batch", False):  # inside batch(): its transaction
            yield self._conn
            return
        self._conn.execute("BEGIN IMMEDIATE")
        try:
            yield self._conn
        except BaseException:
            self._conn.execute("ROLLBACK")
            raise
        self._conn.execute("COMMIT")

    def close(self) -> None:
        """Give back the writer lock if held and close the connection (the store stays)."""
        if self._conn is None:
            return
        self.release_lock()
        self._conn.close()
        self._conn = None

    def __enter__(self) -> RunStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- runs ------------------------------------------------------------------------------
    def record_run(self, run: RunRecord) -> None:
        """Insert or replace one run, committed at once."""
        if run.status not in ("done", "failed"):
            raise ValueError(f"run status must be 'done' or 'failed', got {run.status!r}")
        responses = {str(k): float(v) for k, v in run.responses.items()
                     if v is not None and math.isfinite(float(v))}
        row = (run.key, run.stage, int(run.point), int(run.replicate), _dumps(run.params),
               run.params_hash, int(run.seed), run.engine_version, run.status, run.outcome,
               responses.get("aor_deg"),
               _dumps(run.result), run.reason, int(run.attempts), run.started_at,
               run.finished_at or time.time(), run.wall_time_s, _dumps(run.artefacts))
        with self._tx() as c:
            c.execute("INSERT OR REPLACE INTO runs VALUES "
                      "(?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)", row)
            c.execute("DELETE FROM responses WHERE key = ?", (run.key,))
            c.executemany("INSERT INTO responses VALUES (?,?,?)",
                          [(run.key, k, v) for k, v in sorted(responses.items())])

    def _responses(self, where: str = "", args: Sequence[Any] = ()) -> dict[str, dict[str, float]]:
        """Responses by run key, of the runs that ``where`` (SQL on ``runs``) selects."""
        if self._legacy:  # schema 1, read-only: the one response is the runs' angle
            sql = "SELECT key, 'aor_deg', aor_deg FROM runs WHERE aor_deg IS NOT NULL"
            sql += f" AND {where}" if where else ""
        else:
            sql = "SELECT key, name, value FROM responses"
            sql += f" WHERE key IN (SELECT key FROM runs WHERE {where})" if where else ""
        out: dict[str, dict[str, float]] = {}
        for key, name, value in self._conn.execute(sql, list(args)):
            out.setdefault(key, {})[name] = value
        return out

    def _run_from_row(self, row: tuple, responses: Mapping[str, float] | None = None
                      ) -> RunRecord:
        (key, stage, point, replicate, params, _h, seed, engine, status, outcome, _aor, result,
         reason, attempts, started, finished, wall, artefacts) = row
        where = f"{self.path}: run {key!r}"
        if responses is None:
            responses = self._responses("key = ?", (key,)).get(key, {})
        for angle in (_aor, responses.get("aor_deg")):  # the column and the response
            if angle is not None and not (isinstance(angle, int | float) and 0 < angle < 90):
                # every writer stores an angle in (0, 90) deg: a crafted 1e308 fitted a surface
                raise StoreError(f"{where}: aor_deg {angle!r} is not an angle in (0, 90) deg; "
                                 "the store is damaged (`demcal store salvage` copies the "
                                 "readable runs into a new store)")
        return RunRecord(key=key, stage=stage, point=point, replicate=replicate,
                         params=_loads_object(params, where, "params"), seed=seed,
                         status=status, outcome=outcome, responses=dict(responses),
                         result=_loads_object(result, where, "result", none=True),
                         reason=reason, attempts=attempts, engine_version=engine,
                         started_at=started, finished_at=finished, wall_time_s=wall,
                         artefacts=_loads_object(artefacts, where, "artefacts", none=True))

    def get_run(self, key: str) -> RunRecord | None:
        """The stored run with this key, or None."""
        row = self._conn.execute("SELECT * FROM runs WHERE key = ?", (key,)).fetchone()
        return None if row is None else self._run_from_row(row)

    def runs(self, stage: str | None = None, status: str | None = None) -> list[RunRecord]:
        """Stored runs (of one stage and/or status), by stage, point and replicate."""
        sql, args = "SELECT * FROM runs", []
        where = []
        if stage is not None:
            where.append("stage = ?")
            args.append(stage)
        if status is not None:
            where.append("status = ?")
            args.append(status)
        clause = " AND ".join(where)
        if where:
            sql += " WHERE " + clause
        sql += " ORDER BY stage, point, replicate, key"
        responses = self._responses(clause, args)
        return [self._run_from_row(r, responses.get(r[0], {}))
                for r in self._conn.execute(sql, args).fetchall()]

    def count(self, stage: str | None = None) -> int:
        """Number of stored runs (of one stage)."""
        if stage is None:
            return int(self._conn.execute("SELECT COUNT(*) FROM runs").fetchone()[0])
        return int(self._conn.execute("SELECT COUNT(*) FROM runs WHERE stage = ?",
                                      (stage,)).fetchone()[0])

    # -- stages ----------------------------------------------------------------------------
    def set_stage(self, name: str, status: str, summary: Mapping[str, Any],
                  inputs_hash: str | None = None) -> None:
        """Write a stage's status and JSON summary (replaces the previous one)."""
        if status not in ("running", "done", "failed"):
            raise ValueError(f"stage status must be running, done or failed, got {status!r}")
        with self._tx() as c:
            c.execute("INSERT OR REPLACE INTO stages VALUES (?,?,?,?,?)",
                      (name, status, _dumps(summary), inputs_hash, time.time()))

    def stage(self, name: str) -> StageRecord | None:
        """The stored stage, or None if it never started."""
        row = self._conn.execute("SELECT * FROM stages WHERE name = ?", (name,)).fetchone()
        if row is None:
            return None
        return StageRecord(row[0], row[1], _loads(row[2], f"{self.path}: stage {name!r}"),
                           row[3], row[4])

    def stages(self) -> list[StageRecord]:
        """All stored stages in the order they were last written."""
        rows = self._conn.execute("SELECT * FROM stages ORDER BY updated_at").fetchall()
        return [StageRecord(r[0], r[1], _loads(r[2], f"{self.path}: stage {r[0]!r}"), r[3], r[4])
                for r in rows]

    def delete_stage(self, name: str) -> None:
        """Forget a stage's summary (its runs stay and are reused when still valid)."""
        with self._tx() as c:
            c.execute("DELETE FROM stages WHERE name = ?", (name,))

    # -- meta ------------------------------------------------------------------------------
    def set_meta(self, key: str, value: Any) -> None:
        """Store a JSON-serialisable value under ``key``."""
        with self._tx() as c:
            c.execute("INSERT OR REPLACE INTO meta VALUES (?, ?)", (key, _dumps(value)))

    def meta(self, key: str, default: Any = None) -> Any:
        """The stored value of ``key``, or ``default``."""
        row = self._conn.execute("SELECT value_json FROM meta WHERE key = ?", (key,)).fetchone()
        return default if row is None else _loads(row[0], f"{self.path}: meta {key!r}")


def _readable_rows(conn: sqlite3.Connection, table: str,
                   max_gap: int = 10_000) -> Iterator[tuple]:
    """Rows of ``table`` that SQLite can still read, in rowid order.

    A damaged page stops a scan; the scan then goes on after the row it stopped at, up to
    ``max_gap`` unreadable rowids in a row.
    """
    last, misses = 0, 0
    while misses <= max_gap:
        try:
            for row in conn.execute(f"SELECT rowid, * FROM {table} WHERE rowid > ? "
                                    "ORDER BY rowid", (last,)):
                last, misses = row[0], 0
                yield tuple(row[1:])
            return
        except sqlite3.DatabaseError:
            last += 1
            misses += 1


def _patch_header(path: Path, *, keep_wal: bool) -> None:
    """Make a damaged copy readable: page count from the file size, legacy journal mode.

    A truncated file still says, in its header, how many pages it had; SQLite then refuses
    even its schema. The copy's header gets the pages the file really holds.
    """
    with path.open("r+b") as fh:
        head = bytearray(fh.read(100))
        if len(head) < 100:
            return
        page = int.from_bytes(head[16:18], "big")
        page = 65536 if page == 1 else page
        if page < 512 or page & (page - 1):
            return
        size = path.stat().st_size
        pages = size // page
        fh.truncate(pages * page)
        head[28:32] = pages.to_bytes(4, "big")
        if not keep_wal:
            head[18] = head[19] = 1
        fh.seek(0)
        fh.write(head)


def _salvage_responses(conn: sqlite3.Connection) -> dict[str, dict[str, float]]:
    """The readable rows of a damaged store's ``responses`` table (none in schema 1)."""
    out: dict[str, dict[str, float]] = {}
    try:
        for key, name, value in _readable_rows(conn, "responses"):
            if isinstance(value, int | float):
                out.setdefault(key, {})[name] = float(value)
    except (sqlite3.DatabaseError, ValueError):
        pass  # no such table (schema 1) or unreadable: the runs' own angle column remains
    return out


def _refuse_newer_schema(conn: sqlite3.Connection, src: Path) -> None:
    """Refuse to salvage a store of a newer schema: copied into this demcal's schema, what
    only the newer demcal stores would be dropped without a word."""
    try:
        row = conn.execute("SELECT value_json FROM meta WHERE key = 'schema_version'").fetchone()
        version = json.loads(row[0]) if row is not None else None
    except (sqlite3.DatabaseError, ValueError, TypeError, IndexError, RecursionError):
        return  # unreadable: salvage what it can, as for any damaged store
    if isinstance(version, int) and not isinstance(version, bool) and \
            version > SCHEMA_VERSION:
        raise StoreError(f"{src}: store schema version {version}, this demcal writes "
                         f"{SCHEMA_VERSION}: salvaging it here would turn it into schema "
                         f"{SCHEMA_VERSION} and drop what the newer demcal stores; salvage "
                         "it with that demcal (upgrade demcal)")


def salvage(source: str | Path, target: str | Path) -> dict[str, int]:
    """Copy what can still be read of a damaged store into a new store.

    Rows that SQLite cannot read, or whose JSON is damaged, are skipped. The source is only
    read; the target must not exist yet.

    Parameters
    ----------
    source : str or Path
        The damaged store file (or the study folder holding it).
    target : str or Path
        The new store file to write.

    Returns
    -------
    dict
        ``{"runs": copied, "runs_skipped": n, "stages": copied, "meta": copied}``.

    Raises
    ------
    StoreError
        The source is not an SQLite file, or the target exists.
    """
    src = _salvage_source(Path(source))
    dst = Path(target)
    if dst.exists():
        raise StoreError(f"{dst}: exists; give a new file for the salvaged store")
    tmp = Path(tempfile.mkdtemp(prefix="demcal-salvage-"))
    conn = sqlite3.connect(_readable_copy(src, tmp))
    try:
        _refuse_newer_schema(conn, src)  # before the target is created
        with RunStore(dst) as out:
            counts = _copy_runs(conn, out)
            counts["stages"] = _copy_rows(conn, "stages", lambda row: out.set_stage(
                row[0], row[1], json.loads(row[2]), row[3]))

            def copy_meta(row: tuple) -> bool:
                if row[0] in ("schema_version", LOCK_KEY):  # the target's own
                    return False
                out.set_meta(row[0], json.loads(row[1]))
                return True

            counts["meta"] = _copy_rows(conn, "meta", copy_meta)
    except sqlite3.DatabaseError as exc:
        raise StoreError(f"{src}: cannot be read ({exc}); nothing salvaged") from None
    finally:
        conn.close()
        shutil.rmtree(tmp, ignore_errors=True)
    return counts


def _salvage_source(src: Path) -> Path:
    """The store file to salvage (``src`` or the store in the folder ``src``); StoreError
    where there is no SQLite file to read."""
    if src.is_dir():
        src = src / STORE_NAME
    if not src.is_file() or src.stat().st_size == 0:
        raise StoreError(f"{src}: no readable run store there (nothing to salvage)")
    with src.open("rb") as fh:
        if fh.read(len(_SQLITE_HEADER)) != _SQLITE_HEADER:
            raise StoreError(f"{src}: not an SQLite database (nothing to salvage)")
    return src


def _readable_copy(src: Path, folder: Path) -> Path:
    """A copy of the store ``src`` and its write-ahead log in ``folder``, its header patched
    so that SQLite opens it; the source is only read."""
    copy = folder / STORE_NAME
    shutil.copyfile(src, copy)
    wal = src.with_name(src.name + "-wal")
    if wal.is_file():
        shutil.copyfile(wal, copy.with_name(copy.name + "-wal"))
    _patch_header(copy, keep_wal=wal.is_file())
    return copy


def _copy_runs(conn: sqlite3.Connection, out: RunStore) -> dict[str, int]:
    """Every readable run of ``conn`` into ``out``: ``{"runs": copied, "runs_skipped": n}``
    (the rows SQLite could not read count as skipped)."""
    counts = {"runs": 0, "runs_skipped": 0}
    responses = _salvage_responses(conn)
    for row in _readable_rows(conn, "runs"):
        try:
            # schema 1 kept the angle in the row itself (column 10)
            kept = responses.get(row[0], {} if row[10] is None else {"aor_deg": row[10]})
            out.record_run(out._run_from_row(row, kept))
            counts["runs"] += 1
        except (StoreError, ValueError, TypeError):
            counts["runs_skipped"] += 1
    try:
        total = conn.execute("SELECT COUNT(*) FROM runs").fetchone()[0]
        counts["runs_skipped"] = max(counts["runs_skipped"], total - counts["runs"])
    except sqlite3.DatabaseError:
        pass
    return counts


def _copy_rows(conn: sqlite3.Connection, table: str, copy: Callable[[tuple], Any]) -> int:
    """``copy(row)`` for every readable row of ``table``; the rows copied (a row whose JSON is
    damaged is skipped, and so is one ``copy`` declines by returning False)."""
    n = 0
    for row in _readable_rows(conn, table):
        try:
            if copy(row) is not False:
                n += 1
        except (ValueError, TypeError, IndexError, RecursionError):
            pass
    return n
