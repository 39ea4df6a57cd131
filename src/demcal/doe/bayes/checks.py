"""Does a surrogate follow its own runs? Each run predicted from the others (leave-one-out).

The posterior is as honest as its surrogates: a run the others do not predict (a local
feature of the response a smooth kernel averages away, or an outlier run) means the
surrogate, and so the posterior, is surer near it than the runs allow. Each run left out and
predicted by the rest, its error standardised by the predicted spread of one run, gives a z
that is standard normal for a surrogate that is right about its error. Design-Expert judges
its residuals the same way (externally studentized residuals against Bonferroni limits): a
run beyond the limit ``z_(alpha / 2n)`` is one that n runs would show by chance less than
once in 1 / alpha studies.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import norm

from demcal.doe.bayes.surrogate import Surrogate

__all__ = ["ALPHA", "MIN_RUNS", "SurrogateCheck", "check_surrogate"]

#: Family-wise level of the Bonferroni limit (Design-Expert's, for its outlier-t plot).
ALPHA = 0.05
#: Fewer runs than this say too little about the surrogate's error to judge it.
MIN_RUNS = 10


@dataclass(frozen=True)
class SurrogateCheck:
    """One surrogate's leave-one-out check.

    Attributes
    ----------
    response : str
        The response's name.
    n : int
        Runs it was fitted on.
    rms_z : float
        Root mean square of the standardised leave-one-out errors (about 1 when the
        surrogate is right about its error; a maximum-likelihood fit stays near 1 even where
        it misses locally, so the largest z is the test).
    max_abs_z : float
        The largest of them.
    worst : int
        Index of that run in the surrogate's runs (``x``, ``y``).
    predicted : float
        What the other runs predict there, the response's unit.
    limit : float
        The Bonferroni limit for ``n`` runs at :data:`ALPHA`, ``z_(ALPHA / 2n)``.
    rms_error : float
        Root mean square of the leave-one-out errors, in the response's unit.
    """

    response: str
    n: int
    rms_z: float
    max_abs_z: float
    worst: int
    predicted: float
    limit: float
    rms_error: float

    @property
    def judged(self) -> bool:
        """Enough runs to judge the surrogate (:data:`MIN_RUNS`)."""
        return self.n >= MIN_RUNS

    @property
    def misses_a_run(self) -> bool:
        """Judged, and a run lies beyond the Bonferroni limit."""
        return self.judged and self.max_abs_z > self.limit


def check_surrogate(surrogate: Surrogate) -> SurrogateCheck:
    """Leave-one-out check of a fitted surrogate (:meth:`Surrogate.leave_one_out`).

    Parameters
    ----------
    surrogate : Surrogate

    Returns
    -------
    SurrogateCheck
    """
    mean, std = surrogate.leave_one_out()
    err = surrogate.y - mean
    z = np.abs(err) / np.maximum(std, 1e-300)
    n, worst = len(err), int(np.argmax(z))
    return SurrogateCheck(response=surrogate.name, n=n, rms_z=float(math.sqrt(np.mean(z**2))),
                          max_abs_z=float(z[worst]), worst=worst, predicted=float(mean[worst]),
                          limit=float(norm.isf(ALPHA / (2 * n))),
                          rms_error=float(math.sqrt(np.mean(err**2))))
