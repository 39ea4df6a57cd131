"""Several responses in one calibration: a model per response, the desirability optimum, a
verification of each response against its lab value.

The angle of repose stays the study's first response (it drives range finding and
screening, and its model carries the pile region and the refinement rounds). When the study
has ``[[responses]]`` beside it, the steepest path climbs the overall desirability of every
response's first-order model over the screening runs (:func:`path_climb`), the response
surface stage fits every other response over the same design (:func:`fit_responses`), the
optimum maximises the overall desirability of all of them (:func:`optimize_summary`,
Design-Expert's numerical optimisation) inside the pile region, and the verification judges
each response's mean on fresh seeds against its lab value with the angle's rules
(:func:`check_responses`). A study with the angle alone never enters this module: its results
are as they were.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from demcal import doe
from demcal.calibrate.context import point_runs
from demcal.calibrate.responses import ResponseSpec
from demcal.calibrate.surface_fit import choose_model, fit_rows, replicated
from demcal.calibrate.verify import compare_to_target
from demcal.errors import StudyError
from demcal.store import RunRecord
from demcal.summaries import (
    AnovaRecord,
    Candidate,
    FitStatistics,
    Goal,
    Optimum,
    ResponseModel,
    ResponsesOptimum,
    ResponseVerification,
    anova_records,
)

__all__ = [
    "PathClimb",
    "ResponseFit",
    "check_responses",
    "fit_responses",
    "optimize_summary",
    "path_climb",
    "point_values",
]


@dataclass(frozen=True)
class ResponseFit:
    """One response's model at the response-surface stage.

    Attributes
    ----------
    name : str
    model : ResponseSurface
        The model the optimum is read from (the full quadratic or its reduction).
    model_kind : str
        ``"quadratic"``, ``"reduced"`` or ``"constant"`` (a response that did not vary).
    adequate : bool
        Design-Expert's adequacy rules (:func:`demcal.calibrate.surface_fit.adequacy`).
    statistics : FitStatistics
        p of the model and of the lack of fit, R^2, adjusted and predicted R^2, Adeq Precision
        (all None for a response that did not vary).
    warnings : tuple of str
    excluded_points : tuple of int
        Design points without this response (no pile, or the test did not report it).
    anova : tuple of AnovaRecord
        The ANOVA table's rows.
    """

    name: str
    model: doe.ResponseSurface
    model_kind: str
    adequate: bool
    statistics: FitStatistics
    warnings: tuple[str, ...]
    excluded_points: tuple[int, ...]
    anova: tuple[AnovaRecord, ...]

    def summary(self) -> ResponseModel:
        """What the store and the report keep (the rsm stage's ``responses[name]``)."""
        return ResponseModel(
            model=self.model_kind, adequate=self.adequate, adequacy=self.statistics,
            warnings=list(self.warnings), excluded_points=list(self.excluded_points),
            anova=list(self.anova),
            coefficients_coded={k: float(v) for k, v in self.model.coefficients_coded.items()},
            equation_actual=self.model.equation(units="actual"))


def point_values(recs: Sequence[RunRecord], n_points: int, name: str) -> list[list[float]]:
    """Per design point, the replicates' values of response ``name`` in replicate order; empty
    for a point where a replicate formed no pile or did not report it
    (:func:`demcal.calibrate.context.point_runs`'s replicates)."""
    return point_runs(recs, n_points, name)[2]


#: Half the central difference of the desirability's gradient at the design centre, coded.
#: The first-order models are planes, so only the goals' kinks (a target's peak, a limit)
#: make the result depend on it; a hundredth of the half range sits well inside them.
_GRADIENT_STEP = 0.01


@dataclass(frozen=True)
class PathClimb:
    """The direction of the steepest path when a study has several responses.

    Every response's first-order model over the screening runs predicts it along the path's
    factors (the others held at their centre); the path climbs the gradient, at the design
    centre, of what the desirability search climbs (:func:`demcal.doe.climb`: the overall
    desirability D, or the responses' shortfall from their limits where D is 0).

    Attributes
    ----------
    factors : tuple of str
        The path's factors (the screening's selection), in order.
    goals : tuple of ResponseGoal
        Every response's goal, the angle first; limits default to the screening's observed
        range widened to hold the lab value.
    coefficients : dict str -> dict str -> float
        Per response, the first-order model's coded intercept and coefficients of ``factors``
        (units of the response per coded unit).
    gradient : dict str -> float
        The climb's gradient at the centre, per coded unit of each factor.
    """

    factors: tuple[str, ...]
    goals: tuple[doe.ResponseGoal, ...]
    coefficients: dict[str, dict[str, float]]
    gradient: dict[str, float]

    def predict(self, x: np.ndarray) -> np.ndarray:
        """Every response's first-order prediction (m, r), in the goals' order, at coded
        settings ``x`` (m, k) of ``factors``."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        cols = []
        for g in self.goals:
            c = self.coefficients[g.name]
            cols.append(c["intercept"] + x @ np.array([c[n] for n in self.factors]))
        return np.column_stack(cols)

    @property
    def flat(self) -> bool:
        """No factor moves the climb at the centre (every goal met, or no model varies)."""
        return not any(abs(v) > 0.0 for v in self.gradient.values())

    def alone(self) -> dict[str, dict[str, int]]:
        """Per response, the direction (+1/-1 per factor) its own desirability would climb:
        where it and the path part ways, the others outweighed it."""
        out = {}
        for i, g in enumerate(self.goals):
            grad = _gradient(lambda x, i=i, g=g: doe.climb([g], self.predict(x)[:, [i]]),
                             len(self.factors))
            out[g.name] = {n: 1 if v >= 0 else -1 for n, v in zip(self.factors, grad,
                                                                  strict=True)}
        return out

    def desirability(self, values: Sequence[Mapping[str, float | None]]) -> list[float | None]:
        """The overall desirability D of measured responses (per path step, by name); None
        where a step lacks one."""
        out: list[float | None] = []
        for v in values:
            row = [v.get(g.name) for g in self.goals]
            if any(x is None for x in row):
                out.append(None)
                continue
            d = [float(g.desirability(float(x))) for g, x in zip(self.goals, row, strict=True)]
            out.append(float(doe.overall_desirability(
                [d], [g.importance for g in self.goals])[0]))
        return out

    def misses(self, values: Sequence[Mapping[str, float | None]]) -> list[float | None]:
        """How far each step's measured responses fall short, lower is better (minus the
        climb's value: -D, or the shortfall where D is 0); None where a step lacks one."""
        out: list[float | None] = []
        for v in values:
            row = [v.get(g.name) for g in self.goals]
            out.append(None if any(x is None for x in row)
                       else float(-doe.climb(self.goals, [row])[0]))
        return out

    def summary(self) -> dict[str, Any]:
        """The steepest stage's ``climb``: goals, models, gradient and each response's own
        direction."""
        centre = float(doe.climb(self.goals, self.predict(np.zeros(len(self.factors))))[0])
        return {"goals": goals_json(self.goals), "coefficients_coded": self.coefficients,
                "gradient": dict(self.gradient), "centre_climb": centre,
                "alone": self.alone()}


def _gradient(f: Callable[[np.ndarray], np.ndarray], k: int) -> np.ndarray:
    """Central differences of ``f`` (coded (m, k) -> (m,)) at the centre."""
    h = _GRADIENT_STEP
    steps = np.vstack([np.eye(k) * h, -np.eye(k) * h])
    v = np.asarray(f(steps), dtype=float)
    return (v[:k] - v[k:]) / (2.0 * h)


def _first_order(name: str, design: doe.Design, recs: Sequence[RunRecord],
                 factors: Sequence[str]) -> tuple[dict[str, float], np.ndarray]:
    """A response's first-order model over the screening runs: its coded intercept and
    coefficients of ``factors``, and its point means (NaN: the point lacks it)."""
    runs = point_values(recs, design.n_runs, name)
    means = np.array([float(np.mean(r)) if r else math.nan for r in runs])
    if np.isfinite(means).sum() < 2:
        raise StudyError(f"steepest: response {name!r} was reported by fewer than two "
                         "screening points; check the test's or engine's result names")
    try:
        rs = doe.fit(design, means, model="linear")
    except doe.InputError as exc:
        raise StudyError(f"steepest: the first-order model of {name!r} over the screening "
                         f"runs cannot be fitted ({exc})") from None
    coefs = rs.coefficients_coded
    return {"intercept": float(coefs["intercept"]),
            **{n: float(coefs[n]) for n in factors}}, means


def path_climb(ctx: Any, factors: Sequence[str]) -> PathClimb:
    """The steepest path's direction over ``factors`` from every response's first-order model
    over the screening's runs (``ctx.results.screening_runs``: design and records)."""
    design, recs = ctx.results.screening_runs
    coefficients, goals = {}, []
    for spec in ctx.responses:
        coefficients[spec.name], means = _first_order(spec.name, design, recs, factors)
        goals.append(spec.goal_for(means, ctx.labs.get(spec.name)))
    climb = PathClimb(tuple(factors), tuple(goals), coefficients, {})
    grad = _gradient(lambda x: doe.climb(climb.goals, climb.predict(x)), len(factors))
    return PathClimb(climb.factors, climb.goals, coefficients,
                     {n: float(v) for n, v in zip(factors, grad, strict=True)})


def _fit_one(spec: ResponseSpec, runs: list[list[float]], design: doe.Design, n_reps: int,
             ctx: Any) -> ResponseFit:
    excluded = tuple(i for i, r in enumerate(runs) if not r)
    means = np.array([float(np.mean(r)) if r else math.nan for r in runs])
    finite = means[np.isfinite(means)]
    if finite.size == 0:
        raise StudyError(f"rsm: response {spec.name!r} was reported by no design point's "
                         "runs; check the test's or engine's result names")
    if float(np.ptp(finite)) == 0.0:  # a flat response: nothing to fit, say so
        model = doe.fit(design, np.where(np.isfinite(means), means, finite[0]), terms=[
            "intercept"])
        return ResponseFit(spec.name, model, "constant", False, FitStatistics(), (
            f"{spec.name} did not vary over the design ({finite[0]:g} at every point): no "
            "model; it cannot steer the optimum",), excluded, ())
    rep_design, y_rows = replicated(design, runs, n_reps)
    rows, notes = fit_rows(rep_design, y_rows, n_reps, ctx.study.common_seeds)
    full = doe.fit(design, means, model="quadratic") if n_reps > 1 else rows
    opts = ctx.study.stages.rsm
    choice = choose_model(opts.model, opts.alpha_out, rows, full)
    warnings = [*choice.adequacy.failed, *choice.notes, *notes]
    if excluded:
        warnings.insert(0, f"{len(excluded)} design point(s) without {spec.name}: "
                        + ", ".join(map(str, excluded)))
    return ResponseFit(spec.name, choice.chosen.rows, choice.kind, choice.adequacy.adequate,
                       choice.adequacy.statistics, tuple(warnings), excluded,
                       tuple(anova_records(choice.chosen.table.to_records())))


def fit_responses(ctx: Any, design: doe.Design, recs: Sequence[RunRecord], n_reps: int
                  ) -> dict[str, ResponseFit]:
    """A model per response beside the angle, over the response surface's design."""
    return {spec.name: _fit_one(spec, point_values(recs, design.n_runs, spec.name), design,
                                n_reps, ctx)
            for spec in ctx.responses[1:]}


def _goals(ctx: Any, lead_observed: np.ndarray) -> list[doe.ResponseGoal]:
    fits: Mapping[str, ResponseFit] = ctx.results.response_fits
    goals = []
    for spec in ctx.responses:
        observed = lead_observed if spec.name == ctx.lead.name else \
            fits[spec.name].model.response
        goals.append(spec.goal_for(observed, ctx.labs.get(spec.name)))
    return goals


def _predictors(lead: str, model: doe.ResponseSurface, fits: Mapping[str, ResponseFit],
                offset: float) -> dict[str, Callable[[np.ndarray], np.ndarray]]:
    """Predictors of coded settings; the lead's (``model``) corrected by a refinement
    round's offset."""
    names = tuple(model.names)
    out: dict[str, Callable[[np.ndarray], np.ndarray]] = {
        lead: lambda x: np.asarray(model.predict(x, units="coded"), dtype=float) + offset}
    for name, fit in fits.items():
        sub = [names.index(n) for n in fit.model.names]
        out[name] = (lambda x, m=fit.model, sub=sub:
                     np.asarray(m.predict(x[:, sub], units="coded"), dtype=float))
    return out


def _search(ctx: Any, model: doe.ResponseSurface, predictors: Mapping[str, Any],
            goals: Sequence[doe.ResponseGoal],
            feasible: Callable[[np.ndarray], np.ndarray]) -> doe.DesirabilityResult:
    """The settings of best overall desirability inside the design region and ``feasible``
    (actual (m, k) -> bool (m,): the pile region)."""
    opts = ctx.study.stages.optimize
    space = model.factors.subset(model.names)
    return doe.optimize_desirability(
        predictors, goals, model.names,
        search=doe.Search(n_starts=opts.n_starts, n_solutions=opts.n_solutions,
                          seed=ctx.study.seed,
                          feasible=lambda x: np.asarray(feasible(space.to_actual(x)), bool)),
        to_actual=space.to_actual)


def check_responses(ctx: Any, recs: Sequence[RunRecord]) -> dict[str, ResponseVerification]:
    """Each response of the verification runs against its lab value (every response but the
    lead, whose verification is the stage's own)."""
    goals = {g.name: g for g in ctx.results.goals}
    out = {}
    for spec in ctx.responses[1:]:
        vals = np.array([v for r in recs if r.outcome == "pile"
                         and (v := r.response(spec.name)) is not None], dtype=float)
        lab = ctx.labs.get(spec.name)
        mean = float(vals.mean()) if vals.size else None
        std = float(vals.std(ddof=1)) if vals.size > 1 else (0.0 if vals.size else None)
        rel = None
        if mean is not None and lab is not None and lab.mean != 0:
            rel = abs(mean - lab.mean) / abs(lab.mean) * 100.0
        cmp = None if lab is None else compare_to_target(vals, lab.mean, lab.std, lab.n)
        goal = goals.get(spec.name)
        d = None if goal is None or mean is None else float(goal.desirability(mean))
        out[spec.name] = ResponseVerification(
            values=vals.tolist(), mean=mean, std=std, n=int(vals.size),
            lab=None if lab is None else lab.model_dump(), relative_error_percent=rel,
            **({} if cmp is None else dataclasses.asdict(cmp)), desirability=d)
    return out


def goals_json(goals: Sequence[doe.ResponseGoal]) -> list[dict[str, Any]]:
    """The goals as stored in the optimize summary (what a resume compares)."""
    return [{"name": g.name, "goal": g.goal, "low": g.low, "high": g.high, "target": g.target,
             "weight": g.weight, "importance": g.importance} for g in goals]


def optimize_summary(ctx: Any, clf: Any, constraint: Callable[[np.ndarray], np.ndarray],
                     offset: float, prior: Optimum | None) -> Optimum:
    """The optimize stage's optimum when the study has several responses: the desirability
    optimum of the angle's surface (``ctx.results.rsm_model``, corrected by ``offset``)
    and the other responses' inside the pile region (``constraint`` on actual settings, the
    classifier ``clf``); ``prior`` (this round's stored optimum) is kept when it still is the
    optimum, so a resume runs nothing again.

    Same fields as the angle's own optimum (``candidates``, ``chosen``,
    ``predicted_aor_deg``, ``classifier``), plus ``responses``: the goals, and per candidate
    the overall desirability, each response's prediction (``predicted``) and desirability
    (``individual``).
    """
    opts = ctx.study.stages.optimize
    model = ctx.results.rsm_model
    goals = _goals(ctx, np.asarray(model.response, dtype=float))
    ctx.results.goals = goals
    predictors = _predictors(ctx.lead.name, model, ctx.results.response_fits, offset)
    if prior is not None and _still_best(prior, goals, predictors, model):
        return prior
    try:
        res = _search(ctx, model, predictors, goals, constraint)
    except doe.InputError as exc:
        raise StudyError(f"optimize: no setting inside the pile region ({exc})") from None
    cands = []
    for s in res.solutions:
        actual = s.actual or {}
        at = {n: [actual[n]] for n in model.names}
        iv = model.predict_interval(at, units="actual")
        cands.append(Candidate(
            params={n: float(actual[n]) for n in model.names},
            predicted_lead=float(s.predicted[ctx.lead.name]),
            pi_low=float(iv["pi_low"].iloc[0]) + offset,
            pi_high=float(iv["pi_high"].iloc[0]) + offset,
            p_pile=float(clf.p_pile([ctx.full(actual)])[0]),
            desirability=float(s.desirability),
            predicted=dict(s.predicted), individual=dict(s.individual)))
    unmet = res.unmet()
    return Optimum(
        target=ctx.target, candidates=cands, chosen=cands[0].params,
        predicted_lead=cands[0].predicted_lead, classifier=clf.describe(),
        opts=opts.model_dump(mode="json"),
        responses=ResponsesOptimum(
            goals=[Goal.from_summary(g) for g in goals_json(goals)],
            desirability=res.best.desirability, reachable=res.reachable, unmet=list(unmet)),
        warnings=[f"no setting meets the limits of {', '.join(unmet)} at once with the "
                  "others: the overall desirability is 0"] if unmet else [])


def _still_best(prior: Optimum, goals: Sequence[doe.ResponseGoal],
                predictors: Mapping[str, Any], model: doe.ResponseSurface) -> bool:
    """Whether this round's stored optimum ``prior`` was found for the same goals and
    factors and the current models give it the overall desirability it was stored with
    (within 1e-6): then it stands, and a resume reruns nothing."""
    if prior.responses is None or not prior.candidates \
            or [g.to_summary() for g in prior.responses.goals] != goals_json(goals) \
            or set(prior.chosen) != set(model.names):
        return False
    space = model.factors.subset(model.names)
    x = space.to_coded(np.array([[prior.chosen[n] for n in model.names]]))
    big_d = float(doe.desirability_at(predictors, goals, x)[0])
    stored = prior.best.desirability
    return stored is not None and abs(big_d - stored) <= 1e-6
