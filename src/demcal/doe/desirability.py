"""Several responses at once: Derringer-Suich desirability, as Design-Expert's numerical
optimisation uses it.

Each response gets a goal and limits, and is mapped to an individual desirability d in [0, 1]
(Derringer & Suich 1980, J. Quality Technology 12(4) 214-219)::

    maximize:  d = 0 below L, ((y - L) / (U - L)) ** w between, 1 above U
    minimize:  d = 1 below L, ((U - y) / (U - L)) ** w between, 0 above U
    target:    d = ((y - L) / (T - L)) ** w for L <= y <= T,
               d = ((U - y) / (U - T)) ** w for T <= y <= U, 0 outside [L, U]
    in_range:  d = 1 inside [L, U], 0 outside

(w: the weight, Design-Expert's 0.1-10, default 1). The overall desirability is the geometric
mean of the individual ones weighted by importance r_i (1-5, Design-Expert's "+" to "+++++")::

    D = (prod_i d_i ** r_i) ** (1 / sum_i r_i)

:func:`optimize_desirability` maximises D over the design region (the coded box, or given
bounds) from many starting points by Nelder-Mead, as Design-Expert does with its downhill
simplex, and lists the distinct solutions it finds, best first. Where D is zero (some response
outside its limits) the search follows the summed relative distance to the limits, so a start
outside every response's window still walks into it; a region where no setting meets every
limit returns solutions of D = 0 and :attr:`DesirabilityResult.reachable` False.

The predictors are plain callables of coded settings, so a fitted
:class:`~demcal.doe.model.ResponseSurface` (:func:`surface_predictors`) and any other
surrogate serve alike.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from scipy import optimize as sopt
from scipy.stats import qmc

from demcal.doe.factors import finite_number
from demcal.doe.goal import GOALS, ResponseGoal
from demcal.errors import InputError

__all__ = [
    "GOALS",
    "DesirabilityResult",
    "DesirabilitySolution",
    "ResponseGoal",
    "Search",
    "climb",
    "desirability_at",
    "optimize_desirability",
    "overall_desirability",
    "surface_predictors",
]

Predictor = Callable[[np.ndarray], np.ndarray]


def overall_desirability(d: Any, importance: Sequence[int]) -> np.ndarray:
    """Weighted geometric mean ``(prod_i d_i ** r_i) ** (1 / sum r_i)`` per row.

    Parameters
    ----------
    d : array_like, shape (m, r)
        Individual desirabilities of m points for r responses.
    importance : sequence of int, length r
        r_i, each 1-5.

    Returns
    -------
    ndarray, shape (m,)
        D in [0, 1]; 0 wherever one d_i is 0.
    """
    d = np.atleast_2d(np.asarray(d, dtype=float))
    r = np.asarray(importance, dtype=float)
    if d.shape[1] != r.size:
        raise InputError(f"{d.shape[1]} desirabilities per point but {r.size} importances")
    with np.errstate(divide="ignore"):
        logs = np.log(np.clip(d, 0.0, 1.0))
    return np.exp(logs @ r / r.sum())


@dataclass(frozen=True)
class DesirabilitySolution:
    """One proposed setting.

    Attributes
    ----------
    coded : dict str -> float
        Factor settings, coded.
    actual : dict str -> float or None
        Factor settings in actual units (None without factors).
    desirability : float
        Overall D.
    predicted : dict str -> float
        Each response's prediction, by name.
    individual : dict str -> float
        Each response's d, by name.
    """

    coded: dict[str, float]
    actual: dict[str, float] | None
    desirability: float
    predicted: dict[str, float]
    individual: dict[str, float]


@dataclass(frozen=True)
class DesirabilityResult:
    """Distinct solutions of :func:`optimize_desirability`, best first.

    Attributes
    ----------
    solutions : tuple of DesirabilitySolution
    goals : tuple of ResponseGoal
    names : tuple of str
        Factor names (coded columns, in the predictors' order).
    n_starts : int
        Local searches run.
    """

    solutions: tuple[DesirabilitySolution, ...]
    goals: tuple[ResponseGoal, ...]
    names: tuple[str, ...]
    n_starts: int

    @property
    def best(self) -> DesirabilitySolution:
        """The first solution."""
        return self.solutions[0]

    @property
    def reachable(self) -> bool:
        """True when some setting meets every response's limits (the best D > 0)."""
        return self.best.desirability > 0.0

    def unmet(self) -> tuple[str, ...]:
        """Responses whose d is 0 at the best solution (the ones out of reach)."""
        return tuple(n for n, d in self.best.individual.items() if d <= 0.0)

    def to_frame(self) -> pd.DataFrame:
        """One row per solution: rank, the settings (actual if known, else coded),
        ``desirability``, then ``<response>`` (prediction) and ``d_<response>``."""
        rows = []
        for i, s in enumerate(self.solutions, 1):
            row: dict[str, Any] = {"rank": i, **(s.actual or s.coded),
                                   "desirability": s.desirability}
            for g in self.goals:
                row[g.name] = s.predicted[g.name]
                row[f"d_{g.name}"] = s.individual[g.name]
            rows.append(row)
        return pd.DataFrame(rows)


def climb(goals: Sequence[ResponseGoal], y: Any) -> np.ndarray:
    """What a search for the best overall desirability climbs, per point: D where D > 0, else
    minus the summed shortfall of the responses outside their limits.

    D alone is flat (0) wherever one response lies outside its limits, so a climb started there
    has no way up; the shortfall (:meth:`ResponseGoal.shortfall`) gives it one, and every
    point with D > 0 scores above every point with D = 0.

    Parameters
    ----------
    goals : sequence of ResponseGoal, length r
    y : array_like, shape (m, r)
        The responses of m points, in the goals' order (units of each response).

    Returns
    -------
    ndarray, shape (m,)
        In [-inf, 1]; higher is better.
    """
    y = np.atleast_2d(np.asarray(y, dtype=float))
    d = np.column_stack([g.desirability(y[:, i]) for i, g in enumerate(goals)])
    return _climb(goals, y, overall_desirability(d, [int(g.importance) for g in goals]))


def _climb(goals: Sequence[ResponseGoal], y: np.ndarray, big_d: np.ndarray) -> np.ndarray:
    gap = sum(g.shortfall(y[:, i]) for i, g in enumerate(goals))
    return np.where(big_d > 0.0, big_d, -gap)


def desirability_at(predictors: Mapping[str, Predictor], goals: Sequence[ResponseGoal],
                    x: np.ndarray) -> np.ndarray:
    """Overall desirability D (m,) of coded settings ``x`` (m, k)."""
    return _Objective(predictors, goals).evaluate(np.atleast_2d(x))[2]


def surface_predictors(models: Mapping[str, Any]) -> tuple[tuple[str, ...], dict[str, Predictor]]:
    """Predictors of coded settings from fitted response surfaces, one per response.

    Every model must be fitted over the same factors in the same order.

    Returns
    -------
    names, predictors
        The factor names and ``{response: f(coded (m, k)) -> (m,)}``.
    """
    if not models:
        raise InputError("no response model given")
    names = None
    out: dict[str, Predictor] = {}
    for response, rs in models.items():
        if names is None:
            names = tuple(rs.names)
        elif tuple(rs.names) != names:
            raise InputError(f"response {response!r}: fitted over {', '.join(rs.names)}, the "
                             f"others over {', '.join(names)}; fit every response over the "
                             "same factors")
        out[response] = lambda x, rs=rs: np.asarray(rs.predict(x, units="coded"), dtype=float)
    return names or (), out


class _Objective:
    """Everything a point's score needs: predictions, d, D (vectorised over points)."""

    #: the score of a point outside the feasible region: worse than any inside it
    INFEASIBLE = 1e6

    def __init__(self, predictors: Mapping[str, Predictor], goals: Sequence[ResponseGoal],
                 feasible: Callable[[np.ndarray], np.ndarray] | None = None):
        self.feasible = feasible
        self.goals = tuple(goals)
        self.predictors = [predictors[g.name] for g in self.goals]
        self.importance = [int(g.importance) for g in self.goals]

    def evaluate(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Predictions (m, r), individual d (m, r) and D (m,) at coded points (m, k)."""
        y = np.column_stack([np.asarray(p(x), dtype=float).reshape(-1)
                             for p in self.predictors])
        d = np.column_stack([g.desirability(y[:, i]) for i, g in enumerate(self.goals)])
        return y, d, overall_desirability(d, self.importance)

    def score(self, x: np.ndarray) -> np.ndarray:
        """What the search minimises: -D where D > 0, else the summed shortfall (>= 0)."""
        y, _d, big_d = self.evaluate(x)
        score = -_climb(self.goals, y, big_d)
        if self.feasible is not None:
            ok = np.asarray(self.feasible(x), dtype=bool).reshape(-1)
            score = np.where(ok, score, self.INFEASIBLE)
        return score


def _check_inputs(predictors: Mapping[str, Predictor], goals: Sequence[ResponseGoal],
                  names: Sequence[str], n_starts: int, n_solutions: int) -> None:
    if not goals:
        raise InputError("no response goal given")
    seen: set[str] = set()
    for g in goals:
        if g.name in seen:
            raise InputError(f"response {g.name!r} is listed twice")
        seen.add(g.name)
        if g.name not in predictors:
            raise InputError(f"response {g.name!r} has no model (models: "
                             f"{', '.join(predictors) or 'none'})")
    if not names:
        raise InputError("no factor to optimise over")
    for field, val in (("n_starts", n_starts), ("n_solutions", n_solutions)):
        if isinstance(val, bool) or not isinstance(val, int) or val < 1:
            raise InputError(f"{field} must be an integer >= 1; got {val!r}")


def _box(names: Sequence[str], bounds: Mapping[str, tuple[float, float]] | None
         ) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = -np.ones(len(names)), np.ones(len(names))
    for name, (a, b) in (bounds or {}).items():
        if name not in names:
            raise InputError(f"bounds: {name!r} is not a factor ({', '.join(names)})")
        a, b = finite_number(a, f"bounds[{name!r}]"), finite_number(b, f"bounds[{name!r}]")
        if not a <= b:
            raise InputError(f"bounds[{name!r}]: low must be <= high; got {a:g}, {b:g}")
        j = list(names).index(name)
        lo[j], hi[j] = a, b
    return lo, hi


def _local_searches(obj: _Objective, lo: np.ndarray, hi: np.ndarray, n_starts: int,
                    rng: np.random.Generator) -> np.ndarray:
    """Nelder-Mead from the best of a Latin hypercube (and the centre): the local optima."""
    k = lo.size
    free = hi > lo
    cand = lo + qmc.LatinHypercube(k, rng=rng).random(max(4 * n_starts, 64)) * (hi - lo)
    cand = np.vstack([np.clip(np.zeros(k), lo, hi), cand])
    starts = cand[np.argsort(obj.score(cand), kind="stable")[:n_starts]]
    if not free.any():
        return starts[:1]
    base = starts[0].copy()

    def f(z: np.ndarray) -> float:
        x = base.copy()
        x[free] = z
        return float(obj.score(x.reshape(1, -1))[0])

    found = []
    for x0 in starts:
        res = sopt.minimize(f, x0[free], method="Nelder-Mead",
                            bounds=list(zip(lo[free], hi[free], strict=True)),
                            options={"xatol": 1e-7, "fatol": 1e-10,
                                     "maxiter": 400 * int(free.sum())})
        x = base.copy()
        x[free] = np.clip(res.x, lo[free], hi[free])
        found.append(x)
    return np.array(found)


@dataclass(frozen=True)
class Search:
    """How :func:`optimize_desirability` searches.

    Attributes
    ----------
    bounds : mapping str -> (low, high), optional
        Coded search range of some factors (default the box [-1, 1]); low == high holds a
        factor at that value.
    n_starts, n_solutions : int
        Local searches run, and distinct solutions kept (each >= 1).
    min_distance : float
        Two solutions closer than this (coded, RMS over factors) count as one.
    seed : int or None
        Seed of the starting points.
    feasible : callable, optional
        ``feasible(coded (m, k)) -> bool (m,)``: settings outside it (e.g. where the test
        forms no pile) are never proposed.
    """

    bounds: Mapping[str, tuple[float, float]] | None = None
    n_starts: int = 40
    n_solutions: int = 5
    min_distance: float = 0.1
    seed: int | None = 0
    feasible: Callable[[np.ndarray], np.ndarray] | None = None


def optimize_desirability(
    predictors: Mapping[str, Predictor],
    goals: Sequence[ResponseGoal],
    names: Sequence[str],
    *,
    search: Search = Search(),
    to_actual: Callable[[np.ndarray], np.ndarray] | None = None,
) -> DesirabilityResult:
    """Settings that maximise the overall desirability of several responses.

    Parameters
    ----------
    predictors : mapping str -> callable
        ``{response: f(coded (m, k)) -> (m,)}`` (e.g. from :func:`surface_predictors`).
    goals : sequence of ResponseGoal
        One per response to optimise (each must have a predictor).
    names : sequence of str
        Factor names, the predictors' column order.
    search : Search, optional
        Region, starts, number of solutions, seed.
    to_actual : callable, optional
        Coded (m, k) -> actual (m, k), for the solutions' actual settings.

    Returns
    -------
    DesirabilityResult
        Solutions ranked by D (rounded to 4 decimals), then by distance to the centre.
    """
    names = tuple(names)
    _check_inputs(predictors, goals, names, search.n_starts, search.n_solutions)
    lo, hi = _box(names, search.bounds)
    obj = _Objective(predictors, goals, search.feasible)
    rng = np.random.default_rng(search.seed)
    points = _local_searches(obj, lo, hi, search.n_starts, rng)
    score = obj.score(points)
    if search.feasible is not None:
        points, score = points[score < obj.INFEASIBLE], score[score < obj.INFEASIBLE]
        if not points.size:
            raise InputError("no feasible setting was found in the search region")
    y, d, big_d = obj.evaluate(points)
    centre_dist = np.sqrt(np.mean(points**2, axis=1))
    order = np.lexsort((centre_dist, np.round(score, 4)))
    chosen: list[int] = []
    for i in order:
        if all(np.sqrt(np.mean((points[i] - points[j]) ** 2)) >= search.min_distance
               for j in chosen):
            chosen.append(int(i))
        if len(chosen) == search.n_solutions:
            break
    actual = to_actual(points) if to_actual is not None else None
    sols = tuple(
        DesirabilitySolution(
            coded=dict(zip(names, map(float, points[i]), strict=True)),
            actual=None if actual is None
            else dict(zip(names, map(float, actual[i]), strict=True)),
            desirability=float(big_d[i]),
            predicted={g.name: float(y[i, r]) for r, g in enumerate(obj.goals)},
            individual={g.name: float(d[i, r]) for r, g in enumerate(obj.goals)},
        )
        for i in chosen
    )
    return DesirabilityResult(solutions=sols, goals=obj.goals, names=names,
                              n_starts=search.n_starts)
