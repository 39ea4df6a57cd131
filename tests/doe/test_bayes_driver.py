"""The Bayesian calibration loop: recovery of planted parameters, acquisition, bad settings."""

from __future__ import annotations

import json

import numpy as np
import pytest
from bayes_engine import FACTORS, TRUTH, engine, lab, nonlinear_engine, nonlinear_response

from demcal.doe import Factor, latin_hypercube
from demcal.doe.bayes import (
    BayesSettings,
    Response,
    SamplerSettings,
    acquire_batch,
    calibrate_bayes,
    condition_on,
    fit_surrogate,
    log_posterior,
    sample_posterior,
)
from demcal.errors import InputError

NAMES = ("aor", "density", "drum")


@pytest.mark.parametrize("seed", [1, 5])
def test_three_responses_recover_the_planted_parameters_within_90_runs(seed):
    evaluate = engine(NAMES, seed=seed)
    res = calibrate_bayes(evaluate, FACTORS, lab(NAMES),
                          BayesSettings(max_runs=90, batch=6, tolerance=0.25, seed=seed))
    assert res.n_runs == evaluate.runs <= 90
    assert res.stopped == "tolerance"
    for p, truth in zip(res.posterior.parameters, TRUTH, strict=True):
        assert p.ci95_low <= truth <= p.ci95_high, p
        assert p.ci95_high - p.ci95_low <= 0.5  # a quarter of the coded range [-1, 1]
    assert res.posterior.plausible, res.posterior.warnings
    assert np.all(np.abs(res.best_point - TRUTH) < 0.2)
    assert set(res.best_point_actual) == set(FACTORS.names)
    assert res.identifiability.identifiable


def test_rounds_acquire_batches_near_the_posterior_until_the_budget_ends():
    # A start of 8 runs and a tolerance tighter than the lab allows: the loop must acquire
    # batch after batch and stop on the budget, its new runs where the lab values are.
    evaluate = engine(NAMES, seed=3)
    res = calibrate_bayes(evaluate, FACTORS, lab(NAMES),
                          BayesSettings(max_runs=18, batch=4, tolerance=0.01, seed=3, n_start=8,
                                        sampler=SamplerSettings(n_steps=1000, burn=300)))
    assert res.stopped == "budget"
    assert [r.n_runs for r in res.history] == [8, 12, 16, 18]
    assert res.n_runs == evaluate.runs == 18
    start, new = res.x[:8], res.x[8:]
    dist = lambda pts: np.linalg.norm(pts - TRUTH, axis=1)  # noqa: E731
    assert np.median(dist(new)) < 0.5 * np.median(dist(start))
    for p, truth in zip(res.posterior.parameters, TRUTH, strict=True):
        assert p.ci95_low <= truth <= p.ci95_high, p


def test_a_batch_is_distinct_inside_the_box_and_in_the_posterior_mass():
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (10, 2))
    space = [Factor("p", 0, 1), Factor("q", 0, 1)]
    surrogates = {"y": fit_surrogate("y", x, np.sin(2 * x[:, 0]) + x[:, 1] ** 2)}
    responses = [Response("y", 0.3, 0.05)]
    post = sample_posterior(surrogates, responses, space)
    pts = acquire_batch(surrogates, responses, post, 5, seed=1)
    assert pts.shape == (5, 2)
    assert np.all(np.abs(pts) <= 1)
    gaps = [np.linalg.norm(a - b) for i, a in enumerate(pts) for b in pts[i + 1:]]
    assert min(gaps) > 0.05  # the kriging believer spreads the batch
    # Every chosen point is at least as probable as the posterior's least probable decile.
    floor = np.quantile(post.log_prob, 0.1)
    assert np.all(log_posterior(pts, surrogates, responses) >= floor - 1.0)


@pytest.mark.parametrize(("settings", "message"), [
    (dict(max_runs=20), "max_runs must be >= the space-filling start's 27 runs"),
    (dict(batch=0), "batch must be an integer >= 1"),
    (dict(tolerance=0.0), r"tolerance must be in \(0, 1\]"),
    (dict(tolerance=1.5), r"tolerance must be in \(0, 1\]"),
    (dict(max_runs=10, n_start=12), "max_runs must be >= the space-filling start's 12 runs"),
    (dict(stable_rounds=-1), "stable_rounds must be an integer >= 0"),
    (dict(stable_change=0.0), r"stable_change must be in \(0, 1\]"),
])
def test_bad_settings_are_one_input_error(settings, message):
    evaluate = engine(NAMES)
    with pytest.raises(InputError, match=message) as info:
        calibrate_bayes(evaluate, FACTORS, lab(NAMES), BayesSettings(**settings))
    assert "\n" not in str(info.value)
    assert evaluate.runs == 0  # refused before any run


def test_evaluate_must_answer_every_response_for_every_point():
    with pytest.raises(InputError, match="no values for response drum"):
        calibrate_bayes(engine(("aor", "density")), FACTORS, lab(NAMES))
    with pytest.raises(InputError, match="returned 1 values of aor for 27 points"):
        calibrate_bayes(lambda pts: {"aor": [1.0]}, FACTORS, lab(("aor",)))
    with pytest.raises(InputError, match="varies every factor"):
        calibrate_bayes(engine(NAMES), [*FACTORS, Factor("density", 1, 2, fixed=1.5)],
                        lab(NAMES))


def test_replicate_variances_reach_the_surrogates_and_the_result_is_json():
    base = engine(NAMES, seed=6)

    def evaluate(points):
        # A runner with 4 replicates per point: the mean's variance is the scatter² / 4.
        return {n: (v, np.full(len(v), 0.3**2 / 4)) for n, v in base(points).items()}

    res = calibrate_bayes(evaluate, FACTORS, lab(NAMES),
                          BayesSettings(max_runs=27, tolerance=0.25, seed=6))
    assert np.allclose(res.surrogates["aor"].noise_var, 0.3**2 / 4)
    assert res.surrogates["aor"].noise_std == pytest.approx(0.15)
    out = json.loads(json.dumps(res.to_dict()))
    assert set(out["posterior"]) == set(FACTORS.names)
    assert out["n_runs"] == 27 and out["identifiable"] is True and out["ridge"] == []
    assert out["correlation"]["static_friction"]["static_friction"] == pytest.approx(1.0)
    assert 0.2 <= out["posterior"]["static_friction"]["median"] <= 0.8  # actual units


def test_acquired_runs_shrink_the_posterior_more_than_space_filling_runs():
    # Curved responses and a precise lab: after the start, the loop's 12 chosen runs must
    # narrow the posterior more than 12 more space-filling runs would (same total, 39).
    responses = [Response(n, float(nonlinear_response(n, TRUTH)[0]), 0.1) for n in NAMES]
    sampler = SamplerSettings(n_steps=1200, burn=400, seed=1)
    res = calibrate_bayes(nonlinear_engine(0.5, seed=0), FACTORS, responses,
                          BayesSettings(max_runs=39, batch=6, tolerance=0.01, seed=1,
                                        sampler=sampler))
    assert res.n_runs == 39
    x = latin_hypercube(FACTORS, 39, seed=1, optimization="random-cd").coded
    y = nonlinear_engine(0.5, seed=0)(x)
    spread = sample_posterior({n: fit_surrogate(n, x, y[n]) for n in NAMES}, responses,
                              FACTORS, sampler)
    volume = np.prod(res.posterior.half_widths)
    assert volume < 0.75 * np.prod(spread.half_widths), (res.posterior.half_widths,
                                                         spread.half_widths)
    for p, truth in zip(res.posterior.parameters, TRUTH, strict=True):
        assert p.ci95_low <= truth <= p.ci95_high, p


def test_the_loop_is_deterministic_so_a_caching_runner_resumes_without_new_runs():
    # Every random choice is seeded (start, GP restarts, sampler, acquisition), so a second
    # call asks for exactly the same points: a runner that answers from its store resumes.
    fresh = engine(NAMES, seed=7)
    store: dict[tuple[float, ...], dict[str, float]] = {}

    def cached(points):
        todo = [p for p in points if tuple(p) not in store]
        if todo:
            got = fresh(np.array(todo))
            for i, p in enumerate(todo):
                store[tuple(p)] = {n: got[n][i] for n in NAMES}
        return {n: [store[tuple(p)][n] for p in points] for n in NAMES}

    settings = BayesSettings(max_runs=12, batch=4, tolerance=0.01, seed=7, n_start=8,
                             sampler=SamplerSettings(n_steps=600, burn=200, seed=7))
    first = calibrate_bayes(cached, FACTORS, lab(NAMES), settings)
    assert fresh.runs == 12
    again = calibrate_bayes(cached, FACTORS, lab(NAMES), settings)
    assert fresh.runs == 12  # nothing new was run
    assert np.array_equal(first.x, again.x)
    assert np.array_equal(first.posterior.samples, again.posterior.samples)


def test_a_ridge_that_stops_moving_stops_the_loop_with_the_budget_s_answer():
    """The angle alone leaves a ridge more runs do not narrow: with ``stable_rounds = 2`` the
    loop stops two rounds after the start, its intervals those the whole budget gives (within
    0.1 coded), for fewer than half the budget's acquired runs; without it, the budget."""
    sampler = SamplerSettings(n_steps=1000, burn=300)
    runs = {}
    for m in (0, 2):
        evaluate = engine(("aor",), seed=1)
        runs[m] = calibrate_bayes(evaluate, FACTORS, lab(("aor",)), BayesSettings(
            max_runs=59, batch=4, tolerance=0.25, seed=1, stable_rounds=m, sampler=sampler))
    assert runs[0].stopped == "budget" and runs[0].n_runs == 59
    assert runs[2].stopped == "stable" and runs[2].n_runs == 27 + 2 * 4
    assert not runs[2].identifiability.identifiable
    assert np.max(np.abs(runs[2].posterior.intervals - runs[0].posterior.intervals)) < 0.1


def test_runs_added_at_a_missed_best_point_move_the_posterior_off_it():
    # A verification that missed: 6 runs at the best point read 2 higher than the surrogate
    # promised (a bump the start did not see). Conditioned on them, the surrogate must read
    # what they read there, and the new best point must lie elsewhere, where the refitted
    # surrogate meets the lab value again.
    responses = lab(("aor", "density"))
    cfg = BayesSettings(max_runs=16, batch=4, tolerance=0.25, seed=2, n_start=12,
                        sampler=SamplerSettings(n_steps=1000, burn=300))
    res = calibrate_bayes(engine(("aor", "density"), seed=2), FACTORS, responses, cfg)
    best = res.best_point
    promised = {n: float(s.predict(best)[0][0]) for n, s in res.surrogates.items()}
    x_new = np.repeat(best[None, :], 6, axis=0)
    y_new = {"aor": np.full(6, promised["aor"] + 2.0), "density": np.full(6, promised["density"])}
    again = condition_on(res, x_new, y_new, responses, cfg)
    assert again.n_runs == res.n_runs + 6 and len(again.history) == len(res.history) + 1
    assert again.history[-1].n_runs == again.n_runs and again.stopped == res.stopped
    assert again.x[-6:].tolist() == x_new.tolist()
    reads = float(again.surrogates["aor"].predict(best)[0][0])
    assert abs(reads - (promised["aor"] + 2.0)) < 0.6, reads
    moved = again.best_point
    assert np.linalg.norm(moved - best) > 0.1
    aor_lab = responses[0].mean
    assert abs(float(again.surrogates["aor"].predict(moved)[0][0]) - aor_lab) < 1.0


def test_condition_on_refuses_what_it_cannot_add():
    responses = lab(("aor",))
    cfg = BayesSettings(max_runs=10, batch=2, seed=1, n_start=10,
                        sampler=SamplerSettings(n_steps=400, burn=100))
    res = calibrate_bayes(engine(("aor",), seed=1), FACTORS, responses, cfg)
    with pytest.raises(InputError, match="3 columns"):
        condition_on(res, np.zeros((2, 2)), {"aor": [30.0, 30.0]}, responses, cfg)
    with pytest.raises(InputError, match="no values of response aor"):
        condition_on(res, np.zeros((2, 3)), {"drum": [1.0, 1.0]}, responses, cfg)
    with pytest.raises(InputError, match="returned 1 values of aor for 2 points"):
        condition_on(res, np.zeros((2, 3)), {"aor": [30.0]}, responses, cfg)
