"""Where to run next: points that shrink the posterior most.

The posterior is wide for two reasons: the lab's standard error (no run helps) and the
surrogate's uncertainty ``s_r(x)`` where the posterior lives (runs there help). At a coded point
the share of the likelihood's variance that is the surrogate's,

    u(x) = sum_r s_r(x)² / (se_r² + s_r(x)²),

says how much a run there would sharpen the posterior. Candidates are posterior samples and the
score is ``u(x) * sqrt(p(x) / p_max)``, weighted by the posterior density ``p`` so that it
targets the lab's values (not a minimum of anything); the square root keeps the weight from
collapsing every pick onto the mode (the tails of a ridge need runs too).

A batch is chosen greedily with the *kriging believer*: after each pick the surrogates take
their own prediction there as an observation (hyperparameters kept), which collapses their
variance around it, so the next pick goes elsewhere.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from threadpoolctl import threadpool_limits

from demcal.doe.bayes.posterior import Posterior
from demcal.doe.bayes.responses import Response
from demcal.doe.bayes.surrogate import Surrogate
from demcal.errors import InputError

__all__ = ["acquire_batch", "surrogate_share"]

#: Candidates drawn from the posterior samples (more: slower, hardly better).
N_CANDIDATES = 1000


def surrogate_share(x: np.ndarray, surrogates: Mapping[str, Surrogate],
                    responses: Sequence[Response]) -> np.ndarray:
    """``u(x)``: the surrogates' share of the likelihood variance, summed over responses.

    Parameters
    ----------
    x : (n, k) ndarray
        Coded points.
    surrogates : mapping of str to Surrogate
    responses : sequence of Response

    Returns
    -------
    (n,) ndarray in [0, number of responses]
    """
    total = np.zeros(len(x))
    for r in responses:
        _, s = surrogates[r.name].predict(x)
        total += s**2 / (r.standard_error**2 + s**2)
    return total


def acquire_batch(surrogates: Mapping[str, Surrogate], responses: Sequence[Response],
                  posterior: Posterior, batch: int, seed: int = 0) -> np.ndarray:
    """Choose ``batch`` coded points that shrink the posterior most.

    Parameters
    ----------
    surrogates : mapping of str to Surrogate
        Fitted on every run so far.
    responses : sequence of Response
        The lab's values.
    posterior : Posterior
        The current posterior (its samples are the candidates).
    batch : int
        Points to choose, >= 1.
    seed : int, optional
        Seed of the candidates' subsample.

    Returns
    -------
    (batch, k) ndarray of float64
        Coded settings, distinct, inside the box (fewer only if the posterior has fewer
        distinct samples).

    Raises
    ------
    InputError
        If ``batch`` < 1.
    """
    if not (isinstance(batch, int | np.integer) and batch >= 1):
        raise InputError(f"batch must be an integer >= 1; got {batch!r}")
    rng = np.random.default_rng(seed)
    _, keep = np.unique(posterior.samples, axis=0, return_index=True)
    if len(keep) > N_CANDIDATES:
        keep = rng.choice(keep, N_CANDIDATES, replace=False)
    cand = posterior.samples[keep]
    # Density weight from the sampler's own log posterior (no new surrogate calls); a
    # fantasy does not move the surrogates' means, so the weight stays valid within a batch.
    weight = np.exp(0.5 * (posterior.log_prob[keep] - np.max(posterior.log_prob[keep])))
    current = dict(surrogates)
    chosen: list[np.ndarray] = []
    with threadpool_limits(limits=1, user_api="blas"):  # small matrices: threads only contend
        for _ in range(min(batch, len(cand))):
            best = int(np.argmax(weight * surrogate_share(cand, current, responses)))
            chosen.append(cand[best])
            weight[best] = 0.0  # never the same point twice
            current = {n: s.with_fantasy(chosen[-1]) for n, s in current.items()}
    return np.array(chosen)
