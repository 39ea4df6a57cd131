"""The parameters of a virtual test, by name (the names used by ``--set``, study files, JSON).

Each parameter's symbol, description, unit and bounds stand once, in :mod:`demcal.parameters`
(the registry the bench measurements read too); this module checks values against them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from demcal.errors import InputError
from demcal.parameters import (
    MAX_DENSITY,
    MAX_FRICTION,
    MAX_MODULUS,
    MAX_SURFACE_ENERGY,
    PARAMETERS,
    Parameter,
)

__all__ = ["MAX_DENSITY", "MAX_FRICTION", "MAX_MODULUS", "MAX_SURFACE_ENERGY", "PARAMETERS",
           "Parameter", "ParameterSpec", "check_parameter_sets", "check_parameters",
           "parse_assignments"]

#: The name this module gave :class:`~demcal.parameters.Parameter` before the registries merged.
ParameterSpec = Parameter


def check_parameters(values: dict[str, float]) -> dict[str, float]:
    """Validate named parameter values; unknown names and out-of-range values are refused."""
    out = {}
    for name, value in values.items():
        if name not in PARAMETERS:
            raise InputError(f"unknown parameter {name!r}; known: {', '.join(PARAMETERS)}")
        out[name] = PARAMETERS[name].check(value)
    return out


def check_parameter_sets(parameter_sets: Sequence[Mapping[str, float]],
                         seeds: Sequence[int]) -> list[dict[str, float]]:
    """The runs' complete parameter sets, checked: one seed per set, every set naming every
    parameter of :data:`PARAMETERS` within its bounds (one-line :class:`InputError`s naming
    the set and what it lacks)."""
    if len(parameter_sets) != len(seeds):
        raise InputError(f"need one seed per parameter set; got {len(seeds)} seeds for "
                         f"{len(parameter_sets)} sets")
    checked = []
    for i, pset in enumerate(parameter_sets):
        params = check_parameters(dict(pset))
        missing = set(PARAMETERS) - set(params)
        if missing:
            raise InputError(f"parameter set {i} lacks {', '.join(sorted(missing))}")
        checked.append(params)
    return checked


def parse_assignments(items: list[str]) -> dict[str, float]:
    """Parse ``NAME=VALUE`` strings (``--set``) into validated parameter values."""
    values: dict[str, float] = {}
    for item in items:
        if "=" not in item:
            raise InputError(f"--set expects NAME=VALUE; got {item!r}")
        name, _, raw = item.partition("=")
        values[name.strip()] = raw.strip()  # type: ignore[assignment]
    return check_parameters(values)
