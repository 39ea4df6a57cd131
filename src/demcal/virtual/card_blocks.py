"""What a material card says about how its parameters were found: the engine (``[engine]``)
and the virtual test (``[test]``), the two blocks a run of the card reads, and the particle
they were calibrated with (``[particle_shape]``, informative).

The card's ``[verification]`` and ``[posterior]`` are informative and stay tables
(docs/material_card.md).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Self

from demcal.errors import InputError
from demcal.virtual.config import ROLLING_MODELS

__all__ = ["ENGINE_NAMES", "CardEngine", "CardShape", "CardTest", "flatten", "unflatten"]

#: The engines a card may be for: demcal's own, LAMMPS (docs/lammps.md) or an external engine
#: driven through an input template (docs/external_engines.md).
ENGINE_NAMES = ("demcal", "lammps", "template")


def _written(block: Any) -> dict[str, Any]:
    """The block's fields in order, those that are None left out (TOML has no null)."""
    return {f.name: v for f in dataclasses.fields(block)
            if (v := getattr(block, f.name)) is not None}


def _text(table: Mapping[str, Any], key: str, where: str) -> str | None:
    """``table[key]`` as a string (None where absent); any other type is an input error."""
    value = table.get(key)
    if value is None or isinstance(value, str):
        return value
    raise InputError(f"{where}.{key} must be a string; got {value!r}")


def _number(table: Mapping[str, Any], key: str, where: str) -> float | None:
    """``table[key]`` as a float (None where absent); anything but a number is an input
    error."""
    value = table.get(key)
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(f"{where}.{key} must be a number; got {value!r}")
    return float(value)


@dataclass(frozen=True)
class CardEngine:
    """The card's ``[engine]``: which engine the parameters are for and how it ran.

    Attributes
    ----------
    name : str
        ``"demcal"``, ``"lammps"`` (the parameters are LAMMPS', docs/lammps.md) or
        ``"template"`` (an external engine's: they mean its contact laws).
    version : str or None
        The demcal version that calibrated the material.
    backend : str or None
        demcal's engine backend (``"auto"``, ``"cpu"``, ``"cuda"``).
    rolling_model : str or None
        ``"A"``, ``"C"`` or ``"none"``; None (an external engine's card) reads as ``"A"``.
    lammps_version : str or None
        The LAMMPS the runs used (engine ``"lammps"``).
    dt_fraction : float or None
        The time step as a fraction of the Rayleigh time step.
    command, template, template_sha256 : str or None
        An external engine's command line, its input template and the template's SHA-256.
    """

    name: str = "demcal"
    version: str | None = None
    backend: str | None = None
    rolling_model: str | None = None
    lammps_version: str | None = None
    dt_fraction: float | None = None
    command: str | None = None
    template: str | None = None
    template_sha256: str | None = None

    @property
    def rolling(self) -> str:
        """The rolling-friction model (``"A"`` where the card names none)."""
        return self.rolling_model or "A"

    @property
    def is_external(self) -> bool:
        """An external engine's (driven through a template): demcal does not know its laws."""
        return self.name not in ("demcal", "lammps")

    def to_table(self) -> dict[str, Any]:
        """The ``[engine]`` keys, in order, where set."""
        return _written(self)

    @classmethod
    def from_table(cls, table: Mapping[str, Any], where: str = "engine") -> Self:
        """Read ``[engine]`` (keys a card of another release adds are left out).

        Raises
        ------
        InputError
            An unknown engine or rolling model, a string that is not one, a time step that
            is not a number.
        """
        name = table.get("name") or "demcal"
        if name not in ENGINE_NAMES:
            raise InputError(f"{where}.name must be one of {', '.join(ENGINE_NAMES)}; got "
                             f"{name!r}")
        rolling = table.get("rolling_model")
        if rolling is not None and rolling not in ROLLING_MODELS:
            raise InputError(f"{where}.rolling_model must be one of "
                             f"{', '.join(ROLLING_MODELS)}; got {rolling!r}")
        texts = {k: _text(table, k, where) for k in (
            "version", "backend", "lammps_version", "command", "template", "template_sha256")}
        return cls(name=name, rolling_model=rolling,
                   dt_fraction=_number(table, "dt_fraction", where), **texts)


@dataclass(frozen=True)
class CardTest:
    """The card's ``[test]``: the virtual test the parameters were calibrated in.

    Attributes
    ----------
    kind : str or None
        ``"aor"`` (the engine's lifted cylinder) or ``"analytic"`` (the stand-in).
    fidelity : str or None
        ``"quick"``, ``"small"``, ``"standard"`` or ``"paper"`` (None: ``"quick"``).
    overrides : dict
        Nested settings of :class:`demcal.virtual.AoRTestConfig` over the fidelity's (the
        fidelity's tube and fill written out, then the study's own), ``{"fill": {"count":
        150}}``.
    """

    kind: str | None = None
    fidelity: str | None = None
    overrides: dict[str, Any] = field(default_factory=dict)

    @property
    def fidelity_name(self) -> str:
        """The fidelity a run of the card uses (``"quick"`` where the card names none)."""
        return self.fidelity or "quick"

    def to_table(self) -> dict[str, Any]:
        """The ``[test]`` keys, in order, where set (``overrides`` always)."""
        return _written(self)

    @classmethod
    def from_table(cls, table: Mapping[str, Any], where: str = "test") -> Self:
        """Read ``[test]``: its overrides nested (a TOML card writes them as dotted keys,
        a JSON card nested).

        Raises
        ------
        InputError
            A kind or fidelity that is not a string, overrides that are not a table.
        """
        overrides = table.get("overrides") or {}
        if not isinstance(overrides, dict):
            raise InputError(f"{where}.overrides must be a table")
        if any(isinstance(v, dict) for v in overrides.values()):
            overrides = flatten(overrides)
        return cls(kind=_text(table, "kind", where), fidelity=_text(table, "fidelity", where),
                   overrides=unflatten(overrides))


@dataclass(frozen=True)
class CardShape:
    """The card's ``[particle_shape]``: the particle the parameters were calibrated with
    (informative: a run takes the particle from the test settings).

    Attributes
    ----------
    template : str or None
        The particle template (``"stalk"``, ``"sphere"``, ...).
    length_m, diameter_m : float or None
        The particle's length and diameter, m.
    n_spheres : int or None
        Spheres per clump.
    size_min, size_max : float or None
        The uniform size factor's range.
    """

    template: str | None = None
    length_m: float | None = None
    diameter_m: float | None = None
    n_spheres: int | None = None
    size_min: float | None = None
    size_max: float | None = None

    def to_table(self) -> dict[str, Any]:
        """The ``[particle_shape]`` keys, in order, where set."""
        return _written(self)

    @classmethod
    def from_table(cls, table: Mapping[str, Any], where: str = "particle_shape") -> Self:
        """Read ``[particle_shape]``.

        Raises
        ------
        InputError
            A template that is not a string, a size that is not a number, a sphere count
            that is not a whole number.
        """
        n = table.get("n_spheres")
        if n is not None and (isinstance(n, bool) or not isinstance(n, int)):
            raise InputError(f"{where}.n_spheres must be a whole number; got {n!r}")
        return cls(template=_text(table, "template", where), n_spheres=n,
                   **{k: _number(table, k, where)
                      for k in ("length_m", "diameter_m", "size_min", "size_max")})


def flatten(d: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested tables as dotted keys: ``{"fill": {"count": 150}}`` -> ``{"fill.count": 150}``."""
    out: dict[str, Any] = {}
    for k, v in d.items():
        key = f"{prefix}.{k}" if prefix else str(k)
        if isinstance(v, Mapping):
            out.update(flatten(v, key))
        else:
            out[key] = v
    return out


def unflatten(d: Mapping[str, Any], where: str = "test.overrides") -> dict[str, Any]:
    """Dotted keys as nested tables (:func:`flatten`'s inverse), in order (a later key wins);
    ``where`` names the input in the error for a key below one that holds a value."""
    out: dict[str, Any] = {}
    for key, v in d.items():
        node = out
        parts = str(key).split(".")
        for p in parts[:-1]:
            node = node.setdefault(p, {})
            if not isinstance(node, dict):
                raise InputError(f"{where}: {key!r} sets a key of {p!r}, which is a "
                                 "value, not a table")
        node[parts[-1]] = v
    return out
