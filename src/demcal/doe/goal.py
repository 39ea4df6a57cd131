"""One response's goal and limits, and its Derringer-Suich individual desirability.

Kept apart from the search (:mod:`demcal.doe.desirability`) so that a study file, which names
its responses' goals, is read without loading scipy and pandas.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from demcal.doe.factors import finite_number
from demcal.errors import InputError

__all__ = ["GOALS", "IMPORTANCE_RANGE", "REACHED", "WEIGHT_RANGE", "ResponseGoal"]

GOALS = ("target", "maximize", "minimize", "in_range")
#: Design-Expert's ranges of a goal's weight (the exponent) and importance.
WEIGHT_RANGE = (0.1, 10.0)
IMPORTANCE_RANGE = (1, 5)
#: the desirability from which a target counts as reached (1: the prediction is the target;
#: the search stops within about 1e-4 of it)
REACHED = 0.99

@dataclass(frozen=True)
class ResponseGoal:
    """The goal of one response (units of the response).

    Attributes
    ----------
    name : str
        The response's name (the key a test or engine reports, or a run sheet's column).
    goal : {"target", "maximize", "minimize", "in_range"}
        What is wanted.
    low, high : float
        Desirability limits L < U.
    target : float or None
        T, with ``L <= T <= U``; required by the ``target`` goal, ignored by the others.
    weight : float
        The exponent w of the individual desirability, 0.1-10 (1: linear).
    importance : int
        1-5, the exponent of d in the overall desirability's weighted geometric mean.
    """

    name: str
    goal: str
    low: float
    high: float
    target: float | None = None
    weight: float = 1.0
    importance: int = 3

    def __post_init__(self) -> None:
        where = f"response {self.name!r}"
        if not isinstance(self.name, str) or not self.name:
            raise InputError(f"response name must be a non-empty string; got {self.name!r}")
        if self.goal not in GOALS:
            raise InputError(f"{where}: goal must be one of {', '.join(GOALS)}; "
                             f"got {self.goal!r}")
        low = finite_number(self.low, f"{where}: low")
        high = finite_number(self.high, f"{where}: high")
        if not low < high:
            raise InputError(f"{where}: low must be < high; got low={low:g}, high={high:g}")
        if self.goal == "target":
            if self.target is None:
                raise InputError(f"{where}: goal 'target' needs a target value")
            t = finite_number(self.target, f"{where}: target")
            if not low <= t <= high:
                raise InputError(f"{where}: target must be in low..high ({low:g}..{high:g}); "
                                 f"got {t:g}")
        w = finite_number(self.weight, f"{where}: weight")
        if not WEIGHT_RANGE[0] <= w <= WEIGHT_RANGE[1]:
            raise InputError(f"{where}: weight must be in {WEIGHT_RANGE[0]:g}..{WEIGHT_RANGE[1]:g}"
                             f"; got {w:g}")
        imp = self.importance
        if (isinstance(imp, bool) or not isinstance(imp, int | np.integer)
                or not IMPORTANCE_RANGE[0] <= imp <= IMPORTANCE_RANGE[1]):
            raise InputError(f"{where}: importance must be an integer in "
                             f"{IMPORTANCE_RANGE[0]}..{IMPORTANCE_RANGE[1]}; got {imp!r}")

    def desirability(self, y: Any) -> np.ndarray:
        """Individual desirability d in [0, 1] of responses ``y`` (same shape)."""
        y = np.asarray(y, dtype=float)
        lo, hi, w = float(self.low), float(self.high), float(self.weight)
        inside = (y >= lo) & (y <= hi)
        if self.goal == "in_range":
            return inside.astype(float)
        if self.goal == "maximize":
            return np.where(y >= hi, 1.0, np.where(inside, ((y - lo) / (hi - lo)) ** w, 0.0))
        if self.goal == "minimize":
            return np.where(y <= lo, 1.0, np.where(inside, ((hi - y) / (hi - lo)) ** w, 0.0))
        t = float(self.target)  # type: ignore[arg-type]  # validated above
        d = np.zeros_like(y)
        below = inside & (y <= t)
        above = inside & (y > t)
        d[below] = 1.0 if t == lo else ((y[below] - lo) / (t - lo)) ** w
        if t < hi:
            d[above] = ((hi - y[above]) / (hi - t)) ** w
        return d

    def shortfall(self, y: Any) -> np.ndarray:
        """How far ``y`` lies outside the window where d > 0, in units of ``high - low``
        (0 inside it): the gradient the search follows where the overall desirability is 0."""
        y = np.asarray(y, dtype=float)
        lo, hi = float(self.low), float(self.high)
        if self.goal == "maximize":
            gap = np.maximum(lo - y, 0.0)
        elif self.goal == "minimize":
            gap = np.maximum(y - hi, 0.0)
        else:
            gap = np.maximum(lo - y, 0.0) + np.maximum(y - hi, 0.0)
        return gap / (hi - lo)
