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
    the AoR, the whole result as JSON, the reason of a failure, the attempts made, timings and
    artefact paths.
``stages``
    one row per stage (``rangefind``, ``screening``, ``steepest``, ``rsm``, ``optimize``,
    ``verification``): status ``running``, ``done`` or ``failed``, and a JSON summary whose keys
    are documented in ``demcal.calibrate`` (the report reads them).
``meta``
    key -> JSON value: the validated study, the target, the physical measurements, versions.
"""

from __future__ import annotations

import hashlib
import json
import math
import sqlite3
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["STORE_NAME", "RunRecord", "RunStore", "StageRecord", "params_hash", "run_key"]

STORE_NAME = "demcal.sqlite"
SCHEMA_VERSION = 1

_SCHEMA = """
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
    aor_deg: float | None = None
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


@dataclass
class StageRecord:
    """One stage's status and summary (the JSON documented in ``demcal.calibrate``)."""

    name: str
    status: str
    summary: dict[str, Any]
    inputs_hash: str | None
    updated_at: float


class RunStore:
    """The study's SQLite store at ``path`` (a file, or a study folder holding STORE_NAME).

    Safe to open from several processes; every method commits before returning.
    """

    def __init__(self, path: str | Path) -> None:
        path = Path(path)
        if path.is_dir() or path.suffix == "":
            path = path / STORE_NAME
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self._conn = sqlite3.connect(path, timeout=60.0, isolation_level=None)
        self._conn.execute("PRAGMA journal_mode=WAL")
        self._conn.execute("PRAGMA synchronous=NORMAL")
        self._conn.executescript(_SCHEMA)
        version = self.meta("schema_version")
        if version is None:
            self.set_meta("schema_version", SCHEMA_VERSION)
        elif version != SCHEMA_VERSION:
            raise ValueError(f"{path}: store schema version {version}, this demcal reads "
                             f"{SCHEMA_VERSION}")

    # -- plumbing -------------------------------------------------------------------------
    @contextmanager
    def _tx(self) -> Iterator[sqlite3.Connection]:
        self._conn.execute("BEGIN IMMEDIATE")
        try:
            yield self._conn
        except BaseException:
            self._conn.execute("ROLLBACK")
            raise
        self._conn.execute("COMMIT")

    def close(self) -> None:
        """Close the connection (the store stays on disk)."""
        self._conn.close()

    def __enter__(self) -> RunStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- runs ------------------------------------------------------------------------------
    def record_run(self, run: RunRecord) -> None:
        """Insert or replace one run, committed at once."""
        if run.status not in ("done", "failed"):
            raise ValueError(f"run status must be 'done' or 'failed', got {run.status!r}")
        row = (run.key, run.stage, int(run.point), int(run.replicate), _dumps(run.params),
               run.params_hash, int(run.seed), run.engine_version, run.status, run.outcome,
               None if run.aor_deg is None or not math.isfinite(run.aor_deg)
               else float(run.aor_deg),
               _dumps(run.result), run.reason, int(run.attempts), run.started_at,
               run.finished_at or time.time(), run.wall_time_s, _dumps(run.artefacts))
        with self._tx() as c:
            c.execute("INSERT OR REPLACE INTO runs VALUES "
                      "(?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)", row)

    @staticmethod
    def _run_from_row(row: tuple) -> RunRecord:
        (key, stage, point, replicate, params, _h, seed, engine, status, outcome, aor, result,
         reason, attempts, started, finished, wall, artefacts) = row
        return RunRecord(key=key, stage=stage, point=point, replicate=replicate,
                         params=json.loads(params), seed=seed, status=status, outcome=outcome,
                         aor_deg=aor, result=json.loads(result), reason=reason,
                         attempts=attempts, engine_version=engine, started_at=started,
                         finished_at=finished, wall_time_s=wall,
                         artefacts=json.loads(artefacts))

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
        if where:
            sql += " WHERE " + " AND ".join(where)
        sql += " ORDER BY stage, point, replicate, key"
        return [self._run_from_row(r) for r in self._conn.execute(sql, args).fetchall()]

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
        return StageRecord(row[0], row[1], json.loads(row[2]), row[3], row[4])

    def stages(self) -> list[StageRecord]:
        """All stored stages in the order they were last written."""
        rows = self._conn.execute("SELECT * FROM stages ORDER BY updated_at").fetchall()
        return [StageRecord(r[0], r[1], json.loads(r[2]), r[3], r[4]) for r in rows]

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
        return default if row is None else json.loads(row[0])
