"""The report's "Several responses" section: each response's model, the desirability
optimum, and each response verified against its lab value.

The stored summaries are read once into typed views (:class:`ResponsesView`), so a renamed
key breaks :func:`responses_view` and its test, not the page.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from demcal.report.tables import Table
from demcal.summaries import (
    FitStatistics,
    Optimum,
    ResponseModel,
    ResponseVerification,
    Surface,
    Verification,
)

__all__ = ["ResponseRow", "ResponsesView", "overlay_figure", "responses_tables", "responses_view"]


@dataclass(frozen=True)
class ResponseRow:
    """One response across the stages (None where a stage has not run)."""

    name: str
    goal: str
    low: float
    high: float
    target: float | None
    importance: int
    model: str | None
    adequate: bool | None
    adj_r2: float | None
    pred_r2: float | None
    equation: str | None
    predicted: float | None
    individual: float | None
    verified_mean: float | None
    verified_std: float | None
    verified_n: int | None
    lab_mean: float | None
    relative_error_percent: float | None
    p_value: float | None
    consistent: bool | None


@dataclass(frozen=True)
class ResponsesView:
    """Every response of a several-response study, and the overall desirability."""

    rows: tuple[ResponseRow, ...]
    desirability: float | None
    unmet: tuple[str, ...]


def responses_view(rsm: Surface, optimum: Optimum,
                   verification: Verification) -> ResponsesView | None:
    """The typed view of the stored summaries; None for a study with the angle alone."""
    own = optimum.responses
    if own is None:
        return None
    fits = rsm.responses or {}
    best = optimum.best
    checks = verification.responses or {}
    rows = []
    lead = _lead(optimum)
    for g in own.goals:
        name = g.name
        fit = fits.get(name) or ResponseModel()
        check = checks.get(name) or ResponseVerification()
        lab = check.lab or {}
        if name == lead:  # the lead (the angle): the surface's own model and verification
            fit = ResponseModel(model=rsm.model, adequate=rsm.adequate,
                                adequacy=rsm.adequacy or FitStatistics(),
                                equation_actual=rsm.equation_actual)
            check = ResponseVerification(
                mean=verification.mean, std=verification.std,
                n=verification.n_piles,
                relative_error_percent=verification.relative_error_percent,
                p_value=verification.p_value, consistent=verification.consistent)
            lab = {"mean": g.target}
        rows.append(ResponseRow(
            name=name, goal=g.goal, low=g.low, high=g.high, target=g.target,
            importance=g.importance, model=fit.model, adequate=fit.adequate,
            adj_r2=fit.adequacy.adj_r2, pred_r2=fit.adequacy.pred_r2,
            equation=fit.equation_actual,
            predicted=(best.predicted or {}).get(name),
            individual=(best.individual or {}).get(name),
            verified_mean=check.mean, verified_std=check.std,
            verified_n=check.n, lab_mean=lab.get("mean"),
            relative_error_percent=check.relative_error_percent,
            p_value=check.p_value, consistent=check.consistent))
    return ResponsesView(tuple(rows), own.desirability, tuple(own.unmet))


def responses_tables(view: ResponsesView) -> tuple[Table, Table]:
    """Two tables: each response's goal and model; each response at the optimum and
    verified against its lab value."""
    goals = pd.DataFrame([{
        "response": r.name, "goal": r.goal, "low": r.low, "target": r.target, "high": r.high,
        "importance": r.importance, "model": r.model, "adequate": r.adequate,
        "adj R^2": r.adj_r2, "pred R^2": r.pred_r2} for r in view.rows])
    verified = pd.DataFrame([{
        "response": r.name, "lab": r.lab_mean, "predicted": r.predicted,
        "desirability d": r.individual, "verified mean": r.verified_mean,
        "verified std": r.verified_std, "n": r.verified_n,
        "error (%)": r.relative_error_percent, "p": r.p_value,
        "consistent": r.consistent} for r in view.rows])
    note = ("overall desirability "
            + ("n/a" if view.desirability is None else f"{view.desirability:.3f}")
            + (f"; out of reach together: {', '.join(view.unmet)}" if view.unmet else ""))
    return (Table("responses_goals", "Responses: goals and models", goals),
            Table("responses_verified", "Responses at the optimum and verified", verified,
                  note=note))


def _lead(optimum: Optimum) -> str:
    """The study's lead response: the first goal of its optimum (the angle in a study that
    gives one)."""
    own = optimum.responses
    return own.goals[0].name if own is not None and own.goals else "aor_deg"


def _surfaces(rsm: Surface, lead: str) -> dict[str, Any]:
    """Every response's stored surface (the lead's and the others'), by name."""
    from demcal.report.surface import StoredSurface

    out = {lead: StoredSurface.from_model(rsm.factors, rsm.coefficients_coded)}
    for name, fit in (rsm.responses or {}).items():
        out[name] = StoredSurface.from_model(rsm.factors, fit.coefficients_coded)
    return out


def overlay_figure(rsm: Surface, optimum: Optimum,
                   pair: tuple[str, str], n_grid: int = 60) -> Any:
    """Design-Expert's overlay plot on one factor pair, the other factors at the optimum: the
    region where every response lies within its desirability limits (unshaded), each
    response's limits (dashed) and lab value (solid) as contours, where they cross is what
    the tests pin; the overall desirability's contours and the optimum.

    Pure function of the stored summaries (the models' coded coefficients and the goals).
    """
    import matplotlib
    from matplotlib.figure import Figure

    from demcal.doe.desirability import ResponseGoal, overall_desirability

    surfaces = _surfaces(rsm, _lead(optimum))
    lead = surfaces[_lead(optimum)]
    own = optimum.responses
    goals = [ResponseGoal(g.name, g.goal, g.low, g.high, target=g.target, weight=g.weight,
                          importance=g.importance) for g in (own.goals if own else [])]
    chosen = optimum.chosen
    i, j = lead.index(pair[0]), lead.index(pair[1])
    base = np.array([float(chosen[n]) for n in lead.names])
    gi = np.linspace(lead.low[i], lead.high[i], n_grid)
    gj = np.linspace(lead.low[j], lead.high[j], n_grid)
    xx, yy = np.meshgrid(gi, gj)
    pts = np.tile(base, (xx.size, 1))
    pts[:, i], pts[:, j] = xx.ravel(), yy.ravel()
    coded = lead.to_coded(pts)
    ys = {g.name: surfaces[g.name].predict_coded(coded) for g in goals}
    d = np.column_stack([g.desirability(ys[g.name]) for g in goals])
    big_d = overall_desirability(d, [g.importance for g in goals]).reshape(xx.shape)
    inside = np.all(d > 0, axis=1).reshape(xx.shape)
    fig = Figure(figsize=(4.6, 3.8), dpi=100)
    ax = fig.add_subplot()
    ax.contourf(xx, yy, (~inside).astype(float), levels=[0.5, 1.5], colors=["0.85"])
    colours = matplotlib.colormaps["tab10"]
    for k, g in enumerate(goals):  # the limits dashed, the lab value solid
        z = ys[g.name].reshape(xx.shape)
        for levels, style in ((sorted({g.low, g.high}), "dashed"),
                              ([g.target] if g.target is not None else [], "solid")):
            if levels and float(z.min()) < max(levels) and min(levels) < float(z.max()):
                cs = ax.contour(xx, yy, z, levels=levels, colors=[colours(k)],
                                linewidths=1.0, linestyles=style)
                ax.clabel(cs, fontsize=6, fmt=lambda v, n=g.name: f"{n} {v:.4g}")
    if float(big_d.max()) > 0:
        cd = ax.contour(xx, yy, big_d, levels=[0.2, 0.4, 0.6, 0.8], colors="k",
                        linewidths=0.5, linestyles="dotted")
        ax.clabel(cd, fontsize=6, fmt="D %.1f")
    ax.plot([chosen[lead.names[i]]], [chosen[lead.names[j]]], "r*", ms=10)
    ax.set_xlabel(lead.symbols[i] if lead.symbols[i] != lead.names[i] else lead.names[i])
    ax.set_ylabel(lead.symbols[j] if lead.symbols[j] != lead.names[j] else lead.names[j])
    ax.set_title("Overlay: lab values solid, limits dashed (outside them shaded), D dotted",
                 fontsize=8)
    return fig
