"""A design point of a designed stage (screening, the response surface) as stored: its
settings and its lead response over the replicates."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from demcal.summaries._stored import _Keyed, _stored, stored_as

__all__ = ["DesignRun", "design_runs"]


@dataclass(frozen=True)
class DesignRun(_Keyed):
    """One design point and the lead response measured there.

    Attributes
    ----------
    point : int
        The design row.
    coded, actual : dict str -> float
        The factors' settings, coded (-1..+1) and in their own units.
    value : float or None
        The lead response's mean over the replicates, its unit (stored as ``aor_deg``);
        None where a replicate gave no value (the point is excluded from the fit).
    outcome : str
        ``pile`` (every replicate measured), else the first replicate's outcome that was not,
        or ``missing``.
    replicates : list of float or None
        Each replicate's value in replicate order (empty: excluded; stored as
        ``aor_runs_deg``); None in summaries of releases that did not store them.
    replicate_std : float or None
        Their sample standard deviation (None with one replicate; stored as ``aor_std_deg``,
        beside ``replicates``).
    """

    point: int = 0
    coded: dict[str, float] = field(default_factory=dict)
    actual: dict[str, float] = field(default_factory=dict)
    value: float | None = stored_as("aor_deg")
    outcome: str = ""
    replicates: list[float] | None = stored_as("aor_runs_deg")
    replicate_std: float | None = stored_as("aor_std_deg")

    def to_summary(self) -> dict[str, Any]:
        """The stored form: ``replicates`` and ``replicate_std`` together, where the
        replicates are known."""
        out = _stored(self, ("point", "coded", "actual", "value", "outcome"))
        if self.replicates is not None:
            out["aor_std_deg"] = self.replicate_std
        return out


def design_runs(rows: Any) -> list[DesignRun]:
    """Stored rows (or typed ones) as :class:`DesignRun`\\ s; none for a summary without."""
    return [r if isinstance(r, DesignRun) else DesignRun.from_summary(r) for r in rows or []]
