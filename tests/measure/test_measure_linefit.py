"""The line-fit core: exact lines, outliers, angles and their standard errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from demcal import measure
from demcal.errors import InputError


@pytest.mark.parametrize("method", measure.FIT_METHODS)
def test_exact_line_recovered(method):
    z = np.linspace(0, 50, 40)
    fit = measure.fit_line(z, 0.7 * z + 3.0, method)
    assert fit.slope == pytest.approx(0.7, abs=1e-9)
    assert fit.intercept == pytest.approx(3.0, abs=1e-7)
    assert fit.residual == pytest.approx(0.0, abs=1e-7)
    assert fit.n_points == 40


def test_robust_fits_ignore_outliers_that_bias_least_squares():
    """A skirt: the lowest 15 % of the points lie far outside the flank line."""
    rng = np.random.default_rng(1234)
    z = np.linspace(0, 100, 101)
    x = 1.2 * z + rng.normal(0, 0.3, z.size)
    x[:15] += 25.0
    ls = measure.fit_line(z, x, "least_squares")
    assert abs(ls.slope - 1.2) > 0.1
    for method in ("theil_sen", "ransac"):
        fit = measure.fit_line(z, x, method)
        assert fit.slope == pytest.approx(1.2, abs=0.02), method
    ransac = measure.fit_line(z, x, "ransac")
    assert ransac.n_inliers <= 101 - 15


@pytest.mark.parametrize("method", measure.FIT_METHODS)
def test_slope_stderr_matches_scatter(method):
    """The reported standard error is close to the spread of slopes over noisy repeats."""
    rng = np.random.default_rng(1234)
    z = np.linspace(0, 100, 80)
    slopes, errs = [], []
    for _ in range(60):
        fit = measure.fit_line(z, 0.5 * z + rng.normal(0, 1.0, z.size), method)
        slopes.append(fit.slope)
        errs.append(fit.slope_stderr)
    assert np.mean(errs) == pytest.approx(np.std(slopes, ddof=1), rel=0.35)


def test_flank_angles_and_sides():
    z = np.linspace(0, 10, 20)
    tan = math.tan(math.radians(40))
    left = measure.fit_flank(z, z / tan, "left", 0, 10)
    right = measure.fit_flank(z, 100 - z / tan, "right", 0, 10)
    assert left.angle_deg == pytest.approx(40)
    assert right.angle_deg == pytest.approx(40)
    wall = measure.fit_flank(z, np.full(z.size, 5.0), "left", 0, 10)
    assert wall.angle_deg == pytest.approx(90)
    overhang = measure.fit_flank(z, -0.1 * z, "left", 0, 10)
    assert overhang.angle_deg > 90
    # The window keeps only points inside [z_lo, z_hi].
    partial = measure.fit_flank(z, z / tan, "left", 2, 8)
    assert partial.fit.n_points == int(np.sum((z >= 2) & (z <= 8)))


def test_angle_stderr_from_slope_stderr():
    rng = np.random.default_rng(1234)
    z = np.linspace(0, 10, 50)
    flank = measure.fit_flank(z, z + rng.normal(0, 0.2, 50), "left", 0, 10, "least_squares")
    # d(angle)/d(slope) = -1 / (1 + slope^2) at slope 1.
    expected = math.degrees(flank.fit.slope_stderr / (1 + flank.fit.slope ** 2))
    assert flank.angle_stderr_deg == pytest.approx(expected)
    assert 0 < flank.angle_stderr_deg < 2


def test_too_few_points_and_flat_points_raise():
    with pytest.raises(InputError, match="left flank: too few boundary points"):
        measure.fit_flank(np.arange(10.0), np.arange(10.0), "left", 0, 3)
    with pytest.raises(InputError, match="one height"):
        measure.fit_line(np.ones(8), np.arange(8.0))
    with pytest.raises(InputError, match="fit must be one of"):
        measure.fit_line(np.arange(8.0), np.arange(8.0), "median")
