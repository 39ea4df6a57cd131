"""The state the calibration stages share (:class:`Context`) and the design points'
helpers they all use: a design's rows as runs, their responses per point, the stored rows."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from demcal import doe
from demcal.calibrate.responses import LabValue, ResponseSpec
from demcal.calibrate.rounds import Rounds
from demcal.calibrate.runner import Point, Runner
from demcal.calibrate.study import Study
from demcal.lead import LeadName
from demcal.store import RunRecord, RunStore, params_hash
from demcal.summaries import (
    DesignRun,
    Optimum,
    RangeFind,
    Screening,
    Steepest,
    StudyFactor,
    Surface,
    Verification,
)
from demcal.virtual import PARAMETERS

if TYPE_CHECKING:  # several imports nothing of this module's; its fits are only named here
    from demcal.calibrate.several import ResponseFit

__all__ = ["Context", "StageResults", "clip", "design_points", "exclusion_note", "factor_space",
           "point_means", "point_runs", "run_rows"]


@dataclass
class StageResults:
    """What the stages of one calibration hand on to the next, as they run (None: the stage
    has not run in this call; a disabled screening or path leaves only its selection or
    levels).

    Attributes
    ----------
    rangefind, screening, steepest, rsm, optimize : typed summary or None
        Each stage's summary (:mod:`demcal.summaries`), as stored.
    verification : Verification or None
        The verification stage's summary, with the earlier rounds'
        (:meth:`Verification.in_round`).
    screening_model : ResponseSurface or None
        The lead's main-effects model over the screening runs (the path's direction).
    screening_runs : (Design, list of RunRecord) or None
        The screening design and its runs (the other responses' first-order models).
    rsm_model : ResponseSurface or None
        The lead's response-surface model the optimum is read from.
    response_fits : dict str -> ResponseFit or None
        Every other response's model at the response surface (several responses).
    goals : list of ResponseGoal
        The desirability goals of the several-response optimum.
    verification_runs : list of RunRecord
        The last verification round's runs (the Bayesian strategy conditions on a round that
        missed).
    """

    rangefind: RangeFind | None = None
    screening: Screening | None = None
    steepest: Steepest | None = None
    rsm: Surface | None = None
    optimize: Optimum | None = None
    verification: Verification | None = None
    screening_model: doe.ResponseSurface | None = None
    screening_runs: tuple[doe.Design, list[RunRecord]] | None = None
    rsm_model: doe.ResponseSurface | None = None
    response_fits: dict[str, ResponseFit] | None = None
    goals: list[doe.ResponseGoal] = field(default_factory=list)
    verification_runs: list[RunRecord] = field(default_factory=list)


@dataclass
class Context:
    """State shared by the stages of one study.

    ``fixed``: full parameter set with every factor at its current centre (SI);
    ``factors``: each factor at its current range (range finding moves them:
    :meth:`set_range`);
    ``records``: every run the stages used (for the pile classifier);
    ``target``, ``target_std``, ``target_n``: the lead response's lab mean, spread and count
    (std and count when known); ``responses``: every response aimed at, the lead first (the
    one range finding, screening, the path's relative error and the anchor follow: the
    study's angle where it gives ``[target]``, else its first ``[[responses]]`` table;
    :func:`demcal.calibrate.pipeline.open_study`).
    """

    study: Study
    store: RunStore
    runner: Runner
    fixed: dict[str, float]
    target: float
    factors: list[StudyFactor]
    records: list[RunRecord] = field(default_factory=list)
    results: StageResults = field(default_factory=StageResults)
    target_std: float | None = None
    target_n: int | None = None
    rounds: Rounds = field(default_factory=Rounds)
    #: every response the study aims at, the lead first (:mod:`demcal.calibrate.several`)
    responses: list[ResponseSpec] = field(default_factory=list)
    #: their lab values by name
    labs: dict[str, LabValue] = field(default_factory=dict)

    @property
    def several(self) -> bool:
        """Does the study aim at more responses than its lead?"""
        return len(self.responses) > 1

    @property
    def lead(self) -> ResponseSpec:
        """The response the single-response rules follow (the first aimed at)."""
        return self.responses[0]

    @property
    def lead_name(self) -> LeadName:
        """How people read the lead's name and unit."""
        return LeadName(self.lead.name, self.lead.unit or "")

    @property
    def unit(self) -> str:
        """The lead's unit as the stages' messages write it after a number: `` deg`` for the
        angle, ``""`` for a response without a unit."""
        return self.lead_name.after_number()

    @property
    def lead_words(self) -> str:
        """The lead as the stages' messages name it: ``the AoR`` for the angle."""
        return self.lead_name.words

    def lead_label(self) -> LeadName | None:
        """The result's ``lead`` where the lead is not the angle: the result's keys named for
        the angle (``target_aor_deg``, ``predicted_aor_deg``, ``verification.aor_mean_deg``,
        ...) then hold the lead's values. None for the angle, whose result is what it always
        was."""
        return None if self.lead_name.is_angle else self.lead_name

    def measured(self, record: RunRecord) -> float | None:
        """The lead response of a run, where the run measured it (outcome ``pile``)."""
        value = record.response(self.lead.name)
        return value if record.outcome == "pile" and value is not None else None

    def full(self, actual: dict[str, float]) -> dict[str, float]:
        """The fixed set with ``actual`` factor values applied (floats)."""
        out = dict(self.fixed)
        out.update({k: float(v) for k, v in actual.items()})
        return out

    def reps(self, stage: str) -> int:
        """Replicates per design point of a stage: its own ``replicates`` or the study's."""
        own = getattr(getattr(self.study.stages, stage), "replicates", None)
        return int(own if own is not None else self.study.replicates)

    def factor(self, name: str) -> StudyFactor:
        """The factor ``name`` at its current range."""
        return next(f for f in self.factors if f.name == name)

    def set_range(self, name: str, low: float, high: float) -> None:
        """Move the factor ``name`` to ``low``..``high`` (SI) and its fixed value (the value
        the other factors' runs hold it at) to the new centre."""
        self.factors = [replace(f, low=low, high=high) if f.name == name else f
                        for f in self.factors]
        self.fixed[name] = 0.5 * (low + high)

    def factor_rows(self, factors: Sequence[StudyFactor] | None = None) -> list[dict[str, Any]]:
        """``factors`` (default: the study's, at their current ranges) as the stages store
        them and hash them as their inputs (``{"name", "symbol", "low", "high", "unit"}``)."""
        return [f.to_summary() for f in (self.factors if factors is None else factors)]

    def seed(self, point: int, replicate: int, copy: int | None = None) -> int:
        """Seed of a run.

        By default distinct per design row (``point``), so replicated centre points differ.
        With the study's ``common_seeds`` (common random numbers) every design point of a
        stage gets the same seed set (one seed per replicate), so the differences between
        points are not blurred by the particle packings; identical rows (centre points) still
        differ through ``copy``, their rank among the identical rows.
        """
        if self.study.common_seeds and copy is not None:
            return int(self.study.seed + 1000 * replicate + copy)
        return int(self.study.seed + 1000 * replicate + point)

    def own_fidelity(self, stage: str) -> dict[str, str]:
        """``{"fidelity": name}`` when the stage runs at its own fidelity, else ``{}``."""
        fid = self.study.stage_fidelities().get(stage)
        return {"fidelity": fid} if fid is not None else {}

    def surface_fidelity(self) -> str | None:
        """The fidelity the response surface is fitted on where it is not the study's
        (``stages.rsm.fidelity``), else None: then the surface, its pure error and the
        verification share one test."""
        fid = self.study.stage_fidelities().get("rsm")
        return None if fid is None or fid == self.study.test.fidelity else fid

    def run(self, stage: str, points: Sequence[Point]) -> list[RunRecord]:
        recs = self.runner.run(stage, points)
        self.records.extend(recs)
        return recs

    def begin(self, stage: str, inputs: Any) -> str:
        h = params_hash({"inputs": inputs, "test": self.runner.stage_hash(stage)})
        self.store.set_stage(stage, "running", {}, inputs_hash=h)
        return h


def clip(name: str, value: float) -> float:
    spec = PARAMETERS[name]
    lo = spec.low if not spec.low_open else spec.low + 1e-9
    hi = spec.high if not spec.high_open else spec.high - 1e-9
    return float(min(max(value, lo), hi))


def factor_space(factors: Sequence[StudyFactor]) -> doe.FactorSpace:
    """The coded box of ``factors`` (the designs' and the fits')."""
    return doe.FactorSpace([doe.Factor(f.name, float(f.low), float(f.high), f.unit or "")
                            for f in factors])


def point_means(recs: Sequence[RunRecord], n_points: int, name: str
                ) -> tuple[np.ndarray, list[str]]:
    """Mean of the response ``name`` per design point over its replicates; NaN if any
    replicate did not measure it."""
    y, outcome, _ = point_runs(recs, n_points, name)
    return y, outcome


def point_runs(recs: Sequence[RunRecord], n_points: int, name: str
               ) -> tuple[np.ndarray, list[str], list[list[float]]]:
    """Per design point: the mean of the response ``name`` (NaN if any replicate did not
    measure it: an outcome other than ``pile``, or no such value), the outcome, and the
    replicates' values in replicate order (empty for a point without)."""
    y = np.full(n_points, math.nan)
    outcome = ["pile"] * n_points
    runs: list[list[float]] = [[] for _ in range(n_points)]
    by: dict[int, list[RunRecord]] = {}
    for r in recs:
        by.setdefault(r.point, []).append(r)
    for i in range(n_points):
        rs = sorted(by.get(i, []), key=lambda r: r.replicate)
        bad = [r.outcome for r in rs if r.outcome != "pile" or r.response(name) is None]
        if bad or not rs:
            outcome[i] = bad[0] if bad else "missing"
        else:
            runs[i] = [float(r.response(name)) for r in rs]  # type: ignore[arg-type]
            y[i] = float(np.mean(runs[i]))
    return y, outcome, runs


def _copies(design: doe.Design) -> list[int]:
    """Rank of each row among the rows with identical coded settings (0 for a unique row)."""
    seen: dict[tuple[float, ...], int] = {}
    out = []
    for row in np.round(design.coded, 9):
        key = tuple(float(v) for v in row)
        out.append(seen.get(key, 0))
        seen[key] = out[-1] + 1
    return out


def design_points(ctx: Context, design: doe.Design, replicates: Sequence[int]
                   ) -> list[Point]:
    actual = design.actual
    copies = _copies(design)
    pts = []
    for i in range(design.n_runs):
        values = {n: float(actual[i, j]) for j, n in enumerate(design.names)}
        for r in replicates:
            pts.append(Point(i, r, ctx.full(values), ctx.seed(i, r, copies[i])))
    return pts


def run_rows(design: doe.Design, y: np.ndarray, outcomes: list[str],
              runs: list[list[float]]) -> list[DesignRun]:
    """Each design point's settings, its mean response (None: excluded), outcome and
    replicates."""
    actual = design.actual
    return [DesignRun(
        point=i, coded={n: float(design.coded[i, j]) for j, n in enumerate(design.names)},
        actual={n: float(actual[i, j]) for j, n in enumerate(design.names)},
        value=None if math.isnan(y[i]) else float(y[i]), outcome=outcomes[i],
        replicates=runs[i],
        replicate_std=float(np.std(runs[i], ddof=1)) if len(runs[i]) > 1 else None)
        for i in range(design.n_runs)]


def exclusion_note(excluded: list[int], outcomes: list[str]) -> str:
    if not excluded:
        return "every design point formed a pile"
    kinds = sorted({outcomes[i] for i in excluded})
    return (f"{len(excluded)} design point(s) formed no pile ({', '.join(kinds)}): points "
            f"{', '.join(str(i) for i in excluded)} are stored with their outcome and excluded "
            "from the fit")
