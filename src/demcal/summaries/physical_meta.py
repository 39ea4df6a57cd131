"""What the bench measured, as the store keeps it: meta ``physical``'s derived part, typed.

A study with ``[material] measurements`` stores
:meth:`demcal.physical.derive.PhysicalResult.to_dict` under meta ``physical``: the raw
measurements and what was derived from them. The report's Table 1 and its measurements
table read back the parameter table's rows (each parameter's symbol, shown value and
source), each measured quantity's statistics (:meth:`demcal.physical.stats.RepeatSummary.to_dict`)
and the measured angle of repose; those are read here and nowhere else.

Stores of every release read, and so does a crafted one: a key a store lacks takes None,
a row that is not a table is left out, and the values are kept as stored (the report shows
a value that is not a number as blank).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from demcal.summaries._stored import _Keyed, stored_as

__all__ = ["MeasuredQuantity", "PhysicalMeta", "PhysicalTableRow"]


@dataclass(frozen=True)
class MeasuredQuantity(_Keyed):
    """The statistics of one measured quantity's repeats (its unit throughout).

    Attributes
    ----------
    name, unit : str or None
    n_repeats : int or None
        Repeats (or the declared count of a published range).
    range_only : bool or None
        Only the range of the repeats is known.
    mean, std : float or None
        Mean and sample standard deviation.
    minimum, maximum : float or None
        Smallest and largest repeat, or the published range (stored ``min``, ``max``).
    ci_low, ci_high : float or None
        The mean's confidence interval ...
    ci_level : float or None
        ... at this level.
    """

    name: str | None = None
    unit: str | None = None
    n_repeats: int | None = None
    range_only: bool | None = None
    mean: float | None = None
    std: float | None = None
    minimum: float | None = stored_as("min")
    maximum: float | None = stored_as("max")
    ci_low: float | None = None
    ci_high: float | None = None
    ci_level: float | None = None


@dataclass(frozen=True)
class PhysicalTableRow(_Keyed):
    """One row of the bench's parameter table (the paper's Table 1).

    Attributes
    ----------
    name : str or None
        The parameter (``particle.density``).
    symbol : str or None
    display : str or None
        Its value or range as shown, in its display unit.
    source : str or None
        Where it comes from (``measured: 10 repeats ...``, literature, the preset).
    """

    name: str | None = None
    symbol: str | None = None
    display: str | None = None
    source: str | None = None


def _tables(stored: Any) -> list[Mapping[str, Any]]:
    return [r for r in stored or [] if isinstance(r, Mapping)] if isinstance(stored, list) \
        else []


@dataclass(frozen=True)
class PhysicalMeta:
    """The bench's derived values the report shows (meta ``physical``, key ``derived``).

    Attributes
    ----------
    rows : dict of str to PhysicalTableRow
        The parameter table by parameter name.
    summaries : dict of str to MeasuredQuantity
        Each measured quantity's statistics, by its key.
    target_aor : MeasuredQuantity or None
        The measured angle of repose, degrees (None: not measured on the bench).
    """

    rows: dict[str, PhysicalTableRow] = field(default_factory=dict)
    summaries: dict[str, MeasuredQuantity] = field(default_factory=dict)
    target_aor: MeasuredQuantity | None = None

    @classmethod
    def from_summary(cls, stored: Mapping[str, Any] | None) -> PhysicalMeta:
        """Read meta ``physical`` of any release (empty: a study without bench data, or a
        store whose ``physical`` holds no derived part)."""
        derived = (stored or {}).get("derived") if isinstance(stored, Mapping) else None
        if not isinstance(derived, Mapping):
            return cls()
        rows = [PhysicalTableRow.from_summary(r) for r in _tables(derived.get("table"))]
        summaries = derived.get("summaries")
        target = derived.get("target_aor_deg")
        return cls(
            rows={str(r.name): r for r in rows},
            summaries={str(k): MeasuredQuantity.from_summary(v)
                       for k, v in (summaries.items() if isinstance(summaries, Mapping) else ())
                       if isinstance(v, Mapping)},
            target_aor=MeasuredQuantity.from_summary(target) if isinstance(target, Mapping)
            else None)
