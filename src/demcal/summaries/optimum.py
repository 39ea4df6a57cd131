"""The optimize stage's typed summary: the settings the verification runs, and how they
were found."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from demcal.summaries._stored import (
    _Flat,
    _InRounds,
    _key,
    _Keyed,
    _known,
    _plain,
    _read,
    stored_as,
)

__all__ = ["Candidate", "Goal", "Optimum", "ResponsesOptimum"]


@dataclass(frozen=True)
class Candidate(_Keyed):
    """One setting the optimize stage proposes, ranked best first.

    Attributes
    ----------
    params : dict str -> float
        The factors' values, SI.
    predicted_lead : float or None
        The lead response the surface predicts there (corrected by a refinement round's
        offset; the Bayesian strategy: its surrogate's mean), the lead's unit (the angle: deg).
    pi_low, pi_high : float or None
        The surface's 95 % prediction interval there, the lead's unit (None: no surface, or
        unbounded).
    p_pile : float or None
        The pile region's probability of a pile there.
    desirability : float or None
        The search's desirability (the overall one with several responses); not written by
        the Bayesian strategy.
    predicted, individual : dict str -> float or None
        With several responses: each response's prediction and desirability there.
    """

    params: dict[str, float] = field(default_factory=dict)
    predicted_lead: float | None = stored_as("predicted_aor_deg")
    pi_low: float | None = stored_as("pi_low_deg")
    pi_high: float | None = stored_as("pi_high_deg")
    p_pile: float | None = None
    desirability: float | None = None
    predicted: dict[str, float] | None = None
    individual: dict[str, float] | None = None

    #: the fields every producer writes, None or not (``desirability``, ``predicted`` and
    #: ``individual`` only where set)
    ALWAYS = ("params", "predicted_lead", "pi_low", "pi_high", "p_pile")


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
class Optimum(_InRounds):
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
    target : float or None
        The lab value of the lead response aimed at, its unit (the angle: deg).
    candidates : list of Candidate
        Ranked, best first.
    chosen : dict str -> float
        The best candidate's factors (what the verification runs).
    predicted_lead : float or None
        The lead response predicted there, its unit.
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
    surface_offset : float or None
        In a refinement round, the correction applied: the surface was aimed at the target
        less it, the lead's unit.
    offset_from_rounds : list of int or None
        The earlier rounds whose offsets were pooled.
    measured_offset : float or None
        Their piles' means less the surface there, pooled, the lead's unit.
    offset_weight : float or None
        The share of it applied.
    rounds : list of Optimum
        The earlier rounds' optima, oldest first (each without its own history).
    """

    target: float | None = stored_as("target_aor_deg")
    candidates: list[Candidate] = field(default_factory=list)
    chosen: dict[str, float] = field(default_factory=dict)
    predicted_lead: float | None = stored_as("predicted_aor_deg")
    classifier: dict[str, Any] | None = None
    opts: dict[str, Any] | str | None = None
    source: str | None = None
    responses: ResponsesOptimum | None = None
    warnings: list[str] = field(default_factory=list)
    round: int | None = None
    surface_offset: float | None = stored_as("surface_offset_deg")
    offset_from_rounds: list[int] | None = None
    measured_offset: float | None = stored_as("measured_offset_deg")
    offset_weight: float | None = None
    rounds: list[Optimum] = field(default_factory=list)

    #: the keys every producer writes, None or not
    ALWAYS = ("target", "candidates", "chosen", "predicted_lead")
    #: the lists written only when they hold something (the others: when not None)
    WHEN_FILLED = ("warnings", "rounds")
    #: the Bayesian strategy's summary (``source`` set) has always begun with these, in this
    #: order; the store keeps a summary's key order, so it still does
    POSTERIOR_FIRST = ("target", "chosen", "predicted_lead", "candidates")

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any] | None) -> Optimum:
        """Read a stored optimize summary (any release's and producer's; empty, or a failed
        stage's ``{"error": ...}``: no optimum)."""
        items = _read(cls, summary or {})
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
                out[f.name] = value
        first = self.POSTERIOR_FIRST if self.source is not None else ()
        keys = {f.name: _key(f) for f in dataclasses.fields(self)}
        return {keys[k]: _plain(out[k]) for k in [*first, *(k for k in out if k not in first)]}
