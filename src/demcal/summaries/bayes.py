"""The Bayesian strategy's stage summary, typed: what ``[strategy] kind = "bayes"`` stores.

:mod:`demcal.calibrate.bayes_strategy` builds a :class:`BayesSummary` from the loop's posterior,
verdict and runs and stores :meth:`BayesSummary.to_summary` as the stage ``"bayes"``; the
result JSON holds the same keys less the stored samples and slices
(:meth:`BayesSummary.in_result`). The report's section and the material card's
``[posterior]`` read it back with :meth:`BayesSummary.from_summary`, so a renamed key breaks
this module's test, not a page. Values are in the factors' own units unless a field says
coded (the factor's range mapped to -1..+1).

Stores of every release read: a key a store lacks takes its default (``marks`` came later).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from demcal.summaries._stored import _KeyedEvery, _plain

__all__ = ["BayesLab", "BayesPrediction", "BayesRound", "BayesSummary", "CombinationRow",
           "MarkedPoint", "PosteriorInterval", "RidgeRow", "ShrinkageRow", "SurrogateCheckRow",
           "SurrogateSlice"]


@dataclass(frozen=True)
class PosteriorInterval(_KeyedEvery):
    """One factor's posterior: mean, median and the 95 % credible interval (its units)."""

    mean: float = float("nan")
    median: float = float("nan")
    ci95_low: float = float("nan")
    ci95_high: float = float("nan")


@dataclass(frozen=True)
class RidgeRow(_KeyedEvery):
    """A direction along which the 95 % credible region spans more than half the range.

    Attributes
    ----------
    text : str
        The ridge in parameters (``"static friction up 0.1 = rolling friction down 0.03"``).
    parameters : list of str
        The factors that move along it.
    direction_coded : list of float
        Its unit direction, coded units, in the factors' order.
    fraction : float
        The region's extent along it as a fraction of the range's.
    """

    text: str = ""
    parameters: list[str] = field(default_factory=list)
    direction_coded: list[float] = field(default_factory=list)
    fraction: float = float("nan")


@dataclass(frozen=True)
class ShrinkageRow(_KeyedEvery):
    """How much one more response would shrink a ridge, estimated from the runs.

    Attributes
    ----------
    response : str
        A response the runs report that the study does not aim at.
    ridge : str
        The ridge's text.
    shrinkage : float
        ``1 - extent_after / extent_before`` (0: none, 1: the ridge is gone).
    extent_before, extent_after : float
        95 % extent along the ridge, coded units.
    effective_samples : float
        Smallest effective sample size of the reweighted samples (few: a rough estimate).
    basis : {"runs", "stated"}
        Estimated from a surrogate of the runs' values of the response, or from the slopes
        the study states (``[[strategy.candidates]]``).
    source : str or None
        Where stated slopes come from, as the study says.
    """

    response: str = ""
    ridge: str = ""
    shrinkage: float = float("nan")
    extent_before: float = float("nan")
    extent_after: float = float("nan")
    effective_samples: float = float("nan")
    basis: str = "runs"
    source: str | None = None


@dataclass(frozen=True)
class SurrogateCheckRow(_KeyedEvery):
    """A surrogate's runs, each predicted from the others
    (:func:`demcal.doe.bayes.check_surrogate`).

    Attributes
    ----------
    response : str
    n : int
        Runs it was fitted on.
    rms_z : float
        Root mean square of the standardised leave-one-out errors (about 1 when right).
    max_abs_z : float
        The largest of them, at ``worst``.
    limit : float
        The Bonferroni limit for ``n`` runs (5 %): a run beyond it is one the surrogate
        does not follow.
    worst : dict of str to float
        That run's factors (their units).
    value : float
        That run's response.
    predicted : float
        What the other runs' surrogate predicts there.
    rms_error : float
        Root mean square of the leave-one-out errors, the response's unit.
    judged : bool
        Enough runs to judge the surrogate.
    misses_a_run : bool
        Judged, and a run lies beyond the limit (the study warned of it).
    """

    response: str = ""
    n: int = 0
    rms_z: float = float("nan")
    max_abs_z: float = float("nan")
    limit: float = float("nan")
    worst: dict[str, float] = field(default_factory=dict)
    value: float = float("nan")
    predicted: float = float("nan")
    rms_error: float = float("nan")
    judged: bool = False
    misses_a_run: bool = False


@dataclass(frozen=True)
class CombinationRow(_KeyedEvery):
    """What the tests would leave if the study added some candidates together.

    Attributes
    ----------
    responses : list of str
        The candidates added (one or two).
    ridges : list of str
        The ridges they would leave, in words (empty: every parameter pinned), by a
        linear-Gaussian update of the posterior (:func:`demcal.doe.bayes.ridges_after`).
    """

    responses: list[str] = field(default_factory=list)
    ridges: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class BayesRound(_KeyedEvery):
    """One round of the loop: the runs so far and the posterior's coded 95 % half-widths."""

    round: int = 0
    n_runs: int = 0
    half_widths_coded: dict[str, float] = field(default_factory=dict)
    acceptance_fraction: float = float("nan")
    warnings: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class BayesLab(_KeyedEvery):
    """A response's lab value: mean, standard error of that mean, unit."""

    mean: float = float("nan")
    standard_error: float = float("nan")
    unit: str = ""


@dataclass(frozen=True)
class BayesPrediction(_KeyedEvery):
    """A surrogate at the best point: its mean response and the standard deviation of it."""

    mean: float = float("nan")
    std: float = float("nan")


@dataclass(frozen=True)
class MarkedPoint(_KeyedEvery):
    """A point held against the posterior (``[[strategy.marks]]``).

    Attributes
    ----------
    label : str
    values : dict of str to float
        The factors' values (their units).
    in_box : bool
        Whether the point lies inside the factor ranges.
    credibility : float
        The posterior mass of the smallest highest-density region holding it.
    inside95 : bool
        ``credibility <= 0.95``: inside the 95 % credible region.
    """

    label: str = ""
    values: dict[str, float] = field(default_factory=dict)
    in_box: bool = False
    credibility: float = float("nan")
    inside95: bool = False


@dataclass(frozen=True)
class SurrogateSlice(_KeyedEvery):
    """A surrogate along one factor through the best point, the others held there."""

    x: list[float] = field(default_factory=list)
    mean: list[float] = field(default_factory=list)
    std: list[float] = field(default_factory=list)


def _rows(cls: type, stored: Any) -> list[Any]:
    return [cls.from_summary(s) for s in stored or [] if isinstance(s, Mapping)]


def _by_name(cls: type, stored: Any) -> dict[str, Any]:
    return {str(k): cls.from_summary(v) for k, v in (stored or {}).items()
            if isinstance(v, Mapping)}


#: the fields the result JSON leaves out (the report's drawing data)
_STORED_ONLY = ("samples", "slices")


@dataclass(frozen=True)
class BayesSummary:
    """The stage ``"bayes"``: the posterior, the verdict and how the loop got there.

    Attributes
    ----------
    posterior : dict of str to PosteriorInterval
        Per factor, in the factors' order.
    correlation : dict of str to dict of str to float
        The posterior's correlation matrix, by factor.
    acceptance_fraction : float
        The sampler's.
    map : dict of str to float
        The highest-posterior sample.
    warnings : list of str
        What the sampler or the surrogates warned of.
    identifiable : bool
        Every factor pinned down: no ridge.
    reason : str
        The verdict in a sentence.
    n_runs : int
        Runs the posterior is conditioned on: the loop's (start and rounds) and
        ``verification_runs``.
    verification_runs : int
        Of them, the runs of verification rounds that missed
        (``stages.verification.max_rounds`` > 1): data at the best points where the
        surrogates were wrong.
    stopped : str
        ``tolerance``, ``stable`` or ``budget``.
    ridges : list of RidgeRow
    ridge : list of str
        The ridges' texts.
    shrinkage : list of ShrinkageRow
    history : list of BayesRound
    optimum : dict of str to float
        The best point, the verification's.
    predicted : dict of str to BayesPrediction
        Each surrogate at the best point.
    labs : dict of str to BayesLab
        The lab values the posterior was conditioned on.
    notes : list of str
    settings : dict
        The strategy's settings as run (``max_runs``, ``batch``, ``tolerance``, ``seed``, ...).
    units : dict of str to str
        Each factor's unit.
    marks : list of MarkedPoint
    combinations : list of CombinationRow
        Each candidate alone and each pair of them: the ridges they would leave.
    advice : list of str
        Per ridge (or widest axis), the candidate that would shrink it most, and the fewest
        candidates that would pin every parameter, in sentences.
    surrogate_checks : list of SurrogateCheckRow
        Each response's surrogate against its own runs (leave-one-out), the pile indicator's
        left out.
    samples : dict of str to list of float
        Thinned posterior samples by factor (the corner plot's).
    slices : dict of str to dict of str to SurrogateSlice
        ``{response: {factor: slice}}``.
    """

    posterior: dict[str, PosteriorInterval] = field(default_factory=dict)
    correlation: dict[str, dict[str, float]] = field(default_factory=dict)
    acceptance_fraction: float = float("nan")
    map: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    identifiable: bool = False
    reason: str = ""
    n_runs: int = 0
    verification_runs: int = 0
    stopped: str = ""
    ridges: list[RidgeRow] = field(default_factory=list)
    ridge: list[str] = field(default_factory=list)
    shrinkage: list[ShrinkageRow] = field(default_factory=list)
    history: list[BayesRound] = field(default_factory=list)
    optimum: dict[str, float] = field(default_factory=dict)
    predicted: dict[str, BayesPrediction] = field(default_factory=dict)
    labs: dict[str, BayesLab] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    settings: dict[str, Any] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    marks: list[MarkedPoint] = field(default_factory=list)
    combinations: list[CombinationRow] = field(default_factory=list)
    advice: list[str] = field(default_factory=list)
    surrogate_checks: list[SurrogateCheckRow] = field(default_factory=list)
    samples: dict[str, list[float]] = field(default_factory=dict)
    slices: dict[str, dict[str, SurrogateSlice]] = field(default_factory=dict)

    @property
    def names(self) -> list[str]:
        """The factors, in their order."""
        return list(self.posterior)

    @classmethod
    def from_summary(cls, stored: Mapping[str, Any] | None) -> BayesSummary | None:
        """Read a stored summary of any release; None when it holds no posterior (no
        Bayesian study, or one still running)."""
        if not stored or not isinstance(stored.get("posterior"), Mapping):
            return None
        plain = {f.name: stored[f.name] for f in dataclasses.fields(cls) if f.name in stored}
        plain.update(
            posterior=_by_name(PosteriorInterval, stored["posterior"]),
            ridges=_rows(RidgeRow, stored.get("ridges")),
            shrinkage=_rows(ShrinkageRow, stored.get("shrinkage")),
            history=_rows(BayesRound, stored.get("history")),
            predicted=_by_name(BayesPrediction, stored.get("predicted")),
            labs=_by_name(BayesLab, stored.get("labs")),
            marks=_rows(MarkedPoint, stored.get("marks")),
            combinations=_rows(CombinationRow, stored.get("combinations")),
            surrogate_checks=_rows(SurrogateCheckRow, stored.get("surrogate_checks")),
            slices={str(r): _by_name(SurrogateSlice, per)
                    for r, per in (stored.get("slices") or {}).items()
                    if isinstance(per, Mapping)})
        return cls(**plain)

    def to_summary(self) -> dict[str, Any]:
        """The stored form: every field under its name, nested rows by their own."""
        return {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self)}

    def in_result(self) -> dict[str, Any]:
        """The result JSON's Bayesian part: the stored form less the samples and slices."""
        return {k: v for k, v in self.to_summary().items() if k not in _STORED_ONLY}

