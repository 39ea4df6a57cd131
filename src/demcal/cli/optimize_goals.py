"""``demcal optimize RUNS.csv --goals GOALS.toml``: several responses of one run sheet at once.

Each ``[[responses]]`` of the goals file names a response column of the sheet; a model is
fitted to each (its own ``model``, else ``--model``), and the settings of best overall
desirability (Derringer-Suich, Design-Expert's numerical optimisation;
:mod:`demcal.doe.desirability`) are listed, with each response's prediction and desirability.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from rich.table import Table

from demcal import doe
from demcal.calibrate.responses import ResponseSpec, load_goals
from demcal.cli._common import console
from demcal.errors import InputError

__all__ = ["GoalsRun", "optimize_goals"]


class GoalsRun:
    """What ``optimize --goals`` was asked: the sheet, the goals file and the fit options."""

    def __init__(self, runs: Path, goals: Path, model: str, fit: Callable[..., Any]):
        self.runs, self.goals, self.model, self.fit = runs, goals, model, fit


def _models(run: GoalsRun, specs: list[ResponseSpec], columns: str | None
            ) -> dict[str, doe.ResponseSurface]:
    """A model per goal's response column, over ``columns`` (default: every column but the
    responses and the bookkeeping)."""
    if columns is None:  # every column but the responses and the bookkeeping
        import pandas as pd

        from demcal.cli.doe_cmds import BOOKKEEPING

        head = pd.read_csv(run.runs, nrows=0).columns
        names = {s.name for s in specs}
        columns = ",".join(c for c in head if c not in names and c not in BOOKKEEPING)
    return {s.name: run.fit(s.name, s.model or run.model, columns) for s in specs}


def optimize_goals(run: GoalsRun, columns: str | None, solutions: int, seed: int,
                   json_out: Path | None) -> None:
    """Fit every response of the goals file, find the best overall desirability, print it
    (and write ``json_out``)."""
    specs = {s.name: s for s in load_goals(run.goals)}
    models = _models(run, list(specs.values()), columns)
    names, predictors = doe.surface_predictors(models)
    goals = [specs[n].goal_for(np.asarray(m.response, dtype=float), specs[n].lab(
        run.goals.parent)) for n, m in models.items()]
    first = next(iter(models.values()))
    to_actual = None
    if first.factors is not None:
        to_actual = first.factors.subset(first.names).to_actual
    res = doe.optimize_desirability(predictors, goals, names,
                                    search=doe.Search(n_solutions=solutions, seed=seed),
                                    to_actual=to_actual)
    _print(res)
    if json_out is not None:
        json_out.parent.mkdir(parents=True, exist_ok=True)
        json_out.write_text(json.dumps(result_json(res, models), indent=2))
        console.print(f"results written to {json_out}", highlight=False)


def result_json(res: doe.DesirabilityResult, models: dict[str, doe.ResponseSurface]
                ) -> dict[str, Any]:
    """``{"responses": goals and models, "reachable", "unmet", "solutions": [{"rank",
    "desirability", "settings", "settings_coded", "predicted", "individual"}]}``."""
    return {
        "responses": [{"name": g.name, "goal": g.goal, "low": g.low, "high": g.high,
                       "target": g.target, "weight": g.weight, "importance": g.importance,
                       "model": models[g.name].model} for g in res.goals],
        "reachable": res.reachable, "unmet": list(res.unmet()),
        "solutions": [{"rank": i, "desirability": s.desirability,
                       "settings": s.actual or s.coded, "settings_coded": s.coded,
                       "predicted": s.predicted, "individual": s.individual}
                      for i, s in enumerate(res.solutions, 1)]}


def _print(res: doe.DesirabilityResult) -> None:
    t = Table(title="Settings of best overall desirability (Derringer-Suich)")
    for c in ("rank", *res.names, "D", *(g.name for g in res.goals)):
        t.add_column(c, justify="right")
    for i, s in enumerate(res.solutions, 1):
        settings = s.actual or s.coded
        t.add_row(str(i), *[f"{settings[n]:.4g}" for n in res.names], f"{s.desirability:.3f}",
                  *[f"{s.predicted[g.name]:.4g} (d {s.individual[g.name]:.2f})"
                    for g in res.goals])
    console.print(t)
    if not res.reachable:
        console.print(f"unreachable: no setting in the region meets the limits of "
                      f"{', '.join(res.unmet())} together with the others (overall "
                      "desirability 0); the rows show the nearest settings", highlight=False)


def check_goal_options(goals: Path | None, response: str | None, target: float | None) -> None:
    """``--goals`` replaces ``--response``/``--target``; without it both are needed."""
    if goals is not None and (response is not None or target is not None):
        raise InputError("--goals names the responses and their targets; leave out "
                         "--response and --target")
    if goals is None and (response is None or target is None):
        raise InputError("give --response and --target, or --goals GOALS.toml for several "
                         "responses")
