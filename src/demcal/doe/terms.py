"""Polynomial model terms: names, model matrices and hierarchy.

A term is a tuple of exponents, one per factor: with factors ``(x3, x4, x8)``, ``(0, 0, 0)``
is ``intercept``, ``(1, 0, 0)`` is ``x3``, ``(1, 1, 0)`` is ``x3*x4`` and ``(2, 0, 0)`` is
``x3^2``. Term order follows Design-Expert: intercept, main effects, two-factor
interactions, pure quadratics.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import numpy as np

from demcal.errors import InputError

__all__ = [
    "MODELS",
    "Powers",
    "is_hierarchical",
    "model_matrix",
    "model_terms",
    "parse_term",
    "term_name",
]

Powers = tuple[int, ...]

#: Model orders accepted by :func:`model_terms`.
MODELS = ("linear", "2fi", "quadratic")


def model_terms(n_factors: int, model: str) -> tuple[Powers, ...]:
    """Terms of a standard polynomial model.

    Parameters
    ----------
    n_factors : int
        Number of factors k.
    model : {"linear", "2fi", "quadratic"}
        Main effects; plus two-factor interactions; plus pure quadratics.

    Returns
    -------
    tuple of Powers
        Intercept first; p = 1 + k, 1 + k + k(k-1)/2 or 1 + 2k + k(k-1)/2 terms.
    """
    if model not in MODELS:
        raise InputError(f"model must be one of {', '.join(MODELS)}; got {model!r}")
    k = n_factors
    unit = np.eye(k, dtype=int)
    terms: list[Powers] = [(0,) * k]
    terms += [tuple(int(v) for v in unit[i]) for i in range(k)]
    if model in ("2fi", "quadratic"):
        terms += [
            tuple(int(v) for v in unit[i] + unit[j]) for i, j in itertools.combinations(range(k), 2)
        ]
    if model == "quadratic":
        terms += [tuple(int(v) for v in 2 * unit[i]) for i in range(k)]
    return tuple(terms)


def term_name(powers: Powers, names: Sequence[str]) -> str:
    """Name of a term: ``intercept``, ``x3``, ``x3*x4``, ``x3^2``, ``x3^2*x4``."""
    parts = []
    for name, e in zip(names, powers, strict=True):
        if e == 1:
            parts.append(name)
        elif e > 1:
            parts.append(f"{name}^{e}")
    return "*".join(parts) if parts else "intercept"


def parse_term(text: str, names: Sequence[str]) -> Powers:
    """Inverse of :func:`term_name` (``"x3*x4"`` -> ``(1, 1, 0)``); ``"x3*x3"`` is ``x3^2``."""
    text = str(text).strip()
    powers = [0] * len(names)
    if text in ("intercept", "1"):
        return tuple(powers)
    for piece in text.split("*"):
        piece = piece.strip()
        name, _, exp = piece.partition("^")
        if name not in names:
            raise InputError(f"term {text!r}: unknown factor {name!r}; factors: {', '.join(names)}")
        try:
            e = int(exp) if exp else 1
        except ValueError:
            raise InputError(f"term {text!r}: exponent must be an integer") from None
        if e < 1:
            raise InputError(f"term {text!r}: exponent must be >= 1")
        powers[list(names).index(name)] += e
    return tuple(powers)


def model_matrix(coded: np.ndarray, terms: Sequence[Powers]) -> np.ndarray:
    """Columns of the model for each run.

    Parameters
    ----------
    coded : (n_runs, n_factors) float64 ndarray
        Factor settings (coded units).
    terms : sequence of Powers
        The model's terms.

    Returns
    -------
    (n_runs, n_terms) float64 ndarray
        ``X[i, j] = prod_f coded[i, f] ** terms[j][f]``.
    """
    x = np.asarray(coded, dtype=float)
    cols = [np.prod(x ** np.asarray(t, dtype=float), axis=1) for t in terms]
    return np.column_stack(cols) if cols else np.empty((x.shape[0], 0))


def divides(a: Powers, b: Powers) -> bool:
    """True if term ``a`` is a proper factor of term ``b`` (``x3`` divides ``x3*x4``)."""
    return a != b and all(i <= j for i, j in zip(a, b, strict=True))


def is_hierarchical(terms: Sequence[Powers]) -> bool:
    """True if every factor of every term is in the model too (``x3*x4`` needs x3 and x4)."""
    present = set(terms)
    for t in terms:
        for i, e in enumerate(t):
            if e > 0:
                lower = list(t)
                lower[i] -= 1
                if tuple(lower) not in present:
                    return False
    return True
