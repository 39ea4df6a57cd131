"""The lab's side of a Bayesian calibration: named responses with a mean and a standard error."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from demcal.errors import InputError

__all__ = ["Response", "check_responses"]


@dataclass(frozen=True)
class Response:
    """One measured response the simulation must reproduce.

    Parameters
    ----------
    name : str
        Key of the response in what ``evaluate`` returns (``"aor_deg"``).
    mean : float
        The lab's mean value, in ``unit``.
    standard_error : float
        Standard error of that mean, in ``unit``, > 0: the likelihood's width.
    unit : str, optional
        For display only.

    Raises
    ------
    InputError
        If the name is empty, the mean is not finite, or the standard error is not > 0.
    """

    name: str
    mean: float
    standard_error: float
    unit: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise InputError(f"response name must be a non-empty string; got {self.name!r}")
        if not math.isfinite(float(self.mean)):
            raise InputError(f"response {self.name}: mean must be finite; got {self.mean!r}")
        se = float(self.standard_error)
        if not (math.isfinite(se) and se > 0):
            raise InputError(
                f"response {self.name}: standard_error must be > 0; got {self.standard_error!r}"
            )
        object.__setattr__(self, "mean", float(self.mean))
        object.__setattr__(self, "standard_error", se)


def check_responses(responses: Iterable[Response]) -> tuple[Response, ...]:
    """At least one :class:`Response`, names unique.

    Raises
    ------
    InputError
        If there is none, an item is not a Response, or two share a name.
    """
    items = tuple(responses)
    if not items:
        raise InputError("responses must hold at least one Response; got none")
    names = [r.name for r in items if isinstance(r, Response)]
    if len(names) != len(items):
        raise InputError("responses must be Response objects")
    if len(set(names)) != len(names):
        raise InputError(f"response names must be unique; got {', '.join(names)}")
    return items
