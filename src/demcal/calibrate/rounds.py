"""Verification rounds: the offset a round's piles measured, and how much of it the next
round applies (:mod:`demcal.calibrate.refine` runs the rounds; the stages read these)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from demcal import doe
from demcal.summaries import Optimum, Verification

__all__ = ["Offset", "Rounds", "model_rows", "offset_weight", "pile_mean_row",
           "stored_rounds"]


@dataclass
class Rounds:
    """The verification rounds of one study (:mod:`demcal.calibrate.refine`).

    ``number``: the round now running (1: the response surface's own optimum);
    ``optimize``/``verification``: the optima and verification summaries of the rounds
    already finished, in order; ``stored``: the optima the store held when the study started,
    by round (read once, before round 1 overwrites them; None until then).
    """

    number: int = 1
    optimize: list[Optimum] = field(default_factory=list)
    verification: list[Verification] = field(default_factory=list)
    stored: dict[int, Optimum] | None = None

    def advance(self, optimum: Optimum, verification: Verification) -> None:
        """Finish the round now running with its optimum and verification; the next begins
        (their histories are dropped when they are stored again: :meth:`in_round`)."""
        self.optimize.append(optimum)
        self.verification.append(verification)
        self.number += 1

    def offset(self, model: Any) -> Offset:
        """The surface's offset measured by the finished rounds (:class:`Offset`).

        Each round's piles measure the offset at its optimum (their mean less the surface's
        prediction there). The estimate pools, weighted by their piles, the last round and
        the rounds before it back to the last one whose mean was not confirmed: a confirmed
        round agreed with the offset it was aimed by, so the offsets are one (the
        confirmation is that consistency test); a round that disagreed starts a new
        estimate, so an offset that changes along the way (a curved response) is followed.

        How much of it the next round applies (:attr:`Offset.weight`): all of it when a
        pooled round was not confirmed (the surface is off there by more than its own
        error: only the piles know by how much). When every pooled round was confirmed, the
        measured offset may be the piles' scatter as well as the surface's error, and the two
        are weighed by their variances: the piles' mean s^2 / N, the surface's prediction at
        the pooled optima s^2 h (h = d' (X'X)^-1 d, d the pile-weighted row of the full
        quadratic: :func:`offset_weight`), so w = N h / (N h + 1), the best linear estimate
        of the surface's error there (s^2 cancels).
        """
        if model is None:  # no surface to offset: the Bayesian strategy refits its surrogates
            return Offset()
        pool: list[int] = []
        for j in range(len(self.verification) - 1, -1, -1):
            pool.insert(0, j)
            if self.verification[j].confirmed is not True:
                break
        at = [(dict(self.optimize[j].chosen), int(self.verification[j].n_piles)) for j in pool]
        if not at:
            return Offset()
        y = np.array([float(self.verification[j].mean) for j in pool])
        x = {n: [p[n] for p, _ in at] for n in model.names}
        pred = np.asarray(model.predict(x, units="actual"), dtype=float)
        w = np.array([n for _, n in at], dtype=float)
        confirmed = all(self.verification[j].confirmed is True for j in pool)
        return Offset(float(np.sum(w * (y - pred)) / w.sum()), at,
                      [self.verification[j].round_number for j in pool],
                      weight=offset_weight(model, at) if confirmed else 1.0)


@dataclass(frozen=True)
class Offset:
    """A surface offset (deg) and the optimum piles it was measured on.

    ``deg``: the pooled offset (piles' means less the surface, weighted by the piles);
    ``at``: [(the optimum's factor values, its number of piles)]; ``rounds``: their round
    numbers; ``weight``: the share of it the next round applies (:meth:`Rounds.offset`).
    Round 1 has none: ``Offset()``.
    """

    deg: float = 0.0
    at: list[tuple[dict[str, float], int]] = field(default_factory=list)
    rounds: list[int] = field(default_factory=list)
    weight: float = 1.0

    @property
    def applied(self) -> float:
        """The correction the next round aims by, deg: ``weight * deg``."""
        return self.weight * self.deg


def model_rows(model: Any, points: Sequence[Mapping[str, float]],
                terms: Sequence[tuple[int, ...]]) -> np.ndarray:
    """Model rows (coded) of factor settings ``points`` (actual units) for ``terms``."""
    space = model.factors.subset(model.names)
    return doe.model_matrix(space.to_coded(np.array([[p[n] for n in model.names]
                                                     for p in points])), terms)


def pile_mean_row(model: Any, at: Sequence[tuple[Mapping[str, float], int]],
                   terms: Sequence[tuple[int, ...]]) -> np.ndarray:
    """The pile-weighted mean model row of the optima ``at`` ([(settings, piles)])."""
    n_at = np.array([n for _, n in at], dtype=float)
    return (n_at / n_at.sum()) @ model_rows(model, [p for p, _ in at], terms)


def offset_weight(model: Any, at: Sequence[tuple[Mapping[str, float], int]]) -> float:
    """Share of a measured surface offset to apply when the surface kept its promise:
    N h / (N h + 1) (:meth:`Rounds.offset`), N the piles at the optima ``at``.

    h is the leverage of the pile-weighted optimum row under the *full quadratic* on the
    model's design points, not under the fitted model: a model reduced by backward
    elimination predicts with a variance that ignores the terms' selection, and would make
    the surface look more certain than it is. Where the design cannot hold the full
    quadratic (too few runs, aliased terms), the fitted model's own terms.
    """
    terms = doe.model_terms(len(model.names), "quadratic")
    x = doe.model_matrix(model.coded, terms)
    if x.shape[0] <= x.shape[1] or np.linalg.matrix_rank(x) < x.shape[1]:
        terms, xtx_inv = model.terms, model.xtx_inv
    else:
        xtx_inv = np.linalg.inv(x.T @ x)
    mean_row = pile_mean_row(model, at, terms)
    h = float(mean_row @ xtx_inv @ mean_row)
    n = float(sum(k for _, k in at))
    return n * h / (n * h + 1.0)


def stored_rounds(record: Any) -> dict[int, Optimum]:
    """The optima of a finished optimize stage record by round (``{}`` for none or an
    unfinished one).

    The record holds the last round's summary, with the earlier rounds' under ``"rounds"``;
    a summary without ``"round"`` (written before refinement rounds existed) is round 1.
    """
    if record is None or record.status != "done":
        return {}
    last = Optimum.from_summary(record.summary)
    return {o.round_number: replace(o, rounds=[]) for o in [*last.rounds, last]}
