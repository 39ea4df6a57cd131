"""Exceptions shared by every layer of demcal (this module imports nothing).

- :class:`InputError`: bad user input (a file, a parameter, a design); the message names the
  field and the allowed range. The CLI prints it on one line and exits with code 2.
- :class:`SimulationUnstable`: a numerical failure of the DEM engine (NaN, energy blow-up,
  excessive overlap); the message names the world, the simulated time and the likely cause.
- :class:`StoreError`: the run store cannot be used (damaged, not a demcal store, written by a
  newer demcal, or held by another writer); an InputError, so the CLI exits with 2.
- :class:`StudyError`: a calibration study cannot continue (a stage failed, the store is
  inconsistent with the study file).
"""

from __future__ import annotations

from typing import Any

__all__ = ["DemcalError", "InputError", "SimulationUnstable", "StoreError", "StudyError",
           "validation_message"]


def validation_message(exc: Any, prefix: str = "", *, sep: str = "; ",
                       show_input: bool = False) -> str:
    """The one way a pydantic ``ValidationError`` becomes text: ``a.b: message`` per error.

    Parameters
    ----------
    exc : pydantic.ValidationError
    prefix : str
        Put before each field path (e.g. ``"measurements"``).
    sep : str
        Between the errors ("; " for one line).
    show_input : bool
        Add ``; got VALUE`` to a type or range error (not to a failed check, whose message
        already says it, nor to a missing field or a whole table).
    """
    parts = []
    for err in exc.errors():
        loc = ".".join(str(p) for p in (prefix, *err.get("loc", ())) if p != "")
        msg = str(err.get("msg", "invalid value")).removeprefix("Value error, ")
        tail = ""
        got = err.get("input")
        if show_input and err.get("type") not in ("value_error", "missing") \
                and not isinstance(got, dict):
            tail = f"; got {got!r}"
        parts.append(f"{loc}: {msg}{tail}" if loc else f"{msg}{tail}")
    return sep.join(parts)


class DemcalError(Exception):
    """Base class of every error demcal raises on purpose."""


class InputError(DemcalError, ValueError):
    """Invalid user input. The message names the field and the allowed values."""


class StoreError(InputError):
    """The run store cannot be used; the message says why and how to recover."""


class SimulationUnstable(DemcalError, RuntimeError):
    """The DEM engine stopped a run: NaN, energy blow-up or excessive overlap.

    Attributes
    ----------
    world : int or None
        Index of the world (batched simulation) that failed.
    time_s : float or None
        Simulated time of the failure, s.
    """

    def __init__(self, message: str, *, world: int | None = None, time_s: float | None = None):
        super().__init__(message)
        self.world = world
        self.time_s = time_s


class StudyError(DemcalError, RuntimeError):
    """A calibration study cannot continue; the message says why and what to change."""
