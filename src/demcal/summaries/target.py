"""The lab's angle a study aims at: the store's meta ``target``, typed.

The calibration resolves it once (``demcal.calibrate.pipeline.resolve_target``: from a value,
the pile photos or a measurements file); the angle's response (``calibrate.responses``), the
report's measurement section and the material card read it back. Stores of every release
read: a key a store lacks takes its default.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from demcal.summaries._stored import _KeyedEvery, _read

__all__ = ["Target", "TargetPhoto"]


@dataclass(frozen=True)
class TargetPhoto(_KeyedEvery):
    """One pile photo's measured angle (deg).

    Attributes
    ----------
    file : str or None
        The photo.
    left_deg, right_deg, mean_deg : float or None
        Its left and right flanks' angles and their mean.
    figure : str or None
        The diagnostic figure (PNG) the calibration saved, if any.
    """

    file: str | None = None
    left_deg: float | None = None
    right_deg: float | None = None
    mean_deg: float | None = None
    figure: str | None = None


@dataclass(frozen=True)
class Target(_KeyedEvery):
    """The angle of repose the study calibrates against.

    Attributes
    ----------
    aor_deg : float or None
        Its mean, deg.
    std_deg : float or None
        Its standard deviation between the lab's repeats, deg (None: one repeat, or not given).
    n : int or None
        How many repeats (photos).
    source : str or None
        ``"value"`` (a number or a measurements file) or ``"photos"``.
    photos : list of TargetPhoto
        Each photo's angles, with ``source = "photos"``.
    """

    aor_deg: float | None = None
    std_deg: float | None = None
    n: int | None = None
    source: str | None = None
    photos: list[TargetPhoto] = field(default_factory=list)

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any] | None) -> Target:
        """Read the stored form (any release's)."""
        items = _read(cls, summary or {})
        items["photos"] = [TargetPhoto.from_summary(p) for p in items.get("photos") or []
                           if isinstance(p, Mapping)]
        return cls(**items)
