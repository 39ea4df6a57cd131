"""``[strategy] kind = "bayes"``: a study calibrated by a posterior instead of the DOE stages.

The study's factors become the coded box of :mod:`demcal.doe.bayes`, its responses (the angle
first, then every ``[[responses]]`` table) the lab values the posterior is conditioned on,
and every point the loop asks for is one run of the study's test through the runner (stage
``"bayes"``): stored the moment it ends, found again on resume, run on the pool, Dask or an
external engine like any stage's run. Then the verification stage runs the posterior's best
point on fresh seeds with the DOE path's rules, and the result JSON holds the posterior, the
identifiability verdict with its ridges, the expected shrinkage per response the runs report
beside the study's, the optimum and its verification.

Resume: the loop's every random choice is seeded and run ``i`` of the loop (start and batches
in order) is design row ``i`` with seed ``study seed + i``, so a second call asks for the same
points with the same seeds, the runner finds them all stored, and the result is the same.

Lab standard errors: the likelihood needs each lab mean's standard error ``std / sqrt(n)``.
Without ``n`` the repeats' ``std`` itself is taken (one repeat: the widest honest reading);
without ``std``, :data:`DEFAULT_RELATIVE_STD` of the lab mean as the standard error (2 %,
0.9 deg on a 45 deg angle; the example study's corn-stalk angle, std 1.7 deg over 5 repeats
of 44.1 deg, has 0.76 deg, 1.7 %). Either default is said in the result's ``notes``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from demcal import doe
from demcal.calibrate import refine
from demcal.calibrate import stages as st
from demcal.calibrate.responses import PILE, LabValue, ResponseSpec
from demcal.calibrate.runner import Point
from demcal.doe import bayes
from demcal.errors import InputError, StudyError
from demcal.store import RunRecord
from demcal.summaries import CalibrationResult, Candidate, Optimum, ResultResponses, Verification
from demcal.summaries.bayes import (
    BayesLab,
    BayesPrediction,
    BayesRound,
    BayesSummary,
    CombinationRow,
    MarkedPoint,
    PosteriorInterval,
    RidgeRow,
    ShrinkageRow,
    SurrogateCheckRow,
    SurrogateSlice,
)

__all__ = ["DEFAULT_RELATIVE_STD", "PILE", "STAGE", "can_fail", "lab_responses", "run_bayes",
           "settings"]

#: The DOE path's stages this strategy replaces (their summaries are dropped when it runs).
DOE_STAGES = ("rangefind", "screening", "steepest", "rsm")
#: The runner's stage name of the loop's runs (and of its stored summary).
STAGE = "bayes"
#: Lab std unknown: the standard error is this fraction of the lab mean's magnitude.
DEFAULT_RELATIVE_STD = 0.02
#: Posterior samples kept in the stored summary (the report's corner plot).
STORED_SAMPLES = 800
#: The pile indicator: a pseudo-response, 1 for a run that formed a pile, 0 for any other
#: outcome (as the DOE path's pile classifier counts them), that the posterior conditions
#: on being 1 (the lab formed a pile) with :data:`PILE_SE`. A run without a pile has no
#: angle, so without it the surrogates would extrapolate the angle into the region where
#: no pile forms and the posterior would sit there as happily as anywhere (its name:
#: :data:`demcal.calibrate.responses.PILE`).
#: Its standard error: where the indicator's surrogate reads 0.5 (the pile boundary) the
#: likelihood is exp(-0.5 * 0.5^2 / 0.2^2) = 4 % of its value among piles; at 0, 4e-6.
PILE_SE = 0.2
#: Points of each surrogate slice stored for the report.
SLICE_POINTS = 21
#: A response the runs report beside the study's becomes a shrinkage candidate with at least
#: this many finite values (fewer cannot hold a Gaussian process over the box).
MIN_CANDIDATE_RUNS = 8


def settings(ctx: st.Context) -> bayes.BayesSettings:
    """The loop's settings from the study's ``[strategy]`` table.

    ``batch`` defaults to the runner's workers (a round keeps every worker busy), ``seed``
    to the study's seed.

    Raises
    ------
    InputError
        When ``max_runs`` cannot hold the space-filling start for the study's factors.
    """
    s = ctx.study.strategy
    out = bayes.BayesSettings(
        max_runs=s.max_runs, batch=min(64, s.batch or max(1, int(ctx.runner.workers))),
        tolerance=float(s.tolerance), seed=int(ctx.study.seed if s.seed is None else s.seed),
        n_start=s.n_start, stable_rounds=s.stable_rounds, stable_change=float(s.stable_change))
    try:
        out.check(len(ctx.factors))
    except InputError as exc:
        raise InputError(f"study: {exc}") from None
    return out


def _standard_error(spec: ResponseSpec, lab: LabValue) -> tuple[float, str | None]:
    """The lab mean's standard error (the response's unit) and a note when it is a default."""
    if lab.std is not None and lab.std > 0 and lab.n:
        return lab.std / math.sqrt(lab.n), None
    if lab.std is not None and lab.std > 0:
        return lab.std, (f"{spec.name}: the lab's number of repeats is not given; its std "
                         f"{lab.std:g} is taken as the standard error (one repeat)")
    se = DEFAULT_RELATIVE_STD * abs(lab.mean) or 1.0
    return se, (f"{spec.name}: the lab's std is not given (or 0); its standard error is "
                f"taken as "
                f"{DEFAULT_RELATIVE_STD:.0%} of the lab mean ({se:g})")


def lab_responses(ctx: st.Context) -> tuple[list[bayes.Response], list[str]]:
    """The study's responses as the posterior's lab values, and notes on assumed errors.

    When the test can end without a pile (:func:`can_fail`), the pile indicator
    :data:`PILE` is one more response, held at 1.

    Raises
    ------
    InputError
        For a response without a lab value (a ``maximize``/``minimize``/``in_range`` goal):
        the posterior conditions on measured values only.
    """
    out, notes = [], []
    for spec in ctx.responses:
        lab = ctx.labs.get(spec.name)
        if lab is None or spec.goal != "target":
            raise InputError(f"study: responses {spec.name!r}: strategy kind 'bayes' needs "
                             "a lab value (goal 'target' with target or measurements); got "
                             f"goal {spec.goal!r}")
        se, note = _standard_error(spec, lab)
        out.append(bayes.Response(spec.name, lab.mean, se, spec.unit or ""))
        if note:
            notes.append(note)
    if can_fail(ctx):
        out.append(bayes.Response(PILE, 1.0, PILE_SE))
        notes.append(f"{PILE}: 1 for a run that formed a pile, 0 otherwise; conditioned on 1 "
                     f"(standard error {PILE_SE:g}) so the posterior keeps to where piles form")
    return out, notes


def can_fail(ctx: st.Context) -> bool:
    """Can the study's test end without a pile? (the analytic stand-in only with
    ``no_pile_above``; the lift test and external engines always can)."""
    t = ctx.study.test
    return t.kind != "analytic" or ctx.study.engine is not None or bool(
        (t.analytic or {}).get("no_pile_above"))


def _value(rec: RunRecord, name: str) -> float:
    """A run's response, NaN without a pile or without that response (the fit drops it);
    the pile indicator 1 or 0."""
    if name == PILE:
        return 1.0 if rec.outcome == "pile" else 0.0
    v = rec.response(name) if rec.outcome == "pile" else None
    return math.nan if v is None else float(v)


@dataclass
class _Evaluator:
    """The loop's ``evaluate``: coded points -> runs of the study's test -> responses.

    Row ``i`` of the loop (counted over every call, in order) is design point ``i`` with the
    seed :meth:`Context.seed` gives it, so the same loop asks for the same runs again.
    """

    ctx: st.Context
    space: doe.FactorSpace
    names: tuple[str, ...]
    records: list[RunRecord] = field(default_factory=list)

    def __call__(self, coded: np.ndarray) -> dict[str, np.ndarray]:
        actual = self.space.to_actual(np.asarray(coded, dtype=float))
        start = len(self.records)
        points = [Point(start + i, 0, self.ctx.full(dict(zip(self.space.names, map(float, row),
                                                             strict=True))),
                        self.ctx.seed(start + i, 0))
                  for i, row in enumerate(np.atleast_2d(actual))]
        recs = self.ctx.run(STAGE, points)
        self.records.extend(recs)
        out = {n: np.array([_value(r, n) for r in recs]) for n in self.names}
        if start == 0:
            _check_start(recs, out)
        return out


def _check_start(recs: Sequence[RunRecord], values: Mapping[str, np.ndarray]) -> None:
    """A response that fewer than 3 start runs report cannot be modelled: a StudyError that
    says why, with the start's outcomes (its runs stay stored)."""
    for name, v in values.items():
        n = int(np.isfinite(v).sum())
        if n < 3:
            outcomes = ", ".join(f"{k} {sum(r.outcome == k for r in recs)}"
                                 for k in sorted({str(r.outcome) for r in recs}))
            raise StudyError(f"bayes: only {n} of the {len(recs)} start runs gave {name} "
                             f"(outcomes: {outcomes}); the factor ranges lie where the test "
                             "forms no pile or does not report it: narrow them (the DOE "
                             "path's range finding shows where piles form)")


def _space(ctx: st.Context) -> doe.FactorSpace:
    return st.factor_space(ctx.factors)


def _candidate(name: str, x: np.ndarray, y: np.ndarray, n_lab: int,
               seed: int) -> bayes.Candidate | None:
    """A response the runs report beside the study's, as a shrinkage candidate.

    Its surrogate is fitted on the loop's runs; its lab's standard error is assumed to be the
    fitted run-to-run scatter over the square root of the angle's lab repeats (a test as
    repeatable as the simulation, measured as often as the angle). None when too few runs
    report it or it does not vary.
    """
    ok = np.isfinite(y)
    if ok.sum() < MIN_CANDIDATE_RUNS or np.ptp(y[ok]) <= 0:
        return None
    sur = bayes.fit_surrogate(name, x, y, seed=seed)
    scatter = max(sur.noise_std, 1e-3 * float(np.ptp(y[ok])))
    return bayes.Candidate(name, sur, scatter / math.sqrt(max(1, n_lab)))


def _candidates(records: Sequence[RunRecord], aimed: Sequence[str], x: np.ndarray, n_lab: int,
                seed: int) -> list[bayes.Candidate]:
    """Every response the runs (``records``, one per row of ``x``) report that the study does
    not aim at (``aimed``)."""
    names = sorted({k for r in records for k in r.responses} - set(aimed))
    out = []
    for name in names:
        y = np.array([_value(r, name) for r in records])
        if (c := _candidate(name, x, y, n_lab, seed)) is not None:
            out.append(c)
    return out


def _stated(ctx: st.Context, space: doe.FactorSpace, reported: set[str]
            ) -> tuple[list[bayes.Candidate], dict[str, str | None], list[str]]:
    """The study's stated candidates (``[[strategy.candidates]]``) as linear predictors over
    the coded box, each one's source by name, and a note for each one the runs report
    themselves (their surrogate is taken instead: runs beat a statement)."""
    out, sources, notes = [], {}, []
    for c in ctx.study.strategy.candidates:
        if c.name in reported:
            notes.append(f"candidate {c.name}: the runs report it, so its shrinkage is the "
                         "runs' surrogate's, not the stated slopes'")
            continue
        # a coded unit is half the factor's range
        gradient = tuple(c.slopes.get(f.name, 0.0) * 0.5 * (f.high - f.low) for f in space)
        out.append(bayes.Candidate(c.name, bayes.Sensitivity(gradient), c.standard_error))
        sources[c.name] = c.source
    return out, sources, notes


def _shrinkage(res: bayes.BayesResult, cands: Sequence[bayes.Candidate],
               seed: int, sources: Mapping[str, str | None]) -> list[ShrinkageRow]:
    """Each ridge's expected shrinkage per candidate; ``sources``: the stated candidates'
    (by name; the others' are the runs')."""
    if not cands:
        return []
    rows = bayes.ridge_shrinkage(res.posterior, cands, seed=seed)
    return [ShrinkageRow(response=s.response, ridge=s.ridge, shrinkage=float(s.shrinkage),
                         extent_before=s.extent_before, extent_after=s.extent_after,
                         effective_samples=s.effective_samples,
                         basis="stated" if s.response in sources else "runs",
                         source=sources.get(s.response)) for s in rows]


def _combinations(res: bayes.BayesResult,
                  cands: Sequence[bayes.Candidate]) -> list[CombinationRow]:
    """Each candidate alone and each pair: the ridges the tests would leave with them
    (none for an identifiable posterior: nothing to pin)."""
    if res.identifiability.identifiable:
        return []
    sets = [(c,) for c in cands] + list(itertools.combinations(cands, 2))
    out = []
    for group in sets:
        r = bayes.ridges_after(res.posterior, group)
        out.append(CombinationRow(responses=list(r.responses), ridges=[x.text for x in r.ridges]))
    return out


def _pinning(rows: Sequence[CombinationRow]) -> str | None:
    """The fewest candidates that would pin every parameter, in a sentence (or the set that
    leaves fewest ridges, and what it leaves)."""
    if not rows:
        return None
    best = min(rows, key=lambda r: (len(r.ridges), len(r.responses)))
    added = " and ".join(best.responses)
    if not best.ridges:
        return f"adding {added} would pin every parameter (expected: no ridge left)"
    return (f"no one or two of the candidates would pin every parameter: adding {added} "
            f"would still leave {'; '.join(best.ridges)} (expected)")


#: Below this expected shrinkage a candidate is said not to help much.
HELPS = 0.2


def _advice(rows: Sequence[ShrinkageRow], combos: Sequence[CombinationRow] = ()) -> list[str]:
    """Per ridge (in order), the candidate that would shrink it most, then the fewest
    candidates that would pin every parameter, in sentences: what a study of the angle
    alone does next."""
    out = []
    for ridge in dict.fromkeys(r.ridge for r in rows):
        best = max((r for r in rows if r.ridge == ridge), key=lambda r: r.shrinkage)
        basis = "its stated slopes" if best.basis == "stated" else "the runs' surrogate"
        if best.shrinkage >= HELPS:
            out.append(f"'{ridge}': adding {best.response} would shrink it most "
                       f"({100 * best.shrinkage:.0f} % expected, from {basis})")
        else:
            out.append(f"'{ridge}': no candidate would shrink it much (best {best.response}, "
                       f"{100 * best.shrinkage:.0f} %, from {basis}); it needs a test that weighs "
                       "these parameters differently")
    pin = _pinning(combos)
    return [*out, pin] if pin else out


def _predicted(res: bayes.BayesResult) -> dict[str, BayesPrediction]:
    """Each surrogate's mean response and its standard deviation at the best point."""
    out = {}
    for name, sur in res.surrogates.items():
        mean, std = sur.predict(res.best_point[None, :])
        out[name] = BayesPrediction(mean=float(mean[0]), std=float(std[0]))
    return out


def _history(res: bayes.BayesResult) -> list[BayesRound]:
    names = res.posterior.names
    return [BayesRound(round=i + 1, n_runs=r.n_runs,
                       half_widths_coded=dict(zip(names, r.half_widths, strict=True)),
                       acceptance_fraction=r.acceptance_fraction, warnings=list(r.warnings))
            for i, r in enumerate(res.history)]


def _samples(res: bayes.BayesResult) -> dict[str, list[float]]:
    """A thinned, evenly spaced subset of the posterior samples, in the factors' units."""
    post = res.posterior
    every = max(1, len(post.samples) // STORED_SAMPLES)
    actual = post.factors.to_actual(post.samples[::every])
    return {n: [float(v) for v in actual[:, j]] for j, n in enumerate(post.names)}


def _slices(res: bayes.BayesResult) -> dict[str, dict[str, SurrogateSlice]]:
    """Each surrogate along each factor through the best point (the others held there):
    ``{response: {factor: slice}}`` (x in the factor's units, the mean response and the
    standard deviation of that mean), :data:`SLICE_POINTS` points across the range (the
    report draws them with the lab band)."""
    grid = np.linspace(-1.0, 1.0, SLICE_POINTS)
    space = res.posterior.factors
    out: dict[str, dict[str, SurrogateSlice]] = {}
    for name, sur in res.surrogates.items():
        out[name] = {}
        for j, factor in enumerate(res.posterior.names):
            x = np.tile(res.best_point, (SLICE_POINTS, 1))
            x[:, j] = grid
            mean, std = sur.predict(x)
            out[name][factor] = SurrogateSlice(x=space.to_actual(x)[:, j].tolist(),
                                               mean=mean.tolist(), std=std.tolist())
    return out


def _surrogate_checks(res: bayes.BayesResult) -> tuple[list[SurrogateCheckRow], list[str]]:
    """Each response's surrogate against its own runs (leave-one-out; the pile indicator, a
    0/1 step by design, left out), and a warning for each that misses a run."""
    rows, warn = [], []
    space = res.posterior.factors
    for name, sur in res.surrogates.items():
        if name == PILE:
            continue
        c = bayes.check_surrogate(sur)
        at = space.to_actual(sur.x[c.worst][None, :])[0]
        row = SurrogateCheckRow(
            response=name, n=c.n, rms_z=c.rms_z, max_abs_z=c.max_abs_z, limit=c.limit,
            worst=dict(zip(space.names, map(float, at), strict=True)),
            value=float(sur.y[c.worst]), predicted=c.predicted, rms_error=c.rms_error,
            judged=c.judged, misses_a_run=c.misses_a_run)
        rows.append(row)
        if row.misses_a_run:
            where = ", ".join(f"{n} {v:.3g}" for n, v in row.worst.items())
            warn.append(f"{name}: the run at {where} gave {row.value:.4g} where the other "
                        f"runs predict {row.predicted:.4g}, {c.max_abs_z:.1f} standard "
                        f"deviations off (beyond the limit {c.limit:.1f} for {c.n} runs): the "
                        "surrogate does not follow the response there (a local feature or "
                        "an outlier run), so the posterior is surer near it than the runs "
                        "allow")
    return rows, warn


def _verify(ctx: st.Context, res: bayes.BayesResult,
            predicted: Mapping[str, BayesPrediction]) -> Verification:
    """The verification stage at the best point (the DOE path's rules and seeds).

    The stage reads the optimum from ``ctx.results.optimize``; without a response surface
    there is no Design-Expert confirmation (``confirmed`` None) and the number of runs is
    sized from the runs' own scatter.
    """
    aor, pile = (None if (p := predicted.get(name)) is None else p.mean
                 for name in (ctx.lead.name, PILE))
    best = res.best_point_actual
    k = ctx.rounds.number
    optimum = Optimum(
        target=ctx.target, chosen=best, predicted_lead=aor,
        candidates=[Candidate(params=best, predicted_lead=aor, pi_low=None, pi_high=None,
                              p_pile=None if pile is None else min(1.0, max(0.0, pile)))],
        # never taken for a DOE optimum if the study goes back to kind "doe"
        opts=STAGE, source="the posterior's best sample (strategy bayes)",
        round=k if k > 1 else None).in_round(ctx.rounds.optimize)
    # the report's overview and card
    ctx.store.set_stage("optimize", "done", optimum.to_summary())
    ctx.results.optimize = optimum
    return st.verification(ctx)


def _summary(res: bayes.BayesResult, labs: Sequence[bayes.Response], notes: Sequence[str],
             shrink: list[ShrinkageRow], cfg: bayes.BayesSettings) -> BayesSummary:
    """What the stage stores (the report's source) and the result JSON's Bayesian part
    (the marks are :func:`_marks`')."""
    post, verdict = res.posterior, res.identifiability
    names = post.names
    checks, missed = _surrogate_checks(res)
    ridges = [RidgeRow(text=r.text, parameters=list(r.parameters),
                       direction_coded=list(r.direction), fraction=r.fraction)
              for r in verdict.ridges]
    return BayesSummary(
        posterior={p.name: PosteriorInterval(mean=p.mean_actual, median=p.median_actual,
                                             ci95_low=p.ci95_low_actual,
                                             ci95_high=p.ci95_high_actual)
                   for p in post.parameters},
        correlation={n: dict(zip(names, map(float, row), strict=True))
                     for n, row in zip(names, post.correlation, strict=True)},
        acceptance_fraction=post.acceptance_fraction,
        map=dict(zip(names, map(float, post.factors.to_actual(post.map_point)), strict=True)),
        warnings=[*post.warnings, *missed], identifiable=verdict.identifiable,
        reason=verdict.reason,
        n_runs=res.n_runs, stopped=res.stopped, ridges=ridges, ridge=[r.text for r in ridges],
        shrinkage=shrink, history=_history(res),
        optimum=res.best_point_actual,
        predicted=_predicted(res),
        labs={r.name: BayesLab(mean=r.mean, standard_error=r.standard_error, unit=r.unit)
              for r in labs},
        notes=list(notes),
        settings={"max_runs": cfg.max_runs, "batch": cfg.batch, "tolerance": cfg.tolerance,
                  "seed": cfg.seed, "n_start": cfg.start_runs(len(names)),
                  # only when asked for: a study without it stores what it always stored
                  **({"stable_rounds": cfg.stable_rounds, "stable_change": cfg.stable_change}
                     if cfg.stable_rounds else {})},
        units={p.name: p.unit for p in post.parameters},
        surrogate_checks=checks, samples=_samples(res), slices=_slices(res))


def _marks(ctx: st.Context, res: bayes.BayesResult, labs: Sequence[bayes.Response],
           space: doe.FactorSpace) -> list[MarkedPoint]:
    """The study's marked points (``[[strategy.marks]]``) against the posterior: each one's
    values of the factors and the mass of the smallest highest-density region holding it
    (inside the 95 % credible region when at most 0.95)."""
    out = []
    for mark in ctx.study.strategy.marks:
        values = mark.values or {}  # a value for every factor (parse_study checks it)
        actual = np.array([[values[n] for n in space.names]])
        coded = space.to_coded(actual)
        mass = float(bayes.credibility(res.posterior, res.surrogates, labs, coded)[0])
        out.append(MarkedPoint(label=mark.label,
                               values={n: float(values[n]) for n in space.names},
                               in_box=bool(np.all(np.abs(coded) <= 1.0)), credibility=mass,
                               inside95=bool(mass <= 0.95)))
    return out


def run_bayes(ctx: st.Context) -> CalibrationResult:
    """Calibrate the study by the Bayesian strategy; return its result.

    Stores the stage ``"bayes"`` (its summary: posterior, verdict, ridges, shrinkage, rounds,
    thinned samples) and, through :func:`demcal.calibrate.stages.verification`, the stage
    ``"verification"``; the result is also the store's meta ``"result"``.

    Raises
    ------
    InputError
        Bad settings for the study's factors, or a response without a lab value.
    """
    cfg = settings(ctx)
    labs, notes = lab_responses(ctx)
    if (reps := ctx.study.replicates or 1) > 1:
        notes.append(f"replicates = {reps} (seeds per design point, the DOE path's stages') "
                     "is not used: the strategy runs one seed per point, since a new point "
                     "tells the surrogates more than a replicate and they learn the seed "
                     "scatter themselves")
    for name in DOE_STAGES:  # a study that ran the DOE path before: its runs stay
        ctx.store.delete_stage(name)
    space = _space(ctx)
    h = ctx.begin(STAGE, {"settings": repr(cfg), "labs": [repr(r) for r in labs],
                          "factors": ctx.factor_rows()})
    loop = _Loop(cfg, tuple(labs), tuple(notes), space, h)
    ev = _Evaluator(ctx, space, tuple(r.name for r in labs))
    cond = _Conditioned(bayes.calibrate_bayes(ev, space, labs, cfg), list(ev.records), 0)
    summary, ver = _verified_round(ctx, loop, cond)
    opts = ctx.study.stages.verification
    while ctx.rounds.number < opts.max_rounds and \
            refine.needs_another_round(ver, opts.tolerance_percent):
        # the missed round's runs become data at the point where the surrogates were wrong
        runs = ctx.results.verification_runs
        y = {r.name: [_value(x, r.name) for x in runs] for r in labs}
        cond = _Conditioned(
            bayes.condition_on(cond.result, _coded(space, ver.params, len(runs)), y, labs, cfg),
            [*cond.records, *runs], cond.verification_runs + len(runs))
        ctx.rounds.advance(ctx.results.optimize, ver)
        summary, ver = _verified_round(ctx, loop, cond)
    return _result(ctx, summary, ver)


@dataclass(frozen=True)
class _Loop:
    """What every round of one study shares: settings, lab values, notes on them, the coded
    box and the stage's inputs hash."""

    settings: bayes.BayesSettings
    labs: tuple[bayes.Response, ...]
    notes: tuple[str, ...]
    space: doe.FactorSpace
    inputs_hash: str


@dataclass(frozen=True, eq=False)
class _Conditioned:
    """A posterior and the runs it was conditioned on: ``records`` one per row of
    ``result.x``, the last ``verification_runs`` of them earlier verification rounds'."""

    result: bayes.BayesResult
    records: list[RunRecord]
    verification_runs: int


def _verified_round(ctx: st.Context, loop: _Loop,
                    cond: _Conditioned) -> tuple[BayesSummary, Verification]:
    """Store the stage's summary of the posterior ``cond``, then verify its best point."""
    summary = _summarise(ctx, loop, cond)
    ctx.store.set_stage(STAGE, "done", summary.to_summary(), inputs_hash=loop.inputs_hash)
    return summary, _verify(ctx, cond.result, summary.predicted)


def _coded(space: doe.FactorSpace, params: Mapping[str, float], n: int) -> np.ndarray:
    """(n, k) coded rows of the factors' values in ``params`` (a verification's runs)."""
    row = space.to_coded(np.array([[float(params[f]) for f in space.names]]))
    return np.repeat(row, n, axis=0)


def _summarise(ctx: st.Context, loop: _Loop, cond: _Conditioned) -> BayesSummary:
    """The stage's summary of a posterior: verdict, shrinkage per candidate, combinations,
    advice and the study's marks."""
    res, cfg, labs = cond.result, loop.settings, loop.labs
    lead = ctx.labs.get(ctx.lead.name)
    n_lab = (lead.n if lead is not None else None) or 1
    cands = _candidates(cond.records, [r.name for r in labs], res.x, n_lab, cfg.seed)
    stated, sources, stated_notes = _stated(ctx, loop.space, {c.name for c in cands})
    shrink = _shrinkage(res, [*cands, *stated], cfg.seed, sources)
    combos = _combinations(res, [*cands, *stated])
    return replace(_summary(res, labs, [*loop.notes, *stated_notes], shrink, cfg),
                   marks=_marks(ctx, res, labs, loop.space), combinations=combos,
                   advice=_advice(shrink, combos), verification_runs=cond.verification_runs)


def _result(ctx: st.Context, summary: BayesSummary, ver: Verification) -> CalibrationResult:
    opt: Optimum = ctx.results.optimize
    lead = summary.predicted.get(ctx.lead.name)
    several = None
    if ctx.several:  # the surrogates' means at the best point, as the DOE path's predictions
        several = ResultResponses(
            predicted={name: p.mean for name, p in summary.predicted.items()
                       if name not in (ctx.lead.name, PILE)},
            verification=ver.responses)
    result = CalibrationResult(
        study=ctx.study.name, optimum=dict(summary.optimum), optimum_full=ver.params,
        predicted_lead=None if lead is None else lead.mean, target=ctx.target,
        lead=ctx.lead_label(), verification=ver,
        rounds=refine.round_rows([*ctx.rounds.optimize, opt], [*ctx.rounds.verification, ver]),
        # as the DOE path's: every stored run; the loop's own runs are n_runs_strategy
        n_runs=ctx.store.count(), n_runs_executed=ctx.runner.executed,
        ranges={f.name: [f.low, f.high] for f in ctx.factors}, responses=several,
        bayes=summary, fidelity=ctx.study.test_fidelity)
    ctx.store.set_meta("result", result.to_summary())
    return result
