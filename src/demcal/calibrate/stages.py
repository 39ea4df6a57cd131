"""The calibration stages, each a function of a :class:`Context` that writes its summary.

rangefind -> screening -> steepest -> rsm -> optimize -> verification. The first three live in
their own modules (:mod:`~demcal.calibrate.rangefind`, :mod:`~demcal.calibrate.screening`,
:mod:`~demcal.calibrate.steepest`); here are the response surface, the optimum and the
verification, and every stage by name. Every stage makes its design points, has the runner
run (or find) them, and stores a typed summary (:mod:`demcal.summaries`). A run without a
pile is stored with its outcome and never enters a fit as a number: its design point is
excluded and listed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

from demcal import doe
from demcal.calibrate import several
from demcal.calibrate.classifier import PileClassifier
from demcal.calibrate.context import (
    Context,
    design_points,
    exclusion_note,
    factor_space,
    point_runs,
    run_rows,
)
from demcal.calibrate.rangefind import rangefind
from demcal.calibrate.rounds import (
    Offset,
    stored_rounds,
)
from demcal.calibrate.runner import Point
from demcal.calibrate.screening import screening
from demcal.calibrate.steepest import steepest
from demcal.calibrate.surface_fit import (
    ModelChoice,
    adequacy,
    choose_model,
    fit_rows,
    no_variation,
    replicated,
    resolution_note,
)
from demcal.calibrate.verify import (
    compare_to_target,
    confirmation,
    interval_half_width,
    pure_error_std,
    verification_seed,
    verification_size,
)
from demcal.errors import InputError, StudyError
from demcal.store import RunRecord
from demcal.summaries import (
    AnovaFit,
    Candidate,
    Optimum,
    ResponseModel,
    Surface,
    SurfaceRound,
    Verification,
    anova_records,
)

__all__ = ["Context", "adequacy", "choose_model", "no_variation", "optimize", "rangefind",
           "rsm", "screening", "steepest", "verification"]


# ------------------------------------------------------------------------------ rsm
def rsm(ctx: Context) -> Surface:
    """Box-Behnken (or face-centred CCD) around the centre, quadratic model, full ANOVA.

    Every replicate is a row of the fit and the ANOVA (pure error from the replicates, lack
    of fit against it); R^2, predicted R^2 and Adeq Precision are those of the design-point
    means (the same coefficients), which is what the optimum is read from. When the model is
    not adequate (:func:`adequacy`) and the stage's run budget (``stages.rsm.max_runs``)
    allows, one more replicate of every design point is run and the model refitted, until it
    is adequate or the budget is spent:
    more replicates rather than an optimum read off noise.
    """
    opts = ctx.study.stages.rsm
    levels = ctx.results.steepest.levels
    factors = [replace(ctx.factor(n), low=lv[0], high=lv[2]) for n, lv in levels.items()]
    rows = ctx.factor_rows(factors)
    # the stage's own fidelity enters the hash through its test (Context.begin): left out
    # of the options so that a store written before it keeps its stage
    h = ctx.begin("rsm", {"factors": rows,
                          "opts": opts.model_dump(mode="json", exclude={"fidelity"}),
                          "fixed": ctx.fixed, "reps": ctx.reps("rsm"),
                          "crn": ctx.study.common_seeds})
    design, design_name = _rsm_design(opts, factor_space(factors))
    n_reps = ctx.reps("rsm")
    budget = opts.max_runs if opts.max_runs is not None else design.n_runs * n_reps
    rounds: list[SurfaceRound] = []
    while True:
        last = _replicate_round(ctx, design, n_reps, lambda base: ctx.store.set_stage(
            "rsm", "failed", {"design": design_name, "factors": rows, **base}, inputs_hash=h))
        rounds.append(last.row())
        more = design.n_runs * (n_reps + 1)
        if last.choice.adequacy.adequate or not opts.add_replicates or more > budget:
            break
        n_reps += 1
    choice, model = last.choice, last.choice.chosen.rows
    table, lof_p = choice.chosen.table, choice.chosen.lack_of_fit_p
    responses, response_warnings = _other_responses(ctx, design, last.recs, n_reps)
    surface = Surface(
        design=design_name, fidelity=ctx.surface_fidelity(),
        factors=factors, runs=last.design_rows,
        excluded_points=last.excluded, replicates=n_reps, responses=responses,
        anova=anova_records(table.to_records()),
        fit=AnovaFit.from_summary(table.fit.to_dict()), lack_of_fit_p=lof_p,
        adequacy=choice.adequacy.statistics, rounds=rounds,
        model=choice.kind, removed_terms=list(choice.removed_terms),
        anova_full=anova_records(choice.full.table.to_records()),
        adequacy_full=choice.full.adequacy.statistics,
        coefficients_coded={k: float(v) for k, v in model.coefficients_coded.items()},
        coefficients_actual={k: float(v) for k, v in model.coefficients_actual.items()},
        equation_coded=model.equation(units="coded"),
        equation_actual=model.equation(units="actual"),
        adequate=bool(choice.adequacy.adequate),
        warnings=[*last.warnings(budget), *response_warnings],
        resolution=None if choice.adequacy.adequate else resolution_note(
            choice.full.rows, n_reps, design.n_runs, ctx.unit.strip()))
    ctx.store.set_stage("rsm", "done", surface.to_summary(), inputs_hash=h)
    ctx.results.rsm = surface
    ctx.results.rsm_model = model
    return surface


def _rsm_design(opts: Any, space: doe.FactorSpace) -> tuple[doe.Design, str]:
    """The stage's design in coded units and its stored name (``box_behnken`` or ``ccd``)."""
    try:
        if opts.design == "bbd":
            design = doe.box_behnken(space, center_points=opts.center_points, randomize=False)
        else:
            design = doe.central_composite(space, kind="face", center_points=opts.center_points,
                                           randomize=False)
    except InputError as exc:
        raise InputError(f"stages.rsm.design: {exc}") from None
    return design, "box_behnken" if opts.design == "bbd" else "ccd"


@dataclass(frozen=True)
class _ReplicateRound:
    """One round of the response-surface stage: ``n_reps`` replicates of every design point
    run, fitted and judged."""

    design: doe.Design
    n_reps: int
    recs: list[RunRecord]
    outcomes: list[Any]
    excluded: list[int]
    design_rows: list[Any]
    choice: ModelChoice
    block_notes: list[str]

    def row(self) -> SurfaceRound:
        """The round as the stage's ``rounds`` keeps it."""
        model, adequacy_ = self.choice.chosen.rows, self.choice.adequacy
        return SurfaceRound(
            replicates=self.n_reps, runs=self.design.n_runs * self.n_reps,
            blocks=model.block_df + 1 if model.block_df else 0, model=self.choice.kind,
            removed_terms=list(self.choice.removed_terms), adequate=adequacy_.adequate,
            failed=list(adequacy_.failed), statistics=adequacy_.statistics)

    def warnings(self, budget: int) -> list[str]:
        """What the stage warns of after its last round (``budget``: its run budget)."""
        out = [exclusion_note(self.excluded, self.outcomes)] if self.excluded else []
        out += self.choice.adequacy.failed
        if self.choice.chosen.lack_of_fit_p is None:
            out.append("no lack-of-fit test (no replicated points with spare df)")
        if not self.choice.adequacy.adequate:
            out.append(
                f"the model is not adequate after {self.n_reps} replicate(s) of each design "
                f"point ({self.design.n_runs * self.n_reps} runs; budget stages.rsm.max_runs "
                f"= {budget}): its optimum is a guess within the noise; raise the budget or "
                "the fidelity, or narrow the ranges")
        return [*out, *self.choice.notes, *self.block_notes]


def _replicate_round(ctx: Context, design: doe.Design, n_reps: int,
                     store_failure: Any) -> _ReplicateRound:
    """Run ``n_reps`` replicates of every design point (the stored ones are reused), fit the
    quadratic to every row and choose the model; a fit that fails stores the stage as failed
    (``store_failure(summary)``) and raises :class:`StudyError`."""
    opts = ctx.study.stages.rsm
    recs = ctx.run("rsm", design_points(ctx, design, range(n_reps)))
    y, outcomes, runs = point_runs(recs, design.n_runs, ctx.lead.name)
    excluded = [i for i in range(design.n_runs) if math.isnan(y[i])]
    design_rows = run_rows(design, y, outcomes, runs)
    rep_design, y_rows = replicated(design, runs, n_reps)
    try:
        model, block_notes = fit_rows(rep_design, y_rows, n_reps, ctx.study.common_seeds,
                                      unit=ctx.unit.strip())
        if model.df_resid < 1:
            raise InputError("no residual degrees of freedom")
    except InputError as exc:
        err = f"rsm: the quadratic model cannot be fitted ({exc}); " + exclusion_note(
            excluded, outcomes)
        store_failure({"runs": [r.to_summary() for r in design_rows],
                       "excluded_points": excluded, "replicates": n_reps, "error": err})
        raise StudyError(err) from None
    means = doe.fit(design, y, model="quadratic") if n_reps > 1 else model
    return _ReplicateRound(design=design, n_reps=n_reps, recs=list(recs), outcomes=outcomes,
                           excluded=excluded, design_rows=design_rows,
                           choice=choose_model(opts.model, opts.alpha_out, model, means),
                           block_notes=list(block_notes))


def _other_responses(ctx: Context, design: doe.Design, recs: Sequence[RunRecord], n_reps: int
                     ) -> tuple[dict[str, ResponseModel] | None, list[str]]:
    """Fit every response beside the angle (a several-response study): the models go to
    ``ctx.results.response_fits``; returns their stored form and their warnings (None
    and none, and nothing done, for the angle alone)."""
    if not ctx.several:
        return None, []
    fits = several.fit_responses(ctx, design, recs, n_reps)
    ctx.results.response_fits = fits
    return ({name: f.summary() for name, f in fits.items()},
            [w for f in fits.values() for w in f.warnings])


# ------------------------------------------------------------------------------ optimize
def optimize(ctx: Context) -> Optimum:
    """Settings whose predicted AoR equals the target, ranked; only inside the pile region.

    In a refinement round (``ctx.rounds.number`` > 1, :mod:`demcal.calibrate.refine`) the
    surface is corrected by the offset the earlier rounds measured at their optima
    (:meth:`Rounds.offset`): the optimum is where the surface reads the
    target minus that offset, searched from the previous optimum, so it moves along the
    target contour instead of jumping to another branch of it.
    """
    opts = ctx.study.stages.optimize
    model = ctx.results.rsm_model
    k = ctx.rounds.number
    measured = ctx.rounds.offset(model)
    offset = measured.applied
    aim = ctx.target - offset
    opts_json = opts.model_dump(mode="json")
    if ctx.rounds.stored is None:  # before begin() marks the stage running
        ctx.rounds.stored = stored_rounds(ctx.store.stage("optimize"))
    h = ctx.begin("optimize", {"rsm": ctx.results.rsm.coefficients_coded,
                               "opts": opts_json, "target": ctx.target,
                               **({"round": k, "offset": offset} if k > 1 else {})})
    clf = PileClassifier.fit(ctx.records, [(f.name, f.low, f.high) for f in ctx.study.factors])
    names = list(model.names)

    def constraint(x: np.ndarray) -> np.ndarray:
        return clf.p_pile_grid(ctx.fixed, names, x) >= opts.min_p_pile

    if ctx.several:
        found = several.optimize_summary(ctx, clf, constraint, offset, ctx.rounds.stored.get(k))
        return _store_optimum(ctx, _in_round(found, k, measured), h)
    kept = _stored_optimum(ctx.rounds.stored.get(k), (ctx.target, aim), model, constraint,
                           opts_json)
    if kept is not None:  # a resume (on this or another machine): the decision stands
        return _store_optimum(ctx, kept, h)
    prev = ctx.rounds.optimize[-1].chosen if ctx.rounds.optimize else None
    near = prev or {n: ctx.results.steepest.levels[n][1] for n in names}
    try:
        res = doe.optimize_target(model, aim, constraint=constraint, near=near,
                                  n_solutions=opts.n_solutions, n_starts=opts.n_starts,
                                  units="actual", seed=ctx.study.seed)
    except InputError as exc:
        err = f"optimize: no setting inside the pile region hits the target ({exc})"
        ctx.store.set_stage("optimize", "failed", {"error": err}, inputs_hash=h)
        raise StudyError(err) from None
    if not res.solutions:
        err = "optimize: no setting inside the design region and the pile region hits the target"
        ctx.store.set_stage("optimize", "failed", {"error": err}, inputs_hash=h)
        raise StudyError(err)
    cands = []
    for s in res.solutions:
        full = ctx.full(s.actual or {})
        cands.append(Candidate(
            params={n: float(s.actual[n]) for n in names},  # type: ignore[index]
            predicted_lead=float(s.predicted) + offset,
            pi_low=float(s.pi[0]) + offset if math.isfinite(s.pi[0]) else None,
            pi_high=float(s.pi[1]) + offset if math.isfinite(s.pi[1]) else None,
            p_pile=float(clf.p_pile([full])[0]), desirability=float(s.desirability)))
    found = Optimum(target=ctx.target, candidates=cands, chosen=cands[0].params,
                    predicted_lead=cands[0].predicted_lead, classifier=clf.describe(),
                    opts=opts_json)
    return _store_optimum(ctx, _in_round(found, k, measured), h)


def _in_round(found: Optimum, k: int, measured: Offset) -> Optimum:
    """``found`` as the optimum of round ``k``: a refinement round's also says which offset
    it was aimed by (round 1 stores what it always did)."""
    if k == 1:
        return found
    return replace(found, round=k, surface_offset=measured.applied,
                   offset_from_rounds=measured.rounds, measured_offset=measured.deg,
                   offset_weight=measured.weight)


def _store_optimum(ctx: Context, found: Optimum, h: str) -> Optimum:
    stored = found.in_round(ctx.rounds.optimize)
    ctx.store.set_stage("optimize", "done", stored.to_summary(), inputs_hash=h)
    ctx.results.optimize = stored
    return stored


#: how far (deg) the current surface may put a stored optimum from the target and still keep it
KEEP_OPTIMUM_TOL_DEG = 1e-6


def _stored_optimum(prior: Optimum | None, target: tuple[float, float], model: Any,
                    constraint: Any, opts: dict[str, Any]) -> Optimum | None:
    """The stored optimum of this round (``prior``, or None) if it still solves the current
    problem.

    The optimizer is numerical: the same runs refitted on another machine (other BLAS, other
    numpy) move its answer in the 8th digit, and the verification's stored runs, keyed by
    their exact parameters, would be run again. A stored optimum is kept when the stage
    finished for the same target and settings (``opts``; summaries written before they were
    stored count as the same), its factors are the model's, the current surface predicts the
    target there within :data:`KEEP_OPTIMUM_TOL_DEG` and it lies inside the pile region. A
    surface fitted to other runs moves the prediction far more and the optimum is found anew.
    ``target`` is (the target, what the surface must read: the target less a refinement
    round's offset).
    """
    if prior is None:
        return None
    if (prior.target != target[0] or (prior.opts is not None and prior.opts != opts)
            or set(prior.chosen) != set(model.names) or prior.responses is not None):
        # (responses: the optimum of a study that aimed at several: not this one's)
        return None
    x = np.array([[float(prior.chosen[n]) for n in model.names]])
    if abs(float(model.predict(x, units="actual")[0]) - target[1]) > KEEP_OPTIMUM_TOL_DEG:
        return None
    return prior if bool(np.all(constraint(x))) else None


# ------------------------------------------------------------------------------ verification
def verification(ctx: Context) -> Verification:
    """Replicate runs at the chosen optimum, on fresh seeds: mean, spread, error to the target.

    Starts with ``stages.verification.n`` runs; while the 95 % interval of the mean is wider
    than ``half_width_deg`` either side, or would be at the response surface's pure error
    (the test's scatter measured with many degrees of freedom; not where the surface was
    fitted on another fidelity, whose scatter is another test's), adds the runs needed, up to
    ``max_n`` (:func:`verification_size`).
    """
    opts = ctx.study.stages.verification
    params = ctx.full(ctx.results.optimize.chosen)
    # a surface fitted on another fidelity measured another test's scatter
    sigma, sigma_df = ((None, 0) if ctx.surface_fidelity() is not None
                       else pure_error_std(ctx.results.rsm_model))
    k = ctx.rounds.number
    h = ctx.begin("verification", {"params": params, "n": opts.n,
                                   **({"round": k} if k > 1 else {})})
    n = opts.n
    while True:
        pts = [Point(0, i, params, verification_seed(ctx.study.seed, k, i)) for i in range(n)]
        recs = ctx.run("verification", pts)
        values = [ctx.measured(r) for r in recs]
        vals = np.array([a for a in values if a is not None])
        if opts.half_width_deg is None or vals.size < 2 or vals.size < len(recs):
            break
        want = verification_size(vals, opts.half_width_deg, max(opts.max_n, opts.n), sigma,
                                 sigma_df)
        if want <= n:
            break
        n = want
    mean = float(vals.mean()) if vals.size else None
    std = float(vals.std(ddof=1)) if vals.size > 1 else (0.0 if vals.size else None)
    rel = None if mean is None else abs(mean - ctx.target) / ctx.target * 100.0
    png = next((r.artefacts.get("pile_png") for r in recs if r.artefacts.get("pile_png")), None)
    hw = interval_half_width(vals)
    model = ctx.results.rsm_model
    tol = opts.tolerance_percent
    checks = several.check_responses(ctx, recs) if ctx.several else None
    ver = Verification(
        params=params, values=values, outcomes=[r.outcome for r in recs], mean=mean, std=std,
        relative_error_percent=rel, n=n, n_piles=int(vals.size),
        pile_png=png, half_width=hw if math.isfinite(hw) else None,
        half_width_goal=opts.half_width_deg,
        half_width_reached=bool(opts.half_width_deg is not None and hw <= opts.half_width_deg),
        sized_with_std=sigma, sized_with_df=sigma_df,
        **asdict(compare_to_target(vals, ctx.target, ctx.target_std, ctx.target_n)),
        tolerance_percent=tol,
        within_tolerance=None if tol is None or rel is None else bool(rel <= tol),
        **asdict(confirmation(model, ctx.results.optimize.chosen, vals,
                              offset=ctx.rounds.offset(model))),
        responses=checks, round=k if k > 1 else None)
    ver = ver.in_round(ctx.rounds.verification)
    ctx.store.set_stage("verification", "done", ver.to_summary(), inputs_hash=h)
    ctx.results.verification = ver
    ctx.results.verification_runs = list(recs)
    return ver
