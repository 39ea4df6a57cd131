"""The path of steepest ascent from the screening model toward the target (with several
responses, up their overall desirability), its best step, the response surface's levels
around it, and where the path runs at a cheaper test, the anchor at the study's own."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from demcal import doe
from demcal.calibrate import anchor, several
from demcal.calibrate.context import Context, clip, factor_space, point_means
from demcal.calibrate.runner import Point
from demcal.errors import StudyError
from demcal.store import RunRecord
from demcal.summaries import Anchor, AnchorRun, PathStep, Steepest

__all__ = ["steepest"]


def _path_direction(ctx: Context, selected: list[str]
                    ) -> tuple[dict[str, float], bool, several.PathClimb | None]:
    """The path's coefficients (only their signs matter) and whether it climbs them.

    The angle alone: its screening model's coefficients, climbed toward the target. Several
    responses: the gradient of their overall desirability (:func:`several.path_climb`), climbed;
    where it is flat at the centre (every goal met there) the angle's direction stands.
    """
    rs = ctx.results.screening_model
    climb = several.path_climb(ctx, selected) if ctx.several else None
    if climb is not None and not climb.flat:
        return dict(climb.gradient), True, climb
    coefs = {n: float(rs.coefficients_coded[n]) for n in selected}
    return coefs, ctx.target > float(rs.coefficients_coded["intercept"]), climb


def _step_values(ctx: Context, recs: Sequence[RunRecord], n_points: int
                 ) -> list[dict[str, float | None]]:
    """Per path step, every response's mean over its replicates (None: the step lacks it)."""
    per = {spec.name: several.point_values(recs, n_points, spec.name) for spec in ctx.responses}
    return [{name: float(np.mean(v[i])) if v[i] else None for name, v in per.items()}
            for i in range(n_points)]


def _best_step(miss: Sequence[float | None]) -> int | None:
    """The first step with a result, then on while the miss (lower is better) does not grow;
    None when no step has one."""
    have = [i for i, e in enumerate(miss) if e is not None]
    if not have:
        return None
    best = have[0]
    for i in range(best + 1, len(miss)):
        if miss[i] is None or miss[i] > miss[best]:  # type: ignore[operator]
            break
        best = i
    return best


def _path_summary(ctx: Context, climb: several.PathClimb | None, recs: Sequence[RunRecord],
                  steps: list[PathStep]) -> tuple[Steepest, list[PathStep], list[float | None]]:
    """Several responses: the summary's ``followed`` and ``climb``, the steps with each one's
    ``responses`` and ``desirability``, and the misses the best step is chosen by (``[]``
    for the angle alone: its relative error)."""
    if climb is None:
        return Steepest(), steps, []
    values = _step_values(ctx, recs, len(steps))
    steps = [replace(row, responses=v, desirability=d)
             for row, v, d in zip(steps, values, climb.desirability(values), strict=True)]
    if climb.flat:
        return Steepest(followed=[ctx.responses[0].name], climb=climb.summary()), steps, []
    return (Steepest(followed=[g.name for g in climb.goals], climb=climb.summary()), steps,
            climb.misses(values))


def steepest(ctx: Context) -> Steepest:
    """Path from the screening effects toward the target; best step = centre of the RSM.

    With several responses the path climbs their overall desirability (:func:`_path_direction`)
    and its best step is the last before the measured desirability falls.
    """
    opts = ctx.study.stages.steepest
    rs = ctx.results.screening_model
    selected = ctx.results.screening.selected
    h = ctx.begin("steepest", {"sel": selected, "factors": ctx.factor_rows(),
                               "opts": opts.model_dump(mode="json"), "fixed": ctx.fixed,
                               "coef": {k: float(v) for k, v in rs.coefficients_coded.items()},
                               **({"responses": [r.model_dump(mode="json")
                                                 for r in ctx.responses]}
                                  if ctx.several else {})})
    coefs, ascent, climb = _path_direction(ctx, selected)
    sign = {n: (1 if ascent else -1) * (1 if c >= 0 else -1) for n, c in coefs.items()}
    space = factor_space([ctx.factor(n) for n in selected])
    if opts.step == "auto":
        step_c = 2.0 / (opts.steps - 1)
        start = {n: -float(sign[n]) for n in selected}
    else:
        step_c = float(opts.step)
        start = {n: 0.0 for n in selected}
    n_points = opts.steps
    while True:
        design = doe.steepest_path({n: (c if c != 0 else 1e-12) for n, c in coefs.items()},
                                   factors=space, n_points=n_points,
                                   steps={n: step_c for n in selected}, start=start,
                                   direction="ascent" if ascent else "descent", units="coded")
        actual = design.actual
        path = [{n: clip(n, actual[i, j]) for j, n in enumerate(design.names)}
                for i in range(design.n_runs)]
        pts = [Point(i, r, ctx.full(path[i]), ctx.seed(i, r, 0))
               for i in range(len(path)) for r in range(ctx.reps("steepest"))]
        recs = ctx.run("steepest", pts)  # earlier steps are stored: only new ones run
        y, outcomes = point_means(recs, len(path), ctx.lead.name)
        err = [None if math.isnan(v) else abs(v - ctx.target) / ctx.target * 100 for v in y]
        steps = [PathStep(step=i, actual=path[i],
                          value=None if math.isnan(y[i]) else float(y[i]),
                          outcome=outcomes[i], relative_error_percent=err[i])
                 for i in range(len(path))]
        followed, steps, miss = _path_summary(ctx, climb, recs, steps)
        best = _best_step(miss or err)
        if best is None:
            msg = "steepest: no step of the path formed a pile"
            ctx.store.set_stage("steepest", "failed", Steepest(error=msg).to_summary(),
                                inputs_hash=h)
            raise StudyError(msg)
        # the miss still falls at the last step: go on along the path (bounded)
        if best < len(path) - 1 or n_points >= opts.max_steps or path[-1] == path[-2]:
            break
        n_points = min(opts.max_steps, n_points + 2)
    what = "desirability falls" if miss else "relative error grows"
    if best == len(path) - 1:
        message = (f"the {'desirability still rises' if miss else 'relative error still falls'}"
                   f" at the last step ({len(path)} steps, max_steps {opts.max_steps}): the "
                   "target may lie beyond the path")
    else:
        message = f"after step {best} the {what} or no pile forms: step {best} is the centre"
    step_actual = {n: abs(step_c) * space[n].half_range for n in selected}
    centre, anchored = _surface_centre(ctx, path, y, best, message)
    levels = _levels(ctx, selected, centre, step_actual)
    found = replace(followed, fidelity=ctx.own_fidelity("steepest").get("fidelity"),
                    factors=selected, direction=sign, steps=steps, best_step=best,
                    centre={n: levels[n][1] for n in selected}, levels=levels,
                    message=message if anchored is None else anchored[1],
                    anchor=None if anchored is None else anchored[0])
    ctx.store.set_stage("steepest", "done", found.to_summary(), inputs_hash=h)
    ctx.results.steepest = found
    return found


def _levels(ctx: Context, selected: list[str], centre: Mapping[str, float],
            step_actual: Mapping[str, float]) -> dict[str, list[float]]:
    """The response surface's low, centre and high of each factor: a path step either side of
    the centre, inside the parameter's bounds and the range finding's pile region."""
    found = ctx.results.rangefind
    levels = {}
    for n in selected:
        lo = clip(n, centre[n] - step_actual[n])
        hi = clip(n, centre[n] + step_actual[n])
        scan = None if found is None else found.factor(n)
        if scan is not None and scan.reason:  # keep the rangefind's pile region
            lo, hi = max(lo, min(scan.new_low, centre[n])), min(
                hi, max(scan.new_high, centre[n]))
        if not hi > lo:
            lo, hi = centre[n] - step_actual[n] / 2, centre[n] + step_actual[n] / 2
        levels[n] = [lo, 0.5 * (lo + hi), hi]
    return levels


def _surface_centre(ctx: Context, path: list[dict[str, float]], y: np.ndarray, best: int,
                    path_message: str
                    ) -> tuple[dict[str, float], tuple[Anchor, str] | None]:
    """The response surface's centre on the path, and where it was anchored, the anchor and
    the stage's message.

    The best step of the path, unless the path ran at its own fidelity and
    ``anchor_rounds`` > 0: then the surface's test (the study's own unless
    ``stages.rsm.fidelity`` names another than the path's) is run at path points around it
    (:mod:`demcal.calibrate.anchor`) and the centre is where that test crosses the target;
    the stage's message (``path_message``, what the path itself found) then says so too.
    """
    rounds = ctx.study.stages.steepest.anchor_rounds
    path_fid = ctx.study.stage_fidelities().get("steepest")
    if path_fid is None or path_fid == _surface_test(ctx)[0] or rounds < 1 or len(path) < 2:
        return dict(path[best]), None
    path_values = [float(v) for v in y]
    got: dict[int, RunRecord] = {}
    want: tuple[int, ...] | None = anchor.first_pair(best, len(path))
    cross, piles = None, {}
    for _ in range(rounds):
        if not want:
            break
        pts = [Point(s, 0, ctx.full(path[s]), ctx.seed(s, 0, 0)) for s in want]
        got.update(zip(want, ctx.run(_ANCHOR_STAGE, pts), strict=True))
        piles = {s: v for s, r in got.items() if (v := ctx.measured(r)) is not None}
        cross = anchor.crossing(piles, ctx.target)
        if cross is not None:
            break
        want = anchor.next_pair(path_values, piles, ctx.target)
    step, message = _anchor_step(ctx, piles, cross, best)
    centre_step = anchor.surface_centre(step, len(path))
    runs = [AnchorRun(step=s, actual=path[s],
                      value=ctx.measured(r), outcome=r.outcome,
                      path_value=None if math.isnan(path_values[s]) else path_values[s])
            for s, r in sorted(got.items())]
    anchored = Anchor(fidelity=_surface_test(ctx)[0], runs=runs, crossing_step=cross,
                      centre_step=centre_step, offset=anchor.offset(path_values, piles),
                      message=message)
    return anchor.path_point(path, centre_step), (anchored, (
        f"the path's best step at its own test ({path_fid}) is {best} ({path_message}); "
        f"{message}; the response surface is centred at step {centre_step:.2f}"))


def _anchor_step(ctx: Context, piles: Mapping[int, float], cross: float | None, best: int
                 ) -> tuple[float, str]:
    """The anchored step the surface is centred on, and why."""
    fid, who = _surface_test(ctx)
    if cross is not None:
        return cross, (f"{who} ({fid}) crosses the target "
                       f"{ctx.target:.2f}{ctx.unit} at step {cross:.2f} of the path")
    if not piles:
        return float(best), (f"no anchored point formed a pile at {who} ({fid}): "
                             f"the path's best step {best} is the centre")
    near = min(piles, key=lambda s: abs(piles[s] - ctx.target))
    return float(near), (f"{who} ({fid}) did not reach the target "
                         f"{ctx.target:.2f}{ctx.unit} at the anchored steps {sorted(piles)}: "
                         f"step {near} (closest, {piles[near]:.2f}{ctx.unit}) is the centre; "
                         "the target may lie beyond the path or the ranges")


def _surface_test(ctx: Context) -> tuple[str, str]:
    """The fidelity of the test the response surface is fitted on, which the path is anchored
    at, and its name in the stage's message."""
    fid = ctx.surface_fidelity()
    return (ctx.study.test.fidelity, "the study's test") if fid is None else (
        fid, "the surface's test")


#: the stage name of the anchor's runs (the surface's test, in the steepest stage)
_ANCHOR_STAGE = "steepest_anchor"
