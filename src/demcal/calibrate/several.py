"""Several responses in one calibration: a model per response, the desirability optimum, a
verification of each response against its lab value.

The angle of repose stays the study's first response (it drives range finding, screening and
the steepest path, and its model carries the pile region and the refinement rounds). When the
study has ``[[responses]]`` beside it, the response surface stage fits every other response
over the same design (:func:`fit_responses`), the optimum maximises the overall desirability of
all of them (:func:`optimize_summary`, Design-Expert's numerical optimisation) inside the
pile region, and the verification judges each response's mean on fresh seeds against its lab
value with the angle's rules (:func:`check_responses`). A study with the angle alone never
enters this module: its results are as they were.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from demcal import doe
from demcal.calibrate.responses import AOR, LabValue, ResponseSpec
from demcal.calibrate.verify import compare_to_target
from demcal.errors import StudyError
from demcal.store import RunRecord

__all__ = [
    "ResponseCheck",
    "ResponseFit",
    "check_responses",
    "fit_responses",
    "optimize_summary",
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
        Design-Expert's adequacy rules (:func:`demcal.calibrate.stages.adequacy`).
    statistics : dict
        p of the model and of the lack of fit, R^2, adjusted and predicted R^2, Adeq Precision.
    warnings : tuple of str
    excluded_points : tuple of int
        Design points without this response (no pile, or the test did not report it).
    anova : list of dict
        The ANOVA table's rows.
    """

    name: str
    model: doe.ResponseSurface
    model_kind: str
    adequate: bool
    statistics: dict[str, Any]
    warnings: tuple[str, ...]
    excluded_points: tuple[int, ...]
    anova: tuple[dict[str, Any], ...]

    def summary(self) -> dict[str, Any]:
        """The JSON the store and the report keep (the rsm stage's ``responses[name]``)."""
        return {"model": self.model_kind, "adequate": self.adequate,
                "adequacy": self.statistics, "warnings": list(self.warnings),
                "excluded_points": list(self.excluded_points), "anova": list(self.anova),
                "coefficients_coded": {k: float(v)
                                       for k, v in self.model.coefficients_coded.items()},
                "equation_actual": self.model.equation(units="actual")}


@dataclass(frozen=True)
class ResponseCheck:
    """One response verified at the optimum against its lab value.

    Attributes
    ----------
    name : str
    values : tuple of float
        The verification runs' values (runs that reported it).
    mean, std : float or None
    lab : LabValue or None
        What the lab measured (None for a goal without a lab value).
    relative_error_percent : float or None
        ``|mean - lab| / |lab|`` in percent.
    comparison : dict
        :func:`demcal.calibrate.stages.compare_to_target`'s keys (interval, test, p,
        consistent), None without a lab value.
    desirability : float or None
        The goal's desirability of the verified mean.
    """

    name: str
    values: tuple[float, ...]
    mean: float | None
    std: float | None
    lab: LabValue | None
    relative_error_percent: float | None
    comparison: dict[str, Any] | None
    desirability: float | None

    def to_dict(self) -> dict[str, Any]:
        """The verification summary's ``responses[name]``."""
        return {"values": list(self.values), "mean": self.mean, "std": self.std,
                "n": len(self.values),
                "lab": None if self.lab is None else self.lab.model_dump(),
                "relative_error_percent": self.relative_error_percent,
                **(self.comparison or {}), "desirability": self.desirability}


def point_values(recs: Sequence[RunRecord], n_points: int, name: str) -> list[list[float]]:
    """Per design point, the replicates' values of response ``name`` in replicate order; empty
    for a point where a replicate formed no pile or did not report it."""
    by: dict[int, list[RunRecord]] = {}
    for r in recs:
        by.setdefault(r.point, []).append(r)
    out: list[list[float]] = []
    for i in range(n_points):
        rs = sorted(by.get(i, []), key=lambda r: r.replicate)
        vals = [r.response(name) for r in rs if r.outcome == "pile"]
        ok = rs and len(vals) == len(rs) and all(v is not None for v in vals)
        out.append([float(v) for v in vals] if ok else [])  # type: ignore[arg-type]
    return out


def _fit_one(spec: ResponseSpec, runs: list[list[float]], design: doe.Design, n_reps: int,
             ctx: Any) -> ResponseFit:
    from demcal.calibrate import stages as st

    excluded = tuple(i for i, r in enumerate(runs) if not r)
    means = np.array([float(np.mean(r)) if r else math.nan for r in runs])
    finite = means[np.isfinite(means)]
    if finite.size == 0:
        raise StudyError(f"rsm: response {spec.name!r} was reported by no design point's "
                         "runs; check the test's or engine's result names")
    if float(np.ptp(finite)) == 0.0:  # a flat response: nothing to fit, say so
        model = doe.fit(design, np.where(np.isfinite(means), means, finite[0]), terms=[
            "intercept"])
        return ResponseFit(spec.name, model, "constant", False, {}, (
            f"{spec.name} did not vary over the design ({finite[0]:g} at every point): no "
            "model; it cannot steer the optimum",), excluded, ())
    rep_design, y_rows = st._replicated(design, runs, n_reps)
    rows, notes = st._fit_rows(rep_design, y_rows, n_reps, ctx.study.common_seeds)
    full = doe.fit(design, means, model="quadratic") if n_reps > 1 else rows
    opts = ctx.study.stages.rsm
    choice = st.choose_model(opts.model, opts.alpha_out, rows, full)
    warnings = [*choice["failed"], *choice["notes"], *notes]
    if excluded:
        warnings.insert(0, f"{len(excluded)} design point(s) without {spec.name}: "
                        + ", ".join(map(str, excluded)))
    return ResponseFit(spec.name, choice["rows"], choice["model"], bool(choice["adequate"]),
                       choice["adequacy"], tuple(warnings), excluded,
                       tuple(choice["table"].to_records()))


def fit_responses(ctx: Any, design: doe.Design, recs: Sequence[RunRecord], n_reps: int
                  ) -> dict[str, ResponseFit]:
    """A model per response beside the angle, over the response surface's design."""
    return {spec.name: _fit_one(spec, point_values(recs, design.n_runs, spec.name), design,
                                n_reps, ctx)
            for spec in ctx.responses[1:]}


def _goals(ctx: Any, aor_observed: np.ndarray) -> list[doe.ResponseGoal]:
    fits: Mapping[str, ResponseFit] = ctx.results["_response_fits"]
    goals = []
    for spec in ctx.responses:
        observed = aor_observed if spec.name == AOR else fits[spec.name].model.response
        goals.append(spec.goal_for(observed, ctx.labs.get(spec.name)))
    return goals


def _predictors(model: doe.ResponseSurface, fits: Mapping[str, ResponseFit], offset: float
                ) -> dict[str, Callable[[np.ndarray], np.ndarray]]:
    """Predictors of coded settings; the angle's corrected by a refinement round's offset."""
    names = tuple(model.names)
    out: dict[str, Callable[[np.ndarray], np.ndarray]] = {
        AOR: lambda x: np.asarray(model.predict(x, units="coded"), dtype=float) + offset}
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


def check_responses(ctx: Any, recs: Sequence[RunRecord]) -> dict[str, ResponseCheck]:
    """Each response of the verification runs against its lab value (every response but the
    angle, whose verification is the stage's own)."""
    goals = {g.name: g for g in ctx.results.get("_goals", [])}
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
        out[spec.name] = ResponseCheck(spec.name, tuple(vals.tolist()), mean, std, lab, rel,
                                       cmp, d)
    return out


def goals_json(goals: Sequence[doe.ResponseGoal]) -> list[dict[str, Any]]:
    """The goals as stored in the optimize summary (what a resume compares)."""
    return [{"name": g.name, "goal": g.goal, "low": g.low, "high": g.high, "target": g.target,
             "weight": g.weight, "importance": g.importance} for g in goals]


def optimize_summary(ctx: Any, clf: Any, constraint: Callable[[np.ndarray], np.ndarray],
                     offset: float, prior: dict[str, Any] | None) -> dict[str, Any]:
    """The optimize stage's summary when the study has several responses: the desirability
    optimum of the angle's surface (``ctx.results["_rsm_model"]``, corrected by ``offset``)
    and the other responses' inside the pile region (``constraint`` on actual settings, the
    classifier ``clf``); ``prior`` (this round's stored summary) is kept when it still is the
    optimum, so a resume runs nothing again.

    Same keys as the angle's own optimum (``candidates``, ``chosen``, ``predicted_aor_deg``,
    ``classifier``), plus ``responses``: the goals, and per candidate the overall
    desirability, each response's prediction (``predicted``) and desirability
    (``individual``).
    """
    opts = ctx.study.stages.optimize
    model = ctx.results["_rsm_model"]
    goals = _goals(ctx, np.asarray(model.response, dtype=float))
    ctx.results["_goals"] = goals
    predictors = _predictors(model, ctx.results["_response_fits"], offset)
    space = model.factors.subset(model.names)
    if prior is not None and prior.get("responses", {}).get("goals") == goals_json(goals) \
            and set(prior.get("chosen") or {}) == set(model.names):
        x = space.to_coded(np.array([[prior["chosen"][n] for n in model.names]]))
        big_d = float(doe.desirability_at(predictors, goals, x)[0])
        if abs(big_d - prior["candidates"][0]["desirability"]) <= 1e-6:
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
        cands.append({"params": {n: float(actual[n]) for n in model.names},
                      "predicted_aor_deg": float(s.predicted[AOR]),
                      "pi_low_deg": float(iv["pi_low"].iloc[0]) + offset,
                      "pi_high_deg": float(iv["pi_high"].iloc[0]) + offset,
                      "p_pile": float(clf.p_pile([ctx.full(actual)])[0]),
                      "desirability": float(s.desirability),
                      "predicted": dict(s.predicted), "individual": dict(s.individual)})
    unmet = res.unmet()
    return {"target_aor_deg": ctx.target, "candidates": cands, "chosen": cands[0]["params"],
            "predicted_aor_deg": cands[0]["predicted_aor_deg"],
            "classifier": clf.describe(), "opts": opts.model_dump(mode="json"),
            "responses": {"goals": goals_json(goals), "desirability": res.best.desirability,
                          "reachable": res.reachable, "unmet": list(unmet)},
            **({"warnings": [f"no setting meets the limits of {', '.join(unmet)} at once "
                             "with the others: the overall desirability is 0"]}
               if unmet else {})}
