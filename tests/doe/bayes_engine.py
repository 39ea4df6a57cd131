"""An analytic "engine" with planted parameters for the Bayesian strategy's tests.

Three coded factors, three mildly nonlinear responses with independent gradients (together
they pin every factor), each run scattered by Gaussian noise like a simulation's seed.
"""

from __future__ import annotations

import numpy as np

from demcal.doe import Factor, FactorSpace
from demcal.doe.bayes import Response

FACTORS = FactorSpace([
    Factor("static_friction", 0.2, 0.8),
    Factor("rolling_friction", 0.0, 0.2),
    Factor("restitution", 0.3, 0.7),
])
#: The planted parameters, coded.
TRUTH = np.array([0.3, -0.4, 0.5])
#: The angle's slopes in x1 and x2 (coded): alone it leaves the ridge dx2/dx1 = -A/B.
A, B = 6.0, 3.0
#: Run-to-run scatter of each response (the engine's "seed noise").
NOISE = {"aor": 0.3, "density": 0.2, "drum": 0.2}
#: Lab standard errors.
SE = {"aor": 0.2, "density": 0.15, "drum": 0.15}


def mean_response(name: str, x: np.ndarray) -> np.ndarray:
    """Noise-free response at coded points ``x`` (n, 3)."""
    x = np.atleast_2d(x)
    x1, x2, x3 = x.T
    if name == "aor":
        return 30 + A * x1 + B * x2 + 0.3 * x3 + 0.3 * x1**2
    if name == "density":
        return 10 + 4 * x2 + 1 * x3 + 0.5 * x2**2
    return 5 + 1 * x1 + 4 * x3 + 0.5 * np.sin(2 * x3)


def lab(names: tuple[str, ...]) -> list[Response]:
    """The lab's responses: the engine's value at the truth (no noise: a perfect lab)."""
    return [Response(n, float(mean_response(n, TRUTH)[0]), SE[n]) for n in names]


def engine(names: tuple[str, ...], seed: int = 0):
    """``evaluate(points) -> {name: values}`` with seed noise; counts the runs made."""
    rng = np.random.default_rng(seed)

    def evaluate(points: np.ndarray) -> dict[str, np.ndarray]:
        evaluate.runs += len(points)
        return {n: mean_response(n, points) + NOISE[n] * rng.standard_normal(len(points))
                for n in names}

    evaluate.runs = 0
    return evaluate


def nonlinear_response(name: str, x: np.ndarray) -> np.ndarray:
    """A harder engine: saturating, curved and interacting responses (coded points)."""
    x = np.atleast_2d(x)
    x1, x2, x3 = x.T
    if name == "aor":
        return 30 + 8 * np.tanh(2 * (x1 - 0.2)) + 3 * x2 + 1.5 * x1 * x3
    if name == "density":
        return 10 + 4 * x2 + 2 * x3**2 + x3 + 0.5 * x2 * x1
    return 5 + np.exp(x1) + 4 * np.sin(1.5 * x3)


def nonlinear_engine(noise: float, seed: int = 0):
    """``evaluate`` of :func:`nonlinear_response` with seed noise ``noise`` on every response."""
    rng = np.random.default_rng(seed)

    def evaluate(points: np.ndarray) -> dict[str, np.ndarray]:
        return {n: nonlinear_response(n, points) + noise * rng.standard_normal(len(points))
                for n in ("aor", "density", "drum")}

    return evaluate
