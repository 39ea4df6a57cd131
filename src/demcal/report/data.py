"""Load everything the report shows from a study's run store (and nothing else).

The store contract (meta keys, stage summaries, runs) is documented in ``demcal.calibrate``;
this module only reads it. Every stage is reported with one of five states: ``done``,
``failed`` (its summary holds ``{"error": ...}``), ``running`` (partial), ``missing`` (never
started) or ``disabled`` (turned off in the study and never started).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from demcal.errors import InputError, StoreError
from demcal.lead import LeadName
from demcal.store import STAGES, STORE_NAME, RunRecord, RunStore
from demcal.summaries import (
    CalibrationResult,
    EngineMeta,
    Optimum,
    RangeFind,
    Screening,
    Steepest,
    StudyFactor,
    StudyMeta,
    Surface,
    Target,
    Verification,
    Versions,
)
from demcal.summaries.physical_meta import PhysicalMeta

__all__ = ["META_KEYS", "STAGES", "Lead", "ReportData", "StageView", "load_report_data"]

#: runs stored under another name than the stage they belong to: the steepest stage's
#: anchor runs (the study's own test at path points; demcal.calibrate.anchor)
RUNS_OF: dict[str, str] = {"steepest_anchor": "steepest"}



#: The meta keys of the store contract that the report reads.
META_KEYS = ("study", "study_file", "study_dir", "target", "physical", "fixed_params",
             "factors", "versions", "engine", "result", "lead")


#: the JSON type each meta key must have (a crafted one was an AttributeError in the report)
META_TYPES: dict[str, type | tuple[type, ...]] = {
    "study": dict, "study_file": str, "study_dir": str, "target": dict, "physical": dict,
    "fixed_params": dict, "factors": list, "versions": dict, "engine": dict, "result": dict,
    "lead": dict}


def _check_meta_types(meta: dict[str, Any], store_path: Path) -> None:
    """Refuse a meta value of the wrong JSON type, in one line naming the key."""
    for key, value in meta.items():
        want = META_TYPES.get(key)
        if want is not None and not isinstance(value, want):
            raise StoreError(f"{store_path}: meta {key!r} is a JSON {type(value).__name__}, "
                             "not what demcal writes there; the store is damaged (`demcal "
                             "calibrate` with its study file writes the meta rows anew)")


@dataclass(frozen=True)
class Lead(LeadName):
    """The response a study leads with, as the report names it (:class:`~demcal.lead.LeadName`:
    ``name``, ``unit``, ``label``, ``after_number``), and its lab value.

    Attributes
    ----------
    target, std : float or None
        Its lab value and spread (for another response than the angle; the angle's are the
        meta ``target``).
    n : int or None
    """

    target: float | None = None
    std: float | None = None
    n: int | None = None


@dataclass(frozen=True)
class StageView:
    """One stage as the report sees it.

    Attributes
    ----------
    name : str
        Stage key (``"screening"``).
    status : {"done", "failed", "running", "missing", "disabled"}
    summary : dict
        The stored JSON summary (empty when missing).
    runs : list of RunRecord
        The stage's stored runs, by point and replicate.
    """

    name: str
    status: str
    summary: dict[str, Any] = field(default_factory=dict)
    runs: list[RunRecord] = field(default_factory=list)

    @property
    def title(self) -> str:
        """Human title of the stage."""
        return STAGES.get(self.name, self.name)

    @property
    def ok(self) -> bool:
        """True when the stage finished (``done``)."""
        return self.status == "done"

    @property
    def error(self) -> str | None:
        """The failure message of a failed stage, else None."""
        if self.status != "failed":
            return None
        return str(self.summary.get("error") or "failed (no message stored)")


@dataclass(frozen=True)
class ReportData:
    """All the numbers of a report, read from the store of ``study_dir``.

    Attributes
    ----------
    study_dir : Path
    meta : dict
        Every meta key of the store (``study``, ``target``, ``physical``, ``factors``, ...).
    stages : dict of str -> StageView
        One entry per known stage (missing ones included) and any other stored stage.
    runs : list of RunRecord
        Every stored run.
    """

    study_dir: Path
    meta: dict[str, Any]
    stages: dict[str, StageView]
    runs: list[RunRecord]

    def stage(self, name: str) -> StageView:
        """The stage ``name`` (status ``missing`` if never started)."""
        return self.stages.get(name, StageView(name, "missing"))

    @property
    def verification(self) -> Verification:
        """The verification stage's summary, typed (empty when the stage has not run)."""
        return Verification.from_summary(self.stage("verification").summary)

    @property
    def rangefind(self) -> RangeFind:
        """The range-finding stage's summary, typed (empty when the stage has not run)."""
        return RangeFind.from_summary(self.stage("rangefind").summary)

    @property
    def screening(self) -> Screening:
        """The screening stage's summary, typed (empty when the stage has not run)."""
        return Screening.from_summary(self.stage("screening").summary)

    @property
    def steepest(self) -> Steepest:
        """The steepest path's summary, typed (empty when the stage has not run)."""
        return Steepest.from_summary(self.stage("steepest").summary)

    @property
    def surface(self) -> Surface:
        """The response-surface stage's summary, typed (empty when the stage has not run)."""
        return Surface.from_summary(self.stage("rsm").summary)

    @property
    def optimum(self) -> Optimum:
        """The optimize stage's summary, typed (empty when the stage has not run or failed)."""
        return Optimum.from_summary(self.stage("optimize").summary)

    @property
    def result(self) -> CalibrationResult | None:
        """The finished calibration's result (meta ``result``), typed; None before it ends.

        Raises
        ------
        StoreError
            A result that is not one demcal writes (a damaged or crafted store).
        """
        stored = self.meta.get("result")
        if not stored:
            return None
        try:
            return CalibrationResult.from_summary(stored)
        except (TypeError, ValueError, KeyError, AttributeError) as exc:
            raise StoreError(f"{self.study_dir}: meta 'result' is not what demcal writes there "
                             f"({exc}); the store is damaged (`demcal calibrate` with its "
                             "study file writes it anew)") from None

    @property
    def study(self) -> StudyMeta:
        """The study's settings the report shows (meta ``study``; defaults in a store
        without)."""
        return StudyMeta.from_summary(self.meta.get("study"))

    @property
    def title_name(self) -> str:
        """The study's name, else its folder's."""
        return self.study.name or self.study_dir.name

    @property
    def factors(self) -> list[StudyFactor]:
        """The study's factors and their ranges as it gave them (meta ``factors``)."""
        return [StudyFactor.from_summary(f) for f in self.meta.get("factors") or []
                if isinstance(f, dict)]

    @property
    def physical(self) -> PhysicalMeta:
        """What the bench measured and derived (meta ``physical``; empty without)."""
        return PhysicalMeta.from_summary(self.meta.get("physical"))

    @property
    def fixed_params(self) -> dict[str, float]:
        """Every parameter that is not a factor, at its fixed value, SI (meta
        ``fixed_params``)."""
        return dict(self.meta.get("fixed_params") or {})

    @property
    def versions(self) -> Versions:
        """The software that made the runs (meta ``versions``; all None in a store without)."""
        return Versions.from_summary(self.meta.get("versions"))

    @property
    def engine(self) -> EngineMeta:
        """The engine that made the runs (meta ``engine``; all None in a store without)."""
        return EngineMeta.from_summary(self.meta.get("engine"))

    @property
    def target(self) -> Target | None:
        """The measured angle the study aims at (meta ``target``), or None (no target, or
        another response leads)."""
        stored = self.meta.get("target")
        return None if not stored else Target.from_summary(stored)

    @property
    def lead(self) -> Lead:
        """The response the study leads with (the angle unless the store names another)."""
        own = self.meta.get("lead")
        if not own:
            return Lead()
        return Lead(name=str(own.get("name")), unit=own.get("unit") or "",
                    target=None if own.get("mean") is None else float(own["mean"]),
                    std=own.get("std"), n=own.get("n"))

    @property
    def lead_lab(self) -> Target | None:
        """The lead's lab value, mean, spread and repeats: the measured angle where the angle
        leads (None: no target), else the leading response's lab value."""
        lead = self.lead
        if lead.is_angle:
            return self.target
        return Target(aor_deg=lead.target, std_deg=lead.std, n=lead.n)

    @property
    def lead_target(self) -> float | None:
        """The lead's lab value (the target lines of the stages' figures)."""
        return self.target_aor_deg if self.lead.is_angle else self.lead.target

    @property
    def target_aor_deg(self) -> float | None:
        """Target angle of repose, degrees, or None."""
        t = self.target
        return None if t is None or t.aor_deg is None else float(t.aor_deg)

    @property
    def symbols(self) -> dict[str, str]:
        """Parameter name -> paper-style symbol (from the factors of the meta and stages)."""
        factors = [*self.factors, *(self.screening.factors or []), *self.surface.factors]
        out: dict[str, str] = {}
        for f in factors:
            if f.name and f.symbol:
                out.setdefault(str(f.name), str(f.symbol))
        return out

    def symbol(self, name: str) -> str:
        """Short symbol of a parameter (its name when none is known)."""
        return self.symbols.get(name, name)

    def excluded_runs(self) -> list[RunRecord]:
        """Runs without a usable value of the lead (the angle): failed, or an outcome other
        than a pile."""
        lead = self.lead.name
        return [r for r in self.runs if r.status != "done"
                or (r.outcome not in (None, "pile")) or r.response(lead) is None]


def load_report_data(study_dir: str | Path) -> ReportData:
    """Read a study's store into a :class:`ReportData`.

    Parameters
    ----------
    study_dir : str or Path
        The study folder holding ``demcal.sqlite`` (or the store file itself).

    Raises
    ------
    InputError
        If there is no store there.
    """
    path = Path(study_dir)
    store_path = path if path.is_file() else path / STORE_NAME
    if not store_path.is_file():
        raise InputError(f"study_dir: no run store {STORE_NAME} in {path} "
                         "(run `demcal calibrate` first)")
    with RunStore(store_path, readonly=True) as store:
        meta = {k: v for k in META_KEYS if (v := store.meta(k)) is not None}
        _check_meta_types(meta, store_path)
        runs = store.runs()
        stored = {s.name: s for s in store.stages()}
    by_stage: dict[str, list[RunRecord]] = {}
    for r in runs:
        by_stage.setdefault(RUNS_OF.get(r.stage, r.stage), []).append(r)
    stages: dict[str, StageView] = {}
    disabled = StudyMeta.from_summary(meta.get("study")).disabled_stages
    for name in [*STAGES, *(n for n in stored if n not in STAGES)]:
        rec = stored.get(name)
        if rec is None:
            status = "disabled" if name in disabled else "missing"
            stages[name] = StageView(name, status, {}, by_stage.get(name, []))
        else:
            summary = rec.summary if isinstance(rec.summary, dict) else {}
            stages[name] = StageView(name, rec.status, summary, by_stage.get(name, []))
    return ReportData(study_dir=store_path.parent, meta=meta, stages=stages, runs=runs)
