"""Placeholders of an engine's input template: ``{name}`` replaced by a run's value.

A placeholder is ``{`` + a name + ``}``, the name made of letters, digits, ``_`` and ``.``
(so parameter names such as ``{pp.static_friction}`` work). Everything else is left as it
is: other braces (a Python dict, a JSON object), and ``${name}`` (a LAMMPS/LIGGGHTS
variable). ``{{name}}`` writes a literal ``{name}``.

Numbers are written with Python's ``repr`` (``0.65``, ``1e-05``, ``50000000.0``): the
shortest text that reads back as the same double, in a form every DEM input format reads.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping

from demcal.errors import InputError

__all__ = ["BUILTINS", "fill", "format_value", "placeholders"]

#: placeholders every run gives besides the parameters and the factor symbols
BUILTINS = {
    "seed": "the run's seed (an integer)",
    "run_dir": "the run's own folder (absolute path; the command runs there)",
    "run_key": "the run's key in the store",
    "input": "the filled input file's name (in run_dir)",
    "dt_scale": "1.0, or 0.5 when an unstable/unsettled run is retried with a smaller step",
    "template_dir": "the template's folder (absolute path), for files it includes",
    "python": "the Python interpreter running demcal (for engines written in Python)",
}

_PATTERN = re.compile(r"\{\{([A-Za-z_][\w.]*)\}\}|(?<!\$)\{([A-Za-z_][\w.]*)\}")


def placeholders(text: str) -> set[str]:
    """The placeholder names a template uses (``{{name}}`` and ``${name}`` are not)."""
    return {m.group(2) for m in _PATTERN.finditer(text) if m.group(2)}


def format_value(value: object) -> str:
    """A placeholder's text: integers as they are, other numbers by ``repr`` of the float."""
    if isinstance(value, bool):
        return str(int(value))
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise InputError(f"a placeholder value must be finite; got {value!r}")
        return repr(value)
    if hasattr(value, "item"):  # numpy scalar
        return format_value(value.item())  # type: ignore[attr-defined]
    return str(value)


def fill(text: str, values: Mapping[str, object], where: str = "template") -> str:
    """``text`` with every placeholder replaced by its value.

    Raises
    ------
    InputError
        A placeholder has no value (the message names it and where it is).
    """

    def sub(m: re.Match[str]) -> str:
        if m.group(1):
            return "{" + m.group(1) + "}"
        name = m.group(2)
        if name not in values:
            line = text.count("\n", 0, m.start()) + 1
            raise InputError(f"{where}: line {line}: no value for placeholder {{{name}}}; "
                             "known: " + ", ".join(sorted(values)))
        return format_value(values[name])

    return _PATTERN.sub(sub, text)
