"""The screening stage's typed summary: the Plackett-Burman design, its runs, the
main-effects model's ANOVA and effects, and the factors selected for the next stage."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from demcal.summaries._stored import _Keyed, _read, _stored
from demcal.summaries.anova import AnovaFit, AnovaRecord, anova_records
from demcal.summaries.design import DesignRun, design_runs
from demcal.summaries.study_meta import StudyFactor

__all__ = ["Effect", "Screening", "ScreeningModel"]


@dataclass(frozen=True)
class Effect(_Keyed):
    """One term's effect in the screening model, ranked.

    Attributes
    ----------
    term : str
        The factor (or a dummy column).
    effect : float
        Mean response at +1 less at -1, the response's unit.
    contribution_percent : float
        100 SS(term) / SS(total).
    f, p : float or None
        Its F value and p value (None where not finite: no residual error).
    rank : int
        By |effect|, 1 the largest.
    """

    term: str = ""
    effect: float = 0.0
    contribution_percent: float = 0.0
    f: float | None = None
    p: float | None = None
    rank: int = 0

    #: written even when None
    ALWAYS = ("f", "p")


@dataclass(frozen=True)
class ScreeningModel(_Keyed):
    """Another response's main-effects model over the screening runs (a several-response
    study): which factors move it.

    Attributes
    ----------
    effects : list of Effect
        Every term's effect on it, by rank (empty: no model, see ``note``).
    anova : list of AnovaRecord
        Its ANOVA rows.
    fit : AnovaFit or None
        Its fit statistics (None: no model).
    excluded_points : list of int
        Design points without this response.
    note : str or None
        Why there is no model (the response did not vary, too few points).
    """

    effects: list[Effect] = field(default_factory=list)
    anova: list[AnovaRecord] = field(default_factory=list)
    fit: AnovaFit | None = None
    excluded_points: list[int] = field(default_factory=list)
    note: str | None = None

    #: written even when None
    ALWAYS = ("note",)

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any]) -> ScreeningModel:
        """Read a stored model."""
        items = _read(cls, summary)
        items["effects"] = [Effect.from_summary(e) for e in items.get("effects") or []]
        items["anova"] = anova_records(items.get("anova"))
        if items.get("fit") is not None:
            items["fit"] = AnovaFit.from_summary(items["fit"])
        return cls(**items)


@dataclass(frozen=True)
class Screening:
    """The screening stage (or, where it is disabled, only the factors given).

    Attributes
    ----------
    fidelity : str or None
        The stage's own test fidelity, where it ran at one.
    design : str or None
        ``"plackett_burman"``; None where screening did not run.
    n_runs : int or None
        The design's runs.
    alpha : float or None
        The significance level the factors are selected at.
    factors : list of StudyFactor or None
        The ranges screened.
    dummies : list of str or None
        The design's unused columns.
    runs : list of DesignRun or None
        Every design point and its response; None where screening did not run.
    excluded_points : list of int or None
        Design points without a response (not in the fit).
    anova : list of AnovaRecord or None
        The linear model's ANOVA rows (None: the model could not be fitted).
    fit : AnovaFit or None
        Its fit statistics.
    effects : list of Effect or None
        Every term's effect on the lead response, by rank.
    responses : dict str -> ScreeningModel or None
        With several responses, every other response's model over the same runs; None with
        one.
    selected : list of str
        The factors the next stage varies.
    message : str or None
        Why those, in a sentence.
    error : str or None
        Why the stage failed.
    """

    fidelity: str | None = None
    design: str | None = None
    n_runs: int | None = None
    alpha: float | None = None
    factors: list[StudyFactor] | None = None
    dummies: list[str] | None = None
    runs: list[DesignRun] | None = None
    excluded_points: list[int] | None = None
    anova: list[AnovaRecord] | None = None
    fit: AnovaFit | None = None
    effects: list[Effect] | None = None
    responses: dict[str, ScreeningModel] | None = None
    selected: list[str] = field(default_factory=list)
    message: str | None = None
    error: str | None = None

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any] | None) -> Screening:
        """Read a stored summary (any release's; empty: not run)."""
        items = _read(cls, summary or {})
        if items.get("runs") is not None:
            items["runs"] = design_runs(items["runs"])
        if items.get("factors") is not None:
            items["factors"] = [StudyFactor.from_summary(f) for f in items["factors"]]
        if items.get("effects") is not None:
            items["effects"] = [Effect.from_summary(e) for e in items["effects"]]
        if items.get("anova") is not None:
            items["anova"] = anova_records(items["anova"])
        if items.get("fit") is not None:
            items["fit"] = AnovaFit.from_summary(items["fit"])
        if items.get("responses") is not None:
            items["responses"] = {name: ScreeningModel.from_summary(m)
                                  for name, m in items["responses"].items()}
        items["selected"] = items.get("selected") or []
        return cls(**items)

    def to_summary(self) -> dict[str, Any]:
        """The stored form: each field where set (a failed stage's has no model; ``selected``
        only once chosen)."""
        out = _stored(self)
        if not self.selected and self.anova is None:  # failed: it never chose
            out.pop("selected", None)
        return out

    @property
    def ran(self) -> bool:
        """Whether the design was run (a disabled stage only names its factors)."""
        return self.runs is not None

    @property
    def names(self) -> list[str]:
        """The screened factors' names, in the design's order."""
        return [f.name for f in self.factors or []]
