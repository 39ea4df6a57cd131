"""What a material card says about how its parameters were found: the engine (``[engine]``)
and the virtual test (``[test]``), the two blocks a run of the card reads; the particle they
were calibrated with (``[particle_shape]``), the verification (``[verification]``) and a
Bayesian calibration's posterior (``[posterior]``), which are informative (docs/material_card.md).

Each block is a frozen dataclass whose field names are the card's keys, in the order the card
writes them; ``to_table`` gives the keys that are set and ``from_table`` reads them back,
checking each key's type (keys a card of another release adds are left out).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Self

from demcal.errors import InputError
from demcal.virtual.config import ROLLING_MODELS

__all__ = ["ENGINE_NAMES", "CardEngine", "CardInterval", "CardPosterior", "CardResponseCheck",
           "CardShape", "CardTest", "CardVerification", "flatten", "number", "unflatten"]

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


def number(table: Mapping[str, Any], key: str, where: str) -> float | None:
    """``table[key]`` as a float (None where absent); anything but a number is an input
    error naming ``where.key``."""
    value = table.get(key)
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(f"{where}.{key} must be a number; got {value!r}")
    return float(value)


def _whole(table: Mapping[str, Any], key: str, where: str) -> int | None:
    """``table[key]`` as an int (None where absent); anything but a whole number is an input
    error."""
    value = table.get(key)
    if value is not None and (isinstance(value, bool) or not isinstance(value, int)):
        raise InputError(f"{where}.{key} must be a whole number; got {value!r}")
    return value


def _flag(table: Mapping[str, Any], key: str, where: str) -> bool | None:
    """``table[key]`` as a bool (None where absent); anything else is an input error."""
    value = table.get(key)
    if value is not None and not isinstance(value, bool):
        raise InputError(f"{where}.{key} must be true or false; got {value!r}")
    return value


def _texts(table: Mapping[str, Any], key: str, where: str) -> list[str] | None:
    """``table[key]`` as a list of strings (None where absent)."""
    value = table.get(key)
    if value is None:
        return None
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise InputError(f"{where}.{key} must be a list of strings; got {value!r}")
    return list(value)


def _subtables(table: Mapping[str, Any], key: str, where: str) -> dict[str, Mapping[str, Any]]:
    """``table[key]``: a table of tables, by name ({} where absent)."""
    value = table.get(key) or {}
    if not isinstance(value, Mapping) or not all(isinstance(v, Mapping)
                                                 for v in value.values()):
        raise InputError(f"{where}.{key} must be a table of tables")
    return {str(k): v for k, v in value.items()}


def _read_fields(cls: Any, table: Mapping[str, Any], where: str) -> dict[str, Any]:
    """The scalar fields of the dataclass ``cls`` read from ``table`` by their annotated
    type (``str``, ``int``, ``bool``, else a number); the others are the caller's."""
    readers = {"str | None": _text, "int | None": _whole, "bool | None": _flag,
               "float | None": number}
    return {f.name: readers[f.type](table, f.name, where) for f in dataclasses.fields(cls)
            if f.type in readers}


class _ScalarBlock:
    """A block of scalar keys only (a dataclass of ``str``, ``int``, ``bool`` and number
    fields, each None where the card leaves it out): written and read field by field."""

    def to_table(self) -> dict[str, Any]:
        """The keys, in order, where set."""
        return _written(self)

    @classmethod
    def from_table(cls, table: Mapping[str, Any], where: str) -> Self:
        """Read the block, each key's type checked (``where`` names it in the error)."""
        return cls(**_read_fields(cls, table, where))


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
        return cls(name=name, **_read_fields(cls, table, where))


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
class CardShape(_ScalarBlock):
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

    @classmethod
    def from_table(cls, table: Mapping[str, Any], where: str = "particle_shape") -> Self:
        """Read ``[particle_shape]``.

        Raises
        ------
        InputError
            A template that is not a string, a size that is not a number, a sphere count
            that is not a whole number.
        """
        return super().from_table(table, where)


@dataclass(frozen=True)
class CardResponseCheck(_ScalarBlock):
    """One response of ``[verification.responses.NAME]`` (a several-response study): its lab
    value, the surface's prediction and the verification, in the response's unit.

    Attributes
    ----------
    lab, predicted, mean, std : float or None
        The lab mean, the prediction at the optimum, the verified mean and its standard
        deviation.
    n : int or None
        The verification's runs.
    relative_error_percent : float or None
        ``|mean - lab| / lab``, %.
    consistent : bool or None
        Whether the verified mean is consistent with the lab's (Welch's test).
    """

    lab: float | None = None
    predicted: float | None = None
    mean: float | None = None
    std: float | None = None
    n: int | None = None
    relative_error_percent: float | None = None
    consistent: bool | None = None


@dataclass(frozen=True)
class CardVerification:
    """The card's ``[verification]``: one line and the numbers behind it. The lead response's
    values are under the angle's keys (``aor_mean_deg``) whatever the lead (``lead`` names it
    where it is not the angle), as in the result JSON.

    Attributes
    ----------
    line : str
        The verification in one sentence (``"not verified"`` without runs).
    lead : str or None
        The lead response where it is not the angle.
    aor_mean_deg, aor_std_deg : float or None
        The verified mean and its standard deviation, the lead's unit.
    n : int or None
        The verification's runs.
    relative_error_percent, p_value : float or None
        Against the lab's mean: ``|mean - lab| / lab`` (%) and Welch's p.
    consistent, confirmed, target_in_interval : bool or None
        Welch's verdict, the surface's prediction interval holding the mean, the lab's mean
        inside the 95 % interval of the verified one.
    ci_low_deg, ci_high_deg : float or None
        The 95 % interval of the verified mean.
    confirm_pi_low_deg, confirm_pi_high_deg : float or None
        The surface's 95 % prediction interval of the verification's mean.
    target_aor_deg, predicted_aor_deg : float or None
        The lab's mean and the prediction at the optimum.
    desirability : float or None
        The overall desirability at the optimum (several responses).
    responses : dict of str to CardResponseCheck
        Every response's check (several responses; empty otherwise).
    round : int or None
        The refinement round the verification is from (where above 1).
    surface_offset_deg, measured_offset_deg, offset_weight : float or None
        That round's shift of the surface (:mod:`demcal.calibrate.refine`).
    """

    line: str = ""
    lead: str | None = None
    aor_mean_deg: float | None = None
    aor_std_deg: float | None = None
    n: int | None = None
    relative_error_percent: float | None = None
    p_value: float | None = None
    consistent: bool | None = None
    ci_low_deg: float | None = None
    ci_high_deg: float | None = None
    confirm_pi_low_deg: float | None = None
    confirm_pi_high_deg: float | None = None
    confirmed: bool | None = None
    target_in_interval: bool | None = None
    target_aor_deg: float | None = None
    predicted_aor_deg: float | None = None
    desirability: float | None = None
    responses: dict[str, CardResponseCheck] = field(default_factory=dict)
    round: int | None = None
    surface_offset_deg: float | None = None
    measured_offset_deg: float | None = None
    offset_weight: float | None = None

    def to_table(self) -> dict[str, Any]:
        """The keys, in order, where set; ``responses`` (a table per response) where any."""
        out = _written(self)
        if self.responses:
            out["responses"] = {k: r.to_table() for k, r in self.responses.items()}
        else:
            del out["responses"]
        return out

    @classmethod
    def from_table(cls, table: Mapping[str, Any], where: str = "verification") -> Self:
        """Read ``[verification]`` (``line`` absent: an empty one).

        Raises
        ------
        InputError
            A key whose value has the wrong type.
        """
        fields = _read_fields(cls, table, where)
        responses = {name: CardResponseCheck.from_table(row, f"{where}.responses.{name}")
                     for name, row in _subtables(table, "responses", where).items()}
        return cls(line=_text(table, "line", where) or "", responses=responses, **fields)


@dataclass(frozen=True)
class CardInterval(_ScalarBlock):
    """One calibrated parameter's posterior in ``[posterior.parameters.NAME]``, SI."""

    mean: float | None = None
    median: float | None = None
    ci95_low: float | None = None
    ci95_high: float | None = None


@dataclass(frozen=True)
class CardPosterior:
    """The card's ``[posterior]``, from a Bayesian calibration (``[strategy] kind =
    "bayes"``): whether the tests pin every parameter and what each parameter's posterior is.
    Informative: a run takes the values of ``[parameters]``.

    Attributes
    ----------
    identifiable : bool or None
        Whether the tests pin every calibrated parameter.
    reason : str or None
        The verdict in one sentence.
    ridge, advice : list of str or None
        The ridges left (combinations the tests cannot tell apart) and what would shrink each.
    parameters : dict of str to CardInterval
        Each calibrated parameter's mean, median and 95 % credible interval, SI.
    correlation : dict of str to dict of str to float
        The posterior's correlation, per pair of parameters.
    """

    identifiable: bool | None = None
    reason: str | None = None
    ridge: list[str] | None = None
    advice: list[str] | None = None
    parameters: dict[str, CardInterval] = field(default_factory=dict)
    correlation: dict[str, dict[str, float]] = field(default_factory=dict)

    def to_table(self) -> dict[str, Any]:
        """The keys, in order, where set; ``parameters`` and ``correlation`` as a table per
        parameter."""
        out = _written(self)
        out["parameters"] = {k: p.to_table() for k, p in self.parameters.items()}
        return out

    @classmethod
    def from_table(cls, table: Mapping[str, Any], where: str = "posterior") -> Self:
        """Read ``[posterior]``.

        Raises
        ------
        InputError
            A key whose value has the wrong type, a correlation that is not a number.
        """
        params = {name: CardInterval.from_table(row, f"{where}.parameters.{name}")
                  for name, row in _subtables(table, "parameters", where).items()}
        corr = {a: {b: number(row, b, f"{where}.correlation.{a}") for b in row}
                for a, row in _subtables(table, "correlation", where).items()}
        return cls(identifiable=_flag(table, "identifiable", where),
                   reason=_text(table, "reason", where),
                   ridge=_texts(table, "ridge", where), advice=_texts(table, "advice", where),
                   parameters=params, correlation=corr)  # type: ignore[arg-type]


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
