"""Where does the virtual test form a pile? Logistic regression of outcome vs parameters.

Fitted on every stored run of the study (pile = 1, any other outcome = 0), on the factors
scaled to [-1, 1] by the study's ranges, with a small L2 penalty so that separable data stay
finite. With runs of one class only it is constant (1 if all piles).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import minimize
from scipy.special import expit

from demcal.store import RunRecord

__all__ = ["PileClassifier"]


@dataclass(frozen=True)
class PileClassifier:
    """``p_pile(params)``: probability that a parameter set forms a pile."""

    names: tuple[str, ...]
    centre: np.ndarray
    half: np.ndarray
    coef: np.ndarray  # intercept first
    constant: float | None
    n_runs: int
    n_piles: int

    @classmethod
    def fit(cls, runs: Sequence[RunRecord], factors: Sequence[tuple[str, float, float]],
            penalty: float = 0.05) -> PileClassifier:
        """Fit on ``runs`` over ``factors`` = [(name, low, high)] (SI)."""
        names = tuple(n for n, _, _ in factors)
        lo = np.array([a for _, a, _ in factors], dtype=float)
        hi = np.array([b for _, _, b in factors], dtype=float)
        centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        seen: dict[str, RunRecord] = {r.key: r for r in runs if r.outcome is not None}
        rows = list(seen.values())
        y = np.array([1.0 if r.outcome == "pile" else 0.0 for r in rows])
        n, k = len(rows), int(y.sum())
        if n == 0 or k in (0, n):
            return cls(names, centre, half, np.zeros(len(names) + 1),
                       1.0 if n == 0 or k == n else 0.0, n, k)
        x = np.array([[r.params[m] for m in names] for r in rows], dtype=float)
        z = np.column_stack([np.ones(n), (x - centre) / half])

        def nll(b: np.ndarray) -> tuple[float, np.ndarray]:
            eta = z @ b
            loss = float(np.sum(np.logaddexp(0.0, eta) - y * eta)) + penalty * float(
                b[1:] @ b[1:])
            grad = z.T @ (expit(eta) - y)
            grad[1:] += 2 * penalty * b[1:]
            return loss, grad

        res = minimize(nll, np.zeros(z.shape[1]), jac=True, method="L-BFGS-B")
        return cls(names, centre, half, res.x, None, n, k)

    def p_pile(self, params: Sequence[Mapping[str, float]]) -> np.ndarray:
        """Probability of a pile for each full parameter set."""
        if self.constant is not None:
            return np.full(len(params), self.constant)
        x = np.array([[p[m] for m in self.names] for p in params], dtype=float)
        z = np.column_stack([np.ones(len(x)), (x - self.centre) / self.half])
        return expit(z @ self.coef)

    def p_pile_grid(self, base: Mapping[str, float], names: Sequence[str],
                    x: np.ndarray) -> np.ndarray:
        """Probability of a pile at rows ``x`` of ``names`` (SI), others as in ``base``."""
        x = np.atleast_2d(np.asarray(x, dtype=float))
        if self.constant is not None:
            return np.full(len(x), self.constant)
        feats = np.tile([float(base[m]) for m in self.names], (len(x), 1))
        for j, n in enumerate(names):
            if n in self.names:
                feats[:, self.names.index(n)] = x[:, j]
        z = np.column_stack([np.ones(len(x)), (feats - self.centre) / self.half])
        return expit(z @ self.coef)

    def describe(self) -> dict[str, Any]:
        """JSON summary: runs used, piles, coefficients (coded factors)."""
        return {"n_runs": self.n_runs, "n_piles": self.n_piles,
                "constant": self.constant,
                "coefficients": None if self.constant is not None else
                dict(zip(("intercept", *self.names), map(float, self.coef), strict=True))}
