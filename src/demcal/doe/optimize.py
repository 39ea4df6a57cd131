"""Find factor settings whose predicted response hits a target (Design-Expert's "target" goal).

Design-Expert's desirability for a *target* goal T with lower limit L and upper limit U::

    d = ((y - L) / (T - L)) ** s    for L <= y <= T
    d = ((U - y) / (U - T)) ** t    for T <= y <= U
    d = 0                           outside [L, U]

(s, t: the weights, default 1). :func:`optimize_target` maximises d(yhat(x)) over the design
region (the coded box [-1, 1]^k unless ``bounds`` says otherwise) by Nelder-Mead from many
starting points (a Latin hypercube plus the centre), as Design-Expert does with its downhill
simplex, then keeps distinct solutions ranked by desirability. A fitted surface usually hits
the target on a whole curve or surface, so several distinct solutions are the rule.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import pandas as pd
from scipy import optimize as sopt
from scipy.stats import qmc

from demcal.doe.model import ResponseSurface
from demcal.errors import InputError

__all__ = ["OptimizationResult", "Solution", "optimize_target", "target_desirability"]

Constraint = Callable[[np.ndarray], Any]


def target_desirability(
    y: Any,
    target: float,
    lower: float,
    upper: float,
    *,
    weight_low: float = 1.0,
    weight_high: float = 1.0,
) -> np.ndarray:
    """Design-Expert's desirability of a response with a target goal.

    Parameters
    ----------
    y : float or ndarray of float
        Predicted responses.
    target, lower, upper : float
        T, L and U with ``L <= T <= U`` and ``L < U``.
    weight_low, weight_high : float, optional
        Exponents s (below the target) and t (above it), > 0.

    Returns
    -------
    ndarray of float64
        d in [0, 1], same shape as ``y``; 1 exactly at the target.
    """
    if not (lower <= target <= upper and lower < upper):
        raise InputError(
            f"need lower <= target <= upper and lower < upper; got lower={lower:g}, "
            f"target={target:g}, upper={upper:g}"
        )
    if not (weight_low > 0 and weight_high > 0):
        raise InputError("desirability weights must be > 0")
    y = np.asarray(y, dtype=float)
    d = np.zeros_like(y)
    below = (y >= lower) & (y <= target)
    above = (y > target) & (y <= upper)
    if target > lower:
        d[below] = ((y[below] - lower) / (target - lower)) ** weight_low
    else:
        d[below] = 1.0
    if upper > target:
        d[above] = ((upper - y[above]) / (upper - target)) ** weight_high
    return d


@dataclass(frozen=True)
class Solution:
    """One proposed setting.

    Attributes
    ----------
    coded : dict str -> float
        Factor settings in coded units.
    actual : dict str -> float or None
        Factor settings in actual units (None for a coded-only surface).
    predicted : float
        Predicted mean response.
    desirability : float
        d in [0, 1].
    se_mean : float
        Standard error of the predicted mean.
    ci : tuple of float
        Confidence interval of the mean, (low, high).
    pi : tuple of float
        Prediction interval of one new run, (low, high).
    distance : float
        Coded distance (RMS over factors) to the ``near`` point, or to the centre if none.
    """

    coded: dict[str, float]
    actual: dict[str, float] | None
    predicted: float
    desirability: float
    se_mean: float
    ci: tuple[float, float]
    pi: tuple[float, float]
    distance: float


@dataclass(frozen=True)
class OptimizationResult:
    """Ranked, distinct solutions of :func:`optimize_target`.

    Attributes
    ----------
    solutions : tuple of Solution
        Best first.
    target, lower, upper : float
        The goal.
    n_starts : int
        Local searches run.
    n_rejected : int
        Local optima dropped because the constraint called them infeasible.
    alpha : float
        1 - confidence level of the intervals.
    names : tuple of str
        The model's factors.
    outside : tuple of str
        The factors held (``fixed``) or searched (``bounds``) beyond the design's coded box
        [-1, 1]: there the model extrapolates, and its predictions are a guess.
    """

    solutions: tuple[Solution, ...]
    target: float
    lower: float
    upper: float
    n_starts: int
    n_rejected: int
    alpha: float = 0.05
    names: tuple[str, ...] = field(default=())
    outside: tuple[str, ...] = field(default=())

    @property
    def best(self) -> Solution:
        """The first solution."""
        if not self.solutions:
            raise InputError("no feasible solution was found")
        return self.solutions[0]

    def to_frame(self) -> pd.DataFrame:
        """One row per solution: rank, the actual (else coded) settings, ``<name>_coded``,
        ``predicted``, ``desirability``, ``se_mean``, ``ci_low``, ``ci_high``, ``pi_low``,
        ``pi_high``, ``distance``."""
        rows = []
        for i, s in enumerate(self.solutions, 1):
            row: dict[str, Any] = {"rank": i}
            if s.actual is not None:
                row.update(s.actual)
                row.update({f"{k}_coded": v for k, v in s.coded.items()})
            else:
                row.update(s.coded)
            row.update(
                predicted=s.predicted,
                desirability=s.desirability,
                se_mean=s.se_mean,
                ci_low=s.ci[0],
                ci_high=s.ci[1],
                pi_low=s.pi[0],
                pi_high=s.pi[1],
                distance=s.distance,
            )
            rows.append(row)
        return pd.DataFrame(rows)


def _to_coded_map(
    rs: ResponseSurface, values: Mapping[str, Any], units: str, what: str
) -> dict[str, Any]:
    out = {}
    for name, v in values.items():
        if name not in rs.names:
            raise InputError(
                f"{what}: {name!r} is not a factor of the model ({', '.join(rs.names)})"
            )
        if units == "actual":
            f = rs.factors[name]  # type: ignore[index]  # caller checked factors exist
            if isinstance(v, tuple | list):
                out[name] = tuple(float(f.to_coded(float(x))) for x in v)
            else:
                out[name] = float(f.to_coded(float(v)))
        else:
            out[name] = tuple(float(x) for x in v) if isinstance(v, tuple | list) else float(v)
    return out


def _goal_limits(
    rs: ResponseSurface, target: Any, lower: float | None, upper: float | None
) -> tuple[float, float, float]:
    """The target as a finite float and the desirability limits L, U (Design-Expert's
    defaults: the observed range widened to include the target)."""
    try:
        target = float(target)
    except (TypeError, ValueError):
        raise InputError(f"target must be a number; got {target!r}") from None
    if not math.isfinite(target):
        raise InputError(f"target must be finite; got {target!r}")
    ymin, ymax = float(rs.response.min()), float(rs.response.max())
    lo_lim = min(ymin, target) if lower is None else float(lower)
    hi_lim = max(ymax, target) if upper is None else float(upper)
    if lo_lim == hi_lim:
        lo_lim, hi_lim = target - 1.0, target + 1.0
    return target, lo_lim, hi_lim


def _check_search(n_starts: Any, n_solutions: Any, near_weight: Any, min_distance: Any) -> None:
    for name, val, lo in (("n_starts", n_starts, 1), ("n_solutions", n_solutions, 1)):
        if isinstance(val, bool) or not isinstance(val, int) or val < lo:
            raise InputError(f"{name} must be an integer >= {lo}; got {val!r}")
    if not near_weight >= 0:
        raise InputError(f"near_weight must be >= 0; got {near_weight!r}")
    if not min_distance >= 0:
        raise InputError(f"min_distance must be >= 0; got {min_distance!r}")


def _resolve_units(rs: ResponseSurface, units: str | None) -> str:
    if units is None:
        units = "actual" if rs.factors is not None else "coded"
    if units not in ("coded", "actual"):
        raise InputError(f"units must be 'coded' or 'actual'; got {units!r}")
    if units == "actual" and rs.factors is None:
        raise InputError("units='actual' needs a model fitted with factors")
    return units


def _coded_box(
    rs: ResponseSurface, bounds: Mapping[str, tuple[float, float]] | None, units: str
) -> tuple[np.ndarray, np.ndarray]:
    """Search box in coded units: [-1, 1] per factor unless ``bounds`` narrows or widens it."""
    k = len(rs.names)
    lo = -np.ones(k)
    hi = np.ones(k)
    for name, (a, b) in _to_coded_map(rs, bounds or {}, units, "bounds").items():
        if not a < b:
            raise InputError(f"bounds[{name!r}]: low must be < high; got {a:g}, {b:g}")
        j = rs.names.index(name)
        lo[j], hi[j] = a, b
    return lo, hi


def _fixed_coded(
    rs: ResponseSurface, fixed: Mapping[str, float] | None, units: str
) -> dict[str, float]:
    """Held factors in coded units: the model's own fixed factors, then ``fixed``."""
    fixed_c: dict[str, float] = {}
    if rs.factors is not None:
        for f in rs.factors:
            if f.name in rs.names and f.fixed is not None:
                fixed_c[f.name] = float(f.to_coded(f.fixed))
    fixed_c.update(_to_coded_map(rs, fixed or {}, units, "fixed"))
    return fixed_c


@dataclass(frozen=True)
class _Goal:
    """The target goal: T, L, U and the exponents s, t."""

    target: float
    lower: float
    upper: float
    weight_low: float
    weight_high: float

    def desirability(self, y: np.ndarray) -> np.ndarray:
        return target_desirability(
            y,
            self.target,
            self.lower,
            self.upper,
            weight_low=self.weight_low,
            weight_high=self.weight_high,
        )


@dataclass(frozen=True)
class _Problem:
    """One search: the surface, the goal, the free factors and their box, the held values,
    the preferred point and the feasibility constraint, all in coded units."""

    rs: ResponseSurface
    goal: _Goal
    base: np.ndarray
    free: list[int]
    lo_f: np.ndarray
    hi_f: np.ndarray
    constraint: Constraint | None
    near_c: np.ndarray | None
    near_mask: np.ndarray | None
    near_weight: float

    @property
    def space(self) -> Any:
        rs = self.rs
        return rs.factors.subset(rs.names) if rs.factors is not None else None

    def full(self, z: np.ndarray) -> np.ndarray:
        """Free-factor points (m, len(free)) to full coded points (m, k)."""
        x = np.tile(self.base, (z.shape[0], 1))
        x[:, self.free] = z
        return x

    def feasible(self, x: np.ndarray) -> np.ndarray:
        if self.constraint is None:
            return np.ones(x.shape[0], dtype=bool)
        space = self.space
        pts = space.to_actual(x) if space is not None else x
        ok = np.asarray(self.constraint(pts), dtype=bool).reshape(-1)
        if ok.shape[0] != x.shape[0]:
            raise InputError("constraint must return one bool per point")
        return ok

    def desir(self, x: np.ndarray) -> np.ndarray:
        return self.goal.desirability(self.rs.predict(x, units="coded"))

    def dist(self, x: np.ndarray) -> np.ndarray:
        if self.near_c is None:
            return np.sqrt(np.mean(x**2, axis=1))
        mask = self.near_mask
        return np.sqrt(np.sum(mask * (x - self.near_c) ** 2, axis=1) / max(mask.sum(), 1))

    def objective(self, z: np.ndarray) -> float:
        x = self.full(z.reshape(1, -1))
        if not self.feasible(x)[0]:
            return 2.0
        val = -float(self.desir(x)[0])
        if self.near_c is not None and self.near_weight > 0:
            val += self.near_weight * float(self.dist(x)[0] ** 2)
        return val

    def box(self) -> list[tuple[float, float]]:
        return list(zip(self.lo_f, self.hi_f, strict=True))

    def polish_towards(self, z: np.ndarray) -> np.ndarray:
        """Slide a solution that hits the target to the nearest such point to ``near``."""
        if self.desir(self.full(z.reshape(1, -1)))[0] < 0.999:
            return z
        w = self.near_mask[self.free]
        nz = self.near_c[self.free]
        target = self.goal.target
        res = sopt.minimize(
            lambda v: float(np.sum(w * (v - nz) ** 2)),
            z,
            method="SLSQP",
            jac=lambda v: 2 * w * (v - nz),
            bounds=self.box(),
            constraints=[
                {
                    "type": "eq",
                    "fun": lambda v: (
                        self.rs.predict(self.full(v.reshape(1, -1)), units="coded")[0] - target
                    ),
                }
            ],
            options={"ftol": 1e-12, "maxiter": 200},
        )
        v = np.clip(res.x, self.lo_f, self.hi_f)
        x = self.full(v.reshape(1, -1))
        if res.success and self.desir(x)[0] >= 0.999 and self.feasible(x)[0]:
            return v
        return z


def _starting_points(p: _Problem, n_starts: int, rng: np.random.Generator) -> np.ndarray:
    """The ``n_starts`` most desirable feasible points of a Latin hypercube plus the centre."""
    n_cand = max(4 * n_starts, 64)
    u = qmc.LatinHypercube(len(p.free), rng=rng).random(n_cand)
    cand = p.lo_f + u * (p.hi_f - p.lo_f)
    cand = np.vstack([np.clip(np.zeros(len(p.free)), p.lo_f, p.hi_f), cand])
    xc = p.full(cand)
    ok = p.feasible(xc)
    if not ok.any():
        raise InputError("constraint: every sampled point of the design region is infeasible")
    cand, xc = cand[ok], xc[ok]
    score = -p.desir(xc)
    return cand[np.argsort(score, kind="stable")[:n_starts]]


def _local_optima(p: _Problem, starts: np.ndarray, n_solutions: int) -> np.ndarray:
    """Nelder-Mead from each start (Design-Expert's downhill simplex), then, with a
    preferred point, the best few slid along the target surface towards it."""
    found = []
    for z0 in starts:
        res = sopt.minimize(
            p.objective,
            z0,
            method="Nelder-Mead",
            bounds=p.box(),
            options={"xatol": 1e-7, "fatol": 1e-10, "maxiter": 400 * len(p.free)},
        )
        found.append(np.clip(res.x, p.lo_f, p.hi_f))
    if p.near_c is not None:  # polish the best few (SLSQP is the costly part)
        best_first = np.argsort(-p.desir(p.full(np.array(found))), kind="stable")
        for i in best_first[: 3 * n_solutions]:
            found[i] = p.polish_towards(found[i])
    return p.full(np.array(found))


def _distinct(order: np.ndarray, points: np.ndarray, n: int, min_distance: float) -> list[int]:
    """The first ``n`` of ``order`` that lie ``min_distance`` (coded RMS) from those kept."""
    chosen: list[int] = []
    for i in order:
        if all(np.sqrt(np.mean((points[i] - points[j]) ** 2)) >= min_distance for j in chosen):
            chosen.append(int(i))
        if len(chosen) == n:
            break
    return chosen


def _solution(p: _Problem, x: np.ndarray, row: pd.Series, scores: tuple[float, float]) -> Solution:
    """One ranked point as a :class:`Solution` (``scores``: desirability, distance)."""
    names = p.rs.names
    space = p.space
    act = space.to_actual(x) if space is not None else None
    return Solution(
        coded={n: float(v) for n, v in zip(names, x, strict=True)},
        actual=None if act is None else {n: float(v) for n, v in zip(names, act, strict=True)},
        predicted=float(row["predicted"]),
        desirability=float(scores[0]),
        se_mean=float(row["se_mean"]),
        ci=(float(row["ci_low"]), float(row["ci_high"])),
        pi=(float(row["pi_low"]), float(row["pi_high"])),
        distance=float(scores[1]),
    )


def optimize_target(
    rs: ResponseSurface,
    target: float,
    *,
    lower: float | None = None,
    upper: float | None = None,
    weight_low: float = 1.0,
    weight_high: float = 1.0,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    fixed: Mapping[str, float] | None = None,
    units: Literal["coded", "actual"] | None = None,
    constraint: Constraint | None = None,
    near: Mapping[str, float] | None = None,
    near_weight: float = 0.01,
    n_starts: int = 40,
    n_solutions: int = 5,
    min_distance: float = 0.1,
    alpha: float = 0.05,
    seed: int | np.random.Generator | None = 0,
) -> OptimizationResult:
    """Factor settings inside the design region whose predicted response hits ``target``.

    Parameters
    ----------
    rs : ResponseSurface
        The fitted model.
    target : float
        Target response (e.g. the measured angle of repose, deg).
    lower, upper : float, optional
        Desirability limits L and U; default the smallest and largest observed response,
        widened to include the target (Design-Expert's defaults).
    weight_low, weight_high : float, optional
        Desirability exponents s and t.
    bounds : mapping str -> (float, float), optional
        Search range of some factors, in ``units``; default the coded box [-1, 1].
    fixed : mapping str -> float, optional
        Factors held at a value, in ``units``. Factors of ``rs.factors`` with a ``fixed``
        value are held there too.
    units : {"coded", "actual"}, optional
        Units of ``bounds``, ``fixed`` and ``near``; default actual if the model has factors.
    constraint : callable, optional
        ``constraint(points) -> bool array``: points is an (m, k) float64 array of settings
        (actual units if the model has factors, else coded; columns in ``rs.names`` order);
        True = feasible. Infeasible points are penalised during the search and rejected
        from the solutions (e.g. a classifier of runs that formed no pile).
    near : mapping str -> float, optional
        Preferred settings (in ``units``): a small penalty ``near_weight * mean((x - near)^2)``
        (coded) pulls the search towards it, each solution that hits the target is then slid
        along the target surface to the point nearest ``near`` (SLSQP), and ties in
        desirability are ranked by distance (solutions that slide to the same point merge,
        so fewer than ``n_solutions`` may remain).
    near_weight : float, optional
        Weight of that penalty (>= 0).
    n_starts : int, optional
        Number of local searches (>= 1).
    n_solutions : int, optional
        Number of distinct solutions returned (>= 1).
    min_distance : float, optional
        Two solutions closer than this (coded, RMS over factors) count as one.
    alpha : float, optional
        1 - confidence level of the intervals.
    seed : int or numpy.random.Generator, optional
        Seed of the starting points.

    Returns
    -------
    OptimizationResult
        Solutions ranked by desirability (rounded to 4 decimals), then by distance to
        ``near`` if given, else by the standard error of the prediction (most certain first).

    Raises
    ------
    InputError
        Bad limits, bounds outside the order ``low < high``, unknown factors, or every
        starting point infeasible.
    """
    units = _resolve_units(rs, units)
    target, lo_lim, hi_lim = _goal_limits(rs, target, lower, upper)
    target_desirability(
        target, target, lo_lim, hi_lim, weight_low=weight_low, weight_high=weight_high
    )  # validates the goal
    _check_search(n_starts, n_solutions, near_weight, min_distance)
    lo, hi = _coded_box(rs, bounds, units)
    fixed_c = _fixed_coded(rs, fixed, units)
    free = [j for j, n in enumerate(rs.names) if n not in fixed_c]
    base = np.zeros(len(rs.names))
    for name, v in fixed_c.items():
        base[rs.names.index(name)] = v
    near_c = near_mask = None
    if near is not None:
        nm = _to_coded_map(rs, near, units, "near")
        near_c = np.array([nm.get(n, 0.0) for n in rs.names])
        near_mask = np.array([n in nm for n in rs.names], dtype=float)
    p = _Problem(
        rs=rs,
        goal=_Goal(target, lo_lim, hi_lim, weight_low, weight_high),
        base=base,
        free=free,
        lo_f=lo[free],
        hi_f=hi[free],
        constraint=constraint,
        near_c=near_c,
        near_mask=near_mask,
        near_weight=near_weight,
    )
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    if free:
        points = _local_optima(p, _starting_points(p, n_starts, rng), n_solutions)
    else:
        points = base.reshape(1, -1)
    ok = p.feasible(points)
    n_rejected = int((~ok).sum())
    points = points[ok]
    d = p.desir(points)
    dd = p.dist(points)
    iv = rs.predict_interval(points, units="coded", alpha=alpha)
    second = dd if near_c is not None else iv["se_mean"].to_numpy()
    order = np.lexsort((second, -np.round(d, 4)))
    chosen = _distinct(order, points, n_solutions, min_distance)
    return OptimizationResult(
        solutions=tuple(_solution(p, points[i], iv.iloc[i], (d[i], dd[i])) for i in chosen),
        target=target,
        lower=lo_lim,
        upper=hi_lim,
        n_starts=len(points) + n_rejected if free else 1,
        n_rejected=n_rejected,
        alpha=alpha,
        names=rs.names,
        outside=_outside(rs.names, lo, hi, fixed_c),
    )


#: how far past the design's coded box a held value or a search bound may go before the
#: result calls it an extrapolation (rounding of actual values converted to coded)
_BOX_SLACK = 1e-9


def _outside(names: tuple[str, ...], lo: np.ndarray, hi: np.ndarray,
             fixed_c: Mapping[str, float]) -> tuple[str, ...]:
    """The factors held or searched beyond the coded box [-1, 1], in the model's order."""
    return tuple(n for j, n in enumerate(names)
                 if (abs(fixed_c[n]) > 1 + _BOX_SLACK if n in fixed_c
                     else lo[j] < -1 - _BOX_SLACK or hi[j] > 1 + _BOX_SLACK))
