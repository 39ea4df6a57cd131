"""Screening: the Plackett-Burman design, its main-effects model, effects and ANOVA, and
the factors the next stage varies."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from demcal import doe
from demcal.calibrate.context import (
    Context,
    design_points,
    exclusion_note,
    factor_space,
    point_runs,
    run_rows,
)
from demcal.calibrate.surface_fit import no_variation
from demcal.errors import InputError, StudyError
from demcal.summaries import Effect, Screening

__all__ = ["screening"]


def screening(ctx: Context) -> Screening:
    """Plackett-Burman design, linear fit, effects and ANOVA, the significant factors."""
    opts = ctx.study.stages.screening
    h = ctx.begin("screening", {"factors": ctx.factors, "opts": opts.model_dump(mode="json"),
                                "fixed": ctx.fixed, "reps": ctx.reps("screening")})
    space = factor_space(ctx.factors)
    try:
        design = doe.plackett_burman(space, n_runs=opts.runs, randomize=False)
    except InputError as exc:
        raise InputError(f"stages.screening.runs: {exc}") from None
    recs = ctx.run("screening", design_points(ctx, design, range(ctx.reps("screening"))))
    y, outcomes, per_point = point_runs(recs, design.n_runs, ctx.lead.name)
    excluded = [i for i in range(design.n_runs) if math.isnan(y[i])]
    ran = Screening(
        fidelity=ctx.own_fidelity("screening").get("fidelity"), design="plackett_burman",
        n_runs=design.n_runs, alpha=opts.alpha, factors=[dict(f) for f in ctx.factors],
        dummies=[f"dummy{j + 1}" for j in range(design.dummies.shape[1])],
        runs=run_rows(design, y, outcomes, per_point), excluded_points=excluded)
    try:
        if (flat := no_variation(y)) is not None:  # no effect to screen: say it, now
            raise InputError(flat)
        rs = doe.fit(design, y, model="linear")
        if rs.df_resid < 1:
            raise InputError("no residual degrees of freedom")
    except InputError as exc:
        err = (f"screening: the linear model cannot be fitted ({exc}); "
               + exclusion_note(excluded, outcomes) + ". Run range finding or narrow the "
               "ranges to the pile region")
        ctx.store.set_stage("screening", "failed", replace(ran, error=err).to_summary(),
                            inputs_hash=h)
        raise StudyError(err) from None
    effects = [Effect(term=str(t), effect=float(r["effect"]),
                      contribution_percent=float(r["contribution_percent"]),
                      f=None if not np.isfinite(r["f"]) else float(r["f"]),
                      p=None if not np.isfinite(r["p"]) else float(r["p"]), rank=int(r["rank"]))
               for t, r in rs.effects().iterrows()]
    selected, why = _select(ctx, effects, len(space))
    table = rs.anova()
    found = replace(ran, anova=table.to_records(), fit=table.fit.to_dict(), effects=effects,
                    selected=selected, message=f"selected {', '.join(selected)} ({why}); "
                    + exclusion_note(excluded, outcomes))
    ctx.store.set_stage("screening", "done", found.to_summary(), inputs_hash=h)
    ctx.results["screening"] = found
    ctx.results["_screening_model"] = rs
    ctx.results["_screening_runs"] = (design, recs)  # the other responses' first-order models
    return found


def _select(ctx: Context, effects: list[Effect], k: int) -> tuple[list[str], str]:
    """The factors the next stage varies, and why: those the study gives, else the
    significant ones (at most ``max_factors``), filled up to ``min_factors`` by effect rank."""
    opts = ctx.study.stages.screening
    if opts.factors:
        return [ctx.study.factor(r).name for r in opts.factors], "factors given in the study"
    sig = [e.term for e in effects if e.p is not None and e.p < opts.alpha]
    selected = sig[:opts.max_factors]
    why = f"{len(sig)} significant at alpha={opts.alpha:g}"
    need = min(opts.min_factors, k)
    for e in effects:
        if len(selected) >= need:
            break
        if e.term not in selected:
            selected.append(e.term)
    if len(selected) > len(sig[:opts.max_factors]):
        why += f"; filled up to {need} by effect rank"
    return selected, why
