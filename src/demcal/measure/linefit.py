"""The line-fit core: a straight flank ``x = slope * z + intercept`` and its angle.

Both the photo and the simulated-pile measurements reduce a flank to points ``(z, x)``: the
height above the base line and the horizontal position of the pile's outer boundary at that
height (one point per pixel row). Fitting ``x`` as a function of ``z`` keeps the fit well
conditioned for every angle up to a vertical wall (slope 0, 90 deg) and beyond (an overhang
measures more than 90 deg), so a column measures close to 90 deg instead of failing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from demcal.errors import InputError
from demcal.measure._checks import MIN_FLANK_POINTS, check_fit_method

__all__ = ["Flank", "LineFit", "fit_flank", "fit_line"]

_Z95 = stats.norm.ppf(0.975)


@dataclass(frozen=True)
class LineFit:
    """A fitted line ``x = slope * z + intercept`` (any consistent length unit).

    Attributes
    ----------
    slope : float
        dx/dz, dimensionless.
    intercept : float
        x at z = 0 (the base line), length unit of the points.
    slope_stderr : float
        Standard error of the slope (least squares: the usual OLS error; Theil-Sen: half the
        95 % confidence interval / 1.96; RANSAC: OLS error on the inliers).
    residual : float
        Root-mean-square horizontal residual of the points used in the fit (RANSAC: the
        inliers), length unit of the points.
    n_points, n_inliers : int
        Points offered and points kept by the fit.
    method : str
        ``least_squares``, ``theil_sen`` or ``ransac``.
    """

    slope: float
    intercept: float
    slope_stderr: float
    residual: float
    n_points: int
    n_inliers: int
    method: str

    def x_at(self, z: np.ndarray | float) -> np.ndarray | float:
        """Horizontal position of the line at height ``z``."""
        return self.slope * np.asarray(z) + self.intercept


def _ols(z: np.ndarray, x: np.ndarray) -> tuple[float, float, float]:
    """Least-squares slope, intercept and slope standard error of ``x(z)``."""
    res = stats.linregress(z, x)
    se = float(res.stderr) if len(z) > 2 else math.nan
    return float(res.slope), float(res.intercept), se


def _rms(z: np.ndarray, x: np.ndarray, slope: float, intercept: float) -> float:
    return float(np.sqrt(np.mean((x - (slope * z + intercept)) ** 2)))


def fit_line(z: np.ndarray, x: np.ndarray, method: str = "theil_sen", *,
             field: str = "flank") -> LineFit:
    """Fit ``x = slope * z + intercept`` to boundary points.

    Parameters
    ----------
    z : (n,) float ndarray
        Heights above the base line (any length unit).
    x : (n,) float ndarray
        Horizontal boundary positions, same unit as ``z``.
    method : {"least_squares", "theil_sen", "ransac"}
        Ordinary least squares (:func:`scipy.stats.linregress`); Theil-Sen median of pairwise
        slopes (:func:`scipy.stats.theilslopes`, robust to ~29 % outliers); or RANSAC
        (:func:`skimage.measure.ransac`, threshold 2.5 robust sigma of the Theil-Sen residuals,
        then least squares on the inliers; seeded, so repeatable).
    field : str
        Name used in error messages (e.g. ``"left flank"``).

    Raises
    ------
    InputError
        Fewer than :data:`MIN_FLANK_POINTS` points, or all points at one height.
    """
    method = check_fit_method(method)
    z = np.asarray(z, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    n = int(z.size)
    if n < MIN_FLANK_POINTS:
        raise InputError(
            f"{field}: too few boundary points for a line fit ({n}; need at least "
            f"{MIN_FLANK_POINTS}); widen fit_window or use a finer image/pixel_size")
    if np.ptp(z) <= 0:
        raise InputError(f"{field}: all boundary points lie at one height; no slope to fit")
    if method == "least_squares":
        slope, intercept, se = _ols(z, x)
        return LineFit(slope, intercept, se, _rms(z, x, slope, intercept), n, n, method)
    ts = stats.theilslopes(x, z, alpha=0.95)
    slope, intercept = float(ts.slope), float(ts.intercept)
    if method == "theil_sen":
        se = float(ts.high_slope - ts.low_slope) / (2.0 * _Z95)
        return LineFit(slope, intercept, se, _rms(z, x, slope, intercept), n, n, method)
    from skimage.measure import LineModelND, ransac

    resid = x - (slope * z + intercept)
    scale = 1.4826 * float(np.median(np.abs(resid - np.median(resid))))
    # Perpendicular threshold: 2.5 robust sigma of the horizontal residuals, at least a
    # hair above zero so that exact synthetic lines are all inliers.
    thr = max(2.5 * scale / math.sqrt(1.0 + slope * slope), 1e-9 * (np.ptp(x) + np.ptp(z)))
    data = np.column_stack([z, x])
    _model, inliers = ransac(data, LineModelND, min_samples=2, residual_threshold=thr,
                             max_trials=200, rng=0)
    if inliers is None or int(inliers.sum()) < MIN_FLANK_POINTS or np.ptp(z[inliers]) <= 0:
        inliers = np.ones(n, dtype=bool)
    slope, intercept, se = _ols(z[inliers], x[inliers])
    return LineFit(slope, intercept, se, _rms(z[inliers], x[inliers], slope, intercept), n,
                   int(inliers.sum()), method)


@dataclass(frozen=True)
class Flank:
    """One fitted flank of a pile.

    Attributes
    ----------
    side : {"left", "right"}
        Which flank (left: the boundary on the -x side, rising to the right).
    fit : LineFit
        The fitted line ``x(z)`` in the measurement's length unit.
    z_lo, z_hi : float
        Height range of the fitted points (the fit window), same unit.
    """

    side: str
    fit: LineFit

    z_lo: float
    z_hi: float

    @property
    def angle_deg(self) -> float:
        """Angle between the flank and the horizontal on the pile's outside, deg.

        90 deg is a vertical wall; more than 90 deg an overhang.
        """
        s = self.fit.slope if self.side == "left" else -self.fit.slope
        return math.degrees(math.atan2(1.0, s))

    @property
    def angle_stderr_deg(self) -> float:
        """Standard error of :attr:`angle_deg` from the slope's standard error, deg."""
        s = self.fit.slope
        return math.degrees(self.fit.slope_stderr / (1.0 + s * s))


def fit_flank(z: np.ndarray, x: np.ndarray, side: str, z_lo: float, z_hi: float,
              method: str = "theil_sen") -> Flank:
    """Fit the points of one flank with ``z_lo <= z <= z_hi``; see :func:`fit_line`."""
    z = np.asarray(z, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    keep = (z >= z_lo) & (z <= z_hi) & np.isfinite(x)
    fit = fit_line(z[keep], x[keep], method, field=f"{side} flank")
    return Flank(side, fit, float(z_lo), float(z_hi))
