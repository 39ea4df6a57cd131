"""How many replicates a response-surface design needs to tell its main effects from the noise.

A surface that is not significant says only that the effects were not seen; this module says
how far from seen they were. The largest main effect's t value scales with the square root of
the replicates of every design point (the coefficient stays, its standard error shrinks), so
the replicates ``r`` that resolve an effect of the size estimated at ``r0`` replicates, in a
two-sided test at level ``alpha`` with power ``power``, are about

    r = r0 * ((z(1 - alpha/2) + z(power)) / |t|)^2

(normal quantiles: the residual degrees of freedom grow with the replicates; Montgomery,
*Design and Analysis of Experiments*, the sample size of a two-sided test).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from scipy import stats

from demcal.doe.model import ResponseSurface

__all__ = ["EffectResolution", "replicates_to_resolve"]


@dataclass(frozen=True)
class EffectResolution:
    """The largest main effect of a fitted surface and the replicates that would resolve it.

    Attributes
    ----------
    term : str
        The factor whose main (linear) effect is largest in ``|t|``.
    coefficient : float
        Its coefficient in coded units: the response's change from the centre to the high
        level, the response's unit (the angle: deg).
    t : float
        The coefficient over its standard error.
    noise_std : float
        The fit's residual standard deviation, the response's unit.
    replicates : int
        The replicates of every design point the surface was fitted with.
    replicates_needed : int or None
        The replicates of every design point at which an effect of that size is significant
        at ``alpha`` with probability ``power``; None where the coefficient is exactly zero
        (no number of replicates resolves it).
    alpha, power : float
        The test's level and power.
    """

    term: str
    coefficient: float
    t: float
    noise_std: float
    replicates: int
    replicates_needed: int | None
    alpha: float = 0.05
    power: float = 0.8


def replicates_to_resolve(model: ResponseSurface, replicates: int = 1, *, alpha: float = 0.05,
                          power: float = 0.8) -> EffectResolution | None:
    """The largest main effect of ``model`` and the replicates that resolve an effect its size.

    Parameters
    ----------
    model : ResponseSurface
        A surface fitted to every replicate row (or to one row per design point).
    replicates : int
        The replicates of every design point in that fit (>= 1).
    alpha : float
        The two-sided test's level, in (0, 1).
    power : float
        The probability of finding the effect significant, in (0, 1).

    Returns
    -------
    EffectResolution or None
        None where the model has no main effect or no residual degrees of freedom.

    Examples
    --------
    >>> import numpy as np
    >>> from demcal import doe
    >>> space = doe.FactorSpace([doe.Factor("a", 0, 1), doe.Factor("b", 0, 1)])
    >>> d = doe.factorial(space, center_points=4)
    >>> y = 1.0 * d.coded[:, 0] + np.array([0.5, -0.5, -0.5, 0.5, 1, -1, 1, -1])
    >>> res = replicates_to_resolve(doe.fit(d, y, model="linear"))
    >>> res.term, round(res.t, 2), res.replicates_needed
    ('a', 2.0, 2)
    """
    if replicates < 1:
        raise ValueError(f"replicates must be >= 1; got {replicates}")
    if not (0 < alpha < 1 and 0 < power < 1):
        raise ValueError(f"alpha and power must lie in (0, 1); got {alpha}, {power}")
    mains = [n for n in model.names if n in model.term_names]
    if not mains or model.df_resid < 1 or not math.isfinite(model.std_dev):
        return None
    tvalues = model.tvalues
    term = max(mains, key=lambda n: abs(float(tvalues[n])))
    t = float(tvalues[term])
    if not math.isfinite(t):  # an exact fit: no noise to resolve against
        return None
    z = float(stats.norm.ppf(1 - alpha / 2) + stats.norm.ppf(power))
    needed = None if t == 0 else max(1, math.ceil(replicates * (z / abs(t)) ** 2))
    return EffectResolution(term=term, coefficient=float(model.coefficients_coded[term]), t=t,
                            noise_std=float(model.std_dev), replicates=replicates,
                            replicates_needed=needed, alpha=alpha, power=power)
