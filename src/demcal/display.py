"""Numbers as a reader sees them (this module imports nothing of demcal).

Binary floating point leaves values such as ``0.1 + 0.2`` one bit off their decimal:
``repr`` prints ``0.30000000000000004`` and a material's 114.36 kg/m^3 may come back as
``114.36000000000001``. Every table and console line a person reads goes through
:func:`readable`, a few significant digits; the files a program reads back (the material
card, the run store, ``--json``) keep every digit for the exact round trip.
"""

from __future__ import annotations

__all__ = ["READABLE_DIGITS", "readable"]

#: Significant digits shown by default: more than any measured input of a study carries, few
#: enough that the last-bit noise of a float never shows.
READABLE_DIGITS = 6


def readable(value: object, digits: int = READABLE_DIGITS) -> str:
    """A number rounded for reading: ``digits`` significant digits, no trailing zeros.

    Parameters
    ----------
    value : float, int or other
        The value; a float is rounded, a bool or int printed as is, anything else with
        ``str``.
    digits : int, optional
        Significant digits (``format``'s ``g``), 6 by default.

    Returns
    -------
    str
        ``0.3`` for ``0.30000000000000004``, ``114.36`` for ``114.36000000000001``,
        ``0.000105`` for ``1.05e-4``, ``7.9e+09`` for ``7.9e9``; ``0`` for ``-0.0``.

    Examples
    --------
    >>> readable(0.1 + 0.2)
    '0.3'
    >>> readable(0.44999999999999996)
    '0.45'
    """
    if isinstance(value, bool | int):
        return str(value)
    if isinstance(value, float):
        text = f"{value:.{digits}g}"
        return "0" if text == "-0" else text  # a rounded -0.0 reads as a sign, not a value
    return str(value)
