"""The steepest path's typed summary: the path from the screening model toward the lab
value, its best step, the response surface's levels around it, and where the path ran at a
cheaper test, the anchor at the study's own."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from demcal.summaries._stored import _Keyed, _read, _stored, stored_as

__all__ = ["Anchor", "AnchorRun", "PathStep", "Steepest"]


@dataclass(frozen=True)
class PathStep(_Keyed):
    """One step of the path and its (mean) lead response.

    Attributes
    ----------
    step : int
        0 at the path's start.
    actual : dict str -> float
        The path's factors there, their units.
    value : float or None
        The lead response's mean over the replicates (stored as ``aor_deg``); None where a
        replicate measured none.
    outcome : str
    relative_error_percent : float or None
        ``|value - lab| / lab``, %.
    responses : dict str -> float or None, or None
        With several responses: each one's mean there (None: not every replicate gave it).
    desirability : float or None
        With several responses: the overall desirability of those means (stored with them).
    """

    step: int = 0
    actual: dict[str, float] = field(default_factory=dict)
    value: float | None = stored_as("aor_deg")
    outcome: str = ""
    relative_error_percent: float | None = None
    responses: dict[str, float | None] | None = None
    desirability: float | None = None

    def to_summary(self) -> dict[str, Any]:
        """The stored form; ``responses`` and ``desirability`` together, with several."""
        out = _stored(self, ("step", "actual", "value", "outcome", "relative_error_percent"))
        if self.responses is not None:
            out["desirability"] = self.desirability
        return out


@dataclass(frozen=True)
class AnchorRun(_Keyed):
    """One run of the study's own test at a path point.

    Attributes
    ----------
    step : int
    actual : dict str -> float
    value : float or None
        The study's test there (stored as ``aor_deg``); None: not measured.
    outcome : str
    path_value : float or None
        The path's cheaper test at the same point (stored as ``path_aor_deg``).
    """

    step: int = 0
    actual: dict[str, float] = field(default_factory=dict)
    value: float | None = stored_as("aor_deg")
    outcome: str = ""
    path_value: float | None = stored_as("path_aor_deg")

    #: written even when None
    ALWAYS = ("value", "path_value")


@dataclass(frozen=True)
class Anchor(_Keyed):
    """The path anchored at the study's own test (:mod:`demcal.calibrate.anchor`).

    Attributes
    ----------
    fidelity : str or None
        The study's test fidelity.
    runs : list of AnchorRun
    crossing_step : float or None
        Where that test crosses the lab value along the path (None: not bracketed).
    centre_step : float
        The step the response surface is centred on.
    offset : float or None
        The study's test less the path's, pooled (stored as ``offset_deg``).
    message : str
    """

    fidelity: str | None = None
    runs: list[AnchorRun] = field(default_factory=list)
    crossing_step: float | None = None
    centre_step: float = 0.0
    offset: float | None = stored_as("offset_deg")
    message: str = ""

    #: written even when None
    ALWAYS = ("fidelity", "crossing_step", "offset")

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any]) -> Anchor:
        """Read a stored anchor."""
        items = _read(cls, summary)
        items["runs"] = [AnchorRun.from_summary(r) for r in items.get("runs") or []]
        return cls(**items)


@dataclass(frozen=True)
class Steepest:
    """The steepest path (or, where it is disabled, only the surface's levels).

    Attributes
    ----------
    fidelity : str or None
        The stage's own test fidelity, where it ran at one.
    factors : list of str or None
        The path's factors (screening's selection); None where the path did not run.
    direction : dict str -> int or None
        +1 where a factor goes up along the path, -1 where down.
    steps : list of PathStep or None
    best_step : int or None
    centre : dict str -> float or None
        The response surface's centre.
    levels : dict str -> list of float
        Per factor, the response surface's [low, centre, high].
    message : str or None
    anchor : Anchor or None
        Where the path ran at a cheaper test and was anchored at the study's.
    followed : list of str or None
        With several responses: those whose overall desirability the path climbed.
    climb : dict or None
        With several responses: the climb's gradient and goals
        (:meth:`demcal.calibrate.several.PathClimb.summary`).
    error : str or None
        Why the stage failed.
    """

    fidelity: str | None = None
    factors: list[str] | None = None
    direction: dict[str, int] | None = None
    steps: list[PathStep] | None = None
    best_step: int | None = None
    centre: dict[str, float] | None = None
    levels: dict[str, list[float]] = field(default_factory=dict)
    message: str | None = None
    anchor: Anchor | None = None
    followed: list[str] | None = None
    climb: dict[str, Any] | None = None
    error: str | None = None

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any] | None) -> Steepest:
        """Read a stored summary (any release's; empty: not run)."""
        items = _read(cls, summary or {})
        if items.get("steps") is not None:
            items["steps"] = [PathStep.from_summary(s) for s in items["steps"]]
        if items.get("anchor") is not None:
            items["anchor"] = Anchor.from_summary(items["anchor"])
        items["levels"] = items.get("levels") or {}
        return cls(**items)

    def to_summary(self) -> dict[str, Any]:
        """The stored form: each field where set (a failed stage's: its error alone)."""
        out = _stored(self)
        if self.error is not None and not self.levels:
            out.pop("levels", None)
        return out

    @property
    def ran(self) -> bool:
        """Whether the path was run (a disabled stage only sets the surface's levels)."""
        return self.steps is not None
