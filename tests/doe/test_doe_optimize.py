"""Target optimisation: desirability formula, bounds, fixed factors, constraint, preference."""

from __future__ import annotations

import numpy as np
import pytest

from demcal import doe
from demcal.errors import InputError


def test_target_desirability_formula():
    # Design-Expert: ((y-L)/(T-L))^s below the target, ((U-y)/(U-T))^t above, 0 outside
    y = np.array([30.0, 35.0, 40.0, 45.0, 50.0, 55.0])
    d = doe.target_desirability(y, 40.0, 30.0, 50.0, weight_low=2.0, weight_high=0.5)
    np.testing.assert_allclose(d, [0.0, 0.25, 1.0, np.sqrt(0.5), 0.0, 0.0])
    with pytest.raises(InputError, match="lower <= target <= upper"):
        doe.target_desirability(y, 60.0, 30.0, 50.0)


@pytest.fixture(scope="module")
def sphere_fit():
    """y = 10 - (x1^2 + x2^2 + x3^2) exactly: the target 9 is hit on a sphere of radius 1."""
    space = doe.FactorSpace(
        [doe.Factor("a", 0.0, 2.0), doe.Factor("b", -5.0, 5.0), doe.Factor("c", 10.0, 20.0)]
    )
    d = doe.box_behnken(space, center_points=3, randomize=False)
    y = 10 - np.sum(d.coded**2, axis=1) + 1e-3 * np.sin(np.arange(d.n_runs))
    return doe.fit(d, y, model="quadratic")


def test_solutions_hit_the_target_inside_the_box_and_are_distinct(sphere_fit):
    res = doe.optimize_target(sphere_fit, 9.0, n_solutions=5, seed=1)
    assert len(res.solutions) == 5
    pts = np.array([list(s.coded.values()) for s in res.solutions])
    assert np.all(np.abs(pts) <= 1 + 1e-12)
    for s in res.solutions:
        assert s.predicted == pytest.approx(9.0, abs=1e-3)
        assert s.desirability > 0.999
        assert s.ci[0] < s.predicted < s.ci[1]
        assert s.pi[0] < s.ci[0] and s.ci[1] < s.pi[1]
        act = sphere_fit.factors.to_actual(list(s.coded.values()))
        assert list(s.actual.values()) == pytest.approx(list(act))
    for i in range(5):
        for j in range(i):
            assert np.sqrt(np.mean((pts[i] - pts[j]) ** 2)) >= 0.1
    frame = res.to_frame()
    assert list(frame["rank"]) == [1, 2, 3, 4, 5]
    assert {"a", "b", "c", "a_coded", "predicted", "pi_low"} <= set(frame.columns)


def test_fixed_factor_and_bounds_are_respected(sphere_fit):
    res = doe.optimize_target(sphere_fit, 9.0, fixed={"a": 1.5}, bounds={"b": (0.0, 5.0)}, seed=2)
    for s in res.solutions:
        assert s.actual["a"] == 1.5
        assert 0.0 <= s.actual["b"] <= 5.0
        assert s.predicted == pytest.approx(9.0, abs=1e-3)


def test_a_value_held_or_searched_beyond_the_design_is_named(sphere_fit):
    # a spans 0-2 (coded -1..1): 3 is coded +2; b's search widened past its -5..5
    res = doe.optimize_target(sphere_fit, 9.0, fixed={"a": 3.0}, seed=2)
    assert res.outside == ("a",)
    res = doe.optimize_target(sphere_fit, 9.0, bounds={"b": (-8.0, 5.0)}, seed=2)
    assert res.outside == ("b",)
    res = doe.optimize_target(sphere_fit, 9.0, fixed={"a": 2.0}, bounds={"b": (0.0, 5.0)},
                              seed=2)
    assert res.outside == ()  # on the edge and inside: no extrapolation


def test_unreachable_target_goes_to_the_nearest_edge(sphere_fit):
    res = doe.optimize_target(sphere_fit, 12.0, seed=0)
    best = res.best
    assert best.desirability < 1
    # the maximum of 10 - r^2 is the centre
    assert np.abs(list(best.coded.values())).max() < 1e-3


def test_constraint_rejects_infeasible_points(sphere_fit):
    calls = []

    def feasible(points):
        calls.append(points.shape)
        return points[:, 1] > 2.0  # actual b > 2 (coded > 0.4)

    res = doe.optimize_target(sphere_fit, 9.0, constraint=feasible, seed=3)
    assert calls and all(shape[1] == 3 for shape in calls)
    assert res.solutions
    for s in res.solutions:
        assert s.actual["b"] > 2.0
    with pytest.raises(InputError, match="every sampled point"):
        doe.optimize_target(sphere_fit, 9.0, constraint=lambda p: np.zeros(len(p), bool))


def test_near_point_is_preferred(sphere_fit):
    # the target sphere r = 1 passes through coded (1, 0, 0) = actual (2, 0, 15)
    res = doe.optimize_target(sphere_fit, 9.0, near={"a": 2.0, "b": 0.0, "c": 15.0}, seed=4)
    best = res.best
    assert best.coded["a"] == pytest.approx(1.0, abs=0.05)
    assert abs(best.coded["b"]) < 0.1 and abs(best.coded["c"]) < 0.1
    assert best.distance <= min(s.distance for s in res.solutions[1:])


def test_bad_options(sphere_fit):
    with pytest.raises(InputError, match="not a factor of the model"):
        doe.optimize_target(sphere_fit, 9.0, fixed={"z": 1.0})
    with pytest.raises(InputError, match="low must be < high"):
        doe.optimize_target(sphere_fit, 9.0, bounds={"a": (1.0, 0.5)})
    with pytest.raises(InputError, match="n_solutions"):
        doe.optimize_target(sphere_fit, 9.0, n_solutions=0)
