"""Analytic stand-in for the virtual AoR test: a planted response surface (a test double).

It is NOT a simulation. It has the virtual test's interface (parameters and seed in, a typed
outcome and an angle out) and a known truth, so that the calibration pipeline can be tested
end to end in milliseconds and checked against the answer it must find:

    aor_deg = base_deg + sum_p linear[p] * (x_p - centre[p])
                       + sum_p quadratic[p] * (x_p - centre[p])^2
                       + sum_p cubic[p] * (x_p - centre[p])^3
                       + sum_{p*q} interaction[p*q] * (x_p - centre[p]) (x_q - centre[q])
                       + noise_deg * N(0, 1)       (seeded by the parameters and the seed)

Parts of the space form no pile, as real cohesive materials do: if ``x_p > no_pile_above[p]``
for any p the outcome is ``column`` (no angle). If ``x_p > unstable_above[p]`` and the run's
time-step fraction is not reduced (``dt_scale >= 1``) the outcome is ``unstable`` (a
numerical failure that a retry with a smaller time step cures). ``delay_s`` makes a run take
that long, so that tests can kill a study in the middle of a stage. Parameters in SI, angles deg.

``responses`` plants more responses beside the angle, each its own surface about the same
``centre`` (``base`` + linear, quadratic and interaction terms + ``noise`` N(0, 1)), reported
by every run that formed a pile: a stand-in for a test with several responses.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

__all__ = ["AnalyticOptions", "PlantedResponse", "analytic_aor", "true_aor", "true_responses"]


class PlantedResponse(BaseModel):
    """One more planted response (its own units), about the angle's ``centre``."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    base: float = 0.0
    linear: dict[str, float] = Field(default_factory=dict)
    quadratic: dict[str, float] = Field(default_factory=dict)
    interaction: dict[str, float] = Field(default_factory=dict, description="'p*q' -> coef")
    noise: float = Field(0.0, ge=0)


class AnalyticOptions(BaseModel):
    """The planted surface (parameter names of demcal.virtual; values SI, angles deg).

    Every number must be finite (NaN and infinities are refused).
    """

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    base_deg: float = 35.0
    centre: dict[str, float] = Field(default_factory=dict)
    linear: dict[str, float] = Field(default_factory=dict)
    quadratic: dict[str, float] = Field(default_factory=dict)
    cubic: dict[str, float] = Field(default_factory=dict, description="a term no quadratic "
                                    "response surface can fit")
    interaction: dict[str, float] = Field(default_factory=dict, description="'p*q' -> coef")
    noise_deg: float = Field(0.3, ge=0, le=90, description="an angle's noise, deg")
    no_pile_above: dict[str, float] = Field(default_factory=dict)
    no_pile_outcome: str = "column"
    unstable_above: dict[str, float] = Field(default_factory=dict)
    delay_s: float = Field(0.0, ge=0, le=60, description="wall time of one run (sleep), s")
    responses: dict[str, PlantedResponse] = Field(default_factory=dict, max_length=20,
                                                  description="more responses by name")

    @model_validator(mode="after")
    def _known_names(self) -> AnalyticOptions:
        """Every name is a parameter of the virtual test (a typo was a KeyError per run)."""
        from demcal.virtual import PARAMETERS

        for field in ("centre", "linear", "quadratic", "cubic", "no_pile_above",
                      "unstable_above"):
            for name in getattr(self, field):
                if name not in PARAMETERS:
                    raise ValueError(f"{field}: unknown parameter {name!r}; known: "
                                     f"{', '.join(PARAMETERS)}")
        for r in self.responses.values():
            for name in (*r.linear, *r.quadratic):
                if name not in PARAMETERS:
                    raise ValueError(f"responses: unknown parameter {name!r}; known: "
                                     f"{', '.join(PARAMETERS)}")
        for pq in self.interaction:
            names = [n.strip() for n in pq.split("*")]
            if len(names) != 2 or any(n not in PARAMETERS for n in names):
                raise ValueError(f"interaction: {pq!r} must be 'p*q' of two parameter names")
        return self


def _surface(params: Mapping[str, float], centre: Mapping[str, float], base: float,
             terms: tuple[Mapping[str, float], ...]) -> float:
    """base + linear, quadratic, cubic and interaction terms about ``centre``."""
    def d(p: str) -> float:
        return float(params[p]) - float(centre.get(p, 0.0))

    y = base
    for power, coefs in enumerate(terms[:3], 1):
        y += sum(c * d(p) ** power for p, c in coefs.items())
    for pq, c in terms[3].items():
        p, q = pq.split("*")
        y += c * d(p.strip()) * d(q.strip())
    return float(y)


def true_responses(params: Mapping[str, float],
                   options: AnalyticOptions | Mapping[str, Any]) -> dict[str, float]:
    """The noise-free planted responses of ``options.responses``, by name."""
    o = options if isinstance(options, AnalyticOptions) else AnalyticOptions(**options)
    return {name: _surface(params, o.centre, r.base, (r.linear, r.quadratic, {}, r.interaction))
            for name, r in o.responses.items()}



def true_aor(params: Mapping[str, float], options: AnalyticOptions | Mapping[str, Any]) -> float:
    """The noise-free planted angle, deg (defined also where no pile forms)."""
    o = options if isinstance(options, AnalyticOptions) else AnalyticOptions(**options)
    return _surface(params, o.centre, o.base_deg, (o.linear, o.quadratic, o.cubic,
                                                   o.interaction))


def analytic_aor(params: Mapping[str, float], seed: int,
                 options: AnalyticOptions | Mapping[str, Any], *,
                 dt_scale: float = 1.0) -> dict[str, Any]:
    """One stand-in "run": ``{"outcome", "aor_deg", "reason", "params", "seed", ...}``."""
    o = options if isinstance(options, AnalyticOptions) else AnalyticOptions(**options)
    if o.delay_s:
        time.sleep(o.delay_s)  # stands for a simulation's wall time (fault tests)
    for p, thr in o.unstable_above.items():
        if float(params[p]) > thr and dt_scale >= 1.0:
            return {"outcome": "unstable", "aor_deg": None, "seed": int(seed),
                    "reason": f"stand-in: {p} > {thr:g} is unstable at the full time step",
                    "params": dict(params), "stand_in": True}
    for p, thr in o.no_pile_above.items():
        if float(params[p]) > thr:
            return {"outcome": o.no_pile_outcome, "aor_deg": None, "seed": int(seed),
                    "reason": None, "params": dict(params), "stand_in": True}
    text = json.dumps({"p": {k: repr(float(v)) for k, v in sorted(params.items())},
                       "s": int(seed)})
    rng = np.random.default_rng(int(hashlib.sha256(text.encode()).hexdigest()[:15], 16))
    try:
        aor = true_aor(params, o) + o.noise_deg * float(rng.standard_normal())
    except OverflowError:
        aor = float("nan")
    if not math.isfinite(aor):  # the planted surface overflows: a typed failed run
        return {"outcome": "unstable", "aor_deg": None, "seed": int(seed),
                "reason": "stand-in: the planted surface is not finite here",
                "params": dict(params), "stand_in": True}
    out = {"outcome": "pile", "aor_deg": float(min(max(aor, 0.5), 89.5)), "seed": int(seed),
           "reason": None, "params": dict(params), "stand_in": True}
    if o.responses:  # drawn after the angle's noise: the angle stays as it was without them
        out["responses"] = {name: y + o.responses[name].noise * float(rng.standard_normal())
                            for name, y in true_responses(params, o).items()}
    return out
