"""External mode: run sheets for a DEM run outside demcal, and importing their results.

``demcal calibrate --external`` stops at the first stage with runs missing and writes its run
sheet ``<study dir>/runsheet_<stage>.csv``: one row per run with ``key``, ``stage``, ``point``,
``replicate``, ``seed``, every parameter (SI), an empty column per response the study aims at
(its lead first: ``aor_deg`` for a study of the angle) and an empty ``outcome``. Fill the
responses for each run that measured them (the lead's is needed; another response left
empty was not measured), or ``outcome`` (column, plug, unsettled, unstable) for one that
did not, and ``demcal import`` the sheet; the next ``demcal calibrate`` goes on.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from demcal.calibrate.runner import ExternalPending, Point, Runner
from demcal.errors import InputError
from demcal.limits import MAX_INPUT_FILE_BYTES
from demcal.results import RunResult
from demcal.safety import repeated_column
from demcal.virtual import PARAMETERS

__all__ = ["OUTCOMES", "import_results", "write_run_sheet"]

OUTCOMES = ("pile", "column", "plug", "scattered", "unsettled", "unstable")
#: the angle's name: a value of it must be an angle
_ANGLE = "aor_deg"


def write_run_sheet(pending: ExternalPending, runner: Runner, folder: str | Path,
                    responses: Sequence[str] = (_ANGLE,)) -> Path:
    """Write the pending runs of a stage as CSV, a column per name in ``responses`` (the
    study's, its lead first); return its path."""
    rows = []
    for p in pending.points:
        row = {"key": runner.key(pending.stage, p), "stage": pending.stage, "point": p.point,
               "replicate": p.replicate, "seed": p.seed}
        row.update({n: p.params[n] for n in PARAMETERS if n in p.params})
        row.update({name: None for name in responses}, outcome=None)
        rows.append(row)
    path = Path(folder) / f"runsheet_{pending.stage}.csv"
    pd.DataFrame(rows).to_csv(path, index=False)  # repr floats: exact round trip
    return path


def import_results(csv: str | Path, runner: Runner, responses: Sequence[str] = (_ANGLE,)
                   ) -> int:
    """Store the runs of a filled run sheet; return how many were stored.

    ``responses``: the study's, its lead first (the sheet's response columns). A row needs
    the lead's value (then the outcome defaults to ``pile``) or an ``outcome`` other than
    pile; another response left empty was not measured. The row's key is recomputed from its
    stage, parameters and seed and must match (the sheet belongs to this study and test).
    Every row is checked first and the runs are stored in one transaction: a bad row (or a
    run given twice) stores nothing.
    """
    path = Path(csv)
    frame = _read_sheet(path, {"key", "stage", "point", "replicate", "seed", *responses,
                               "outcome"})
    # every row is checked before any is stored; then all are stored in one transaction
    todo: list[tuple[str, Point, RunResult, int]] = []
    seen: dict[str, int] = {}
    for i, row in frame.iterrows():
        line = int(i) + 2  # type: ignore[call-overload]
        stage, p = _checked_row(row, f"{path.name} row {line}", runner, frame.columns, seen)
        seen[row["key"]] = line
        if (response := _response(row, f"{path.name} row {line}", responses)) is None:
            continue  # not done yet
        outcome, values = response
        todo.append((stage, p, _imported(runner.key(stage, p), outcome, values, path),
                     2 if outcome in ("unstable", "unsettled") else 1))
    with runner.store.batch():
        for stage, p, res, attempts in todo:
            runner.record(stage, p, res, attempts=attempts, started=0.0)
    return len(todo)


def _read_sheet(path: Path, need: set[str]) -> pd.DataFrame:
    """A filled run sheet as read (only an empty cell missing), its columns checked: a file
    that is not one, a column named twice or one missing is an input error."""
    if not path.is_file():
        raise InputError(f"results file not found (or not a file): {path}")
    if path.stat().st_size > MAX_INPUT_FILE_BYTES:
        raise InputError(f"{path}: larger than {MAX_INPUT_FILE_BYTES // 2**20} MB; not a run "
                         "sheet")
    try:
        # only an empty cell is "not done yet": a typed 'nan' or 'NA' is refused, not skipped
        frame = pd.read_csv(path, encoding="utf-8", keep_default_na=False, na_values=[""])
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text (UTF-8) file; a run sheet is a CSV file") \
            from None
    except pd.errors.EmptyDataError:
        raise InputError(f"{path}: empty; a run sheet has a header and one row per run") \
            from None
    except (pd.errors.ParserError, ValueError) as exc:
        raise InputError(f"{path}: not a readable CSV run sheet ({one_line(exc)})") from None
    if (twice := repeated_column(path)) is not None:
        raise InputError(f"{path}: the column {twice!r} appears twice in the header; give "
                         "each column one name")
    if missing := need - set(frame.columns):
        raise InputError(f"{path}: missing column(s) {', '.join(sorted(missing))}")
    return frame


def _checked_row(row: pd.Series, where: str, runner: Runner, columns: pd.Index,
                 seen: dict[str, int]) -> tuple[str, Point]:
    """A row's stage and run, its key recomputed and checked against the row's and against
    the rows before it (``seen``: key -> line)."""
    try:
        params = {n: _finite(row[n], n) for n in PARAMETERS if n in columns}
        p = Point(_int(row["point"], "point"), _int(row["replicate"], "replicate"), params,
                  _int(row["seed"], "seed"))
    except ValueError as exc:
        raise InputError(f"{where}: {exc}") from None
    stage = str(row["stage"])
    if runner.key(stage, p) != row["key"]:
        raise InputError(f"{where}: key does not match its stage, parameters and seed "
                         "(a sheet of another study, or edited parameters)")
    if row["key"] in seen:
        raise InputError(f"{where}: the same run (key {row['key']}) as row "
                         f"{seen[row['key']]}; give each run once")
    return stage, p


def _imported(key: str, outcome: str, values: dict[str, float], path: Path) -> RunResult:
    """An imported row as a run result: a pile's responses, or an outcome that measured
    nothing."""
    pile = outcome == "pile"
    return RunResult(key, outcome, responses=values if pile else {},
                     reason=None if pile else "imported", detail={"imported_from": str(path)})


def _value(cell: object, name: str, where: str) -> float | None:
    """A response cell: None when empty, else a finite number (an angle: in (0, 90))."""
    if cell is None or (isinstance(cell, float) and math.isnan(cell)):
        return None
    try:
        value = float(cell)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InputError(f"{where}: {name} must be a number; got {cell!r}") from None
    if name == _ANGLE and not 0 < value < 90:
        raise InputError(f"{where}: {name} must be in (0, 90) for a pile; got {value!r}")
    if not math.isfinite(value):
        raise InputError(f"{where}: {name} must be a finite number; got {cell!r}")
    return value


def _response(row: pd.Series, where: str, responses: Sequence[str]
              ) -> tuple[str, dict[str, float]] | None:
    """A row's ``(outcome, {response: value})``; None when the lead's cell and the outcome are
    empty (not done yet)."""
    lead = responses[0]
    values = {n: v for n in responses if (v := _value(row[n], n, where)) is not None}
    outcome = row["outcome"]
    outcome = None if not isinstance(outcome, str) or not outcome.strip() else outcome.strip()
    if outcome is None and lead not in values:
        if values:
            raise InputError(f"{where}: {', '.join(values)} given without {lead}, the "
                             f"response the study leads with; give {lead} (or an outcome)")
        return None
    if outcome not in (None, "pile") and values:
        given = ", ".join(f"{n} {v!r}" for n, v in values.items())
        raise InputError(f"{where}: {given} given for a run whose outcome is {outcome!r}; "
                         "give the responses for a pile, or an outcome without them")
    outcome = outcome or "pile"
    if outcome not in OUTCOMES:
        raise InputError(f"{where}: outcome must be one of {', '.join(OUTCOMES)}; got "
                         f"{outcome!r}")
    if outcome == "pile" and lead not in values:
        raise InputError(f"{where}: {lead} must be given for a pile; got {row[lead]!r}")
    return outcome, values


def _int(value: object, name: str) -> int:
    """An integer cell (``3`` or ``3.0``), else ValueError naming the column."""
    try:
        f = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be an integer; got {value!r}") from None
    if not math.isfinite(f) or f != int(f) or abs(f) > 2**53:
        raise ValueError(f"{name} must be an integer; got {value!r}")
    return int(f)


def _finite(value: object, name: str) -> float:
    """A finite number cell, else ValueError naming the column."""
    try:
        f = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number; got {value!r}") from None
    if not math.isfinite(f):
        raise ValueError(f"{name} must be a finite number; got {value!r}")
    return f


def one_line(exc: object) -> str:
    """An error message on one line."""
    return " ".join(str(exc).split())
