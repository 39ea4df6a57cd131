"""The replicates that resolve a surface's largest main effect (demcal.doe.power), checked
against a Monte Carlo of the design at that many replicates: the effect is significant in
about the stated fraction of the experiments."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from demcal import doe
from demcal.doe.power import replicates_to_resolve

SPACE = doe.FactorSpace([doe.Factor("a", 0, 1), doe.Factor("b", 0, 1), doe.Factor("c", 0, 1)])


def _exact_fit(effect: float, sigma: float) -> doe.ResponseSurface:
    """A Box-Behnken fit whose coefficient of ``a`` is exactly ``effect`` and whose residual
    std is exactly ``sigma``: the residual is a vector orthogonal to every model column."""
    d = doe.box_behnken(SPACE, center_points=3, randomize=False)
    clean = doe.fit(d, 40.0 + effect * d.coded[:, 0], model="quadratic")
    X = clean.model_matrix
    e = np.random.default_rng(7).normal(size=d.n_runs)
    e -= X @ np.linalg.lstsq(X, e, rcond=None)[0]
    e *= sigma * np.sqrt(clean.df_resid / (e @ e))
    return doe.fit(d, 40.0 + effect * d.coded[:, 0] + e, model="quadratic")


def _power(model: doe.ResponseSurface, effect: float, sigma: float, reps: int,
           n_sim: int = 3000) -> float:
    """The fraction of simulated experiments (``reps`` replicates of every point, Gaussian
    noise ``sigma``) in which ``a``'s coefficient is significant at 0.05 (numpy's least
    squares: an independent reference for the t test)."""
    X = np.tile(model.model_matrix, (reps, 1))
    n, p = X.shape
    xtx_inv = np.linalg.inv(X.T @ X)
    ia = model.term_names.index("a")
    crit = stats.t.ppf(0.975, n - p)
    rng = np.random.default_rng(11)
    y = effect * X[:, ia] + rng.normal(0.0, sigma, size=(n_sim, n))
    beta = y @ X @ xtx_inv  # (n_sim, p): xtx_inv is symmetric
    resid = y - beta @ X.T
    s2 = (resid ** 2).sum(axis=1) / (n - p)
    t = beta[:, ia] / np.sqrt(s2 * xtx_inv[ia, ia])
    return float(np.mean(np.abs(t) > crit))


@pytest.mark.parametrize(("effect", "sigma"), [(1.3, 3.7), (2.0, 3.0), (0.8, 4.0)])
def test_the_replicates_stated_give_the_power_stated(effect, sigma):
    model = _exact_fit(effect, sigma)
    res = replicates_to_resolve(model)
    assert res is not None and res.term == "a"
    assert res.coefficient == pytest.approx(effect) and res.noise_std == pytest.approx(sigma)
    assert res.replicates_needed is not None and res.replicates_needed > 1
    # at the replicates stated, about 80 % of experiments see the effect; one fewer, less
    at = _power(model, effect, sigma, res.replicates_needed)
    assert 0.76 <= at <= 0.92, at
    assert _power(model, effect, sigma, res.replicates_needed - 1) < at


def test_the_replicates_already_run_count():
    model = _exact_fit(1.3, 3.7)
    one, three = replicates_to_resolve(model, 1), replicates_to_resolve(model, 3)
    assert one is not None and three is not None
    assert three.replicates_needed == pytest.approx(3 * one.replicates_needed, abs=3)


def test_a_large_effect_needs_what_was_run_and_no_effect_has_no_answer():
    big = replicates_to_resolve(_exact_fit(20.0, 1.0))
    assert big is not None and big.replicates_needed == 1
    d = doe.box_behnken(SPACE, center_points=3, randomize=False)
    flat = doe.fit(d, 40.0 + np.random.default_rng(3).normal(size=d.n_runs), model="quadratic")
    res = replicates_to_resolve(flat)
    assert res is not None and res.replicates_needed is not None
    with pytest.raises(ValueError, match="replicates must be >= 1"):
        replicates_to_resolve(flat, 0)
    with pytest.raises(ValueError, match="alpha and power"):
        replicates_to_resolve(flat, power=1.0)
