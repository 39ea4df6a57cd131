"""The model parameters a measurement can set, with the virtual test's names and units.

Each parameter's symbol, label, unit, bounds and display unit stand once, in
:mod:`demcal.parameters` (the registry the virtual test reads too); here they are in the order
of the paper's Table 1 (``Parameter.table_row``), the order of the bench-measurement tables.
Values are SI; ``display_unit`` and ``display_scale`` are for tables only (moduli in MPa, as in
the paper).
"""

from __future__ import annotations

from demcal.parameters import PARAMETERS as _REGISTRY
from demcal.parameters import Parameter

__all__ = ["PARAMETERS", "Parameter", "ParameterInfo", "parameter_info"]

#: The name this module gave :class:`~demcal.parameters.Parameter` before the registries merged.
ParameterInfo = Parameter

#: Every parameter demcal.physical can fix or give a range to, in the order of the paper's
#: Table 1 (then the rest).
PARAMETERS: dict[str, Parameter] = {
    p.name: p for p in sorted(_REGISTRY.values(), key=lambda p: p.table_row)}


def parameter_info(name: str) -> Parameter:
    """The :class:`~demcal.parameters.Parameter` of ``name``; KeyError lists the known names."""
    try:
        return PARAMETERS[name]
    except KeyError:
        raise KeyError(f"unknown parameter {name!r}; known: {', '.join(PARAMETERS)}") from None
