"""The stored response surface as a callable polynomial (from its coded coefficients).

The report never refits: it evaluates ``coefficients_coded`` of the ``rsm`` stage summary,
whose term names use the factor names (or their symbols), with :func:`demcal.doe.parse_term`.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from demcal.doe import model_matrix, parse_term
from demcal.errors import InputError
from demcal.summaries import StudyFactor, Surface

__all__ = ["StoredSurface", "significant_pairs"]


@dataclass(frozen=True)
class StoredSurface:
    """A polynomial in coded units rebuilt from an ``rsm`` stage summary.

    Attributes
    ----------
    names : tuple of str
        Factor (parameter) names, in the order of the summary's factors.
    symbols : tuple of str
        Their short symbols.
    low, high : (k,) float64 ndarray
        Actual values of the coded levels -1 and +1 (the factors' units).
    terms : tuple of tuple of int
        Exponents of each term.
    coefficients : (p,) float64 ndarray
        Coefficients in coded units, degrees.
    points : (n, k) float64 ndarray or None
        The design's runs in actual units (NaN where a run lacks a factor), where the
        surface was built from its stage (:meth:`from_surface`).
    """

    names: tuple[str, ...]
    symbols: tuple[str, ...]
    low: np.ndarray
    high: np.ndarray
    terms: tuple[tuple[int, ...], ...]
    coefficients: np.ndarray
    points: np.ndarray | None = None

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any]) -> StoredSurface:
        """Build from the stored ``rsm`` summary; InputError if its coefficients cannot be
        read."""
        return cls.from_model([StudyFactor.from_summary(f) for f in summary.get("factors") or []],
                              summary.get("coefficients_coded") or {})

    @classmethod
    def from_surface(cls, surface: Surface) -> StoredSurface:
        """Build from the typed response-surface stage, with its design points; InputError
        as :meth:`from_model`."""
        surf = cls.from_model(surface.factors, surface.coefficients_coded)
        points = np.array([[float(r.actual.get(n, math.nan)) for n in surf.names]
                           for r in surface.runs], dtype=float).reshape(-1, len(surf.names))
        return dataclasses.replace(surf, points=points)

    @classmethod
    def from_model(cls, factors: Sequence[StudyFactor], coefs: Mapping[str, Any]
                   ) -> StoredSurface:
        """Build from the factors (``name``, ``symbol``, ``low``, ``high``) and the coded
        coefficients by term; InputError if the coefficients cannot be read."""
        if not factors or not coefs:
            raise InputError("rsm summary: factors and coefficients_coded are needed")
        names = tuple(f.name for f in factors)
        symbols = tuple(f.symbol or f.name for f in factors)
        terms = None
        for labels in (names, symbols):
            try:
                terms = tuple(parse_term(t, labels) for t in coefs)
                break
            except InputError:
                continue
        if terms is None:
            raise InputError(f"rsm summary: coefficient terms {list(coefs)} do not use the "
                             f"factor names {list(names)}")
        values = np.array([math.nan if v is None else float(v) for v in coefs.values()])
        return cls(names, symbols, np.array([float(f.low) for f in factors]),
                   np.array([float(f.high) for f in factors]), terms, values)

    def to_coded(self, actual: np.ndarray) -> np.ndarray:
        """Actual settings (..., k) -> coded."""
        centre, half = (self.low + self.high) / 2, (self.high - self.low) / 2
        return (np.asarray(actual, dtype=float) - centre) / half

    def to_actual(self, coded: np.ndarray) -> np.ndarray:
        """Coded settings (..., k) -> actual."""
        centre, half = (self.low + self.high) / 2, (self.high - self.low) / 2
        return centre + np.asarray(coded, dtype=float) * half

    def predict_coded(self, coded: np.ndarray) -> np.ndarray:
        """Predicted AoR (deg) at coded settings of shape (m, k)."""
        x = np.atleast_2d(np.asarray(coded, dtype=float))
        return model_matrix(x, self.terms) @ self.coefficients

    def index(self, name: str) -> int:
        """Position of a factor given by name or symbol."""
        if name in self.names:
            return self.names.index(name)
        if name in self.symbols:
            return self.symbols.index(name)
        raise InputError(f"unknown factor {name!r}; factors: {', '.join(self.names)}")


def significant_pairs(surface: Surface, alpha: float = 0.05,
                      at_least: int = 1) -> list[tuple[str, str]]:
    """Factor pairs to draw: interactions with p < ``alpha`` in the stored ANOVA.

    When fewer than ``at_least`` interactions are significant, the pairs of the most
    significant main effects fill in (so a surface is always drawn for 2+ factors).
    """
    names = [f.name for f in surface.factors]
    symbols = [f.symbol or f.name for f in surface.factors]
    pvals: dict[tuple[int, ...], float] = {}
    for rec in surface.anova:
        term, p = rec.term, rec.p
        for labels in (names, symbols):
            try:
                powers = parse_term(term, labels)
            except InputError:
                continue
            pvals[powers] = math.inf if p is None else float(p)
            break
    pairs: list[tuple[str, str]] = []
    for powers, p in sorted(pvals.items(), key=lambda kv: kv[1]):
        idx = [i for i, e in enumerate(powers) if e]
        if len(idx) == 2 and all(powers[i] == 1 for i in idx) and p < alpha:
            pairs.append((names[idx[0]], names[idx[1]]))
    if len(pairs) < at_least and len(names) >= 2:
        mains = sorted(range(len(names)), key=lambda i: pvals.get(
            tuple(int(j == i) for j in range(len(names))), math.inf))
        for i, j in itertools.combinations(mains, 2):
            pair = (names[min(i, j)], names[max(i, j)])
            if pair not in pairs:
                pairs.append(pair)
            if len(pairs) >= at_least:
                break
    return pairs
