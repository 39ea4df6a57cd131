"""What one run returns, typed: its outcome and its named responses.

Every engine and test (demcal's lift test, LAMMPS, the analytic stand-in, an external engine
through a template) hands its finished run to the study as one :class:`RunResult`, whose
constructor keeps only finite numbers as responses; the store keeps each response by name and
the statistics fit one model per response. A response is any finite number a test reports
under a name: the lift test's ``aor_deg`` (deg), ``pile_height_m`` and ``base_diameter_m``
(m), ``bulk_density_kg_m3`` (kg/m^3) and ``mass_left_kg`` (kg) (``demcal.virtual.aor.RESPONSES``);
every number of an external engine's result JSON by its key.

This module imports nothing of demcal, so every layer may use it (like :mod:`demcal.errors`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

__all__ = ["RunResult", "finite_responses"]

def finite_responses(values: Mapping[str, Any]) -> dict[str, float]:
    """The finite real numbers of ``values`` (bools, None, NaN, text and lists dropped), as
    floats: what may be stored and fitted as a response."""
    out: dict[str, float] = {}
    for name, v in values.items():
        if isinstance(v, bool) or not isinstance(v, int | float):
            continue
        fv = float(v)
        if math.isfinite(fv):
            out[str(name)] = fv
    return out


@dataclass(frozen=True)
class RunResult:
    """One finished run.

    Attributes
    ----------
    key : str
        The run's store key.
    outcome : str
        The test's typed outcome (``pile``, ``column``, ``unstable``, an engine failure...).
    responses : dict str -> float
        The run's measured responses by name (finite numbers only; empty for a run that
        measured nothing).
    reason : str or None
        Why the outcome is not a measurement, when it is not.
    wall_time_s : float or None
        Wall time of the run (s).
    detail : dict
        Everything else the test recorded (stored as the run's result JSON).
    worker : dict
        Which process ran it: ``{"pid", "numba_threads"}``.
    """

    key: str
    outcome: str
    responses: dict[str, float] = field(default_factory=dict)
    reason: str | None = None
    wall_time_s: float | None = None
    detail: dict[str, Any] = field(default_factory=dict)
    worker: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        # one place builds a result: every engine's numbers are filtered to finite floats
        object.__setattr__(self, "key", str(self.key))
        object.__setattr__(self, "outcome", str(self.outcome))
        object.__setattr__(self, "responses", finite_responses(self.responses or {}))
        if self.wall_time_s is not None:
            object.__setattr__(self, "wall_time_s", float(self.wall_time_s))
        object.__setattr__(self, "detail", dict(self.detail or {}))

    def value(self, name: str) -> float | None:
        """The response ``name``, or None if the run did not report it."""
        return self.responses.get(name)

    def with_worker(self, worker: Mapping[str, Any]) -> RunResult:
        """The same result, naming the process that ran it."""
        return RunResult(self.key, self.outcome, dict(self.responses), self.reason,
                         self.wall_time_s, dict(self.detail), dict(worker))
