"""External mode: run sheets for a DEM run outside demcal, and importing their results.

``demcal calibrate --external`` stops at the first stage with runs missing and writes its run
sheet ``<study dir>/runsheet_<stage>.csv``: one row per run with ``key``, ``stage``, ``point``,
``replicate``, ``seed``, every parameter (SI) and empty ``aor_deg`` and ``outcome`` columns.
Fill ``aor_deg`` (deg) for each run that formed a pile, or ``outcome`` (column, plug,
unsettled, unstable) for one that did not, and ``demcal import`` the sheet; the next
``demcal calibrate`` goes on.
"""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd

from demcal.calibrate.runner import ExternalPending, Point, Runner
from demcal.errors import InputError
from demcal.limits import MAX_INPUT_FILE_BYTES
from demcal.results import RunResult
from demcal.virtual import PARAMETERS

__all__ = ["OUTCOMES", "import_results", "write_run_sheet"]

OUTCOMES = ("pile", "column", "plug", "scattered", "unsettled", "unstable")


def write_run_sheet(pending: ExternalPending, runner: Runner, folder: str | Path) -> Path:
    """Write the pending runs of a stage as CSV; return its path."""
    rows = []
    for p in pending.points:
        row = {"key": runner.key(pending.stage, p), "stage": pending.stage, "point": p.point,
               "replicate": p.replicate, "seed": p.seed}
        row.update({n: p.params[n] for n in PARAMETERS if n in p.params})
        row.update(aor_deg=None, outcome=None)
        rows.append(row)
    path = Path(folder) / f"runsheet_{pending.stage}.csv"
    pd.DataFrame(rows).to_csv(path, index=False)  # repr floats: exact round trip
    return path


def import_results(csv: str | Path, runner: Runner) -> int:
    """Store the runs of a filled run sheet; return how many were stored.

    A row needs ``aor_deg`` (then the outcome defaults to ``pile``) or an ``outcome`` other
    than pile. The row's key is recomputed from its stage, parameters and seed and must match
    (the sheet belongs to this study and test). Every row is checked first and the runs are
    stored in one transaction: a bad row (or a run given twice) stores nothing.
    """
    path = Path(csv)
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
    need = {"key", "stage", "point", "replicate", "seed", "aor_deg", "outcome"}
    if missing := need - set(frame.columns):
        raise InputError(f"{path}: missing column(s) {', '.join(sorted(missing))}")
    # every row is checked before any is stored; then all are stored in one transaction
    todo: list[tuple[str, Point, dict, int]] = []
    seen: dict[str, int] = {}
    for i, row in frame.iterrows():
        line = int(i) + 2  # type: ignore[call-overload]
        where = f"{path.name} row {line}"
        try:
            params = {n: _finite(row[n], n) for n in PARAMETERS if n in frame.columns}
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
        seen[row["key"]] = line
        if (response := _response(row, where)) is None:
            continue  # not done yet
        outcome, aor = response
        todo.append((stage, p, _imported(runner.key(stage, p), outcome, aor, path),
                     2 if outcome in ("unstable", "unsettled") else 1))
    with runner.store.batch():
        for stage, p, res, attempts in todo:
            runner.record(stage, p, res, attempts=attempts, started=0.0)
    return len(todo)


def _imported(key: str, outcome: str, aor: float | None, path: Path) -> RunResult:
    """An imported row as a run result: a pile's angle, or an outcome that measured nothing."""
    pile = outcome == "pile"
    return RunResult(key, outcome, responses={"aor_deg": aor} if pile else {},
                     reason=None if pile else "imported", detail={"imported_from": str(path)})


def _response(row: pd.Series, where: str) -> tuple[str, float | None] | None:
    """A row's ``(outcome, aor_deg)``; None when both cells are empty (not done yet)."""
    aor = row["aor_deg"]
    try:
        aor = None if aor is None or (isinstance(aor, float) and math.isnan(aor)) \
            else float(aor)
    except ValueError:
        raise InputError(f"{where}: aor_deg must be a number; got {aor!r}") from None
    outcome = row["outcome"]
    outcome = None if not isinstance(outcome, str) or not outcome.strip() else outcome.strip()
    if outcome is None and aor is None:
        return None
    if outcome not in (None, "pile") and aor is not None:
        raise InputError(f"{where}: aor_deg {aor!r} given for a run whose outcome is "
                         f"{outcome!r}; give an angle for a pile, or an outcome without an "
                         "angle")
    outcome = outcome or "pile"
    if outcome not in OUTCOMES:
        raise InputError(f"{where}: outcome must be one of {', '.join(OUTCOMES)}; got "
                         f"{outcome!r}")
    if outcome == "pile" and (aor is None or not 0 < aor < 90):
        raise InputError(f"{where}: aor_deg must be in (0, 90) for a pile; got {aor!r}")
    return outcome, aor


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
