"""Surrogates and the posterior of the Bayesian strategy against analytic references."""

from __future__ import annotations

import numpy as np
import pytest

from demcal.doe import Factor, FactorSpace
from demcal.doe.bayes import Response, SamplerSettings, fit_surrogate, sample_posterior
from demcal.errors import InputError

# A linear-Gaussian case whose posterior the box does not truncate: y = G x + c with lab
# standard errors SE; the truth sits > 4 posterior standard deviations from every bound.
G = np.array([[2.0, 1.0, 0.0], [0.0, 1.5, -1.0], [1.0, 0.0, 2.0]])
C = np.array([10.0, 20.0, 30.0])
SE = np.array([0.2, 0.15, 0.25])
X0 = np.array([0.2, -0.1, 0.3])
SPACE = FactorSpace([Factor("a", 0, 1), Factor("b", 0, 2, unit="mm"), Factor("c", -1, 1)])


class Linear:
    """An exact 'surrogate': response i of the linear model, no uncertainty."""

    def __init__(self, i: int):
        self.i = i

    def predict(self, x):
        x = np.atleast_2d(x)
        return x @ G[self.i] + C[self.i], np.zeros(len(x))


def _lab() -> list[Response]:
    y = G @ X0 + C
    return [Response(f"r{i}", y[i], SE[i]) for i in range(3)]


def _analytic() -> tuple[np.ndarray, np.ndarray]:
    precision = G.T @ np.diag(SE**-2) @ G
    cov = np.linalg.inv(precision)
    return cov @ G.T @ np.diag(SE**-2) @ (G @ X0), cov


def _check_gaussian(post, mean, cov):
    sd = np.sqrt(np.diag(cov))
    # Monte Carlo error: ~3600 correlated samples, a few hundred effective.
    assert np.all(np.abs(post.mean - mean) < 0.15 * sd), (post.mean, mean)
    assert np.allclose(np.diag(post.covariance) / np.diag(cov), 1.0, atol=0.15)
    corr = cov / np.outer(sd, sd)
    assert np.allclose(post.correlation, corr, atol=0.07)
    assert post.plausible, post.warnings


def test_posterior_matches_the_analytic_gaussian_with_an_exact_model():
    mean, cov = _analytic()
    post = sample_posterior({f"r{i}": Linear(i) for i in range(3)}, _lab(), SPACE,
                            SamplerSettings(seed=3))
    _check_gaussian(post, mean, cov)
    assert 0.2 < post.acceptance_fraction < 0.8
    # Summaries: the 95 % interval of a Gaussian is mean +- 1.96 sd, and actual units follow.
    b = post.parameters[1]
    assert b.ci95_high - b.ci95_low == pytest.approx(2 * 1.96 * np.sqrt(cov[1, 1]), rel=0.12)
    assert b.median_actual == pytest.approx(1.0 + b.median)
    assert set(post.to_dict()["posterior"]["b"]) == {"mean", "median", "ci95_low", "ci95_high"}


def test_posterior_matches_the_analytic_gaussian_through_fitted_surrogates():
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (30, 3))
    surrogates = {f"r{i}": fit_surrogate(f"r{i}", x, x @ G[i] + C[i]) for i in range(3)}
    for i, s in surrogates.items():
        m, sd = s.predict(X0)
        assert m[0] == pytest.approx(Linear(int(i[1])).predict(X0)[0][0], abs=0.01)
        assert sd[0] < 0.01  # a noise-free linear response is learned almost exactly
    mean, cov = _analytic()
    _check_gaussian(sample_posterior(surrogates, _lab(), SPACE, SamplerSettings(seed=4)),
                    mean, cov)


def test_surrogate_learns_the_run_to_run_scatter_and_excludes_it_from_its_std():
    rng = np.random.default_rng(1)
    x = rng.uniform(-1, 1, (60, 2))
    y = 3 * x[:, 0] - x[:, 1] + 0.5 * rng.standard_normal(60)
    s = fit_surrogate("y", x, y, seed=1)
    assert 0.35 < s.noise_std < 0.65
    _, sd = s.predict(np.zeros((1, 2)))
    assert sd[0] < 0.3  # the mean is known better than one run


def test_surrogate_with_replicate_variances_and_fantasies():
    rng = np.random.default_rng(2)
    x = rng.uniform(-1, 1, (20, 2))
    s = fit_surrogate("y", x, np.sin(2 * x[:, 0]) + x[:, 1], noise_var=np.full(20, 1e-4))
    far = np.array([[0.95, -0.95]])
    _, before = s.predict(far)
    fantasy = s.with_fantasy(far)
    m_after, after = fantasy.predict(far)
    assert after[0] < 0.5 * before[0]
    assert m_after[0] == pytest.approx(s.predict(far)[0][0], abs=1e-3)


def test_surrogate_drops_failed_runs_and_rejects_bad_input():
    x = np.linspace(-1, 1, 6).reshape(-1, 1)
    y = np.array([1.0, 2, np.nan, 4, 5, 6])
    assert len(fit_surrogate("y", x, y).y) == 5
    with pytest.raises(InputError, match="3 finite runs"):
        fit_surrogate("y", x[:2], y[:2])
    with pytest.raises(InputError, match="6 settings"):
        fit_surrogate("y", x, y[:4])


def test_a_lab_value_beyond_the_runs_is_said_to_be_out_of_reach():
    class Line:
        def predict(self, x):
            x = np.atleast_2d(x)
            return 10 + 2 * x[:, 0], np.zeros(len(x))

    space = FactorSpace([Factor("mu", 0.1, 0.9)])
    post = sample_posterior({"y": Line()}, [Response("y", 13.0, 0.2)], space,
                            SamplerSettings(n_steps=600, burn=200, seed=1))
    assert not post.plausible
    text = " ".join(post.warnings)
    assert "piles at its high bound" in text
    assert "outside what the runs reach" in text
    # Inside its reach, the same model is fine.
    post = sample_posterior({"y": Line()}, [Response("y", 11.0, 0.2)], space,
                            SamplerSettings(n_steps=600, burn=200, seed=1))
    assert post.plausible, post.warnings


def test_a_response_without_surrogate_and_bad_sampler_settings_are_input_errors():
    with pytest.raises(InputError, match="no surrogate for response"):
        sample_posterior({}, [Response("y", 1.0, 0.1)], SPACE)
    with pytest.raises(InputError, match="burn"):
        SamplerSettings(n_steps=100, burn=100)
    with pytest.raises(InputError, match="standard_error must be > 0"):
        Response("y", 1.0, 0.0)


def test_credibility_is_the_gaussians_highest_density_mass():
    """For a Gaussian posterior the smallest highest-density region through a point holds
    chi2_k(d^2) of the mass, d the point's Mahalanobis distance from the mean."""
    from scipy import stats

    from demcal.doe.bayes import credibility

    mean, cov = _analytic()
    surrogates = {f"r{i}": Linear(i) for i in range(3)}
    post = sample_posterior(surrogates, _lab(), SPACE, SamplerSettings(seed=3))
    chol = np.linalg.cholesky(cov)
    direction = np.array([0.6, -0.48, 0.64])  # a unit vector in whitened coordinates
    masses = np.array([0.3, 0.7, 0.95])
    radii = np.sqrt(stats.chi2.ppf(masses, 3))
    points = mean + (chol @ (radii[:, None] * direction).T).T
    got = credibility(post, surrogates, _lab(), points)
    assert np.allclose(got, masses, atol=0.04), (got, masses)
    assert credibility(post, surrogates, _lab(), [[1.5, 0.0, 0.0]])[0] == 1.0  # off the box
