"""Summaries of repeated bench measurements and the rule that turns a spread into a range.

A :class:`RepeatSummary` holds the repeats of one quantity with their mean, sample standard
deviation (ddof = 1), min-max range and the two-sided confidence interval of the mean from
Student's t distribution (``mean +- t_{(1+level)/2, n-1} s / sqrt(n)``). When a source gives
only the range of its repeats (the paper's inclined-plane angles: "10 repeats, between 21 and
35 deg"), :func:`summarize_range` keeps just that range: no mean, no deviation, no interval
are invented.

:func:`suggest_range` turns a summary into a factor range by a named rule:

``"minmax"`` (default)
    the smallest and largest repeat (or the published range);
``"mean_std"``
    ``mean +- k * std`` (k = 2 by default): about 95 % of single measurements of a
    normal population;
``"ci"``
    the confidence interval of the mean at the summary's level.

The result is clipped to the parameter's physical bounds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from scipy import stats as _st

from demcal.errors import InputError
from demcal.physical._validate import as_scalar, as_values

__all__ = [
    "RANGE_RULES",
    "RangeRule",
    "RepeatSummary",
    "std_interval",
    "suggest_range",
    "summarize",
    "summarize_range",
]

RangeRule = Literal["minmax", "mean_std", "ci"]
#: The rules understood by :func:`suggest_range`.
RANGE_RULES: tuple[str, ...] = ("minmax", "mean_std", "ci")


@dataclass(frozen=True)
class RepeatSummary:
    """Statistics of the repeats of one measured quantity.

    Attributes
    ----------
    name : str
        What was measured (e.g. ``"particle.density"``).
    unit : str
        Unit of every number below (SI, or the suffix of the name for degrees / percent).
    values : tuple of float
        The repeats; empty when only a range was published.
    n_repeats : int or None
        Number of repeats (``len(values)``, or the declared count of a range-only record).
    mean, std : float or None
        Mean and sample standard deviation (ddof = 1); None for range-only records, and
        ``std`` is None for a single repeat.
    minimum, maximum : float
        Smallest and largest repeat (or the published range).
    ci_low, ci_high : float or None
        Two-sided confidence interval of the mean (Student t, ``n - 1`` degrees of freedom);
        None with fewer than 2 repeats.
    level : float
        Confidence level of the interval, in (0, 1).
    """

    name: str
    unit: str
    values: tuple[float, ...]
    n_repeats: int | None
    mean: float | None
    std: float | None
    minimum: float
    maximum: float
    ci_low: float | None
    ci_high: float | None
    level: float

    @property
    def range_only(self) -> bool:
        """True when only the min-max range of the repeats is known."""
        return not self.values

    @property
    def central(self) -> float:
        """The mean, or the midpoint of the range of a range-only record."""
        if self.mean is not None:
            return self.mean
        return 0.5 * (self.minimum + self.maximum)

    def map(self, func: Any, *, name: str, unit: str) -> RepeatSummary:
        """Summary of ``func(repeat)`` for a monotone increasing ``func`` (e.g. tan of angles).

        Repeats are mapped one by one and summarised afresh; a range-only record maps its
        end points.
        """
        if self.range_only:
            return summarize_range(
                float(np.ravel(func(self.minimum))[0]),
                float(np.ravel(func(self.maximum))[0]),
                name=name,
                unit=unit,
                n_repeats=self.n_repeats,
            )
        return summarize(
            np.asarray(func(np.asarray(self.values)), dtype=float),
            name=name,
            unit=unit,
            level=self.level,
        )

    def to_dict(self) -> dict[str, Any]:
        """Plain-JSON form."""
        return {
            "name": self.name,
            "unit": self.unit,
            "values": list(self.values),
            "n_repeats": self.n_repeats,
            "range_only": self.range_only,
            "mean": self.mean,
            "std": self.std,
            "min": self.minimum,
            "max": self.maximum,
            "ci_low": self.ci_low,
            "ci_high": self.ci_high,
            "ci_level": self.level,
        }


def _check_level(level: Any) -> float:
    return as_scalar(level, "level", "dimensionless", low=0.0, high=1.0, low_inclusive=False,
                     high_inclusive=False)


def summarize(
    values: Sequence[float] | np.ndarray,
    *,
    name: str = "values",
    unit: str = "",
    level: float = 0.95,
) -> RepeatSummary:
    """Mean, sample standard deviation, range and t confidence interval of repeats.

    Parameters
    ----------
    values : (n,) array_like of float
        The repeats (n >= 1), in ``unit``.
    name : str, keyword-only
        Name of the quantity, used in error messages.
    unit : str, keyword-only
        Unit of the values.
    level : float, keyword-only
        Confidence level of the interval of the mean, in (0, 1).

    Returns
    -------
    RepeatSummary

    Examples
    --------
    >>> s = summarize([116.15, 126.14, 101.42, 112.35, 115.74], name="density", unit="kg/m^3")
    >>> round(s.mean, 2), s.minimum, s.maximum
    (114.36, 101.42, 126.14)
    """
    arr = as_values(values, name, unit or "dimensionless")
    lvl = _check_level(level)
    n = int(arr.size)
    mean = float(np.mean(arr))
    std = float(np.std(arr, ddof=1)) if n > 1 else None
    ci_low = ci_high = None
    if std is not None:
        half = float(_st.t.ppf(0.5 + lvl / 2.0, n - 1)) * std / math.sqrt(n)
        ci_low, ci_high = mean - half, mean + half
    return RepeatSummary(
        name=name,
        unit=unit,
        values=tuple(float(v) for v in arr),
        n_repeats=n,
        mean=mean,
        std=std,
        minimum=float(np.min(arr)),
        maximum=float(np.max(arr)),
        ci_low=ci_low,
        ci_high=ci_high,
        level=lvl,
    )


def std_interval(std: float, n: int, level: float = 0.95) -> tuple[float, float]:
    """Confidence interval of a normal population's standard deviation from a sample's.

    ``s sqrt((n-1) / chi2_{(1+level)/2, n-1})`` to ``s sqrt((n-1) / chi2_{(1-level)/2, n-1})``:
    a standard deviation from a few repeats is itself uncertain (6 repeats: about -38 % to
    +145 % at 95 %), so a seed-to-seed std of 2.3 from 6 piles does not show that the true one
    is above 2.

    Parameters
    ----------
    std : float
        Sample standard deviation (ddof = 1), in any unit (the interval is in the same).
    n : int
        Number of repeats it came from (>= 2).
    level : float, optional
        Confidence level, in (0, 1).

    Returns
    -------
    (float, float)
        Lower and upper limits.

    Examples
    --------
    >>> lo, hi = std_interval(2.0, 6)
    >>> round(lo, 2), round(hi, 2)
    (1.25, 4.91)
    """
    s = as_scalar(std, "std", "the values' unit", low=0.0)
    if int(n) != n or n < 2:
        raise InputError(f"n must be an integer >= 2 (repeats behind the std); got {n!r}")
    lvl = _check_level(level)
    dof = int(n) - 1
    upper_q = float(_st.chi2.ppf(0.5 + lvl / 2.0, dof))
    lower_q = float(_st.chi2.ppf(0.5 - lvl / 2.0, dof))
    return s * math.sqrt(dof / upper_q), s * math.sqrt(dof / lower_q)


def summarize_range(
    minimum: float,
    maximum: float,
    *,
    name: str = "values",
    unit: str = "",
    n_repeats: int | None = None,
    level: float = 0.95,
) -> RepeatSummary:
    """A record known only by the range of its repeats (no mean, deviation or interval).

    Parameters
    ----------
    minimum, maximum : float
        Smallest and largest repeat, in ``unit`` (minimum <= maximum).
    name, unit : str, keyword-only
        Name and unit of the quantity.
    n_repeats : int or None, keyword-only
        Declared number of repeats behind the range, if known (>= 1).
    level : float, keyword-only
        Kept for consistency with :func:`summarize`; no interval is computed.
    """
    lo = as_scalar(minimum, f"{name} minimum", unit or "dimensionless")
    hi = as_scalar(maximum, f"{name} maximum", unit or "dimensionless")
    if lo > hi:
        raise InputError(f"{name}: minimum must be <= maximum; got minimum={lo:g}, maximum={hi:g}")
    if n_repeats is not None and (
        isinstance(n_repeats, bool) or not isinstance(n_repeats, int) or n_repeats < 1
    ):
        raise InputError(f"{name}: n_repeats must be an integer >= 1; got {n_repeats!r}")
    return RepeatSummary(
        name=name,
        unit=unit,
        values=(),
        n_repeats=n_repeats,
        mean=None,
        std=None,
        minimum=lo,
        maximum=hi,
        ci_low=None,
        ci_high=None,
        level=_check_level(level),
    )


def suggest_range(
    summary: RepeatSummary,
    *,
    rule: RangeRule = "minmax",
    k: float = 2.0,
    bounds: tuple[float, float] = (-math.inf, math.inf),
) -> tuple[float, float]:
    """A factor range from the spread of measured repeats (see the module docstring).

    Parameters
    ----------
    summary : RepeatSummary
        The measured quantity, in the parameter's unit.
    rule : {"minmax", "mean_std", "ci"}, keyword-only
        How the range is drawn from the spread.
    k : float, keyword-only
        Number of standard deviations for ``"mean_std"`` (> 0).
    bounds : (float, float), keyword-only
        Physical bounds of the parameter; the range is clipped to them.

    Returns
    -------
    (low, high) : tuple of float
        ``low <= high``; equal when the spread is zero (one repeat, identical repeats).

    Raises
    ------
    InputError
        Unknown rule, bad ``k``, or a rule the record cannot support (``"mean_std"`` or
        ``"ci"`` on a range-only record or on a single repeat).
    """
    if rule not in RANGE_RULES:
        raise InputError(f"rule must be one of {', '.join(RANGE_RULES)}; got {rule!r}")
    if rule == "minmax":
        low, high = summary.minimum, summary.maximum
    elif rule == "mean_std":
        kk = as_scalar(k, "k", "standard deviations", low=0.0, low_inclusive=False)
        if summary.std is None or summary.mean is None:
            raise InputError(
                f"rule 'mean_std' needs at least 2 repeats of {summary.name}; "
                f"got {'a range only' if summary.range_only else '1 repeat'}"
            )
        low, high = summary.mean - kk * summary.std, summary.mean + kk * summary.std
    else:
        if summary.ci_low is None or summary.ci_high is None:
            raise InputError(
                f"rule 'ci' needs at least 2 repeats of {summary.name}; "
                f"got {'a range only' if summary.range_only else '1 repeat'}"
            )
        low, high = summary.ci_low, summary.ci_high
    b_lo, b_hi = float(bounds[0]), float(bounds[1])
    if not b_lo <= b_hi:
        raise InputError(f"bounds must satisfy lower <= upper; got {bounds!r}")
    low = min(max(low, b_lo), b_hi)
    high = min(max(high, b_lo), b_hi)
    return float(low), float(high)
