"""What the study file asked for, as the store keeps it: meta ``study`` and ``factors``, typed.

The calibration writes the validated study (``Study.model_dump``) and its factors once per
study (``demcal.calibrate.pipeline``); the report, the material card and ``demcal report``
read back the few settings they show: the study's name, its test and fidelity, its material
preset and overrides, the backend, the engine, which stages it turned off. Those are read
here and nowhere else, so a renamed study field breaks this module's test, not a cell of the
report.

Stores of every release read: a key a store lacks (or holds as None) takes the default the
study file has for it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from demcal.summaries._stored import _KeyedEvery

__all__ = ["StudyFactor", "StudyMaterial", "StudyMeta", "StudyTest"]


def _section(stored: Mapping[str, Any] | None, key: str) -> dict[str, Any]:
    """``stored[key]`` where it is a table, else {} (an old or crafted store)."""
    value = (stored or {}).get(key)
    return dict(value) if isinstance(value, Mapping) else {}


@dataclass(frozen=True)
class StudyFactor(_KeyedEvery):
    """One factor of the study and its range as the study gave it (meta ``factors``).

    Attributes
    ----------
    name : str
        The parameter (``pp.static_friction``).
    symbol : str or None
        Its paper-style symbol (``x3``).
    low, high : float or None
        The range, SI units.
    unit : str or None
        The unit of ``low`` and ``high``.
    """

    name: str = ""
    symbol: str | None = None
    low: float | None = None
    high: float | None = None
    unit: str | None = None


@dataclass(frozen=True)
class StudyTest:
    """The study's ``[test]``: which virtual test, at which fidelity, with which overrides.

    Attributes
    ----------
    kind : str
        ``aor`` (the lifted cylinder) or ``analytic``.
    fidelity : str
        ``quick``, ``small``, ``standard`` or ``paper``.
    overrides : dict
        The fidelity's settings the study changed (``rolling_model``, ``n_particles``, ...).
    """

    kind: str = "aor"
    fidelity: str = "quick"
    overrides: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class StudyMaterial:
    """The study's ``[material]``: the preset of its fixed values and what it overrode.

    Attributes
    ----------
    preset : str or None
        The material preset (``corn_stalk``); None in a store that names none.
    overrides : dict of str to float
        Fixed values the study file set itself, SI units.
    """

    preset: str | None = None
    overrides: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class StudyMeta:
    """The study settings the report and the material card show (meta ``study``).

    Attributes
    ----------
    name : str or None
        The study's name (None: the report names it after its folder).
    backend : str
        demcal's backend: ``auto``, ``cpu`` or ``cuda``.
    engine : str
        ``[executor] engine``: ``demcal`` or ``lammps``.
    test : StudyTest
    material : StudyMaterial
    disabled_stages : tuple of str
        The stages the study turned off (``enabled = false``).
    """

    name: str | None = None
    backend: str = "auto"
    engine: str = "demcal"
    test: StudyTest = StudyTest()
    material: StudyMaterial = StudyMaterial()
    disabled_stages: tuple[str, ...] = ()

    @classmethod
    def from_summary(cls, stored: Mapping[str, Any] | None) -> StudyMeta:
        """Read meta ``study`` (a dump of the validated study) of any release."""
        study = dict(stored or {})
        test, material = _section(study, "test"), _section(study, "material")
        stages = _section(study, "stages")
        return cls(
            name=str(study["name"]) if study.get("name") else None,
            backend=str(study.get("backend") or "auto"),
            engine=str(_section(study, "executor").get("engine") or "demcal"),
            test=StudyTest(kind=str(test.get("kind") or "aor"),
                           fidelity=str(test.get("fidelity") or "quick"),
                           overrides=_section(test, "overrides")),
            material=StudyMaterial(preset=str(material["preset"]) if material.get("preset")
                                   else None, overrides=_section(material, "overrides")),
            disabled_stages=tuple(str(name) for name, conf in stages.items()
                                  if isinstance(conf, Mapping) and conf.get("enabled") is False))
