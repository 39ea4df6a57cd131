"""Screening: the Plackett-Burman design, its main-effects model, effects and ANOVA, and
the factors the next stage varies."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
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
from demcal.store import RunRecord
from demcal.summaries import AnovaFit, Effect, Screening, ScreeningModel, anova_records

__all__ = ["screening"]


def screening(ctx: Context) -> Screening:
    """Plackett-Burman design, linear fit, effects and ANOVA, the significant factors."""
    opts = ctx.study.stages.screening
    h = ctx.begin("screening", {"factors": ctx.factor_rows(), "opts": opts.model_dump(mode="json"),
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
        n_runs=design.n_runs, alpha=opts.alpha, factors=list(ctx.factors),
        dummies=[f"dummy{j + 1}" for j in range(design.dummies.shape[1])],
        runs=run_rows(design, y, outcomes, per_point), excluded_points=excluded)
    try:
        if (flat := no_variation(y, ctx.unit.strip())) is not None:  # nothing to screen: say it
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
    effects = _effects(rs)
    others = _other_models(ctx, design, recs) if ctx.several else None
    selected, why = _select(ctx, effects, len(space), others)
    table = rs.anova()
    found = replace(ran, anova=anova_records(table.to_records()),
                    fit=AnovaFit.from_summary(table.fit.to_dict()), effects=effects,
                    responses=others, selected=selected,
                    message=f"selected {', '.join(selected)} ({why}); "
                    + exclusion_note(excluded, outcomes))
    ctx.store.set_stage("screening", "done", found.to_summary(), inputs_hash=h)
    ctx.results.screening = found
    ctx.results.screening_model = rs
    ctx.results.screening_runs = (design, recs)  # the other responses' first-order models
    return found


def _effects(rs: doe.ResponseSurface) -> list[Effect]:
    """A main-effects model's effects, by rank (p and F None where not finite)."""
    return [Effect(term=str(t), effect=float(r["effect"]),
                   contribution_percent=float(r["contribution_percent"]),
                   f=None if not np.isfinite(r["f"]) else float(r["f"]),
                   p=None if not np.isfinite(r["p"]) else float(r["p"]), rank=int(r["rank"]))
            for t, r in rs.effects().iterrows()]


def _other_models(ctx: Context, design: doe.Design, recs: Sequence[RunRecord]
                  ) -> dict[str, ScreeningModel]:
    """Every response beside the lead: its main-effects model over the same runs, or why
    there is none (it did not vary; too few design points reported it)."""
    out = {}
    for spec in ctx.responses[1:]:
        y, _, runs = point_runs(recs, design.n_runs, spec.name)
        excluded = [i for i, r in enumerate(runs) if not r]
        try:
            if (flat := no_variation(y, unit="")) is not None:
                raise InputError(flat)
            rs = doe.fit(design, y, model="linear")
            if rs.df_resid < 1:
                raise InputError("no residual degrees of freedom")
        except InputError as exc:
            out[spec.name] = ScreeningModel(excluded_points=excluded,
                                            note=f"{spec.name}: no model ({exc})")
            continue
        table = rs.anova()
        out[spec.name] = ScreeningModel(effects=_effects(rs),
                                        anova=anova_records(table.to_records()),
                                        fit=AnovaFit.from_summary(table.fit.to_dict()),
                                        excluded_points=excluded)
    return out


def _significant(effects: Sequence[Effect], alpha: float) -> list[str]:
    """The terms with p < ``alpha``, by rank."""
    return [e.term for e in effects if e.p is not None and e.p < alpha]


def _by_best_rank(per: Mapping[str, list[str]], order: list[str]) -> list[str]:
    """The terms significant for any response (``per``: each response's, by rank), ordered by
    their best rank over those responses; ties in ``order`` (the lead's effect order)."""
    best: dict[str, int] = {}
    for terms in per.values():
        for r, term in enumerate(terms):
            best[term] = min(best.get(term, r), r)
    at = {term: i for i, term in enumerate(order)}
    return sorted(best, key=lambda term: (best[term], at.get(term, len(at))))


def _select(ctx: Context, effects: list[Effect], k: int,
            others: Mapping[str, ScreeningModel] | None) -> tuple[list[str], str]:
    """The factors the next stage varies, and why: those the study gives, else the
    significant ones (at most ``max_factors``; with several responses, those significant for
    any of them, by their best rank), filled up to ``min_factors`` by the lead's effect
    rank."""
    opts = ctx.study.stages.screening
    if opts.factors:
        return [ctx.study.factor(r).name for r in opts.factors], "factors given in the study"
    per = {ctx.lead.name: _significant(effects, opts.alpha),
           **{name: _significant(m.effects, opts.alpha) for name, m in (others or {}).items()}}
    sig = _by_best_rank(per, [e.term for e in effects])
    selected = sig[:opts.max_factors]
    why = f"{len(sig)} significant at alpha={opts.alpha:g}"
    if others:
        why += " for some response [" + "; ".join(
            f"{name}: {', '.join(terms) or 'none'}" for name, terms in per.items()) + "]"
    need = min(opts.min_factors, k)
    for e in effects:
        if len(selected) >= need:
            break
        if e.term not in selected:
            selected.append(e.term)
    if len(selected) > len(sig[:opts.max_factors]):
        why += f"; filled up to {need} by effect rank"
    return selected, why
