"""The verification stage's typed summary: runs at the optimum on fresh seeds, judged
against the lab."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from demcal.summaries._stored import _InRounds, _key, _KeyedEvery, _read, by_key, stored_as

__all__ = ["ResponseVerification", "Verification"]


@dataclass(frozen=True)
class ResponseVerification(_KeyedEvery):
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
    ci_low, ci_high : float or None
        The 95 % t-interval of the mean, in the response's unit.
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
    ci_low: float | None = stored_as("ci_low_deg")
    ci_high: float | None = stored_as("ci_high_deg")
    target_in_interval: bool | None = None
    p_value: float | None = None
    test: str | None = None
    consistent: bool | None = None
    desirability: float | None = None


@dataclass(frozen=True)
class Verification(_InRounds):
    """The verification stage: replicate runs at the optimum on fresh seeds, judged against
    the lab's angle (and, in a several-response study, every response against its lab value).

    Attributes
    ----------
    params : dict str -> float
        The full parameter set run, SI.
    values : list of float or None
        Each run's value of the lead response, its unit (the angle: deg; None: no pile).
    outcomes : list of str
        Each run's outcome.
    mean, std : float or None
        Mean and sample standard deviation of the runs' values.
    relative_error_percent : float or None
        ``|mean - target| / target``, %.
    n, n_piles : int
        Runs made and runs that gave a value (piles formed).
    pile_png : str or None
        A side view of one verification pile.
    half_width, half_width_goal : float or None
        The 95 % interval's half width reached and the study's goal for it.
    half_width_reached : bool
    sized_with_std : float or None
        The pure-error standard deviation the run count was sized with.
    sized_with_df : int or float or None
        Its degrees of freedom.
    ci_low, ci_high : float or None
        The 95 % t-interval of the mean.
    target_in_interval : bool or None
        The lab value inside it.
    p_value : float or None
        The t-test against the lab (:func:`demcal.calibrate.verify.compare_to_target`).
    test : str or None
        Which t-test.
    consistent : bool or None
        p >= 0.05.
    tolerance_percent : float or None
        The study's tolerance on the relative error, %.
    within_tolerance : bool or None
    confirm_pi_low, confirm_pi_high : float or None
        The surface's 95 % prediction interval for the mean of n runs (Design-Expert's
        confirmation).
    confirmed : bool or None
        The mean inside it.
    responses : dict str -> ResponseVerification or None
        Every response of a several-response study; None with the angle alone.
    round : int or None
        The refinement round (None: the first and only).
    rounds : list of Verification
        The earlier rounds' verifications, oldest first (each without its own history).

    The units are the lead response's (the angle: deg); the stored keys keep the angle's
    names (``aor_mean_deg``...), a file format every release reads.
    """

    params: dict[str, float] = field(default_factory=dict)
    values: list[float | None] = stored_as("aor_deg", factory=list)
    outcomes: list[str] = field(default_factory=list)
    mean: float | None = stored_as("aor_mean_deg")
    std: float | None = stored_as("aor_std_deg")
    relative_error_percent: float | None = None
    n: int = 0
    n_piles: int = 0
    pile_png: str | None = None
    half_width: float | None = stored_as("half_width_deg")
    half_width_goal: float | None = stored_as("half_width_goal_deg")
    half_width_reached: bool = False
    sized_with_std: float | None = stored_as("sized_with_std_deg")
    sized_with_df: int | float | None = None
    ci_low: float | None = stored_as("ci_low_deg")
    ci_high: float | None = stored_as("ci_high_deg")
    target_in_interval: bool | None = None
    p_value: float | None = None
    test: str | None = None
    consistent: bool | None = None
    tolerance_percent: float | None = None
    within_tolerance: bool | None = None
    confirm_pi_low: float | None = stored_as("confirm_pi_low_deg")
    confirm_pi_high: float | None = stored_as("confirm_pi_high_deg")
    confirmed: bool | None = None
    responses: dict[str, ResponseVerification] | None = None
    round: int | None = None
    rounds: list[Verification] = field(default_factory=list)

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any] | None) -> Verification:
        """Read a stored verification summary (any release's; empty: not verified)."""
        items = _read(cls, summary or {})
        if items.get("responses") is not None:
            items["responses"] = {name: ResponseVerification.from_summary(r)
                                  for name, r in items["responses"].items()}
        items["rounds"] = [cls.from_summary(r) for r in items.get("rounds") or []]
        return cls(**items)

    #: the fields the result JSON's ``verification`` holds, in its order
    IN_RESULT = ("mean", "std", "relative_error_percent", "n", "ci_low", "ci_high", "p_value",
                 "consistent", "test", "half_width", "half_width_goal", "half_width_reached",
                 "confirm_pi_low", "confirm_pi_high", "confirmed", "target_in_interval",
                 "tolerance_percent", "within_tolerance", "values")

    def in_result(self) -> dict[str, Any]:
        """The result JSON's ``verification``: the fields of :attr:`IN_RESULT` under their
        stored keys (the file formats share them)."""
        return by_key(self, self.IN_RESULT)

    @property
    def done(self) -> bool:
        """Whether any run was made (an empty summary reads as not verified)."""
        return self.n > 0 or bool(self.outcomes)

    def stored_responses(self) -> dict[str, dict[str, Any]] | None:
        """Every response's verification as stored (None with the lead alone)."""
        if self.responses is None:
            return None
        return {name: r.to_summary() for name, r in self.responses.items()}

    def to_summary(self) -> dict[str, Any]:
        """The stored form: every field, less ``responses``, ``round`` and ``rounds`` where
        they are empty (a single-response, single-round study stores what it always did)."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name == "responses":
                if value is not None:
                    out["responses"] = self.stored_responses()
            elif f.name == "rounds":
                if value:
                    out["rounds"] = [r.to_summary() for r in value]
            elif f.name != "round" or value is not None:
                out[_key(f)] = value
        return out
