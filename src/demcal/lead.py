"""How a study's lead response is named for people, in one place.

The console's result lines, the stages' messages, the report and the material card all name
the response a study leads with (the angle of repose unless the study says otherwise,
docs/responses.md) and write its unit after a number; they take both from :class:`LeadName`.

This module imports nothing of demcal, so every layer may use it (like :mod:`demcal.results`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["ANGLE", "LeadName"]

#: the angle of repose's response name
ANGLE = "aor_deg"


@dataclass(frozen=True)
class LeadName:
    """A lead response's name and unit, and how people read them.

    Attributes
    ----------
    name : str
        The response's name (``aor_deg``: the angle of repose).
    unit : str
        Its unit (``deg`` for the angle; ``""`` for none).
    """

    name: str = ANGLE
    unit: str = "deg"

    @classmethod
    def of_result(cls, result: Mapping[str, Any]) -> LeadName:
        """The lead of a result JSON (its ``lead``: name and unit, written where the lead is not
        the angle; without it, the angle)."""
        lead = result.get("lead")
        if not lead:
            return cls()
        return cls(name=str(lead["name"]), unit=str(lead.get("unit") or ""))

    @property
    def is_angle(self) -> bool:
        """Whether the lead is the angle of repose."""
        return self.name == ANGLE

    @property
    def label(self) -> str:
        """As a table or a card labels it: ``AoR`` for the angle, else the response's name."""
        return "AoR" if self.is_angle else self.name

    @property
    def words(self) -> str:
        """As a sentence names it: ``the AoR`` for the angle, else the response's name."""
        return "the AoR" if self.is_angle else self.name

    def after_number(self, *, degree_sign: bool = False) -> str:
        """What follows a number of it: `` deg`` for the angle (``°`` with ``degree_sign``),
        `` <unit>`` for another response, ``""`` for one without a unit."""
        if self.is_angle and degree_sign:
            return "°"
        return f" {self.unit}" if self.unit else ""
