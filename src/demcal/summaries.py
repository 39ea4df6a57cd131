"""Typed stage summaries: what a calibration stage stores and what the report, the material
card and the result JSON read back.

A stage's summary lives in the run store as JSON. ``from_summary``
(:meth:`Verification.from_summary`, :meth:`Optimum.from_summary`,
:meth:`Surface.from_summary`) reads one written by any
release (a key it lacks takes its default, as older stores lack the newer keys; keys it does
not know are left out), and ``to_summary`` writes this release's keys in a fixed order.
Readers use the attributes, so renaming a field breaks the code that reads it and its tests,
not a cell of the report.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Self, TypeVar

__all__ = ["Candidate", "Goal", "Optimum", "ResponseModel", "ResponseVerification",
           "ResponsesOptimum", "Surface", "Verification"]

_T = TypeVar("_T")


def _known(cls: type[_T], summary: Mapping[str, Any]) -> dict[str, Any]:
    """The items of ``summary`` that are fields of the dataclass ``cls``."""
    names = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    return {k: v for k, v in summary.items() if k in names}


class _Flat:
    """A summary stored as its own fields: read from any release's (a key it lacks takes its
    default, a key it does not know is left out), written as every field in order."""

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any]) -> Self:
        """Read the stored form."""
        return cls(**_known(cls, summary))

    def to_summary(self) -> dict[str, Any]:
        """The stored form: every field."""
        return dataclasses.asdict(self)  # type: ignore[call-overload]


@dataclass(frozen=True)
class ResponseVerification(_Flat):
    """One response of a several-response study at the verification (its lab comparison).

    Attributes
    ----------
    values : list of float
        The verification runs' values of the response (runs that reported it), its unit.
    mean, std : float or None
        Their mean and sample standard deviation.
    n : int
        How many runs reported it.
    lab : dict or None
        The lab value as the study gave it (``mean``, ``std``, ``n``, ``unit``...).
    relative_error_percent : float or None
        ``|mean - lab| / |lab|``, %.
    ci_low_deg, ci_high_deg : float or None
        The 95 % t-interval of the mean, in the response's unit (the keys keep the angle's
        names for the store's sake).
    target_in_interval, consistent : bool or None
        The lab mean inside that interval; the t-test's p >= 0.05.
    p_value : float or None
    test : str or None
        Which t-test.
    desirability : float or None
        The goal's desirability of the verified mean.
    """

    values: list[float] = field(default_factory=list)
    mean: float | None = None
    std: float | None = None
    n: int = 0
    lab: dict[str, Any] | None = None
    relative_error_percent: float | None = None
    ci_low_deg: float | None = None
    ci_high_deg: float | None = None
    target_in_interval: bool | None = None
    p_value: float | None = None
    test: str | None = None
    consistent: bool | None = None
    desirability: float | None = None


@dataclass(frozen=True)
class Verification:
    """The verification stage: replicate runs at the optimum on fresh seeds, judged against
    the lab's angle (and, in a several-response study, every response against its lab value).

    Attributes
    ----------
    params : dict str -> float
        The full parameter set run, SI.
    aor_deg : list of float or None
        Each run's angle, deg (None: no pile).
    outcomes : list of str
        Each run's outcome.
    aor_mean_deg, aor_std_deg : float or None
        Mean and sample standard deviation of the piles' angles, deg.
    relative_error_percent : float or None
        ``|mean - target| / target``, %.
    n, n_piles : int
        Runs made and piles formed.
    pile_png : str or None
        A side view of one verification pile.
    half_width_deg, half_width_goal_deg : float or None
        The 95 % interval's half width reached and the study's goal for it, deg.
    half_width_reached : bool
    sized_with_std_deg : float or None
        The pure-error standard deviation the run count was sized with, deg.
    sized_with_df : int or float or None
        Its degrees of freedom.
    ci_low_deg, ci_high_deg : float or None
        The 95 % t-interval of the mean, deg.
    target_in_interval : bool or None
        The lab angle inside it.
    p_value : float or None
        The t-test against the lab (:func:`demcal.calibrate.verify.compare_to_target`).
    test : str or None
        Which t-test.
    consistent : bool or None
        p >= 0.05.
    tolerance_percent : float or None
        The study's tolerance on the relative error, %.
    within_tolerance : bool or None
    confirm_pi_low_deg, confirm_pi_high_deg : float or None
        The surface's 95 % prediction interval for the mean of n runs (Design-Expert's
        confirmation), deg.
    confirmed : bool or None
        The mean inside it.
    responses : dict str -> ResponseVerification or None
        Every response of a several-response study; None with the angle alone.
    round : int or None
        The refinement round (None: the first and only).
    rounds : list of Verification
        The earlier rounds' verifications, oldest first (each without its own history).
    """

    params: dict[str, float] = field(default_factory=dict)
    aor_deg: list[float | None] = field(default_factory=list)
    outcomes: list[str] = field(default_factory=list)
    aor_mean_deg: float | None = None
    aor_std_deg: float | None = None
    relative_error_percent: float | None = None
    n: int = 0
    n_piles: int = 0
    pile_png: str | None = None
    half_width_deg: float | None = None
    half_width_goal_deg: float | None = None
    half_width_reached: bool = False
    sized_with_std_deg: float | None = None
    sized_with_df: int | float | None = None
    ci_low_deg: float | None = None
    ci_high_deg: float | None = None
    target_in_interval: bool | None = None
    p_value: float | None = None
    test: str | None = None
    consistent: bool | None = None
    tolerance_percent: float | None = None
    within_tolerance: bool | None = None
    confirm_pi_low_deg: float | None = None
    confirm_pi_high_deg: float | None = None
    confirmed: bool | None = None
    responses: dict[str, ResponseVerification] | None = None
    round: int | None = None
    rounds: list[Verification] = field(default_factory=list)

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any] | None) -> Verification:
        """Read a stored verification summary (any release's; empty: not verified)."""
        items = _known(cls, summary or {})
        if items.get("responses") is not None:
            items["responses"] = {name: ResponseVerification.from_summary(r)
                                  for name, r in items["responses"].items()}
        items["rounds"] = [cls.from_summary(r) for r in items.get("rounds") or []]
        return cls(**items)

    @property
    def done(self) -> bool:
        """Whether any run was made (an empty summary reads as not verified)."""
        return self.n > 0 or bool(self.outcomes)

    @property
    def round_number(self) -> int:
        """The refinement round, 1 for the first."""
        return self.round or 1

    def to_summary(self) -> dict[str, Any]:
        """The stored form: every field, less ``responses``, ``round`` and ``rounds`` where
        they are empty (a single-response, single-round study stores what it always did)."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name == "responses":
                if value is not None:
                    out["responses"] = {k: r.to_summary() for k, r in value.items()}
            elif f.name == "rounds":
                if value:
                    out["rounds"] = [r.to_summary() for r in value]
            elif f.name != "round" or value is not None:
                out[f.name] = value
        return out


def _written(obj: Any, always: tuple[str, ...]) -> dict[str, Any]:
    """The stored form of the flat dataclass ``obj``: its fields in order, those not named in
    ``always`` only where they hold a value (a key a producer does not write stays out, so
    the summary it stored reads back to the same keys)."""
    return {f.name: copy.deepcopy(v) for f in dataclasses.fields(obj)
            if (v := getattr(obj, f.name)) is not None or f.name in always}


def _plain(value: Any) -> Any:
    """``value`` as JSON: a typed summary by its ``to_summary``, lists and dicts item by item,
    anything else copied (the stored form shares nothing with the object)."""
    if isinstance(value, list):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if hasattr(value, "to_summary"):
        return value.to_summary()
    return copy.deepcopy(value)


@dataclass(frozen=True)
class Candidate(_Flat):
    """One setting the optimize stage proposes, ranked best first.

    Attributes
    ----------
    params : dict str -> float
        The factors' values, SI.
    predicted_aor_deg : float or None
        The angle the surface predicts there (corrected by a refinement round's offset; the
        Bayesian strategy: its surrogate's mean), deg.
    pi_low_deg, pi_high_deg : float or None
        The surface's 95 % prediction interval there, deg (None: no surface, or unbounded).
    p_pile : float or None
        The pile region's probability of a pile there.
    desirability : float or None
        The search's desirability (the overall one with several responses); not written by
        the Bayesian strategy.
    predicted, individual : dict str -> float or None
        With several responses: each response's prediction and desirability there.
    """

    params: dict[str, float] = field(default_factory=dict)
    predicted_aor_deg: float | None = None
    pi_low_deg: float | None = None
    pi_high_deg: float | None = None
    p_pile: float | None = None
    desirability: float | None = None
    predicted: dict[str, float] | None = None
    individual: dict[str, float] | None = None

    #: the keys every producer writes, None or not
    ALWAYS = ("params", "predicted_aor_deg", "pi_low_deg", "pi_high_deg", "p_pile")

    def to_summary(self) -> dict[str, Any]:
        """The stored form (``desirability``, ``predicted`` and ``individual`` only where
        set)."""
        return _written(self, self.ALWAYS)


@dataclass(frozen=True)
class Goal(_Flat):
    """One response's goal in a several-response optimum (what a resume compares).

    Attributes
    ----------
    name : str
        The response.
    goal : str
        ``"target"``, ``"maximize"``, ``"minimize"`` or ``"in_range"``.
    low, high : float
        The desirability's limits, the response's unit.
    target : float or None
        The value aimed at (a ``"target"`` goal).
    weight : float
    importance : int
    """

    name: str = ""
    goal: str = ""
    low: float = 0.0
    high: float = 0.0
    target: float | None = None
    weight: float = 1.0
    importance: int = 3


@dataclass(frozen=True)
class ResponsesOptimum:
    """The desirability side of a several-response optimum.

    Attributes
    ----------
    goals : list of Goal
        Every response's goal, the angle first.
    desirability : float or None
        The best candidate's overall desirability D.
    reachable : bool or None
        Whether some setting has every response inside its limits.
    unmet : list of str
        The responses whose limits no setting meets together with the others.
    """

    goals: list[Goal] = field(default_factory=list)
    desirability: float | None = None
    reachable: bool | None = None
    unmet: list[str] = field(default_factory=list)

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any]) -> ResponsesOptimum:
        """Read a stored ``optimize.responses``."""
        items = _known(cls, summary)
        items["goals"] = [Goal.from_summary(g) for g in items.get("goals") or []]
        return cls(**items)

    def to_summary(self) -> dict[str, Any]:
        """The stored form: every field."""
        return {"goals": [g.to_summary() for g in self.goals],
                "desirability": self.desirability, "reachable": self.reachable,
                "unmet": list(self.unmet)}


@dataclass(frozen=True)
class Optimum:
    """The optimize stage: the settings the verification runs, and how they were found.

    One type for the three producers, told apart by what they fill in:

    - the angle's response surface (:func:`demcal.calibrate.stages.optimize`): ``classifier``
      and ``opts`` (the stage's options), each candidate's ``desirability``;
    - several responses (:func:`demcal.calibrate.several.optimize_summary`): the same and
      ``responses`` (the goals and the overall desirability), each candidate's
      ``predicted`` and ``individual``, and ``warnings`` when a limit is out of reach;
    - the Bayesian strategy (:mod:`demcal.calibrate.bayes_strategy`): ``opts`` is
      ``"bayes"`` and ``source`` says where the point came from (the posterior's best
      sample); one candidate, without a surface's interval or a classifier.

    Attributes
    ----------
    target_aor_deg : float or None
        The lab angle aimed at, deg.
    candidates : list of Candidate
        Ranked, best first.
    chosen : dict str -> float
        The best candidate's factors (what the verification runs).
    predicted_aor_deg : float or None
        The angle predicted there, deg.
    classifier : dict or None
        The pile region's description (:meth:`PileClassifier.describe`).
    opts : dict or str or None
        The stage's options as run (a resume keeps an optimum only for the same ones), or
        ``"bayes"``; None in a store written before they were stored.
    source : str or None
        Where an optimum not read off a response surface came from.
    responses : ResponsesOptimum or None
        A several-response study's goals and desirability; None with the angle alone.
    warnings : list of str
    round : int or None
        The refinement round (:mod:`demcal.calibrate.refine`; None: the first).
    surface_offset_deg : float or None
        In a refinement round, the correction applied: the surface was aimed at the target
        less it, deg.
    offset_from_rounds : list of int or None
        The earlier rounds whose offsets were pooled.
    measured_offset_deg : float or None
        Their piles' means less the surface there, pooled, deg.
    offset_weight : float or None
        The share of it applied.
    rounds : list of Optimum
        The earlier rounds' optima, oldest first (each without its own history).
    """

    target_aor_deg: float | None = None
    candidates: list[Candidate] = field(default_factory=list)
    chosen: dict[str, float] = field(default_factory=dict)
    predicted_aor_deg: float | None = None
    classifier: dict[str, Any] | None = None
    opts: dict[str, Any] | str | None = None
    source: str | None = None
    responses: ResponsesOptimum | None = None
    warnings: list[str] = field(default_factory=list)
    round: int | None = None
    surface_offset_deg: float | None = None
    offset_from_rounds: list[int] | None = None
    measured_offset_deg: float | None = None
    offset_weight: float | None = None
    rounds: list[Optimum] = field(default_factory=list)

    #: the keys every producer writes, None or not
    ALWAYS = ("target_aor_deg", "candidates", "chosen", "predicted_aor_deg")
    #: the lists written only when they hold something (the others: when not None)
    WHEN_FILLED = ("warnings", "rounds")
    #: the Bayesian strategy's summary (``source`` set) has always begun with these, in this
    #: order; the store keeps a summary's key order, so it still does
    POSTERIOR_FIRST = ("target_aor_deg", "chosen", "predicted_aor_deg", "candidates")

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any] | None) -> Optimum:
        """Read a stored optimize summary (any release's and producer's; empty, or a failed
        stage's ``{"error": ...}``: no optimum)."""
        items = _known(cls, summary or {})
        items["candidates"] = [Candidate.from_summary(c) for c in items.get("candidates") or []]
        items["chosen"] = items.get("chosen") or {}
        # an empty "responses" reads as none, as the report always took it
        items["responses"] = (ResponsesOptimum.from_summary(items["responses"])
                              if items.get("responses") else None)
        items["warnings"] = items.get("warnings") or []
        items["rounds"] = [cls.from_summary(r) for r in items.get("rounds") or []]
        return cls(**items)

    @property
    def done(self) -> bool:
        """Whether there is an optimum (an empty or failed summary has none)."""
        return bool(self.chosen)

    @property
    def best(self) -> Candidate:
        """The best candidate (an empty one where there is none)."""
        return self.candidates[0] if self.candidates else Candidate()

    @property
    def round_number(self) -> int:
        """The refinement round, 1 for the first."""
        return self.round or 1

    def in_round(self, earlier: list[Optimum]) -> Optimum:
        """This optimum as stored in its round: with the ``earlier`` rounds' optima as its
        history (each without its own), and any history it carried dropped."""
        return dataclasses.replace(
            self, rounds=[dataclasses.replace(e, rounds=[]) for e in earlier])

    def to_summary(self) -> dict[str, Any]:
        """The stored form: the fields in order (the Bayesian strategy's: its own order,
        :attr:`POSTERIOR_FIRST`); ``classifier``, ``opts``, ``source``, ``responses``, the
        round's and ``warnings``/``rounds`` only where set, so each producer's summary keeps
        exactly the keys, in the order, it always wrote."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            unset = value is None or (f.name in self.WHEN_FILLED and not value)
            if f.name in self.ALWAYS or not unset:
                out[f.name] = _plain(value)
        first = self.POSTERIOR_FIRST if self.source is not None else ()
        return {k: out[k] for k in [*first, *(k for k in out if k not in first)]}


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
    adequacy : dict
        p of the model and of the lack of fit, R^2, adjusted and predicted R^2, Adeq Precision.
    warnings : list of str
    excluded_points : list of int
        Design points without this response.
    anova : list of dict
        The ANOVA table's rows.
    coefficients_coded : dict str -> float
        The model's coefficients in coded units, by term.
    equation_actual : str or None
        The model in the factors' units.
    """

    model: str | None = None
    adequate: bool | None = None
    adequacy: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    excluded_points: list[int] = field(default_factory=list)
    anova: list[dict[str, Any]] = field(default_factory=list)
    coefficients_coded: dict[str, float] = field(default_factory=dict)
    equation_actual: str | None = None


@dataclass(frozen=True)
class Surface:
    """The response-surface stage: the design, its runs, the angle's quadratic (or reduced)
    model, its ANOVA and Design-Expert's adequacy, and in a several-response study every other
    response's model.

    The nested rows (``factors``, ``runs``, ``anova``, ``rounds``) keep the stored form; the
    report's model helpers read them alike from the screening stage's summary.

    Attributes
    ----------
    design : str or None
        ``"box_behnken"`` or ``"ccd"``.
    factors : list of dict
        ``{"name", "symbol", "low", "high", "unit"}``: the ranges the design spans.
    runs : list of dict
        Per design point: ``point``, ``coded``, ``actual``, ``aor_deg`` (the replicates'
        mean), ``outcome``, ``aor_runs_deg``, ``aor_std_deg``.
    excluded_points : list of int
        Design points without a pile (not in the fit).
    replicates : int or None
        Replicates per design point used (more are added while the model is not adequate).
    responses : dict str -> ResponseModel or None
        Every response beside the angle; None with the angle alone.
    anova : list of dict
        The ANOVA of the model the optimum is read from (every replicate a row).
    fit : dict
        Its fit statistics.
    lack_of_fit_p : float or None
    adequacy : dict or None
        The design-point means' statistics Design-Expert's rules judge.
    rounds : list of dict or None
        One row per replicate round: replicates, runs, model, adequacy.
    model : str or None
        ``"quadratic"`` or ``"reduced"`` (None: a store written before the reduction, a
        quadratic).
    removed_terms : list of str or None
    anova_full, adequacy_full : list of dict, dict or None
        The full quadratic model's ANOVA and adequacy.
    coefficients_coded, coefficients_actual : dict str -> float
        The model's coefficients by term, in coded and in actual units.
    equation_coded, equation_actual : str or None
    adequate : bool or None
    warnings : list of str
    """

    design: str | None = None
    factors: list[dict[str, Any]] = field(default_factory=list)
    runs: list[dict[str, Any]] = field(default_factory=list)
    excluded_points: list[int] = field(default_factory=list)
    replicates: int | None = None
    responses: dict[str, ResponseModel] | None = None
    anova: list[dict[str, Any]] = field(default_factory=list)
    fit: dict[str, Any] = field(default_factory=dict)
    lack_of_fit_p: float | None = None
    adequacy: dict[str, Any] | None = None
    rounds: list[dict[str, Any]] | None = None
    model: str | None = None
    removed_terms: list[str] | None = None
    anova_full: list[dict[str, Any]] | None = None
    adequacy_full: dict[str, Any] | None = None
    coefficients_coded: dict[str, float] = field(default_factory=dict)
    coefficients_actual: dict[str, float] = field(default_factory=dict)
    equation_coded: str | None = None
    equation_actual: str | None = None
    adequate: bool | None = None
    warnings: list[str] = field(default_factory=list)

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
        for name in ("factors", "runs", "excluded_points", "anova", "warnings"):
            items[name] = items.get(name) or []
        for name in ("fit", "coefficients_coded", "coefficients_actual"):
            items[name] = items.get(name) or {}
        return cls(**items)

    @property
    def names(self) -> list[str]:
        """The factors' names, in the design's order."""
        return [str(f["name"]) for f in self.factors]

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
