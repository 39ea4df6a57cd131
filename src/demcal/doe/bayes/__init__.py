"""Bayesian calibration: what the tests identify, and how well (issue 40).

Pure statistics over the coded box [-1, 1]^k (numpy, scipy, scikit-learn, emcee); nothing
here runs a simulation. Typical use::

    from demcal.doe import bayes

    responses = [bayes.Response("aor_deg", 38.2, 0.6), bayes.Response("bulk_density", 412, 3)]
    result = bayes.calibrate_bayes(evaluate, factors, responses,
                                   bayes.BayesSettings(max_runs=90, batch=4, tolerance=0.25))
    result.posterior.to_dict()            # intervals in actual units, correlation
    result.identifiability.reason         # "not identifiable: ... sf up 0.06 = rf down 0.02 ..."

The pieces work on their own: :func:`fit_surrogate` (a Gaussian process per response),
:func:`sample_posterior`, :func:`identify` and :func:`ridge_shrinkage`, :func:`acquire_batch`.
See docs/bayes.md.
"""

from demcal.doe.bayes.acquisition import acquire_batch, surrogate_share
from demcal.doe.bayes.checks import SurrogateCheck, check_surrogate
from demcal.doe.bayes.driver import (
    BayesResult,
    BayesSettings,
    Evaluate,
    Round,
    calibrate_bayes,
    condition_on,
)
from demcal.doe.bayes.identifiability import (
    Candidate,
    Identifiability,
    Ridge,
    RidgesAfter,
    Sensitivity,
    Shrinkage,
    identify,
    ridge_shrinkage,
    ridges_after,
)
from demcal.doe.bayes.posterior import (
    ParameterSummary,
    Posterior,
    SamplerSettings,
    credibility,
    log_posterior,
    sample_posterior,
)
from demcal.doe.bayes.responses import Response
from demcal.doe.bayes.surrogate import Predictor, Surrogate, fit_surrogate

__all__ = [
    "BayesResult",
    "BayesSettings",
    "Candidate",
    "Evaluate",
    "Identifiability",
    "ParameterSummary",
    "Posterior",
    "Predictor",
    "Response",
    "Ridge",
    "RidgesAfter",
    "Round",
    "SamplerSettings",
    "Sensitivity",
    "Shrinkage",
    "Surrogate",
    "SurrogateCheck",
    "acquire_batch",
    "calibrate_bayes",
    "check_surrogate",
    "condition_on",
    "credibility",
    "fit_surrogate",
    "identify",
    "log_posterior",
    "ridge_shrinkage",
    "ridges_after",
    "sample_posterior",
    "surrogate_share",
]
