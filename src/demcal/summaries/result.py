"""A calibration's result, typed: what ``demcal calibrate`` prints, writes as ``--json`` and
stores as the meta ``"result"``.

Both strategies build one :class:`CalibrationResult` (the DOE path in
:func:`demcal.calibrate.pipeline.run_stages`, the Bayesian strategy in
:mod:`demcal.calibrate.bayes_strategy`); the console, the material card and the report read its
attributes. :meth:`CalibrationResult.to_summary` writes the result JSON, a file format: its
keys keep the angle's names (``target_aor_deg``, ``verification.aor_mean_deg``) whatever the
lead response, as every release wrote them, and :meth:`CalibrationResult.from_summary` reads
one of any release.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

from demcal.lead import LeadName
from demcal.summaries._stored import _Keyed, stored_as
from demcal.summaries.bayes import BayesSummary
from demcal.summaries.optimum import Goal, Optimum
from demcal.summaries.spread import TargetSpread
from demcal.summaries.surface import FitStatistics
from demcal.summaries.verification import ResponseVerification, Verification

__all__ = ["CalibrationResult", "ResultResponses", "ResultRound", "SurfaceFacts"]


@dataclass(frozen=True)
class ResultRound(_Keyed):
    """One verification round in a few numbers (the result's ``rounds``).

    Attributes
    ----------
    round : int
        The round, 1 for the first.
    optimum : dict str -> float
        The factors it verified.
    predicted_lead : float or None
        The lead response predicted there, its unit (the angle: deg).
    surface_offset, measured_offset, offset_weight : float or None
        A refinement round's aim (:class:`demcal.summaries.Optimum`); None in the first round
        and in the Bayesian strategy's rounds, which are not aimed by an offset.
    n_piles : int
        Runs that gave a value.
    mean, std, relative_error_percent, half_width, ci_low, ci_high : float or None
        The verification's mean, sample std, error against the lab (%), and its 95 % interval.
    confirm_pi_low, confirm_pi_high : float or None
        The surface's 95 % prediction interval for that mean.
    confirmed, target_in_interval, within_tolerance : bool or None
    p_value : float or None
        The t-test against the lab value.
    """

    round: int = 1
    optimum: dict[str, float] = field(default_factory=dict)
    predicted_lead: float | None = stored_as("predicted_aor_deg")
    surface_offset: float | None = stored_as("surface_offset_deg")
    measured_offset: float | None = stored_as("measured_offset_deg")
    offset_weight: float | None = None
    n_piles: int = 0
    mean: float | None = stored_as("aor_mean_deg")
    std: float | None = stored_as("aor_std_deg")
    relative_error_percent: float | None = None
    half_width: float | None = stored_as("half_width_deg")
    ci_low: float | None = stored_as("ci_low_deg")
    ci_high: float | None = stored_as("ci_high_deg")
    confirm_pi_low: float | None = stored_as("confirm_pi_low_deg")
    confirm_pi_high: float | None = stored_as("confirm_pi_high_deg")
    confirmed: bool | None = None
    target_in_interval: bool | None = None
    within_tolerance: bool | None = None
    p_value: float | None = None

    #: every field but the aim's offsets, which a round aimed by none leaves out
    ALWAYS: ClassVar[tuple[str, ...]] = (
        "round", "optimum", "predicted_lead", "n_piles", "mean", "std",
        "relative_error_percent", "half_width", "ci_low", "ci_high", "confirm_pi_low",
        "confirm_pi_high", "confirmed", "target_in_interval", "within_tolerance", "p_value")

    @classmethod
    def of(cls, optimum: Optimum, verification: Verification) -> ResultRound:
        """The row of a round's optimum and its verification."""
        v = verification
        return cls(round=v.round_number, optimum=dict(optimum.chosen),
                   predicted_lead=optimum.predicted_lead, surface_offset=optimum.surface_offset,
                   measured_offset=optimum.measured_offset,
                   offset_weight=optimum.offset_weight, n_piles=v.n_piles, mean=v.mean,
                   std=v.std, relative_error_percent=v.relative_error_percent,
                   half_width=v.half_width, ci_low=v.ci_low, ci_high=v.ci_high,
                   confirm_pi_low=v.confirm_pi_low, confirm_pi_high=v.confirm_pi_high,
                   confirmed=v.confirmed, target_in_interval=v.target_in_interval,
                   within_tolerance=v.within_tolerance, p_value=v.p_value)

    @property
    def aimed(self) -> bool:
        """Whether the round was aimed by an offset of earlier rounds (DOE refinement)."""
        return self.surface_offset is not None


@dataclass(frozen=True)
class SurfaceFacts:
    """The DOE path's response surface in the result (its ``rsm_*`` keys).

    Attributes
    ----------
    adequate : bool or None
        Design-Expert's adequacy rules.
    adequacy : FitStatistics
        Their numbers (``adj_r2``, ``pred_r2``, ``adeq_precision``, ``p_model``,
        ``lack_of_fit_p``...).
    model : str
        ``"quadratic"`` or ``"reduced"``.
    removed_terms : list of str
        The terms a reduced model dropped.
    resolution : str or None
        Where the model is not adequate: its largest main effect against the noise and the
        replicates that would resolve it (``rsm_resolution``, only where set).
    """

    adequate: bool | None = None
    adequacy: FitStatistics = field(default_factory=FitStatistics)
    model: str = "quadratic"
    removed_terms: list[str] = field(default_factory=list)
    resolution: str | None = None

    def to_summary(self) -> dict[str, Any]:
        """The result's keys, in their order (``rsm_resolution`` only where set)."""
        out = {"rsm_adequate": self.adequate, "rsm_adequacy": self.adequacy.to_summary(),
               "rsm_model": self.model, "rsm_removed_terms": list(self.removed_terms)}
        if self.resolution is not None:
            out["rsm_resolution"] = self.resolution
        return out

    @classmethod
    def from_result(cls, result: Mapping[str, Any]) -> SurfaceFacts | None:
        """Read the keys of a result; None where it has none (the Bayesian strategy's)."""
        if "rsm_adequate" not in result and "rsm_adequacy" not in result:
            return None
        return cls(adequate=result.get("rsm_adequate"),
                   adequacy=FitStatistics.from_summary(result.get("rsm_adequacy") or {}),
                   model=str(result.get("rsm_model") or "quadratic"),
                   removed_terms=list(result.get("rsm_removed_terms") or []),
                   resolution=result.get("rsm_resolution"))

    def label(self) -> str:
        """The model in words: ``full quadratic`` or ``reduced (removed A^2, ...)``."""
        if self.model == "quadratic":
            return "full quadratic"
        return f"reduced (removed {', '.join(self.removed_terms) or 'none'})"


@dataclass(frozen=True)
class ResultResponses:
    """Every response against its lab value, in a several-response study (the result's
    ``responses``).

    Attributes
    ----------
    predicted : dict str -> float or None
        Each response predicted at the optimum: the surfaces' (DOE) or the surrogates' means
        (Bayesian; the lead left out), in its unit.
    verification : dict str -> ResponseVerification or None
        Each response's verification against its lab value.
    goals : list of Goal or None
        The desirability goals (DOE); None in the Bayesian strategy, which has none.
    desirability : float or None
        The overall desirability at the optimum (DOE).
    """

    predicted: dict[str, float | None] = field(default_factory=dict)
    verification: dict[str, ResponseVerification] | None = None
    goals: list[Goal] | None = None
    desirability: float | None = None

    def to_summary(self) -> dict[str, Any]:
        """The stored form: the DOE path's goals and desirability first, where it has them."""
        verification = None if self.verification is None else {
            name: r.to_summary() for name, r in self.verification.items()}
        head: dict[str, Any] = {} if self.goals is None else {
            "goals": [g.to_summary() for g in self.goals], "desirability": self.desirability}
        return {**head, "predicted": dict(self.predicted), "verification": verification}

    @classmethod
    def from_summary(cls, stored: Mapping[str, Any]) -> ResultResponses:
        """Read the stored form (any release's)."""
        checks = stored.get("verification")
        goals = stored.get("goals")
        return cls(predicted=dict(stored.get("predicted") or {}),
                   verification=None if checks is None else {
                       str(name): ResponseVerification.from_summary(r)
                       for name, r in checks.items()},
                   goals=None if goals is None else [Goal.from_summary(g) for g in goals],
                   desirability=stored.get("desirability"))


@dataclass(frozen=True)
class CalibrationResult:
    """A finished calibration: the optimum, its verification and how it was reached.

    Attributes
    ----------
    study : str
        The study's name.
    optimum : dict str -> float
        The calibrated factors, SI.
    optimum_full : dict str -> float
        Every parameter of the verified set, SI.
    predicted_lead : float or None
        The lead response predicted at the optimum (the surface's or the surrogate's), its
        unit (the angle: deg).
    target : float
        The lab value of the lead response, its unit.
    verification : Verification
        The last round's verification (the fields :attr:`Verification.IN_RESULT` are kept).
    rounds : list of ResultRound
        One row per verification round, oldest first.
    n_runs : int
        Every run the store holds (a reused store may hold other studies' runs).
    n_runs_executed : int
        The runs made by this call (0: a resume that found everything).
    ranges : dict str -> [low, high]
        Each factor's range as searched (after range finding), SI.
    lead : LeadName or None
        The lead response where it is not the angle (its values are under the angle's keys).
    n_runs_used : int or None
        The runs this study's stages used (DOE path).
    surface : SurfaceFacts or None
        The response surface's adequacy and model (DOE path).
    stages : dict or None
        Each stage's design and runs as the result JSON lists them (DOE path; a file format
        for people and scripts, not read back by demcal).
    responses : ResultResponses or None
        Every response against its lab value (several-response studies).
    bayes : BayesSummary or None
        The posterior, verdict and advice (strategy ``"bayes"``; without its samples and
        slices, which only the stage's store keeps).
    spread : TargetSpread or None
        Where two or more of the optimize stage's distinct settings reach the target and lie
        far apart: how many, and each factor's span among them (``target_spread``; DOE
        path).
    fidelity : str or None
        The fidelity of the test the verification and the card ran (``quick`` ... ``paper``;
        a stage may have run at another, which its own block names). None for the analytic
        stand-in or an external engine's test, and in a result of an earlier release.
    """

    study: str
    optimum: dict[str, float]
    optimum_full: dict[str, float]
    predicted_lead: float | None
    target: float
    verification: Verification
    rounds: list[ResultRound] = field(default_factory=list)
    n_runs: int = 0
    n_runs_executed: int = 0
    ranges: dict[str, list[float]] = field(default_factory=dict)
    lead: LeadName | None = None
    n_runs_used: int | None = None
    surface: SurfaceFacts | None = None
    stages: dict[str, Any] | None = None
    responses: ResultResponses | None = None
    bayes: BayesSummary | None = None
    spread: TargetSpread | None = None
    fidelity: str | None = None

    def __post_init__(self) -> None:
        # the result JSON writes a Bayesian study's optimum from its posterior: a different
        # one here would be lost without a word
        if self.bayes is not None and dict(self.optimum) != dict(self.bayes.optimum):
            raise ValueError(f"CalibrationResult.optimum {self.optimum} is not its posterior's "
                             f"optimum {self.bayes.optimum}")

    @property
    def strategy(self) -> str:
        """``"bayes"`` or ``"doe"``."""
        return "doe" if self.bayes is None else "bayes"

    @property
    def n_runs_strategy(self) -> int | None:
        """The Bayesian loop's own runs, without the verification rounds' (None: DOE path)."""
        return None if self.bayes is None else self.bayes.n_runs - self.bayes.verification_runs

    @property
    def lead_name(self) -> LeadName:
        """The lead response (the angle where the result names none)."""
        return self.lead or LeadName()

    def to_summary(self) -> dict[str, Any]:
        """The result JSON, in the key order every release wrote."""
        out: dict[str, Any] = {"study": self.study}
        if self.fidelity is not None:
            out["fidelity"] = self.fidelity
        if self.bayes is not None:  # the posterior's keys first (its optimum among them)
            out.update(strategy="bayes", **self.bayes.in_result())
        else:
            out["optimum"] = dict(self.optimum)
        out.update(optimum_full=dict(self.optimum_full), predicted_aor_deg=self.predicted_lead,
                   target_aor_deg=self.target)
        if self.lead is not None:
            out["lead"] = {"name": self.lead.name, "unit": self.lead.unit}
        out.update(verification=self.verification.in_result(),
                   rounds=[r.to_summary() for r in self.rounds],
                   n_runs=self.n_runs)  # the posterior's n_runs is the loop's: this replaces it
        if self.n_runs_strategy is not None:
            out["n_runs_strategy"] = self.n_runs_strategy
        if self.n_runs_used is not None:
            out["n_runs_used"] = self.n_runs_used
        out.update(n_runs_executed=self.n_runs_executed,
                   ranges={k: list(v) for k, v in self.ranges.items()})
        if self.surface is not None:
            out.update(self.surface.to_summary())
        if self.stages is not None:
            out["stages"] = self.stages
        if self.responses is not None:
            out["responses"] = self.responses.to_summary()
        if self.spread is not None:
            out["target_spread"] = self.spread.to_summary()
        return out

    @classmethod
    def from_summary(cls, stored: Mapping[str, Any]) -> CalibrationResult:
        """Read a result JSON of any release."""
        bayes = BayesSummary.from_summary(stored) if stored.get("strategy") == "bayes" else None
        if bayes is not None:  # the loop's and the rounds' runs, as the stage counted them
            bayes = replace(bayes, n_runs=int(stored.get("n_runs_strategy") or 0)
                            + bayes.verification_runs)
        lead = stored.get("lead")
        several = stored.get("responses")
        return cls(
            study=str(stored.get("study") or ""), optimum=dict(stored.get("optimum") or {}),
            optimum_full=dict(stored.get("optimum_full") or {}),
            predicted_lead=stored.get("predicted_aor_deg"),
            target=float(stored.get("target_aor_deg") or 0.0),
            verification=Verification.from_summary(stored.get("verification")),
            rounds=[ResultRound.from_summary(r) for r in stored.get("rounds") or []],
            n_runs=int(stored.get("n_runs") or 0),
            n_runs_executed=int(stored.get("n_runs_executed") or 0),
            ranges={k: list(v) for k, v in (stored.get("ranges") or {}).items()},
            lead=None if not lead else LeadName(name=str(lead["name"]),
                                                unit=str(lead.get("unit") or "")),
            n_runs_used=stored.get("n_runs_used"), surface=SurfaceFacts.from_result(stored),
            stages=stored.get("stages"),
            responses=None if several is None else ResultResponses.from_summary(several),
            bayes=bayes, spread=TargetSpread.from_summary(stored.get("target_spread")),
            fidelity=stored.get("fidelity"))
