"""Input validation shared by the measure functions (the wrapper validates; the core trusts)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from demcal.errors import InputError

#: Default flank fit window, as fractions of the pile height above the base line.
#: 0.2 drops the toe (the skirt of particles spread on the plate is typically one or two
#: particle diameters thick on an engine pile 5-10 diameters high, and the photo's toe is
#: blurred by shadow and stray grains); 0.8 drops the rounded apex (or the rim of a
#: flat-topped pile). The middle 60 % of the height is the straight flank of both cones and
#: mesa-shaped piles.
DEFAULT_FIT_WINDOW: tuple[float, float] = (0.2, 0.8)

#: Line-fit methods accepted by every measure function.
FIT_METHODS: tuple[str, ...] = ("least_squares", "theil_sen", "ransac")

#: Fewest boundary points (pixel rows) a flank fit accepts.
MIN_FLANK_POINTS = 5


def check_fit_window(fit_window: Any, field: str = "fit_window") -> tuple[float, float]:
    """Return ``(lo, hi)`` with ``0 <= lo < hi <= 1`` or raise :class:`InputError`."""
    try:
        lo, hi = (float(v) for v in fit_window)
    except (TypeError, ValueError):
        raise InputError(
            f"{field} must be two numbers (lo, hi) with 0 <= lo < hi <= 1, fractions of the "
            f"pile height; got {fit_window!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 <= lo < hi <= 1.0):
        raise InputError(
            f"{field} must satisfy 0 <= lo < hi <= 1 (fractions of the pile height); "
            f"got ({lo:g}, {hi:g})")
    return lo, hi


def check_fit_method(fit: Any, field: str = "fit") -> str:
    """Return ``fit`` if it names a known line-fit method, else raise :class:`InputError`."""
    if fit not in FIT_METHODS:
        raise InputError(f"{field} must be one of {', '.join(FIT_METHODS)}; got {fit!r}")
    return str(fit)


def check_positive(value: Any, field: str) -> float:
    """Return ``value`` as a finite float > 0, else raise :class:`InputError`."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{field} must be a number > 0; got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise InputError(f"{field} must be a finite number > 0; got {value!r}")
    return v


def check_spheres(centres: Any, radii: Any) -> tuple[np.ndarray, np.ndarray]:
    """Validate sphere centres ``(n, 3)`` m and radii ``(n,)`` m; return float64 copies."""
    try:
        c = np.asarray(centres, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError("centres must be a numeric (n_spheres, 3) array, m") from None
    try:
        r = np.asarray(radii, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError("radii must be a numeric (n_spheres,) array, m") from None
    if c.ndim != 2 or c.shape[1] != 3:
        raise InputError(f"centres must have shape (n_spheres, 3), m; got {c.shape}")
    if c.shape[0] == 0:
        raise InputError("centres is empty: a pile needs at least one sphere")
    if r.ndim != 1 or r.shape[0] != c.shape[0]:
        raise InputError(
            f"radii must have shape ({c.shape[0]},) to match centres; got {r.shape}")
    if not np.all(np.isfinite(c)):
        raise InputError("centres must be finite (no NaN or inf)")
    if not (np.all(np.isfinite(r)) and np.all(r > 0)):
        raise InputError("radii must be finite and > 0, m")
    return c, r
