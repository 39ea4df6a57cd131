"""Quality gates for fitted flanks, and the robust combination of the flanks that pass.

A pile's angle is a statement about its straight flank. A fit that follows one stalk standing
at the edge (a "flank" of 95 deg), a flank with a handful of boundary points, or points that
scatter about the line as much as the window is high, says nothing about it and must not be
averaged in. :func:`flank_rejection` names why a flank fails; :func:`combine_angles` reduces
the angles that pass to one value (their mean by default) and their spread.

The same gates serve photos (two flanks) and simulated piles (two flanks per view or one per
sector).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

from demcal.errors import InputError
from demcal.measure.linefit import Flank

__all__ = ["COMBINE_METHODS", "DEFAULT_GATES", "FlankGates", "combine_angles",
           "flank_rejection", "spread_deg"]

#: How the accepted flank angles of a pile become its angle.
COMBINE_METHODS: tuple[str, ...] = ("mean", "median", "trimmed_mean")
#: Fraction cut from each end by ``trimmed_mean``.
TRIM_FRACTION = 0.2


@dataclass(frozen=True)
class FlankGates:
    """Limits a fitted flank must meet to count (angles in deg).

    Attributes
    ----------
    min_angle_deg, max_angle_deg : float
        Accepted flank angles. Above ``max_angle_deg`` (default 80) the "flank" is a wall: a
        particle standing at the edge, a column, or an overhang (> 90); below
        ``min_angle_deg`` (default 5) it is a skirt on the plate, not a pile's flank.
    min_points : int
        Fewest boundary points (pixel rows) in the fit window (default 8).
    max_residual_fraction : float
        Largest root-mean-square distance of the points from the fitted line, perpendicular to
        it, as a fraction of the fit window's height (default 0.25): a flank whose points
        scatter more is not straight over the window. (Flanks of a small simulated pile,
        two or three stalk lengths long, scatter 10-20 % about their line.)
    max_stderr_deg : float
        Largest standard error of the angle from the fit (default 8).
    """

    min_angle_deg: float = 5.0
    max_angle_deg: float = 80.0
    min_points: int = 8
    max_residual_fraction: float = 0.25
    max_stderr_deg: float = 8.0

    def __post_init__(self) -> None:
        for name in ("min_angle_deg", "max_angle_deg", "max_residual_fraction",
                     "max_stderr_deg"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise InputError(f"gates.{name} must be a finite number > 0; got {v!r}")
        if not self.min_angle_deg < self.max_angle_deg <= 180.0:
            raise InputError(
                f"gates: need 0 < min_angle_deg < max_angle_deg <= 180 deg; got "
                f"{self.min_angle_deg:g} and {self.max_angle_deg:g}")
        if isinstance(self.min_points, bool) or not isinstance(self.min_points, int) or not (
                2 <= self.min_points <= 100_000):
            raise InputError(f"gates.min_points must be an integer in 2..100000; got "
                             f"{self.min_points!r}")


DEFAULT_GATES = FlankGates()


def flank_rejection(flank: Flank, gates: FlankGates | None = DEFAULT_GATES) -> str | None:
    """Why ``flank`` fails the gates (one short phrase), or None when it passes.

    ``gates=None`` accepts every flank (no gates).
    """
    if gates is None:
        return None
    return _angle_rejection(flank.angle_deg, gates) or _fit_rejection(flank, gates)


def _angle_rejection(angle: float, gates: FlankGates) -> str | None:
    """Why a flank at ``angle`` (deg) is no pile's flank, or None when its angle passes."""
    if not math.isfinite(angle):
        return "no angle"
    if angle > gates.max_angle_deg:
        kind = " (an overhang)" if angle > 90.0 else ""
        return f"{angle:.1f} deg is steeper than the limit ({gates.max_angle_deg:g} deg){kind}"
    if angle < gates.min_angle_deg:
        return f"{angle:.1f} deg is flatter than the limit ({gates.min_angle_deg:g} deg)"
    return None


def _fit_rejection(flank: Flank, gates: FlankGates) -> str | None:
    """Why the straight line fitted to ``flank`` says nothing of it, or None when it holds."""
    fit = flank.fit
    if fit.n_points < gates.min_points:
        return f"{fit.n_points} boundary points (need {gates.min_points})"
    height = flank.z_hi - flank.z_lo
    perpendicular = fit.residual / math.sqrt(1.0 + fit.slope * fit.slope)
    if height > 0 and perpendicular > gates.max_residual_fraction * height:
        return (f"poor fit: points scatter {perpendicular / height:.0%} of the window height "
                f"about the line (limit {gates.max_residual_fraction:.0%})")
    se = flank.angle_stderr_deg
    if math.isfinite(se) and se > gates.max_stderr_deg:
        return f"uncertain fit: angle standard error {se:.1f} deg (limit {gates.max_stderr_deg:g})"
    return None


def check_combine(combine: str, field: str = "combine") -> str:
    """Return ``combine`` if it names a method of :data:`COMBINE_METHODS`."""
    if combine not in COMBINE_METHODS:
        raise InputError(f"{field} must be one of {', '.join(COMBINE_METHODS)}; got {combine!r}")
    return str(combine)


def combine_angles(angles: Sequence[float], combine: str = "mean") -> float:
    """One angle (deg) from a pile's accepted flank angles.

    ``mean`` (default: the most efficient once the gates have removed the outliers),
    ``median`` or ``trimmed_mean`` (20 % cut at each end), which are not swung by one or two
    odd flanks that pass the gates.
    """
    check_combine(combine)
    a = np.asarray(angles, dtype=np.float64)
    if a.size == 0:
        return math.nan
    if combine == "median":
        return float(np.median(a))
    if combine == "trimmed_mean":
        return float(stats.trim_mean(a, TRIM_FRACTION))
    return float(np.mean(a))


def spread_deg(angles: Sequence[float]) -> float:
    """Within-pile spread of flank angles: sample standard deviation, deg (0 for one)."""
    a = np.asarray(angles, dtype=np.float64)
    return float(np.std(a, ddof=1)) if a.size > 1 else 0.0
