"""Where a study stands, read from its store while it runs (``demcal store status``).

A standard study on LAMMPS runs for hours and resumes across sessions; its user wants to
know, without opening the database: who is writing it (and whether that process still
runs), which stages are done, how many runs each holds, what the surface and the optimum
said, and the verification's piles so far. Everything here is read-only and typed.
"""

from __future__ import annotations

import math
import statistics
import time
from dataclasses import dataclass
from typing import Any

from demcal.lead import ANGLE
from demcal.store import RunStore, describe_holder, holder_alive
from demcal.summaries import CalibrationResult, Optimum, Surface, Verification
from demcal.summaries.bayes import BayesSummary
from demcal.summaries.study_meta import StudyMeta

__all__ = ["StageProgress", "StudyProgress", "Writer", "study_progress"]

#: the stages in the order a study runs them (a stage's beside-tests, ``rsm+drum``, count
#: with it)
ORDER = ("rangefind", "screening", "steepest", "rsm", "optimize", "verification", "bayes")


@dataclass(frozen=True)
class Writer:
    """The process that holds the study's writer lock.

    Attributes
    ----------
    description : str
        ``pid 123 on host h since 2026-01-01 12:00:00 UTC (demcal calibrate s.toml)``.
    alive : bool or None
        Whether it still runs (None: another host, which cannot be checked from here).
    """

    description: str
    alive: bool | None

    def line(self) -> str:
        """The writer in words."""
        state = {True: "running", False: "no longer running: a resume takes its lock over",
                 None: "on another host: cannot be checked here"}[self.alive]
        return f"{self.description}; {state}"


@dataclass(frozen=True)
class StageProgress:
    """One stage: its status, its stored runs and what it found, in a few words.

    Attributes
    ----------
    name, status : str
    runs : int
        Its stored runs (the runs of tests beside it included).
    found : str
        What it found (empty: nothing to say yet).
    """

    name: str
    status: str
    runs: int
    found: str


@dataclass(frozen=True)
class StudyProgress:
    """A study's state as its store holds it.

    Attributes
    ----------
    name : str
        The study's name.
    runs : int
        Every stored run.
    last_run_s : float or None
        Seconds since the last run finished (None: no run yet).
    writer : Writer or None
        The writer lock's holder (None: no calibration holds it).
    stages : list of StageProgress
        In the order a study runs them; stages not begun are left out.
    verification : list of float
        The lead response of every verification pile stored so far (a running stage has no
        summary yet; its runs are there).
    result : str or None
        The finished calibration's verification in one line (None: not finished).
    """

    name: str
    runs: int
    last_run_s: float | None
    writer: Writer | None
    stages: list[StageProgress]
    verification: list[float]
    result: str | None

    def verification_line(self) -> str | None:
        """The verification's piles so far: how many, their mean and standard deviation."""
        v = self.verification
        if not v:
            return None
        spread = f", std {statistics.stdev(v):.2f}" if len(v) > 1 else ""
        return (f"{len(v)} verification pile(s) so far (every round): mean "
                f"{statistics.fmean(v):.2f}"
                f"{spread} ({', '.join(f'{x:.2f}' for x in v)})")


def _surface_found(summary: dict[str, Any]) -> str:
    s = Surface.from_summary(summary)
    if s.adequate is None:
        return ""
    p = s.adequacy.p_model if s.adequacy is not None else None
    return ("adequate" if s.adequate else "not adequate") + (
        "" if p is None else f" (model p {p:.3g})")


def _optimum_found(summary: dict[str, Any]) -> str:
    opt = Optimum.from_summary(summary)
    chosen = ", ".join(f"{k} {v:.4g}" for k, v in opt.chosen.items())
    pred = "" if opt.predicted_lead is None else f"; predicted {opt.predicted_lead:.2f}"
    return f"{chosen}{pred}" if chosen else ""


def _verified(v: Verification) -> str:
    """A verification in a few words: its mean, spread, piles and error ("" before any)."""
    if v.mean is None:
        return ""
    rel = "" if v.relative_error_percent is None else \
        f", {v.relative_error_percent:.2f} % from the target"
    std = "" if v.std is None else f" +/- {v.std:.2f}"
    return f"mean {v.mean:.2f}{std} on {v.n} piles{rel}"


def _verification_found(summary: dict[str, Any]) -> str:
    return _verified(Verification.from_summary(summary))


def _bayes_found(summary: dict[str, Any]) -> str:
    bayes = BayesSummary.from_summary(summary)
    if bayes is None:
        return ""
    return "identifiable" if bayes.identifiable else \
        f"not identifiable: {len(bayes.ridge)} ridge(s) left"


#: what each stage's summary says, in a few words (the others: their one-line ``message``)
_FOUND = {"rsm": _surface_found, "optimize": _optimum_found,
          "verification": _verification_found, "bayes": _bayes_found}


def _found(name: str, summary: dict[str, Any]) -> str:
    """What a finished stage's summary says, in a few words."""
    if name in _FOUND:
        return _FOUND[name](summary)
    message = summary.get("message")  # range finding says what it did in one line
    return str(message) if isinstance(message, str) else ""


def _writer(store: RunStore) -> Writer | None:
    holder = store.lock_holder()
    if holder is None:
        return None
    return Writer(description=describe_holder(holder), alive=holder_alive(holder))


def study_progress(store: RunStore) -> StudyProgress:
    """Where the study of ``store`` stands (read only; works while it runs)."""
    runs = store.runs()
    by_stage: dict[str, int] = {}
    for r in runs:
        base = r.stage.partition("+")[0]  # a test beside the stage counts with it
        by_stage[base] = by_stage.get(base, 0) + 1
    records = {s.name: s for s in store.stages()}
    stages = [StageProgress(name=n, status=records[n].status, runs=by_stage.get(n, 0),
                            found=_found(n, records[n].summary)
                            if records[n].status == "done" else "")
              for n in ORDER if n in records]
    lead = _lead(store)
    piles = [v for r in sorted((r for r in runs if r.stage == "verification"),
                               key=lambda r: r.finished_at)
             if (v := r.response(lead)) is not None and math.isfinite(v)]
    stored = store.meta("result")
    result = None
    if isinstance(stored, dict) and stored:
        res = CalibrationResult.from_summary(stored)
        if words := _verified(res.verification):
            result = f"verified {words} (target {res.target:.2f})"
    last = max((r.finished_at for r in runs), default=None)
    study = StudyMeta.from_summary(store.meta("study"))
    return StudyProgress(name=str(study.name or store.path.parent.name), runs=len(runs),
                         last_run_s=None if last is None else max(0.0, time.time() - last),
                         writer=_writer(store), stages=stages, verification=piles,
                         result=result)


def _lead(store: RunStore) -> str:
    """The study's lead response (the angle where the study names no other)."""
    own = store.meta("lead")
    return str(own["name"]) if isinstance(own, dict) and own.get("name") else ANGLE
