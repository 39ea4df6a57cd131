"""Factors of a designed experiment and the coding between actual and coded units.

A factor is varied between a low and a high level. Designs and models work in *coded* units,
where the low level is -1, the high level +1 and the centre 0::

    coded = (actual - centre) / half_range,   centre = (low + high) / 2,
    half_range = (high - low) / 2

A factor may be *fixed*: it keeps one actual value in every run (for example the parameters
that the paper's steepest-ascent and Box-Behnken stages hold "at intermediate values").
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from demcal.errors import InputError
from demcal.safety import regular_input

__all__ = ["Factor", "FactorSpace", "as_factor_space", "finite_number", "load_factors"]

#: largest |low| or |high| of a factor: its designs' levels (axial points beyond the range)
#: and its model's squares stay finite
MAX_FACTOR_VALUE = 1e150


def finite_number(value: Any, field: str) -> float:
    """``value`` as a float if it is a finite number, else an InputError naming ``field``."""
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{field} must be a number; got {value!r}") from None
    if not math.isfinite(out):
        raise InputError(f"{field} must be finite; got {value!r}")
    return out


@dataclass(frozen=True)
class Factor:
    """One factor: a name and the actual values of its low and high levels.

    Parameters
    ----------
    name : str
        Identifier used for columns and model terms (``"x3"``, ``"pp.static_friction"``).
    low, high : float
        Actual values of the coded levels -1 and +1, in the factor's unit; ``low < high``.
    unit : str, optional
        Unit of the actual values, for display only (``""`` for dimensionless).
    fixed : float or None, optional
        If given, the factor is held at this actual value and not varied by designs.
    description : str, optional
        Free text (``"CCS-CCS static friction coefficient"``).

    Raises
    ------
    InputError
        If the name is empty, a level is not finite, ``low >= high`` or ``fixed`` is not finite.
    """

    name: str
    low: float
    high: float
    unit: str = ""
    fixed: float | None = None
    description: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise InputError(f"factor name must be a non-empty string; got {self.name!r}")
        low = finite_number(self.low, f"low of factor {self.name}")
        high = finite_number(self.high, f"high of factor {self.name}")
        if not low < high:
            raise InputError(
                f"low must be < high for factor {self.name}; got low={low:g}, high={high:g}"
            )
        if not math.isfinite(high - low) or max(abs(low), abs(high)) > MAX_FACTOR_VALUE:
            # a +-1e308 range overflowed to inf levels (a sheet of inf, exit 0)
            raise InputError(f"factor {self.name}: low and high must lie within "
                             f"+-{MAX_FACTOR_VALUE:g}; got low={low:g}, high={high:g}")
        object.__setattr__(self, "low", low)
        object.__setattr__(self, "high", high)
        if self.fixed is not None:
            object.__setattr__(self, "fixed",
                               finite_number(self.fixed, f"fixed of factor {self.name}"))

    @property
    def center(self) -> float:
        """Actual value of the coded level 0, ``(low + high) / 2``."""
        return 0.5 * (self.low + self.high)

    @property
    def half_range(self) -> float:
        """Actual distance between the centre and a level, ``(high - low) / 2``."""
        return 0.5 * (self.high - self.low)

    @property
    def is_fixed(self) -> bool:
        """True if the factor is held at :attr:`fixed`."""
        return self.fixed is not None

    def to_coded(self, actual: Any) -> Any:
        """Convert actual values to coded units: ``(actual - center) / half_range``.

        Parameters
        ----------
        actual : float or ndarray of float
            Values in the factor's unit.

        Returns
        -------
        float or ndarray of float64
            Same shape as ``actual``; -1 at ``low``, +1 at ``high``.
        """
        return (np.asarray(actual, dtype=float) - self.center) / self.half_range

    def to_actual(self, coded: Any) -> Any:
        """Convert coded values to actual units: ``center + coded * half_range``.

        Parameters
        ----------
        coded : float or ndarray of float
            Values in coded units.

        Returns
        -------
        float or ndarray of float64
            Same shape as ``coded``, in the factor's unit.
        """
        return self.center + np.asarray(coded, dtype=float) * self.half_range


class FactorSpace(Sequence[Factor]):
    """An ordered set of factors with unique names; converts whole design matrices.

    Parameters
    ----------
    factors : iterable of Factor
        At least one factor; names must be unique.

    Raises
    ------
    InputError
        If there is no factor, an element is not a :class:`Factor`, or two share a name.
    """

    __slots__ = ("_factors", "_index")

    def __init__(self, factors: Iterable[Factor]):
        items = tuple(factors)
        if not items:
            raise InputError("factors must hold at least one factor; got none")
        for f in items:
            if not isinstance(f, Factor):
                raise InputError(f"factors must be Factor objects; got {type(f).__name__}")
        index: dict[str, int] = {}
        for i, f in enumerate(items):
            if f.name in index:
                raise InputError(f"factor names must be unique; {f.name!r} appears twice")
            index[f.name] = i
        self._factors = items
        self._index = index

    # Sequence protocol
    def __len__(self) -> int:
        return len(self._factors)

    def __getitem__(self, key: Any) -> Any:  # int, slice or name
        if isinstance(key, str):
            try:
                return self._factors[self._index[key]]
            except KeyError:
                raise InputError(
                    f"unknown factor {key!r}; known factors: {', '.join(self.names)}"
                ) from None
        return self._factors[key]

    def __iter__(self) -> Iterator[Factor]:
        return iter(self._factors)

    def __contains__(self, item: object) -> bool:
        if isinstance(item, str):
            return item in self._index
        return item in self._factors

    def __eq__(self, other: object) -> bool:
        return isinstance(other, FactorSpace) and self._factors == other._factors

    def __hash__(self) -> int:
        return hash(self._factors)

    def __repr__(self) -> str:
        return f"FactorSpace({list(self._factors)!r})"

    @property
    def names(self) -> tuple[str, ...]:
        """Factor names, in order."""
        return tuple(f.name for f in self._factors)

    @property
    def free(self) -> FactorSpace:
        """The factors that are not fixed (the ones a design varies)."""
        free = [f for f in self._factors if not f.is_fixed]
        if not free:
            raise InputError("every factor is fixed; at least one must vary")
        return FactorSpace(free)

    @property
    def low(self) -> np.ndarray:
        """(n_factors,) float64 ndarray: actual low levels."""
        return np.array([f.low for f in self._factors])

    @property
    def high(self) -> np.ndarray:
        """(n_factors,) float64 ndarray: actual high levels."""
        return np.array([f.high for f in self._factors])

    @property
    def center(self) -> np.ndarray:
        """(n_factors,) float64 ndarray: actual centres."""
        return np.array([f.center for f in self._factors])

    @property
    def half_range(self) -> np.ndarray:
        """(n_factors,) float64 ndarray: actual half ranges."""
        return np.array([f.half_range for f in self._factors])

    def index(self, name: str) -> int:  # type: ignore[override]
        """Position of the factor called ``name``."""
        if name not in self._index:
            raise InputError(f"unknown factor {name!r}; known factors: {', '.join(self.names)}")
        return self._index[name]

    def subset(self, names: Sequence[str]) -> FactorSpace:
        """The factors called ``names``, in that order."""
        return FactorSpace(self[n] for n in names)

    def _matrix(self, values: Any, what: str) -> np.ndarray:
        arr = np.asarray(values, dtype=float)
        one = arr.ndim == 1
        arr2 = arr.reshape(1, -1) if one else arr
        if arr2.ndim != 2 or arr2.shape[1] != len(self):
            raise InputError(
                f"{what} must have {len(self)} columns ({', '.join(self.names)}); "
                f"got shape {arr.shape}"
            )
        return arr2

    def to_coded(self, actual: Any) -> np.ndarray:
        """Convert a matrix of actual values to coded units.

        Parameters
        ----------
        actual : (n_runs, n_factors) or (n_factors,) array_like of float
            Columns in the order of :attr:`names`.

        Returns
        -------
        ndarray of float64
            Same shape as ``actual``.
        """
        arr = np.asarray(actual, dtype=float)
        out = (self._matrix(arr, "actual values") - self.center) / self.half_range
        return out.reshape(arr.shape)

    def to_actual(self, coded: Any) -> np.ndarray:
        """Convert a matrix of coded values to actual units.

        Parameters
        ----------
        coded : (n_runs, n_factors) or (n_factors,) array_like of float
            Columns in the order of :attr:`names`.

        Returns
        -------
        ndarray of float64
            Same shape as ``coded``.
        """
        arr = np.asarray(coded, dtype=float)
        out = self.center + self._matrix(arr, "coded values") * self.half_range
        return out.reshape(arr.shape)

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """Plain-data form, the inverse of :func:`load_factors`'s table layout."""
        out: dict[str, dict[str, Any]] = {}
        for f in self._factors:
            d: dict[str, Any] = {"low": f.low, "high": f.high}
            if f.unit:
                d["unit"] = f.unit
            if f.fixed is not None:
                d["fixed"] = f.fixed
            if f.description:
                d["description"] = f.description
            out[f.name] = d
        return out


def as_factor_space(factors: Any, *, n_expected: int | None = None) -> FactorSpace:
    """Coerce a FactorSpace, a sequence of Factor, or a mapping name -> (low, high)."""
    if isinstance(factors, FactorSpace):
        space = factors
    elif isinstance(factors, Mapping):
        items = []
        for name, spec in factors.items():
            if isinstance(spec, Factor):
                items.append(spec)
            elif isinstance(spec, Mapping):
                items.append(_factor_from_table(str(name), spec, f"factors.{name}"))
            else:
                try:
                    low, high = spec
                except (TypeError, ValueError):
                    raise InputError(
                        f"factors.{name} must be (low, high) or a table; got {spec!r}"
                    ) from None
                items.append(Factor(str(name), low, high))
        space = FactorSpace(items)
    else:
        space = FactorSpace(factors)
    if n_expected is not None and len(space) != n_expected:
        raise InputError(f"factors must hold {n_expected} factors; got {len(space)}")
    return space


_KEYS = {"name", "low", "high", "unit", "fixed", "description"}


def _factor_from_table(name: str, table: Mapping[str, Any], where: str) -> Factor:
    unknown = set(table) - _KEYS
    if unknown:
        raise InputError(
            f"{where}: unknown key(s) {', '.join(sorted(unknown))}; allowed: "
            "low, high, unit, fixed, description"
        )
    for key in ("low", "high"):
        if key not in table:
            raise InputError(f"{where}.{key} is missing")
    return Factor(
        name=name,
        low=finite_number(table["low"], f"{where}.low"),
        high=finite_number(table["high"], f"{where}.high"),
        unit=str(table.get("unit", "")),
        fixed=None if table.get("fixed") is None
        else finite_number(table["fixed"], f"{where}.fixed"),
        description=str(table.get("description", "")),
    )


def load_factors(path: str | Path) -> FactorSpace:
    """Read factors from a TOML file.

    Two layouts are accepted. Tables, in file order::

        [factors.x3]
        low = 0.35
        high = 0.70
        description = "CCS-CCS static friction coefficient"

        [factors."pp.rolling_friction"]
        low = 0.01
        high = 0.02
        fixed = 0.015          # optional: held at this value

    or an array of tables, with the name as a key::

        [[factors]]
        name = "x3"
        low = 0.35
        high = 0.70

    Parameters
    ----------
    path : str or Path
        The TOML file.

    Returns
    -------
    FactorSpace

    Raises
    ------
    InputError
        If the file is missing or not TOML, has no ``factors``, or a factor is invalid
        (the message names the field, e.g. ``factors.x3.low``).
    """
    p = regular_input(path, "factors file")  # a named pipe would block the read
    try:
        with p.open("rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise InputError(f"factors file {str(p)!r} does not exist") from None
    except (tomllib.TOMLDecodeError, RecursionError) as exc:  # RecursionError: too deep
        raise InputError(f"factors file {str(p)!r} is not valid TOML: {exc}") from None
    section = data.get("factors")
    if section is None:
        raise InputError(f"factors file {str(p)!r} has no [factors] section")
    items: list[Factor] = []
    if isinstance(section, Mapping):
        for name, table in section.items():
            if not isinstance(table, Mapping):
                raise InputError(f"factors.{name} must be a table with low and high")
            items.append(_factor_from_table(str(name), table, f"factors.{name}"))
    elif isinstance(section, list):
        for i, table in enumerate(section):
            if not isinstance(table, Mapping) or "name" not in table:
                raise InputError(f"factors[{i}].name is missing")
            items.append(_factor_from_table(str(table["name"]), table, f"factors[{i}]"))
    else:
        raise InputError("factors must be a table of tables or an array of tables")
    return FactorSpace(items)
