"""The Bayesian calibration loop: start, then rounds of fit -> posterior -> stop or acquire.

``evaluate`` is a plain callable from coded settings to responses; the study runner (store,
resume, Dask, every engine) plugs in there. Nothing in this module runs a simulation.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from demcal.doe.bayes.acquisition import acquire_batch
from demcal.doe.bayes.identifiability import Identifiability, identify
from demcal.doe.bayes.posterior import Posterior, SamplerSettings, sample_posterior
from demcal.doe.bayes.responses import Response, check_responses
from demcal.doe.bayes.surrogate import Surrogate, coded_points, fit_surrogate
from demcal.doe.designs import latin_hypercube
from demcal.doe.factors import FactorSpace, as_factor_space
from demcal.errors import InputError

__all__ = ["BayesResult", "BayesSettings", "Evaluate", "Round", "calibrate_bayes", "condition_on"]

#: ``evaluate(points_coded) -> {response name: (n,) values}``; NaN marks a failed run.
Evaluate = Callable[[np.ndarray], Mapping[str, Any]]

#: Space-filling start per factor (the issue: ~8-10).
START_PER_FACTOR = 9


@dataclass(frozen=True)
class BayesSettings:
    """The strategy's settings (``[strategy] kind = "bayes"``).

    Parameters
    ----------
    max_runs : int
        Budget of runs, the start included.
    batch : int
        Runs per round after the start, >= 1 (the runner's workers).
    tolerance : float
        Stop when every 95 % interval's half-width is at most this, coded units, in (0, 1]
        (0.25: a quarter of the range wide).
    seed : int
        Seed of the start, the surrogates, the sampler and the acquisition.
    n_start : int or None
        Space-filling start; None: 9 per factor.
    stable_rounds : int
        Stop once the posterior has stopped changing: when, over this many rounds in a row,
        no 95 % interval's end moved by more than ``stable_change`` and the posterior is
        plausible (a ridge that more runs do not narrow spends no more of the budget). 0 (the
        default): off, stop on the tolerance or the budget only.
    stable_change : float
        The largest move of an interval's end, coded units, in (0, 1], that counts as no
        change (0.05: 2.5 % of the range; the sampler's own noise is ~0.01-0.02).
    sampler : SamplerSettings
        How each round's posterior is sampled.

    Raises
    ------
    InputError
        With one message naming the setting and its allowed values.
    """

    max_runs: int = 90
    batch: int = 4
    tolerance: float = 0.25
    seed: int = 0
    n_start: int | None = None
    stable_rounds: int = 0
    stable_change: float = 0.05
    sampler: SamplerSettings = field(default_factory=SamplerSettings)

    def __post_init__(self) -> None:
        if not (isinstance(self.batch, int) and self.batch >= 1):
            raise InputError(f"strategy batch must be an integer >= 1; got {self.batch!r}")
        tol = self.tolerance
        if not (isinstance(tol, int | float) and 0 < tol <= 1):
            raise InputError(
                f"strategy tolerance must be in (0, 1] (coded half-width); got {tol!r}"
            )
        if not isinstance(self.max_runs, int):
            raise InputError(f"strategy max_runs must be an integer; got {self.max_runs!r}")
        if self.n_start is not None and not (isinstance(self.n_start, int) and self.n_start >= 3):
            raise InputError(f"strategy n_start must be an integer >= 3; got {self.n_start!r}")
        if not (isinstance(self.stable_rounds, int) and self.stable_rounds >= 0):
            raise InputError("strategy stable_rounds must be an integer >= 0 (0: off); got "
                             f"{self.stable_rounds!r}")
        change = self.stable_change
        if not (isinstance(change, int | float) and 0 < change <= 1):
            raise InputError("strategy stable_change must be in (0, 1] (coded units); got "
                             f"{change!r}")

    def start_runs(self, k: int) -> int:
        """Runs of the space-filling start for ``k`` factors."""
        return START_PER_FACTOR * k if self.n_start is None else self.n_start

    def check(self, k: int) -> None:
        """Raise InputError if the budget cannot hold the start for ``k`` factors."""
        start = self.start_runs(k)
        if self.max_runs < start:
            raise InputError(
                f"strategy max_runs must be >= the space-filling start's {start} runs "
                f"({'n_start' if self.n_start else f'{START_PER_FACTOR} per factor'}); "
                f"got {self.max_runs}"
            )


@dataclass(frozen=True)
class Round:
    """One round of the loop.

    Attributes
    ----------
    n_runs : int
        Runs the round's surrogates were fitted on.
    half_widths : tuple of float
        95 % half-widths per factor, coded.
    acceptance_fraction : float
        The sampler's.
    warnings : tuple of str
        The posterior's.
    """

    n_runs: int
    half_widths: tuple[float, ...]
    acceptance_fraction: float
    warnings: tuple[str, ...]


@dataclass(frozen=True, eq=False)
class BayesResult:
    """What the strategy found.

    Attributes
    ----------
    posterior : Posterior
        The last round's.
    identifiability : Identifiability
        Its verdict.
    surrogates : dict of str to Surrogate
        The last round's, per response.
    x : (n_runs, k) ndarray
        Coded settings of every run, in run order.
    y : dict of str to (n_runs,) ndarray
        Every run's responses.
    history : tuple of Round
        One per round.
    stopped : str
        ``"tolerance"`` (every interval within it), ``"stable"`` (the intervals stopped
        moving: ``BayesSettings.stable_rounds``) or ``"budget"``.
    """

    posterior: Posterior
    identifiability: Identifiability
    surrogates: dict[str, Surrogate]
    x: np.ndarray
    y: dict[str, np.ndarray]
    history: tuple[Round, ...]
    stopped: str

    @property
    def n_runs(self) -> int:
        """Runs made, the start included."""
        return len(self.x)

    @property
    def best_point(self) -> np.ndarray:
        """(k,) the posterior's maximum a posteriori sample, coded."""
        return self.posterior.map_point

    def to_dict(self) -> dict[str, Any]:
        """Plain data for the result JSON (the issue's fields; actual units)."""
        verdict = self.identifiability
        out = self.posterior.to_dict()
        out.update({
            "identifiable": verdict.identifiable,
            "reason": verdict.reason,
            "ridge": [{"text": r.text, "parameters": list(r.parameters),
                       "direction_coded": list(r.direction), "fraction": r.fraction}
                      for r in verdict.ridges],
            "n_runs": self.n_runs,
            "stopped": self.stopped,
            "best": self.best_point_actual,
        })
        return out

    @property
    def best_point_actual(self) -> dict[str, float]:
        """The best point in the factors' units, keyed by factor."""
        actual = self.posterior.factors.to_actual(self.best_point)
        return dict(zip(self.posterior.names, map(float, actual), strict=True))


def _column(value: Any, name: str, n: int) -> np.ndarray:
    vals = np.asarray(value, dtype=float).reshape(-1)
    if len(vals) != n:
        raise InputError(f"evaluate returned {len(vals)} values of {name} for {n} points")
    return vals


def _evaluate(evaluate: Evaluate, points: np.ndarray,
              responses: Sequence[Response]) -> dict[str, tuple[np.ndarray, np.ndarray | None]]:
    """Call ``evaluate``; check it answered every response for every point.

    A response's answer is its values, or ``(values, variances)`` when the runner knows each
    point's variance (a replicate mean's squared standard error).
    """
    got = evaluate(points.copy())
    out: dict[str, tuple[np.ndarray, np.ndarray | None]] = {}
    for r in responses:
        if r.name not in got:
            raise InputError(f"evaluate returned no values for response {r.name}")
        value, var = got[r.name], None
        if isinstance(value, tuple):
            value, var = value
            var = _column(var, f"{r.name} variances", len(points))
        out[r.name] = (_column(value, r.name, len(points)), var)
    return out


def _append(old: dict[str, tuple[np.ndarray, np.ndarray | None]],
            new: dict[str, tuple[np.ndarray, np.ndarray | None]]
            ) -> dict[str, tuple[np.ndarray, np.ndarray | None]]:
    out = {}
    for name, (vals, var) in old.items():
        new_vals, new_var = new[name]
        if (var is None) != (new_var is None):
            raise InputError(f"evaluate gave variances of {name} in some rounds, not in others")
        out[name] = (np.concatenate([vals, new_vals]),
                     None if var is None else np.concatenate([var, new_var]))
    return out


def _fit_all(x: np.ndarray, data: Mapping[str, tuple[np.ndarray, np.ndarray | None]],
             seed: int) -> dict[str, Surrogate]:
    return {name: fit_surrogate(name, x, vals, noise_var=var, seed=seed)
            for name, (vals, var) in data.items()}


def _fit_and_sample(x: np.ndarray, data: Mapping[str, tuple[np.ndarray, np.ndarray | None]],
                    responses: Sequence[Response], space: FactorSpace, settings: BayesSettings
                    ) -> tuple[dict[str, Surrogate], Posterior, Round]:
    """One round's surrogates on every run so far, the posterior they give, and the round's
    row of the history."""
    surrogates = _fit_all(x, data, settings.seed)
    posterior = sample_posterior(surrogates, responses, space, settings.sampler)
    step = Round(len(x), tuple(map(float, posterior.half_widths)),
                 posterior.acceptance_fraction, posterior.warnings)
    return surrogates, posterior, step


def calibrate_bayes(evaluate: Evaluate, factors: Any, responses: Sequence[Response],
                    settings: BayesSettings | None = None) -> BayesResult:
    """Calibrate by Bayesian inference over the coded box, with Gaussian-process surrogates.

    Parameters
    ----------
    evaluate : callable
        ``evaluate(points)`` with ``points`` an (n, k) array of coded settings returns a
        mapping from each response's name to its n values (NaN for a failed run), or to
        ``(values, variances)`` when each point's variance is known (replicates): the
        surrogate then takes them as per-point noise instead of learning one.
    factors : FactorSpace, sequence of Factor or mapping
        The k factors, all varied (fixed factors stay with the runner).
    responses : sequence of Response
        The lab's means and standard errors.
    settings : BayesSettings, optional
        Budget, batch, tolerance, seed.

    Returns
    -------
    BayesResult

    Raises
    ------
    InputError
        Bad settings (one message), a fixed factor, or ``evaluate`` answering the wrong shape.
    """
    space = as_factor_space(factors)
    if any(f.is_fixed for f in space):
        raise InputError("the Bayesian strategy varies every factor; pass the free ones "
                         f"(fixed: {', '.join(f.name for f in space if f.is_fixed)})")
    responses = check_responses(responses)
    settings = settings or BayesSettings()
    settings.check(len(space))
    x = latin_hypercube(space, settings.start_runs(len(space)), seed=settings.seed,
                        optimization="random-cd").coded
    data = _evaluate(evaluate, x, responses)
    history: list[Round] = []
    intervals: list[np.ndarray] = []
    while True:
        surrogates, posterior, step = _fit_and_sample(x, data, responses, space, settings)
        history.append(step)
        intervals.append(posterior.intervals)
        stopped = _stop(posterior, settings, len(x), intervals)
        if stopped:
            break
        new = acquire_batch(surrogates, responses, posterior,
                            min(settings.batch, settings.max_runs - len(x)),
                            seed=settings.seed + len(history))
        data = _append(data, _evaluate(evaluate, new, responses))
        x = np.vstack([x, new])
    return BayesResult(posterior=posterior, identifiability=identify(posterior),
                       surrogates=surrogates, x=x, y={n: v for n, (v, _) in data.items()},
                       history=tuple(history), stopped=stopped)


def condition_on(result: BayesResult, x_new: Any, y_new: Mapping[str, Any],
                 responses: Sequence[Response], settings: BayesSettings) -> BayesResult:
    """The result conditioned on more runs as well: the surrogates refitted on every run, the
    posterior sampled again and its verdict redone; one more :class:`Round` in the history.

    This is how a verification that missed becomes data: its runs sit at the best point, where
    the surrogates were wrong, so the refitted ones know the response there and the next best
    point moves along the ridge to where the runs (not the first fit) say the lab value lies.

    Parameters
    ----------
    result : BayesResult
        Of :func:`calibrate_bayes` (or of an earlier call), its surrogates with a learned
        noise term (runs given without variances).
    x_new : (m, k) array_like of float
        Coded settings of the runs to add.
    y_new : mapping of str to (m,) array_like of float
        Their values of every response (NaN for a failed run).
    responses : sequence of Response
        The lab values, as given to :func:`calibrate_bayes`.
    settings : BayesSettings
        As given to :func:`calibrate_bayes` (seed and sampler).

    Returns
    -------
    BayesResult
        ``stopped`` as ``result``'s.

    Raises
    ------
    InputError
        Points of the wrong width, values missing or of the wrong length, or a result whose
        runs came with variances.
    """
    x_new = coded_points(x_new, result.x.shape[1], "x_new")
    if any(s.noise_var is not None for s in result.surrogates.values()):
        raise InputError("condition_on: the result's runs came with variances; runs without "
                         "them cannot be added")
    new = {}
    for r in check_responses(responses):
        if r.name not in y_new:
            raise InputError(f"condition_on: no values of response {r.name}")
        new[r.name] = (_column(y_new[r.name], r.name, len(x_new)), None)
    data = _append({n: (result.y[n], None) for n in new}, new)
    x = np.vstack([result.x, x_new])
    surrogates, posterior, step = _fit_and_sample(x, data, responses, result.posterior.factors,
                                                  settings)
    return BayesResult(posterior=posterior, identifiability=identify(posterior),
                       surrogates=surrogates, x=x, y={n: v for n, (v, _) in data.items()},
                       history=(*result.history, step), stopped=result.stopped)


def _stop(posterior: Posterior, settings: BayesSettings, n_runs: int,
          intervals: Sequence[np.ndarray]) -> str:
    """Why to stop now ("tolerance", "stable", "budget"), or "" to go on; ``intervals``: each
    round's (k, 2) coded 95 % intervals so far, this round's last."""
    if posterior.plausible and np.all(posterior.half_widths <= settings.tolerance):
        return "tolerance"
    m = settings.stable_rounds
    if m and posterior.plausible and len(intervals) > m:
        moves = [np.max(np.abs(b - a)) for a, b in zip(intervals[-m - 1:-1], intervals[-m:],
                                                       strict=True)]
        if max(moves) <= settings.stable_change:
            return "stable"
    if n_runs >= settings.max_runs:
        return "budget"
    return ""

