"""What made a study's runs: the store's meta ``versions`` and ``engine``, typed.

The calibration writes both once per study (``demcal.calibrate.pipeline``); the report's
provenance line and the material card's ``[engine]`` read them back. Stores of every release
read: a key a store lacks takes None.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from demcal.summaries._stored import _Keyed

__all__ = ["BUILT_IN_ENGINES", "EngineMeta", "Versions"]

#: the engines whose contact laws demcal writes itself (its own, and LAMMPS through its
#: backend); any other kind is an external engine run through a template
BUILT_IN_ENGINES = ("demcal", "lammps")


@dataclass(frozen=True)
class Versions(_Keyed):
    """The software that made a study's runs (meta ``versions``).

    Attributes
    ----------
    demcal, python, numpy : str or None
        Their versions.
    engine_backend : str or None
        The study's ``backend`` (auto, cpu, cuda).
    engine : str or None
        The engine of the virtual test: ``demcal`` or ``lammps``.
    lammps : str or None
        The version ``lmp -h`` names, with the LAMMPS engine only.
    """

    ALWAYS = ("demcal", "python", "numpy", "engine_backend", "engine")

    demcal: str | None = None
    python: str | None = None
    numpy: str | None = None
    engine_backend: str | None = None
    engine: str | None = None
    lammps: str | None = None

    def line(self) -> str:
        """``"demcal 0.4, python 3.12.3, ..."``: every version the store holds."""
        return ", ".join(f"{k} {v}" for k, v in self.to_summary().items() if v is not None)


@dataclass(frozen=True)
class EngineMeta(_Keyed):
    """Which engine produced a study's runs (meta ``engine``).

    Attributes
    ----------
    kind : str or None
        ``demcal``, ``lammps``, or an external engine's kind (``template``).
    name : str or None
        For people: the kind, or ``"template: <command>"``.
    backend : str or None
        demcal's backend (built-in engines only).
    command : list of str or None
        An external engine's command line.
    template : str or None
        Its input template's path ...
    template_sha256 : str or None
        ... and that file's SHA-256, as the runs used it.
    result : dict or None
        How its result is read (the study's ``[engine.result]`` settings).
    """

    ALWAYS = ("kind", "name")

    kind: str | None = None
    name: str | None = None
    backend: str | None = None
    command: list[str] | None = None
    template: str | None = None
    template_sha256: str | None = None
    result: dict[str, Any] | None = None

    @property
    def external(self) -> bool:
        """True where a user's engine (not demcal's, not LAMMPS) made the runs."""
        return self.kind is not None and self.kind not in BUILT_IN_ENGINES
