"""The range-finding stage's typed summary: each factor scanned at the others' centre, the
part of its range where the test measures, and whether the lab value lies in what it saw."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from demcal.summaries._stored import _Keyed, _KeyedEvery, _read, _stored, stored_as

__all__ = ["RangeFind", "ScanFactor", "ScanPoint", "ScanReach"]


@dataclass(frozen=True)
class ScanPoint(_KeyedEvery):
    """One point of a factor's scan.

    Attributes
    ----------
    value : float
        The factor's value there, its unit.
    outcome : str
        The run's outcome (``pile``: measured).
    response : float or None
        The lead response there (stored as ``aor_deg``); None where the run measured none.
    """

    value: float = 0.0
    outcome: str = ""
    response: float | None = stored_as("aor_deg")

    @property
    def measured(self) -> bool:
        """Whether the run gave the response (an outcome of ``pile`` with a value)."""
        return self.outcome == "pile" and self.response is not None


@dataclass(frozen=True)
class ScanFactor(_Keyed):
    """One factor's scan and the range kept.

    Attributes
    ----------
    name, symbol : str
        The factor.
    low, high : float
        The range scanned (after any move within the hard limits).
    new_low, new_high : float
        The range kept: the longest contiguous run of measured points.
    points : list of ScanPoint
        Every point, in the scan's order.
    reason : str or None
        Why the range was cut (or why nothing was measured); None when kept whole.
    """

    name: str = ""
    symbol: str | None = None
    low: float = 0.0
    high: float = 0.0
    new_low: float = 0.0
    new_high: float = 0.0
    points: list[ScanPoint] = field(default_factory=list)
    reason: str | None = None

    #: written even when None
    ALWAYS = ("symbol", "reason")

    @classmethod
    def from_summary(cls, row: Mapping[str, Any]) -> ScanFactor:
        """Read a stored factor row."""
        items = _read(cls, row)
        items["points"] = [ScanPoint.from_summary(p) for p in items.get("points") or []]
        return cls(**items)


@dataclass(frozen=True)
class ScanReach(_KeyedEvery):
    """Another response than the lead over the scans (a several-response study): the span
    the scans measured and whether its lab value lies in it.

    Attributes
    ----------
    name : str
        The response.
    low, high : float or None
        The smallest and largest value the scans' points measured, its unit (None: none).
    lab : float or None
        Its lab value (None: a goal without one).
    in_range : bool or None
        The lab value between them (None without a lab value or a measured point).
    """

    name: str = ""
    low: float | None = None
    high: float | None = None
    lab: float | None = None
    in_range: bool | None = None


@dataclass(frozen=True)
class RangeFind:
    """The range-finding stage.

    Attributes
    ----------
    fidelity : str or None
        The stage's own test fidelity, where it ran at one.
    factors : list of ScanFactor
    response_min, response_max : float or None
        The smallest and largest lead response the scans measured (stored as
        ``response_min_deg``, ``response_max_deg``); None when none was.
    target_in_range : bool
        Whether the lab value lies between them.
    message : str
        What the stage found and did, in a sentence.
    reach : list of float or None
        A failed stage's reach within the hard limits, [low, high] (stored as
        ``reach_deg``).
    error : str or None
        Why the stage failed.
    responses : list of ScanReach or None
        Every other response over the scans (several responses); None with one.
    """

    fidelity: str | None = None
    factors: list[ScanFactor] = field(default_factory=list)
    response_min: float | None = stored_as("response_min_deg")
    response_max: float | None = stored_as("response_max_deg")
    target_in_range: bool = False
    message: str = ""
    reach: list[float] | None = stored_as("reach_deg")
    error: str | None = None
    responses: list[ScanReach] | None = None

    #: written even when None (no measured point); the others: when not None
    ALWAYS = ("factors", "response_min", "response_max", "target_in_range", "message")

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any] | None) -> RangeFind:
        """Read a stored summary (any release's; empty: not run)."""
        items = _read(cls, summary or {})
        items["factors"] = [ScanFactor.from_summary(f) for f in items.get("factors") or []]
        if items.get("responses") is not None:
            items["responses"] = [ScanReach.from_summary(r) for r in items["responses"]]
        return cls(**items)

    def to_summary(self) -> dict[str, Any]:
        """The stored form: the fields in order, ``fidelity``, ``reach``, ``error`` and
        ``responses`` only where set."""
        return _stored(self, self.ALWAYS)

    @property
    def done(self) -> bool:
        """Whether any factor was scanned."""
        return bool(self.factors)

    def factor(self, name: str) -> ScanFactor | None:
        """The scan of factor ``name``, if it was scanned."""
        return next((f for f in self.factors if f.name == name), None)
