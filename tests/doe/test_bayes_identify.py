"""The identifiability verdict: a ridge named in parameters, and what would shrink it."""

from __future__ import annotations

import re

import numpy as np
import pytest
from bayes_engine import FACTORS, A, B, engine, lab

from demcal.doe import Factor, FactorSpace
from demcal.doe.bayes import (
    BayesSettings,
    Candidate,
    SamplerSettings,
    Sensitivity,
    calibrate_bayes,
    fit_surrogate,
    identify,
    ridge_shrinkage,
    ridges_after,
    sample_posterior,
)
from demcal.doe.bayes.identifiability import _chord
from demcal.errors import InputError


@pytest.fixture(scope="module")
def angle_alone():
    """The engine's angle alone, over the 27-run space-filling start (one round)."""
    return calibrate_bayes(engine(("aor",), seed=2), FACTORS, lab(("aor",)),
                           BayesSettings(max_runs=27, tolerance=0.25, seed=2))


def _friction_ridge(verdict):
    for r in verdict.ridges:
        if {"static_friction", "rolling_friction"} <= set(r.parameters):
            return r
    raise AssertionError(f"no ridge names both frictions: {verdict.reason}")


def test_one_response_leaves_a_ridge_named_with_the_analytic_trade_off(angle_alone):
    verdict = angle_alone.identifiability
    assert verdict.identifiable is False
    assert verdict.reason.startswith("not identifiable")
    ridge = _friction_ridge(verdict)
    v = dict(zip(FACTORS.names, ridge.direction, strict=True))
    # aor = 30 + A x1 + B x2 + ...: constant along dx2/dx1 = -A/B (coded units).
    slope = v["rolling_friction"] / v["static_friction"]
    assert slope == pytest.approx(-A / B, rel=0.2)
    assert ridge.fraction > 0.5
    # In words and actual units: rolling friction moves by 0.02 (a tenth of its 0.2 range) and
    # static friction the other way by B/A * 0.2 coded * 0.3 half-range = 0.03.
    assert re.fullmatch(r"rolling_friction up 0\.02 = static_friction down 0\.0(2[5-9]|3[0-5]?)",
                        ridge.text), ridge.text
    steps = dict(zip(FACTORS.names, ridge.steps, strict=True))
    assert steps["rolling_friction"] == pytest.approx(0.02)
    assert steps["static_friction"] == pytest.approx(-B / A * 0.2 * 0.3, rel=0.2)
    assert ridge.text in verdict.reason
    # Restitution barely moves the angle: free on its own.
    assert any(r.parameters == ("restitution",) for r in verdict.ridges)


def test_the_density_test_is_reported_to_shrink_the_ridge_and_an_unrelated_one_not(angle_alone):
    res = angle_alone
    density = fit_surrogate("density", res.x, engine(("density",), seed=3)(res.x)["density"])
    # A test that sees restitution only: it cannot cut the friction ridge.
    x3_only = fit_surrogate("x3_only", res.x, 5 + 4 * res.x[:, 2])
    ridge = _friction_ridge(res.identifiability)
    out = ridge_shrinkage(res.posterior, [Candidate("density", density, 0.15),
                                          Candidate("x3_only", x3_only, 0.15)], [ridge])
    by_name = {s.response: s for s in out}
    assert by_name["density"].shrinkage > 0.6, by_name["density"]
    assert abs(by_name["x3_only"].shrinkage) < 0.2, by_name["x3_only"]
    assert by_name["density"].ridge == ridge.text
    assert by_name["density"].effective_samples > 30


def test_what_the_tests_would_leave_with_one_or_two_more(angle_alone):
    """The angle alone leaves two ridges; the density test alone pins rolling friction (one
    ridge left), density and drum together pin all three factors, as the three-response
    calibration below does; a test that sees only restitution leaves the friction ridge."""
    res = angle_alone
    assert len(res.identifiability.ridges) == 2
    density = Candidate("density", fit_surrogate(
        "density", res.x, engine(("density",), seed=3)(res.x)["density"]), 0.15)
    drum = Candidate("drum", fit_surrogate(
        "drum", res.x, engine(("drum",), seed=5)(res.x)["drum"]), 0.15)
    one = ridges_after(res.posterior, [density])
    both = ridges_after(res.posterior, [density, drum])
    assert one.responses == ("density",) and both.responses == ("density", "drum")
    assert len(one.ridges) == 1, one
    assert both.ridges == (), both
    # nothing added: the verdict's own ridges, by the Gaussian extent
    assert len(ridges_after(res.posterior, []).ridges) == 2
    x3_only = Candidate("x3_only", Sensitivity((0.0, 0.0, 4.0)), 0.15)
    left = ridges_after(res.posterior, [x3_only])
    assert any({"static_friction", "rolling_friction"} <= set(r.parameters)
               for r in left.ridges), left


def test_three_responses_are_identifiable(angle_alone):
    names = ("aor", "density", "drum")
    res = calibrate_bayes(engine(names, seed=4), FACTORS, lab(names),
                          BayesSettings(max_runs=27, tolerance=0.25, seed=4))
    assert res.identifiability.identifiable, res.identifiability.reason
    assert res.identifiability.reason.startswith("identifiable")
    assert res.identifiability.ridges == ()


def test_a_tight_gaussian_is_identifiable_and_a_flat_one_is_not():
    space = FactorSpace([Factor("p", 0, 1), Factor("q", 0, 1)])

    class Exact:
        def __init__(self, g):
            self.g = np.asarray(g, dtype=float)

        def predict(self, x):
            x = np.atleast_2d(x)
            return x @ self.g, np.zeros(len(x))

    from demcal.doe.bayes import Response

    settings = SamplerSettings(n_steps=800, burn=200, seed=1)
    tight = sample_posterior({"u": Exact([1, 0]), "v": Exact([0, 1])},
                             [Response("u", 0.1, 0.05), Response("v", -0.2, 0.05)], space,
                             settings)
    assert identify(tight).identifiable
    # p - q = 0 only: the diagonal p = q is a ridge, "p up 0.1 = q up 0.1".
    diag = sample_posterior({"u": Exact([1, -1])}, [Response("u", 0.0, 0.05)], space, settings)
    verdict = identify(diag)
    assert not verdict.identifiable
    assert verdict.ridges[0].text == "p up 0.1 = q up 0.1"
    assert verdict.ridges[0].chord == pytest.approx(2 * np.sqrt(2), rel=0.05)


def test_chord_of_the_box():
    assert _chord(np.zeros(2), np.array([1.0, 0.0])) == pytest.approx(2.0)
    assert _chord(np.array([0.5, 0.0]), np.array([1.0, 1.0]) / np.sqrt(2)) == pytest.approx(
        1.5 * np.sqrt(2))


def test_candidate_needs_a_positive_standard_error():
    with pytest.raises(InputError, match="standard_error must be > 0"):
        Candidate("d", None, 0.0)


def test_known_slopes_alone_estimate_the_shrinkage(angle_alone):
    # No runs of the new test, only how it moves: 4 per coded unit of rolling friction cuts
    # the friction ridge; the same slope in restitution does not.
    ridge = _friction_ridge(angle_alone.identifiability)
    out = ridge_shrinkage(angle_alone.posterior,
                          [Candidate("drum", Sensitivity((0.0, 4.0, 0.0)), 0.15),
                           Candidate("other", Sensitivity((0.0, 0.0, 4.0)), 0.15)], [ridge])
    assert out[0].shrinkage > 0.6
    assert abs(out[1].shrinkage) < 0.2
    with pytest.raises(InputError, match="2 slopes for 3 factors"):
        Sensitivity((1.0, 2.0)).predict(np.zeros((1, 3)))


def test_a_stuck_sampler_is_said():
    from demcal.doe.bayes.posterior import _build

    class Flat:
        def predict(self, x):
            return np.zeros(len(np.atleast_2d(x))), np.ones(len(np.atleast_2d(x)))

    from demcal.doe.bayes import Response

    space = FactorSpace([Factor("p", 0, 1)])
    samples = np.random.default_rng(0).uniform(-0.5, 0.5, (200, 1))
    post = _build(space, samples, np.zeros(200), 0.05, ({"y": Flat()}, [Response("y", 0, 1)]))
    assert not post.plausible
    assert "accepted only 5% of its moves" in post.warnings[0]
