"""Where else the target is met: the spread of the optimize stage's distinct settings that
reach it.

A response surface fitted to one response meets a target along a surface (a line with two
factors), not at one point: every setting on it predicts the target. The optimize stage
returns several distinct settings (ranked, at least ``min_distance`` apart in coded units);
when two or more of them reach the target and differ over a fair part of a factor's range,
the calibrated set is one choice among them, and a user who takes it into another process
(a hopper, a mixer) may get another flow from any of the others. This module says so, with
the numbers: how many settings, and each factor's span among them against its range.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from demcal.doe.goal import REACHED
from demcal.summaries.optimum import Optimum

__all__ = ["FactorSpan", "TargetSpread", "target_spread"]

#: a factor's span among the candidates counts from this fraction of its searched range
MIN_FRACTION = 0.1


@dataclass(frozen=True)
class FactorSpan:
    """One factor's values among the settings that reach the target.

    Attributes
    ----------
    name : str
        The factor.
    low, high : float
        The smallest and largest value among them, SI.
    fraction : float
        ``(high - low)`` over the factor's searched range.
    """

    name: str
    low: float
    high: float
    fraction: float

    def to_summary(self) -> dict[str, Any]:
        """The stored form."""
        return {"name": self.name, "low": self.low, "high": self.high,
                "fraction": self.fraction}


@dataclass(frozen=True)
class TargetSpread:
    """The distinct settings that reach the target, and how far apart they lie.

    Attributes
    ----------
    n : int
        How many of the optimize stage's distinct settings reach the target (>= 2).
    target : float
        The target, the lead response's unit.
    spans : list of FactorSpan
        Each factor whose values among them span at least :data:`MIN_FRACTION` of its
        range, widest first.
    """

    n: int
    target: float
    spans: list[FactorSpan]

    def to_summary(self) -> dict[str, Any]:
        """The result JSON's ``target_spread``."""
        return {"n": self.n, "target": self.target,
                "spans": [s.to_summary() for s in self.spans]}

    @classmethod
    def from_summary(cls, stored: Mapping[str, Any] | None) -> TargetSpread | None:
        """Read a result's ``target_spread`` (None where it has none)."""
        if not stored:
            return None
        return cls(n=int(stored["n"]), target=float(stored["target"]),
                   spans=[FactorSpan(name=str(s["name"]), low=float(s["low"]),
                                     high=float(s["high"]), fraction=float(s["fraction"]))
                          for s in stored.get("spans") or []])

    def line(self, unit: str = " deg") -> str:
        """The finding in one sentence, with what would pin the point."""
        spans = ", ".join(f"{s.name} {s.low:.4g}-{s.high:.4g} ({100 * s.fraction:.0f} % of "
                          "its range)" for s in self.spans)
        return (f"the target is met along a surface, not at one point: {self.n} distinct "
                f"settings predict {self.target:.4g}{unit}, with {spans}; the calibrated set "
                "is one of them. Another response ([[responses]], docs/responses.md) or the "
                "Bayesian strategy (docs/bayes.md) says which combinations the tests pin down")


def target_spread(optimum: Optimum, ranges: Mapping[str, Sequence[float]],
                  reached: float = REACHED) -> TargetSpread | None:
    """The spread of the optimum's candidates that reach the target, or None where fewer
    than two do or none spans :data:`MIN_FRACTION` of a factor's range.

    Parameters
    ----------
    optimum : Optimum
        The optimize stage's summary (its candidates with their desirability; the
        Bayesian strategy's have none, and its posterior says more).
    ranges : mapping of str to (low, high)
        Each factor's searched range, SI.
    reached : float
        The desirability from which a candidate counts as reaching the target.
    """
    if optimum.target is None:
        return None
    hits = [c for c in optimum.candidates
            if c.desirability is not None and c.desirability >= reached]
    if len(hits) < 2:
        return None
    spans = []
    for name, (low, high) in ranges.items():
        values = [c.params[name] for c in hits if name in c.params]
        if len(values) < 2 or not high > low:
            continue
        fraction = (max(values) - min(values)) / (high - low)
        if fraction >= MIN_FRACTION:
            spans.append(FactorSpan(name=name, low=min(values), high=max(values),
                                    fraction=fraction))
    if not spans:
        return None
    return TargetSpread(n=len(hits), target=float(optimum.target),
                        spans=sorted(spans, key=lambda s: -s.fraction))
