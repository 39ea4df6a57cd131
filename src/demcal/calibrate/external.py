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
    (the sheet belongs to this study and test).
    """
    path = Path(csv)
    if not path.is_file():
        raise InputError(f"results file not found: {path}")
    frame = pd.read_csv(path)
    need = {"key", "stage", "point", "replicate", "seed", "aor_deg", "outcome"}
    if missing := need - set(frame.columns):
        raise InputError(f"{path}: missing column(s) {', '.join(sorted(missing))}")
    stored = 0
    for i, row in frame.iterrows():
        where = f"{path.name} row {int(i) + 2}"  # type: ignore[call-overload]
        params = {n: float(row[n]) for n in PARAMETERS if n in frame.columns}
        p = Point(int(row["point"]), int(row["replicate"]), params, int(row["seed"]))
        if runner.key(str(row["stage"]), p) != row["key"]:
            raise InputError(f"{where}: key does not match its stage, parameters and seed "
                             "(a sheet of another study, or edited parameters)")
        aor = row["aor_deg"]
        aor = None if aor is None or (isinstance(aor, float) and math.isnan(aor)) else float(aor)
        outcome = row["outcome"]
        outcome = None if not isinstance(outcome, str) or not outcome.strip() else \
            outcome.strip()
        if outcome is None and aor is None:
            continue  # not done yet
        outcome = outcome or "pile"
        if outcome not in OUTCOMES:
            raise InputError(f"{where}: outcome must be one of {', '.join(OUTCOMES)}; "
                             f"got {outcome!r}")
        if outcome == "pile" and (aor is None or not 0 < aor < 90):
            raise InputError(f"{where}: aor_deg must be in (0, 90) for a pile; got {aor!r}")
        runner.record(str(row["stage"]), p, {"outcome": outcome, "aor_deg": aor,
                                             "reason": "imported" if outcome != "pile" else
                                             None, "result": {"imported_from": str(path)}},
                      attempts=2 if outcome in ("unstable", "unsettled") else 1, started=0.0)
        stored += 1
    return stored
