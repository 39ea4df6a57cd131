"""Which parameters the tests pin down: ridges of the posterior, and what would remove them.

The posterior's covariance (coded units) has principal axes. Along each axis the 95 % credible
region has an extent (the central 95 % of the samples projected on the axis); the box has a
length too (the chord through the posterior mean along the axis). An axis along which the
region spans more than half the box is a *ridge*: the tests leave a direction in which the
parameters trade against each other (or one parameter alone is free). The verdict names it in
the factors' units: "static friction up 0.1 = rolling friction down 0.03".

Which response would remove it: for a response the study could add, with a surrogate fitted
on the runs already made and the test's standard error, draw a plausible truth from the
posterior, take the surrogate's value there as that test's lab value, and reweight the
posterior samples by its likelihood (importance sampling, no new runs and no new sampling).
The ridge's extent after, over before, averaged over a few such truths, is the expected
shrinkage.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from demcal.doe.bayes.posterior import Posterior
from demcal.doe.bayes.surrogate import Predictor
from demcal.errors import InputError

__all__ = [
    "Candidate",
    "Identifiability",
    "Ridge",
    "RidgesAfter",
    "Sensitivity",
    "Shrinkage",
    "identify",
    "ridge_shrinkage",
    "ridges_after",
]

#: A ridge spans more than this fraction of the box along its axis (the issue's definition).
RIDGE_FRACTION = 0.5
#: Factors whose share of a ridge's direction is below this fraction of the largest are not
#: named in the verdict (they hardly move along it).
NAMED_SHARE = 0.25
#: The verdict's step: the leading factor moves by this fraction of its range.
STEP_FRACTION = 0.1


@dataclass(frozen=True)
class Ridge:
    """A principal axis of the posterior and its extent.

    Attributes
    ----------
    direction : tuple of float
        Unit vector in coded units, one component per factor; signed so that the largest
        component is positive.
    steps : tuple of float
        The move along it in the factors' units when the leading factor moves by a tenth of
        its range (the numbers in ``text``).
    extent : float
        Length of the central 95 % of the samples along ``direction``, coded units.
    chord : float
        Length of the box along ``direction`` through the posterior mean, coded units.
    parameters : tuple of str
        Factors that move along it (component >= a quarter of the largest), leading first.
    text : str
        The direction in words.
    """

    direction: tuple[float, ...]
    steps: tuple[float, ...]
    extent: float
    chord: float
    parameters: tuple[str, ...]
    text: str

    @property
    def fraction(self) -> float:
        """``extent / chord``: the share of the box the 95 % region spans along the axis."""
        return self.extent / self.chord

    @property
    def is_ridge(self) -> bool:
        """True when the region spans more than half the box along the axis."""
        return self.fraction > RIDGE_FRACTION


@dataclass(frozen=True)
class Identifiability:
    """The verdict.

    Attributes
    ----------
    identifiable : bool
        False when the posterior has a ridge.
    reason : str
        One sentence.
    ridges : tuple of Ridge
        The ridges, widest first (empty when identifiable).
    axes : tuple of Ridge
        Every principal axis, widest first.
    """

    identifiable: bool
    reason: str
    ridges: tuple[Ridge, ...]
    axes: tuple[Ridge, ...]


def _chord(point: np.ndarray, direction: np.ndarray) -> float:
    """Length of the line through ``point`` along ``direction`` inside [-1, 1]^k."""
    moving = np.abs(direction) > 1e-12
    a = (-1.0 - point[moving]) / direction[moving]
    b = (1.0 - point[moving]) / direction[moving]
    return float(np.min(np.maximum(a, b)) - np.max(np.minimum(a, b)))


def _extent(proj: np.ndarray, weights: np.ndarray | None = None) -> float:
    """Width of the central 95 % of (weighted) projections."""
    if weights is None:
        lo, hi = np.quantile(proj, [0.025, 0.975])
        return float(hi - lo)
    order = np.argsort(proj)
    cum = np.cumsum(weights[order])
    cum /= cum[-1]
    lo, hi = np.interp([0.025, 0.975], cum, proj[order])
    return float(hi - lo)


def _words(posterior: Posterior,
           direction: np.ndarray) -> tuple[tuple[float, ...], tuple[str, ...], str]:
    """Steps in actual units, the factors named, and the sentence."""
    factors = posterior.factors
    lead = int(np.argmax(np.abs(direction)))
    # Move the leading factor by a tenth of its range (0.2 coded), the others in proportion.
    steps = (2 * STEP_FRACTION / direction[lead]) * direction * factors.half_range
    order = np.argsort(-np.abs(direction))
    named = [i for i in order if abs(direction[i]) >= NAMED_SHARE * abs(direction[lead])]

    def phrase(i: int) -> str:
        unit = f" {factors[i].unit}" if factors[i].unit else ""
        return f"{factors[i].name} {'up' if steps[i] > 0 else 'down'} {abs(steps[i]):.2g}{unit}"

    if len(named) == 1:
        text = f"{factors[lead].name} alone"
    else:
        text = f"{phrase(named[0])} = " + " and ".join(phrase(i) for i in named[1:])
    return tuple(map(float, steps)), tuple(factors[i].name for i in named), text


def _axis(posterior: Posterior, v: np.ndarray, extent: Callable[[np.ndarray], float]
          ) -> Ridge:
    """The principal axis ``v`` (signed so its largest component is positive), its 95 %
    extent as ``extent(v)`` measures it, its chord through the posterior mean, in words."""
    v = v * np.sign(v[int(np.argmax(np.abs(v)))])
    steps, names, text = _words(posterior, v)
    return Ridge(direction=tuple(map(float, v)), steps=steps, extent=extent(v),
                 chord=_chord(posterior.mean, v), parameters=names, text=text)


def _axes(posterior: Posterior) -> list[Ridge]:
    vals, vecs = np.linalg.eigh(posterior.covariance)
    centred = posterior.samples - posterior.mean
    out = [_axis(posterior, vecs[:, i], lambda v: _extent(centred @ v))
           for i in np.argsort(vals)[::-1]]
    return sorted(out, key=lambda r: -r.fraction)


def identify(posterior: Posterior) -> Identifiability:
    """Whether the tests identify every parameter, and if not, along which ridge they trade.

    Parameters
    ----------
    posterior : Posterior
        Samples over the coded box.

    Returns
    -------
    Identifiability
        ``identifiable`` is False when along some principal axis of the posterior covariance
        the 95 % credible region spans more than half the box; ``reason`` names each such
        ridge in the factors' units.
    """
    axes = _axes(posterior)
    ridges = tuple(a for a in axes if a.is_ridge)
    if not ridges:
        reason = ("identifiable: along every principal axis the 95 % credible region spans at "
                  f"most half the box (widest {axes[0].fraction:.0%}, along {axes[0].text})")
        return Identifiability(True, reason, (), tuple(axes))
    parts = [f"{r.text} (the 95 % region spans {r.fraction:.0%} of the box along it)"
             for r in ridges]
    noun = "a ridge" if len(ridges) == 1 else f"{len(ridges)} ridges"
    reason = f"not identifiable: the tests leave {noun}: " + "; ".join(parts)
    return Identifiability(False, reason, ridges, tuple(axes))


@dataclass(frozen=True)
class Candidate:
    """A response the study could add.

    Parameters
    ----------
    name : str
        The response's name.
    surrogate : Predictor
        Its surrogate over the coded box (fitted on the runs made so far), or a
        :class:`Sensitivity` when only its slopes are known.
    standard_error : float
        Expected standard error of its lab mean, in its unit, > 0.
    """

    name: str
    surrogate: Predictor
    standard_error: float

    def __post_init__(self) -> None:
        if not float(self.standard_error) > 0:
            raise InputError(f"candidate {self.name}: standard_error must be > 0")


@dataclass(frozen=True)
class Sensitivity:
    """A response known only by how it moves with each factor: a linear Predictor.

    For a test the study has no runs of yet ("the drum responds to rolling friction"), the
    expected shrinkage of a ridge needs only the response's slopes: what a run would show.

    Parameters
    ----------
    gradient : tuple of float
        Change of the response per coded unit of each factor (half the factor's range), in
        the response's unit, in the factors' order.
    """

    gradient: tuple[float, ...]

    def predict(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``x @ gradient`` (the intercept does not matter here) and zero uncertainty."""
        pts = np.atleast_2d(np.asarray(x, dtype=float))
        if pts.shape[1] != len(self.gradient):
            raise InputError(f"sensitivity has {len(self.gradient)} slopes for "
                             f"{pts.shape[1]} factors")
        return pts @ np.asarray(self.gradient, dtype=float), np.zeros(len(pts))


@dataclass(frozen=True)
class Shrinkage:
    """Expected effect of one candidate response on one ridge.

    Attributes
    ----------
    response : str
        The candidate.
    ridge : str
        The ridge's text.
    extent_before, extent_after : float
        95 % extent along the ridge, coded units (after: mean over the plausible truths).
    effective_samples : float
        Smallest effective sample size of the reweighted samples (few: a rough estimate).
    """

    response: str
    ridge: str
    extent_before: float
    extent_after: float
    effective_samples: float

    @property
    def shrinkage(self) -> float:
        """``1 - extent_after / extent_before``: 0 no help, 1 the ridge is gone."""
        return 1.0 - self.extent_after / self.extent_before


def _reweighted(ridge: Ridge, samples: np.ndarray, pred: tuple[np.ndarray, np.ndarray],
                se: float, truths: np.ndarray) -> tuple[float, float]:
    """Mean 95 % extent along ``ridge`` and least ESS, over hypothetical lab values."""
    mean, std = pred
    var = se**2 + std**2
    proj = samples @ np.asarray(ridge.direction)
    extents, ess = [], []
    for t in truths:
        logw = -0.5 * ((mean - mean[t]) ** 2 / var + np.log(var))
        w = np.exp(logw - logw.max())
        extents.append(_extent(proj, w))
        ess.append(w.sum() ** 2 / np.sum(w**2))
    return float(np.mean(extents)), float(np.min(ess))


def ridge_shrinkage(posterior: Posterior, candidates: Sequence[Candidate],
                    ridges: Sequence[Ridge] | None = None, *, n_truths: int = 8,
                    seed: int = 0) -> tuple[Shrinkage, ...]:
    """Expected shrinkage of each ridge if the study added each candidate response.

    Parameters
    ----------
    posterior : Posterior
        The current posterior.
    candidates : sequence of Candidate
        Responses the study could add, with their surrogates and standard errors.
    ridges : sequence of Ridge, optional
        Default: the ridges of :func:`identify`, or its widest axis when there is none.
    n_truths : int, optional
        Plausible truths (posterior samples) averaged over.
    seed : int, optional
        Seed of the choice of truths and samples.

    Returns
    -------
    tuple of Shrinkage
        One per (ridge, candidate), ridges in order, candidates in order.
    """
    if ridges is None:
        verdict = identify(posterior)
        ridges = verdict.ridges or verdict.axes[:1]
    rng = np.random.default_rng(seed)
    pick = rng.choice(len(posterior.samples), min(4000, len(posterior.samples)), replace=False)
    samples = posterior.samples[pick]
    truths = rng.choice(len(samples), n_truths, replace=False)
    out = []
    for c in candidates:
        m, s = c.surrogate.predict(samples)
        pred = (np.asarray(m, dtype=float), np.asarray(s, dtype=float))
        for r in ridges:
            before = _extent((samples - posterior.mean) @ np.asarray(r.direction))
            after, ess = _reweighted(r, samples, pred, float(c.standard_error), truths)
            out.append(Shrinkage(c.name, r.text, before, after, ess))
    return tuple(out)


@dataclass(frozen=True)
class RidgesAfter:
    """The ridges the posterior would keep if the study added some responses together.

    Attributes
    ----------
    responses : tuple of str
        The candidates added.
    ridges : tuple of Ridge
        The ridges left, widest share of the box first (empty: every parameter pinned).
    """

    responses: tuple[str, ...]
    ridges: tuple[Ridge, ...]


#: two-sided 95 % of a normal distribution: a Gaussian's 95 % extent is 2 * Z95 * sd
Z95 = 1.959963984540054


def _gradient(candidate: Candidate, samples: np.ndarray) -> tuple[np.ndarray, float]:
    """The candidate's slopes over the posterior (least squares of its mean prediction on
    the coded samples: exact for known slopes, a local linear model of a surrogate) and its
    variance at the lab (standard error squared plus the surrogate's mean variance)."""
    m, sd = candidate.surrogate.predict(samples)
    design = np.column_stack([np.ones(len(samples)), samples])
    coef = np.linalg.lstsq(design, np.asarray(m, dtype=float), rcond=None)[0]
    var = float(candidate.standard_error) ** 2 + float(np.mean(np.asarray(sd, float) ** 2))
    return coef[1:], var


def ridges_after(posterior: Posterior, candidates: Sequence[Candidate]) -> RidgesAfter:
    """What the tests would leave if the study added every one of ``candidates`` together.

    :func:`ridge_shrinkage` asks how much one response narrows one ridge; with more factors
    than responses a new response can pin a combination that no single ridge lies along
    (three factors, the angle alone: two ridges; one more test: one ridge left, along a new
    combination). Here the posterior's covariance is updated as a linear-Gaussian model
    would be by each candidate's measurement (slopes ``g`` over the posterior, variance
    ``r``: ``C' = C - C G^T (G C G^T + R)^-1 G C``, the Kalman update), and the verdict of
    :func:`identify` is taken on ``C'``: a principal axis whose Gaussian 95 % extent
    (``2 * 1.96 * sd``) spans more than half the box along it is a ridge left.

    A linear-Gaussian update needs no reweighted samples, so a strong new constraint is not
    lost to a handful of effective samples; it reads a curved ridge by its chord and a flat
    posterior's extent about 13 % wider than its samples' (a uniform's 95 % range is 1.65 sd,
    not 1.96).

    Parameters
    ----------
    posterior : Posterior
        The current posterior.
    candidates : sequence of Candidate
        The responses added together, with their surrogates and standard errors.

    Returns
    -------
    RidgesAfter
    """
    cov = np.atleast_2d(posterior.covariance)
    if candidates:
        grads, variances = zip(*(_gradient(c, posterior.samples) for c in candidates),
                               strict=True)
        g = np.array(grads)
        gain = cov @ g.T @ np.linalg.inv(g @ cov @ g.T + np.diag(variances))
        cov = cov - gain @ g @ cov
    sym = 0.5 * (cov + cov.T)
    _, vecs = np.linalg.eigh(sym)

    def gaussian(v: np.ndarray) -> float:  # 2 * 1.96 sd along v
        return 2 * Z95 * float(np.sqrt(max(float(v @ sym @ v), 0.0)))

    axes = [_axis(posterior, v, gaussian) for v in vecs.T]
    return RidgesAfter(tuple(c.name for c in candidates),
                       tuple(sorted((a for a in axes if a.is_ridge), key=lambda r: -r.fraction)))
