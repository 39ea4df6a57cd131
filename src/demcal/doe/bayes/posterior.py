"""The posterior over the coded box: a uniform prior times the lab's Gaussian likelihood.

For a coded setting ``x`` and each response ``r`` with lab mean ``y_r`` and standard error
``se_r``, the surrogate predicts ``m_r(x)`` with standard deviation ``s_r(x)``; the likelihood is

    L(x) = prod_r N(y_r; m_r(x), se_r² + s_r(x)²)

so the surrogate's own uncertainty widens the posterior instead of being ignored (a region the
runs have not explored cannot be ruled out). The prior is uniform over [-1, 1]^k, the ranges
the study gave. The posterior is sampled with emcee's ensemble sampler; nothing here runs a
simulation.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import emcee
import numpy as np
from scipy.stats import qmc
from threadpoolctl import threadpool_limits

from demcal.doe.bayes.responses import Response, check_responses
from demcal.doe.bayes.surrogate import Predictor, coded_points
from demcal.doe.factors import FactorSpace, as_factor_space
from demcal.errors import InputError

__all__ = [
    "ParameterSummary",
    "Posterior",
    "SamplerSettings",
    "credibility",
    "log_posterior",
    "sample_posterior",
]

#: Below this mean acceptance fraction the ensemble barely moved (emcee's guidance: 0.2-0.5).
MIN_ACCEPTANCE = 0.1
#: A response whose best point misses the lab value by more than this many standard
#: deviations (lab and surrogate together) is out of the runs' reach.
MAX_MISFIT_SD = 3.0


@dataclass(frozen=True)
class SamplerSettings:
    """How the posterior is sampled (emcee's EnsembleSampler).

    Parameters
    ----------
    n_walkers : int or None, optional
        Walkers of the ensemble; None: ``max(4 k, 8)`` for k factors (emcee needs > 2 k).
    n_steps : int, optional
        Steps per walker, burn-in included.
    burn : int, optional
        Steps discarded at the start, while the walkers leave their starting points.
    thin : int, optional
        Keep every ``thin``-th step (neighbouring steps are correlated).
    seed : int, optional
        Seed of the starting points and of the sampler.

    Raises
    ------
    InputError
        If a count is not a positive integer or ``burn >= n_steps``.
    """

    n_walkers: int | None = None
    n_steps: int = 2000
    burn: int = 500
    thin: int = 5
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("n_steps", "thin"):
            if not (isinstance(getattr(self, name), int) and getattr(self, name) >= 1):
                raise InputError(f"sampler {name} must be an integer >= 1")
        if not (isinstance(self.burn, int) and 0 <= self.burn < self.n_steps):
            raise InputError(
                f"sampler burn must be in [0, n_steps={self.n_steps}); got {self.burn!r}"
            )
        if self.n_walkers is not None and not (
            isinstance(self.n_walkers, int) and self.n_walkers >= 4
        ):
            raise InputError(f"sampler n_walkers must be an integer >= 4; got {self.n_walkers!r}")

    def walkers(self, k: int) -> int:
        """Number of walkers for ``k`` factors (at least 2 k + 2, as emcee requires)."""
        n = max(4 * k, 8) if self.n_walkers is None else self.n_walkers
        return max(n, 2 * k + 2)


@dataclass(frozen=True)
class ParameterSummary:
    """Marginal posterior of one factor.

    Attributes
    ----------
    name, unit : str
        The factor's.
    mean, median, ci95_low, ci95_high : float
        Coded units; the interval holds the central 95 % of the samples.
    mean_actual, median_actual, ci95_low_actual, ci95_high_actual : float
        The same in the factor's unit.
    """

    name: str
    unit: str
    mean: float
    median: float
    ci95_low: float
    ci95_high: float
    mean_actual: float
    median_actual: float
    ci95_low_actual: float
    ci95_high_actual: float

    @property
    def half_width(self) -> float:
        """Half the 95 % interval, coded units (the stopping rule's measure)."""
        return 0.5 * (self.ci95_high - self.ci95_low)


@dataclass(frozen=True, eq=False)
class Posterior:
    """Samples of the posterior over the coded box and their summaries.

    Attributes
    ----------
    factors : FactorSpace
        The factors, in the order of the columns.
    parameters : tuple of ParameterSummary
        One per factor.
    mean : (k,) ndarray
        Posterior mean, coded.
    covariance, correlation : (k, k) ndarray
        Of the samples, coded units (the correlation is unit-free).
    samples : (n, k) ndarray
        Thinned samples after burn-in, coded.
    log_prob : (n,) ndarray
        Log posterior (up to a constant) of each sample.
    acceptance_fraction : float
        Mean over walkers.
    map_point : (k,) ndarray
        The sample of highest posterior density, coded.
    warnings : tuple of str
        Why the posterior may be implausible, in words; empty when nothing was found.
    """

    factors: FactorSpace
    parameters: tuple[ParameterSummary, ...]
    mean: np.ndarray
    covariance: np.ndarray = field(repr=False)
    correlation: np.ndarray
    samples: np.ndarray = field(repr=False)
    log_prob: np.ndarray = field(repr=False)
    acceptance_fraction: float
    map_point: np.ndarray
    warnings: tuple[str, ...]

    @property
    def names(self) -> tuple[str, ...]:
        """Factor names, in column order."""
        return self.factors.names

    @property
    def plausible(self) -> bool:
        """True when no warning was raised."""
        return not self.warnings

    @property
    def intervals(self) -> np.ndarray:
        """(k, 2) the 95 % intervals' ends (low, high), coded."""
        return np.array([[p.ci95_low, p.ci95_high] for p in self.parameters])

    @property
    def half_widths(self) -> np.ndarray:
        """(k,) half-widths of the 95 % intervals, coded."""
        return np.array([p.half_width for p in self.parameters])

    def to_dict(self) -> dict[str, Any]:
        """Plain data for JSON: intervals in actual units keyed by factor, correlation rows."""
        return {
            "posterior": {
                p.name: {"mean": p.mean_actual, "median": p.median_actual,
                         "ci95_low": p.ci95_low_actual, "ci95_high": p.ci95_high_actual}
                for p in self.parameters
            },
            "correlation": {n: dict(zip(self.names, map(float, row), strict=True))
                            for n, row in zip(self.names, self.correlation, strict=True)},
            "acceptance_fraction": self.acceptance_fraction,
            "map": dict(zip(self.names, map(float, self.factors.to_actual(self.map_point)),
                            strict=True)),
            "warnings": list(self.warnings),
        }


def _check_surrogates(surrogates: Mapping[str, Predictor],
                      responses: Sequence[Response]) -> None:
    missing = [r.name for r in responses if r.name not in surrogates]
    if missing:
        raise InputError(f"no surrogate for response(s) {', '.join(missing)}")


def log_posterior(x: Any, surrogates: Mapping[str, Predictor],
                  responses: Sequence[Response]) -> np.ndarray:
    """Log posterior density (up to a constant) at coded points; -inf outside the box.

    Parameters
    ----------
    x : (n, k) array_like of float
        Coded settings.
    surrogates : mapping of str to Predictor
        A surrogate per response name.
    responses : sequence of Response
        The lab's values.

    Returns
    -------
    (n,) ndarray of float64
    """
    pts = coded_points(x)
    out = np.full(len(pts), -np.inf)
    inside = np.all(np.abs(pts) <= 1.0, axis=1)
    if not inside.any():
        return out
    total = np.zeros(int(inside.sum()))
    for r in responses:
        m, s = surrogates[r.name].predict(pts[inside])
        var = r.standard_error**2 + np.asarray(s, dtype=float) ** 2
        # The log-variance term matters: where the surrogate is unsure the likelihood is
        # wider and lower, so unexplored regions are neither ruled out nor favoured.
        total -= 0.5 * ((np.asarray(m, dtype=float) - r.mean) ** 2 / var + np.log(2 * np.pi * var))
    out[inside] = total
    return out


def credibility(posterior: Posterior, surrogates: Mapping[str, Predictor],
                responses: Sequence[Response], points: Any) -> np.ndarray:
    """The posterior mass of the smallest highest-density region that holds each point.

    A point lies inside the 95 % credible region (the highest-density one) when this is at
    most 0.95: it is the share of the posterior's samples denser than the point. 0 at the
    mode; 1 outside the factor box.

    Parameters
    ----------
    posterior : Posterior
        Sampled with ``surrogates`` and ``responses`` (its ``log_prob`` is compared).
    surrogates : mapping of str to Predictor
        A surrogate per response name.
    responses : sequence of Response
        The lab's values.
    points : (n, k) array_like of float
        Coded settings.

    Returns
    -------
    (n,) ndarray of float64, in [0, 1]
    """
    logp = log_posterior(points, surrogates, responses)
    return np.array([float(np.mean(posterior.log_prob > lp)) for lp in logp])


def _start(logp: Any, k: int, n_walkers: int, seed: int) -> np.ndarray:
    """Starting walkers: the best of a scrambled Sobol sample over the box."""
    # Starting near the mass (rather than anywhere) shortens the burn-in; taking the best of
    # many spread points keeps the walkers distinct, as the ensemble moves need.
    cand = 2.0 * qmc.Sobol(k, rng=np.random.default_rng(seed)).random(2048) - 1.0
    best = np.argsort(logp(cand))[::-1][:n_walkers]
    return cand[best]


def _summary(factors: FactorSpace, samples: np.ndarray) -> tuple[ParameterSummary, ...]:
    q = np.quantile(samples, [0.025, 0.5, 0.975], axis=0)
    mean = samples.mean(axis=0)
    out = []
    for i, f in enumerate(factors):
        coded = (float(mean[i]), float(q[1, i]), float(q[0, i]), float(q[2, i]))
        actual = tuple(float(f.to_actual(c)) for c in coded)
        out.append(ParameterSummary(f.name, f.unit, *coded, *actual))
    return tuple(out)


def _edge_warnings(parameters: Sequence[ParameterSummary]) -> list[str]:
    """A 95 % interval squeezed against a bound: the box truncates the posterior."""
    out = []
    for p in parameters:
        for side, inner, outer in (("high", p.ci95_low, p.ci95_high),
                                   ("low", -p.ci95_high, -p.ci95_low)):
            if inner > 0.8 and outer > 0.98:
                out.append(f"{p.name}: the posterior piles at its {side} bound "
                           f"(95 % interval {p.ci95_low_actual:.4g} to {p.ci95_high_actual:.4g}"
                           f"{' ' + p.unit if p.unit else ''}); the lab value may lie outside "
                           "what the runs reach: widen the range")
    return out


def _misfit_warnings(point: np.ndarray, surrogates: Mapping[str, Predictor],
                     responses: Sequence[Response]) -> list[str]:
    """A response the best point cannot match: the lab value is out of the runs' reach."""
    out = []
    for r in responses:
        m, s = surrogates[r.name].predict(point.reshape(1, -1))
        z = (float(m[0]) - r.mean) / float(np.hypot(r.standard_error, s[0]))
        if abs(z) > MAX_MISFIT_SD:
            ys = getattr(surrogates[r.name], "y", None)
            seen = "" if ys is None else f"; the runs gave {np.min(ys):.4g} to {np.max(ys):.4g}"
            out.append(f"{r.name}: the best point gives {float(m[0]):.4g}, {abs(z):.1f} standard "
                       f"errors from the lab's {r.mean:.4g}{seen}: the lab value lies outside "
                       "what the runs reach")
    return out


def sample_posterior(surrogates: Mapping[str, Predictor], responses: Sequence[Response],
                     factors: Any, settings: SamplerSettings | None = None) -> Posterior:
    """Sample the posterior over the coded box of ``factors``.

    Parameters
    ----------
    surrogates : mapping of str to Predictor
        A surrogate per response (``predict(x) -> (mean, std)`` on coded points).
    responses : sequence of Response
        The lab's means and standard errors.
    factors : FactorSpace, sequence of Factor or mapping
        The factors (columns of the coded points), for names and actual units.
    settings : SamplerSettings, optional
        Walkers, steps, burn-in, thinning and seed.

    Returns
    -------
    Posterior
        With ``warnings`` when the acceptance fraction is below 0.1, a 95 % interval is
        pressed against a bound, or the best point misses a lab value by > 3 standard deviations.

    Raises
    ------
    InputError
        If a response has no surrogate.
    """
    space = as_factor_space(factors)
    responses = check_responses(responses)
    _check_surrogates(surrogates, responses)
    settings = settings or SamplerSettings()
    k = len(space)
    n_walkers = settings.walkers(k)

    def logp(x: np.ndarray) -> np.ndarray:
        return log_posterior(x, surrogates, responses)

    # Half stretch (emcee's default, affine-invariant), half differential evolution, which
    # follows a long thin ridge at an angle to the axes. Not the DE snooker move: on a plain
    # Gaussian it gave half the variance with 12 walkers.
    moves = [(emcee.moves.StretchMove(), 0.5), (emcee.moves.DEMove(), 0.5)]
    sampler = emcee.EnsembleSampler(n_walkers, k, logp, vectorize=True, moves=moves)
    sampler.random_state = np.random.RandomState(settings.seed).get_state()
    with threadpool_limits(limits=1, user_api="blas"):  # small matrices: threads only contend
        sampler.run_mcmc(_start(logp, k, n_walkers, settings.seed), settings.n_steps)
    samples = sampler.get_chain(discard=settings.burn, thin=settings.thin, flat=True)
    log_prob = sampler.get_log_prob(discard=settings.burn, thin=settings.thin, flat=True)
    return _build(space, samples, log_prob, float(np.mean(sampler.acceptance_fraction)),
                  (surrogates, responses))


def _build(space: FactorSpace, samples: np.ndarray, log_prob: np.ndarray, acceptance: float,
           model: tuple[Mapping[str, Predictor], Sequence[Response]]) -> Posterior:
    parameters = _summary(space, samples)
    cov = np.atleast_2d(np.cov(samples, rowvar=False))
    sd = np.sqrt(np.diag(cov))
    corr = cov / np.outer(sd, sd) if np.all(sd > 0) else np.eye(len(sd))
    map_point = samples[int(np.argmax(log_prob))]
    notes = []
    if acceptance < MIN_ACCEPTANCE:
        notes.append(f"the sampler accepted only {acceptance:.0%} of its moves (< "
                     f"{MIN_ACCEPTANCE:.0%}): the posterior is too narrow or jagged for it; "
                     "treat the intervals as rough")
    notes += _edge_warnings(parameters)
    notes += _misfit_warnings(map_point, *model)
    return Posterior(factors=space, parameters=parameters, mean=samples.mean(axis=0),
                     covariance=cov, correlation=corr, samples=samples, log_prob=log_prob,
                     acceptance_fraction=acceptance, map_point=map_point, warnings=tuple(notes))
