"""Input checks shared by the pure functions of demcal.physical (raise InputError)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from demcal.errors import InputError


def as_values(
    values: Any,
    name: str,
    unit: str,
    *,
    low: float | None = None,
    high: float | None = None,
    low_inclusive: bool = True,
    high_inclusive: bool = True,
) -> np.ndarray:
    """Convert scalar or array-like input to a 1-D float64 array, checked.

    Raises
    ------
    InputError
        Naming ``name`` when the input is empty, not numeric, not finite, or outside
        ``[low, high]`` (bounds inclusive or not as told).
    """
    try:
        arr = np.atleast_1d(np.asarray(values, dtype=np.float64))
    except (TypeError, ValueError):
        raise InputError(
            f"{name} must be a number or a list of numbers ({unit}); got {values!r}"
        ) from None
    if arr.ndim != 1:
        raise InputError(
            f"{name} must be a number or a 1-D list of numbers ({unit}); got shape {arr.shape}"
        )
    if arr.size == 0:
        raise InputError(f"{name} needs at least one value ({unit}); got an empty list")
    rng = _range_text(low, high, low_inclusive, high_inclusive)
    for i, v in enumerate(arr):
        bad = not math.isfinite(v)
        if low is not None and (v < low or (v == low and not low_inclusive)):
            bad = True
        if high is not None and (v > high or (v == high and not high_inclusive)):
            bad = True
        if bad:
            where = f"{name}[{i}]" if arr.size > 1 else name
            raise InputError(f"{where} must be {rng} ({unit}); got {v!r}")
    return arr


def as_scalar(
    value: Any,
    name: str,
    unit: str,
    *,
    low: float | None = None,
    high: float | None = None,
    low_inclusive: bool = True,
    high_inclusive: bool = True,
) -> float:
    """A single checked float (see :func:`as_values`)."""
    arr = as_values(
        value,
        name,
        unit,
        low=low,
        high=high,
        low_inclusive=low_inclusive,
        high_inclusive=high_inclusive,
    )
    if arr.size != 1:
        raise InputError(f"{name} must be a single number ({unit}); got {arr.size} values")
    return float(arr[0])


def _range_text(low: float | None, high: float | None, lo_in: bool, hi_in: bool) -> str:
    if low is None and high is None:
        return "a finite number"
    if high is None:
        return f"a finite number {'>=' if lo_in else '>'} {low:g}"
    if low is None:
        return f"a finite number {'<=' if hi_in else '<'} {high:g}"
    return f"in {'[' if lo_in else '('}{low:g}, {high:g}{']' if hi_in else ')'}"
