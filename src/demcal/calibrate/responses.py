"""``[[responses]]``: the responses a calibration aims at, with the lab's values and goals.

One table per response, in a study or in a goals file of ``demcal optimize --goals``::

    [[responses]]
    name = "aor_deg"            # the key a test or engine reports
    target = 44.12              # the lab value (or measurements = "repeats.txt")
    std = 1.74                  # its repeats' standard deviation, and how many
    n = 8
    goal = "target"             # target | maximize | minimize | in_range
    low = 40.0                  # desirability limits (default: the observed range,
    high = 48.0                 #   widened to hold the target, as Design-Expert)
    weight = 1.0                # 0.1-10, the desirability's exponent
    importance = 3              # 1-5

A study without ``[[responses]]`` has one: the angle of its ``[target]`` table. The angle
(``aor_deg``) stays the study's first response: it drives range finding and screening; the
steepest path climbs the overall desirability of every response's first-order model, every
response is fitted at the response surface, the optimum maximises the overall desirability of
all of them (:mod:`demcal.doe.desirability`) and the verification judges each against its lab
value.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from demcal.doe.goal import ResponseGoal
from demcal.errors import InputError
from demcal.lead import ANGLE
from demcal.safety import read_text_input
from demcal.summaries.target import Target

__all__ = ["AOR", "LabValue", "ResponseSpec", "aor_spec", "load_goals", "read_repeats"]

#: The lift test's own response: its angle of repose, deg.
AOR = ANGLE
#: The Bayesian strategy's pile indicator, a pseudo-response (demcal.calibrate.bayes_strategy):
#: a name no study response or candidate may take.
PILE = "pile_formed"
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_.]{0,63}$")
#: At most this many repeats in a measurements file.
MAX_REPEATS = 100_000


def _check_name(name: str) -> None:
    """A response's name: a key a test can report, and not the pile indicator's."""
    if not _NAME.match(name):
        raise ValueError(f"name must be a letter or _ then letters, digits, _ or . (at most "
                         f"64); got {name!r}")
    if name == PILE:
        raise ValueError(f"name {PILE!r} is the Bayesian strategy's pile indicator; name "
                         "the response the test reports")


class LabValue(BaseModel):
    """What the lab measured for one response: mean, standard deviation and repeats."""

    model_config = ConfigDict(frozen=True)

    mean: float
    std: float | None = None
    n: int | None = None

    @property
    def standard_error(self) -> float | None:
        """std / sqrt(n), when both are known."""
        if self.std is None or not self.n:
            return None
        return self.std / math.sqrt(self.n)


class ResponseSpec(BaseModel):
    """One ``[[responses]]`` table (units of the response throughout)."""

    model_config = ConfigDict(extra="forbid")

    name: str = Field(description="the key a test or engine reports")
    unit: str | None = Field(None, max_length=32)
    target: float | None = Field(None, description="the lab value")
    std: float | None = Field(None, ge=0, description="the lab repeats' standard deviation")
    n: int | None = Field(None, ge=1, le=MAX_REPEATS, description="the lab repeats")
    measurements: str | None = Field(None, description="a file of the lab's repeats")
    goal: Literal["target", "maximize", "minimize", "in_range"] = "target"
    low: float | None = None
    high: float | None = None
    weight: float = Field(1.0, ge=0.1, le=10.0)
    importance: int = Field(3, ge=1, le=5)
    model: Literal["linear", "2fi", "quadratic"] | None = Field(
        None, description="the model fitted to it (goals files of demcal optimize)")

    @model_validator(mode="after")
    def _consistent(self) -> ResponseSpec:
        _check_name(self.name)
        for field in ("target", "std", "low", "high"):
            v = getattr(self, field)
            if v is not None and not math.isfinite(v):
                raise ValueError(f"{field} must be finite; got {v!r}")
        if self.target is not None and self.measurements is not None:
            raise ValueError("give target or measurements, not both")
        if self.goal == "target" and self.target is None and self.measurements is None:
            raise ValueError("goal 'target' needs the lab value: target = ... or "
                             "measurements = FILE")
        if self.low is not None and self.high is not None:
            if not self.low < self.high:
                raise ValueError(f"low must be < high; got low={self.low:g}, "
                                 f"high={self.high:g}")
            if self.target is not None and self.goal == "target" and \
                    not self.low <= self.target <= self.high:
                raise ValueError(f"target must be in low..high ({self.low:g}..{self.high:g}); "
                                 f"got {self.target:g}")
        if self.goal == "in_range" and (self.low is None or self.high is None):
            raise ValueError("goal 'in_range' needs low and high")
        return self

    def lab(self, base: Path | None = None) -> LabValue | None:
        """The lab's value: ``target`` (with ``std`` and ``n``) or the mean of the
        ``measurements`` file's repeats (relative to ``base``); None for a goal without one."""
        if self.target is not None:
            return LabValue(mean=float(self.target), std=self.std, n=self.n)
        if self.measurements is None:
            return None
        path = Path(self.measurements)
        if base is not None and not path.is_absolute():
            path = base / path
        if path.suffix == ".toml":  # demcal physical's measurements: the summary by name
            return _physical_lab(path, self.name)
        values = read_repeats(path, f"responses {self.name!r}: measurements")
        std = float(np.std(values, ddof=1)) if values.size > 1 else None
        return LabValue(mean=float(values.mean()), std=std, n=int(values.size))

    def goal_for(self, observed: np.ndarray, lab: LabValue | None) -> ResponseGoal:
        """The desirability goal, limits defaulting as Design-Expert's: the smallest and
        largest observed response, widened to hold the lab value."""
        obs = np.asarray(observed, dtype=float)
        obs = obs[np.isfinite(obs)]
        centre = None if lab is None else lab.mean
        pool = [*obs.tolist(), *([centre] if centre is not None else [])]
        if not pool and (self.low is None or self.high is None):
            raise InputError(f"responses {self.name!r}: no observed value to set the "
                             "desirability limits from; give low and high")
        low = self.low if self.low is not None else min(pool)
        high = self.high if self.high is not None else max(pool)
        if not low < high:  # a flat response: a window of +/- 1 unit around it
            low, high = low - 1.0, high + 1.0
        if centre is not None and self.goal == "target" and not low <= centre <= high:
            raise InputError(f"responses {self.name!r}: the lab value {centre:g} lies outside "
                             f"the desirability limits {low:g}..{high:g}")
        return ResponseGoal(self.name, self.goal, float(low), float(high),
                            target=centre if self.goal == "target" else None,
                            weight=float(self.weight), importance=int(self.importance))


def _physical_lab(path: Path, name: str) -> LabValue:
    """A response's lab value from a measurements TOML (``demcal physical``'s repeats, e.g.
    ``[measurements.bulk_density]`` for ``bulk_density_kg_m3``)."""
    from demcal.physical import derive_parameters, load_measurements

    s = derive_parameters(load_measurements(path)).summaries.get(name)
    if s is None or s.mean is None:
        raise InputError(f"responses {name!r}: measurements {path} has no repeats of {name}")
    return LabValue(mean=float(s.mean), std=s.std, n=s.n_repeats)


def aor_spec(own: ResponseSpec | None, target: Target) -> ResponseSpec:
    """The angle's response: its own ``[[responses]]`` goal, limits, weight and importance
    (or the defaults), at the target the study resolved (the store's meta "target", from a
    value, photos or a measurements file)."""
    fields = {} if own is None else own.model_dump(exclude={"target", "std", "n", "measurements"})
    fields.update(name=AOR, unit="deg", target=float(target.aor_deg),  # type: ignore[arg-type]
                  std=target.std_deg, n=target.n)
    return ResponseSpec(**fields)


def _repeat(tok: str, where: str) -> float:
    try:
        v = float(tok)
    except ValueError:
        raise InputError(f"{where}: not a number: {tok[:40]!r}") from None
    if not math.isfinite(v):
        raise InputError(f"{where}: not finite: {tok!r}")
    return v


def read_repeats(path: Path, where: str) -> np.ndarray:
    """The numbers of a repeats file: one or more per line, separated by commas, spaces or
    semicolons; ``#`` starts a comment. Refused: a missing or huge file, a non-number, fewer
    than one value, a non-finite value."""
    text = read_text_input(path, where)
    values: list[float] = []
    for lineno, line in enumerate(text.splitlines(), 1):
        values += [_repeat(tok, f"{where}: {path} line {lineno}")
                   for tok in re.split(r"[,\s;]+", line.split("#", 1)[0].strip()) if tok]
        if len(values) > MAX_REPEATS:
            raise InputError(f"{where}: {path}: more than {MAX_REPEATS} repeats")
    if not values:
        raise InputError(f"{where}: {path} holds no number")
    return np.array(values)




def load_goals(path: Path) -> list[ResponseSpec]:
    """The ``[[responses]]`` of a goals file (``demcal optimize --goals``); bad fields are one
    InputError line naming each."""
    import tomllib

    from pydantic import TypeAdapter, ValidationError

    from demcal.errors import validation_message

    try:
        data = tomllib.loads(read_text_input(path, "--goals"))
    except (tomllib.TOMLDecodeError, RecursionError) as exc:
        raise InputError(f"--goals: {path} is not valid TOML: {exc}") from None
    unknown = set(data) - {"responses"}
    if unknown:
        raise InputError(f"--goals: {path}: unknown table(s) {', '.join(sorted(unknown))}; a "
                         "goals file holds [[responses]] tables")
    try:
        specs = TypeAdapter(list[ResponseSpec]).validate_python(data.get("responses") or [])
    except ValidationError as exc:
        raise InputError(f"--goals: {validation_message(exc, 'responses')}") from None
    if not specs:
        raise InputError(f"--goals: {path} has no [[responses]] table")
    names = [s.name for s in specs]
    if len(set(names)) != len(names):
        raise InputError(f"--goals: {path}: a response is listed twice")
    return specs
