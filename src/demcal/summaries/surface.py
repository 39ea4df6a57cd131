"""The response-surface stage's typed summary: the design, its runs, the model, its ANOVA
and adequacy, and every other response's model."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from demcal.summaries._stored import _Flat, _known, _plain
from demcal.summaries.anova import AnovaFit, AnovaRecord, anova_records
from demcal.summaries.design import DesignRun, design_runs
from demcal.summaries.study_meta import StudyFactor

__all__ = ["FitStatistics", "ResponseModel", "Surface", "SurfaceRound"]


@dataclass(frozen=True)
class FitStatistics(_Flat):
    """A response-surface model's fit statistics as Design-Expert judges it (of the
    design-point means; :func:`demcal.calibrate.surface_fit.adequacy` computes them).

    Stored as a summary's ``adequacy`` (and the result's ``rsm_adequacy``); a key an older
    store lacks reads as None.

    Attributes
    ----------
    p_model : float or None
        The model's F-test p-value.
    lack_of_fit_p : float or None
        The lack-of-fit test's p-value (None: no replicated points with spare df).
    r2, adj_r2 : float or None
    pred_r2 : float or None
        Predicted R^2 (PRESS); None where it is not finite.
    adeq_precision : float or None
        Adeq Precision (signal to noise); None where it is not finite.
    """

    p_model: float | None = None
    lack_of_fit_p: float | None = None
    r2: float | None = None
    adj_r2: float | None = None
    pred_r2: float | None = None
    adeq_precision: float | None = None

    @property
    def known(self) -> bool:
        """Whether any statistic is known (none: a response that could not be modelled, or a
        result that stored none)."""
        return any(v is not None for v in dataclasses.astuple(self))


@dataclass(frozen=True)
class SurfaceRound:
    """One replicate round of the response-surface stage: the model fitted after it and
    Design-Expert's verdict (the stage adds replicates while the model is not adequate).

    Attributes
    ----------
    replicates : int
        Replicates of each design point so far.
    runs : int
        Runs fitted (design points x replicates).
    blocks : int
        Blocks of the fit (0: one seed set, no block term).
    model : str
        ``"quadratic"`` or ``"reduced"``.
    removed_terms : list of str
    adequate : bool
    failed : list of str
        The adequacy rules the model failed, in words.
    statistics : FitStatistics
        The statistics the rules judged (stored flat in the row, after ``failed``).
    """

    replicates: int = 1
    runs: int = 0
    blocks: int = 0
    model: str = "quadratic"
    removed_terms: list[str] = field(default_factory=list)
    adequate: bool = False
    failed: list[str] = field(default_factory=list)
    statistics: FitStatistics = field(default_factory=FitStatistics)

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any]) -> SurfaceRound:
        """Read a stored row (any release's)."""
        items = _known(cls, summary)
        items["statistics"] = FitStatistics.from_summary(summary)
        return cls(**items)

    def to_summary(self) -> dict[str, Any]:
        """The stored row: the round's fields, then the statistics' keys."""
        row = {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self)
               if f.name != "statistics"}
        return {**row, **self.statistics.to_summary()}


@dataclass(frozen=True)
class ResponseModel(_Flat):
    """One response's model beside the angle at the response-surface stage (a
    several-response study; :class:`demcal.calibrate.several.ResponseFit` writes it).

    Attributes
    ----------
    model : str or None
        ``"quadratic"``, ``"reduced"`` or ``"constant"`` (the response did not vary).
    adequate : bool or None
        Design-Expert's adequacy rules.
    adequacy : FitStatistics
        p of the model and of the lack of fit, R^2, adjusted and predicted R^2, Adeq Precision
        (all None for a response that could not be modelled).
    warnings : list of str
    excluded_points : list of int
        Design points without this response.
    anova : list of AnovaRecord
        The ANOVA table's rows.
    coefficients_coded : dict str -> float
        The model's coefficients in coded units, by term.
    equation_actual : str or None
        The model in the factors' units.
    """

    model: str | None = None
    adequate: bool | None = None
    adequacy: FitStatistics = field(default_factory=FitStatistics)
    warnings: list[str] = field(default_factory=list)
    excluded_points: list[int] = field(default_factory=list)
    anova: list[AnovaRecord] = field(default_factory=list)
    coefficients_coded: dict[str, float] = field(default_factory=dict)
    equation_actual: str | None = None

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any]) -> ResponseModel:
        """Read a stored model (any release's)."""
        items = _known(cls, summary)
        items["adequacy"] = FitStatistics.from_summary(items.get("adequacy") or {})
        items["anova"] = anova_records(items.get("anova"))
        return cls(**items)


@dataclass(frozen=True)
class Surface:
    """The response-surface stage: the design, its runs, the angle's quadratic (or reduced)
    model, its ANOVA and Design-Expert's adequacy, and in a several-response study every other
    response's model.

    The design's runs (:class:`DesignRun`, as screening's), the ANOVA rows and the fit
    statistics are typed, and so is each replicate round (:class:`SurfaceRound`).

    Attributes
    ----------
    design : str or None
        ``"box_behnken"`` or ``"ccd"``.
    fidelity : str or None
        The test fidelity the surface was fitted on where it is not the study's
        (``stages.rsm.fidelity``; the verification runs the study's).
    factors : list of StudyFactor
        The ranges the design spans.
    runs : list of DesignRun
        Per design point: its settings, the lead response's mean over the replicates, its
        outcome and each replicate's value.
    excluded_points : list of int
        Design points without a pile (not in the fit).
    replicates : int or None
        Replicates per design point used (more are added while the model is not adequate).
    responses : dict str -> ResponseModel or None
        Every response beside the angle; None with the angle alone.
    anova : list of AnovaRecord
        The ANOVA of the model the optimum is read from (every replicate a row).
    fit : AnovaFit or None
        Its fit statistics (None: a failed stage's).
    lack_of_fit_p : float or None
    adequacy : FitStatistics or None
        The design-point means' statistics Design-Expert's rules judge (None: a failed
        stage's).
    rounds : list of SurfaceRound or None
        One row per replicate round: replicates, runs, model, adequacy.
    model : str or None
        ``"quadratic"`` or ``"reduced"`` (None: a store written before the reduction, a
        quadratic).
    removed_terms : list of str or None
    anova_full, adequacy_full : list of AnovaRecord, FitStatistics or None
        The full quadratic model's ANOVA and adequacy.
    coefficients_coded, coefficients_actual : dict str -> float
        The model's coefficients by term, in coded and in actual units.
    equation_coded, equation_actual : str or None
    adequate : bool or None
    warnings : list of str
    resolution : str or None
        Where the model is not adequate: its largest main effect against the noise and the
        replicates that would resolve it (:func:`demcal.calibrate.surface_fit.resolution_note`).
    """

    design: str | None = None
    fidelity: str | None = None
    factors: list[StudyFactor] = field(default_factory=list)
    runs: list[DesignRun] = field(default_factory=list)
    excluded_points: list[int] = field(default_factory=list)
    replicates: int | None = None
    responses: dict[str, ResponseModel] | None = None
    anova: list[AnovaRecord] = field(default_factory=list)
    fit: AnovaFit | None = None
    lack_of_fit_p: float | None = None
    adequacy: FitStatistics | None = None
    rounds: list[SurfaceRound] | None = None
    model: str | None = None
    removed_terms: list[str] | None = None
    anova_full: list[AnovaRecord] | None = None
    adequacy_full: FitStatistics | None = None
    coefficients_coded: dict[str, float] = field(default_factory=dict)
    coefficients_actual: dict[str, float] = field(default_factory=dict)
    equation_coded: str | None = None
    equation_actual: str | None = None
    adequate: bool | None = None
    warnings: list[str] = field(default_factory=list)
    resolution: str | None = None

    #: written even when None (no lack-of-fit test); the other fields: when not None
    ALWAYS = ("lack_of_fit_p",)

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any] | None) -> Surface:
        """Read a stored rsm summary (any release's; empty: not run; a failed stage's: its
        design and runs)."""
        items = _known(cls, summary or {})
        if items.get("responses") is not None:
            items["responses"] = {name: ResponseModel.from_summary(r)
                                  for name, r in items["responses"].items()}
        for name in ("factors", "excluded_points", "warnings"):
            items[name] = items.get(name) or []
        items["factors"] = [StudyFactor.from_summary(f) for f in items["factors"]]
        items["runs"] = design_runs(items.get("runs"))
        items["anova"] = anova_records(items.get("anova"))
        if items.get("anova_full") is not None:
            items["anova_full"] = anova_records(items["anova_full"])
        if items.get("fit") is not None:
            items["fit"] = AnovaFit.from_summary(items["fit"])
        if items.get("rounds") is not None:
            items["rounds"] = [SurfaceRound.from_summary(r) for r in items["rounds"]]
        for name in ("adequacy", "adequacy_full"):
            if items.get(name) is not None:
                items[name] = FitStatistics.from_summary(items[name])
        for name in ("coefficients_coded", "coefficients_actual"):
            items[name] = items.get(name) or {}
        return cls(**items)

    @property
    def names(self) -> list[str]:
        """The factors' names, in the design's order."""
        return [f.name for f in self.factors]

    @property
    def ranges(self) -> dict[str, tuple[float, float]]:
        """Each factor's range the design spans, ``(low, high)``, SI."""
        return {f.name: (f.low, f.high) for f in self.factors}

    @property
    def model_kind(self) -> str:
        """The model the optimum is read from (``"quadratic"`` where a store predates the
        reduction)."""
        return self.model or "quadratic"

    def to_summary(self) -> dict[str, Any]:
        """The stored form: the fields in order, each where it is not None (``responses``
        only in a several-response study), ``lack_of_fit_p`` always."""
        return {f.name: _plain(v) for f in dataclasses.fields(self)
                if (v := getattr(self, f.name)) is not None or f.name in self.ALWAYS}
