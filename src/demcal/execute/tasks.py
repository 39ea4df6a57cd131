"""One unit of work: a run (or a chunk of runs, batched as worlds of one engine).

Tasks are plain picklable data so that any executor (a local process, a spawned pool worker,
a Dask worker) can run them with :func:`run_chunk`; the result of every run is a typed
:class:`demcal.results.RunResult` (outcome, named responses, reason, wall time, details).
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from demcal.results import RunResult
from demcal.virtual.lammps_options import LammpsOptions  # light: pydantic alone

if TYPE_CHECKING:  # the virtual tests are imported where they run (a task stays light)
    from demcal.execute.engine_spec import ResolvedEngine
    from demcal.virtual.drum import DrumResult
    from demcal.virtual.drum_settings import DrumSettings

__all__ = ["MEASUREMENT_VERSION", "RunTask", "TestDef", "run_chunk"]

#: How an engine pile is measured, part of every engine run's identity: runs measured by an
#: older method are not mixed with new ones in a resumed study (they are run again).
#: 2: flank quality gates, mean of the accepted flanks (demcal.measure.quality).
MEASUREMENT_VERSION = 2


@dataclass(frozen=True)
class TestDef:
    """The virtual test: ``kind`` "aor" (fidelity, overrides; on ``engine`` "demcal" or
    "lammps", started as ``lammps`` says), "drum" (the rotating drum on the same engines:
    fidelity and :func:`demcal.virtual.drum_settings.drum_settings`' overrides), "analytic"
    (stand-in) or "template" (an external engine: ``external``, a
    :class:`demcal.execute.engine_spec.ResolvedEngine` with its ``runs_dir`` and ``symbols``)."""

    __test__ = False  # not a pytest class

    kind: str = "aor"
    fidelity: str = "quick"
    overrides: dict[str, Any] = field(default_factory=dict)
    analytic: dict[str, Any] = field(default_factory=dict)
    backend: str = "auto"
    engine: str = "demcal"
    lammps: LammpsOptions = field(default_factory=LammpsOptions)
    external: ResolvedEngine | None = None

    def identity(self) -> dict[str, Any]:
        """What defines the test's results (the backend and how LAMMPS is started do not;
        the engine does: a LAMMPS run is never taken for a demcal one, nor the other way)."""
        if self.kind == "analytic":
            return {"kind": "analytic", "analytic": self.analytic}
        if self.kind == "drum":
            drum = {"kind": "drum", "config": _drum_identity(self)}
            if self.engine != "demcal":  # demcal's drum identity (and stored runs) unchanged
                drum["engine"] = _engine_identity(self.engine)
            return drum
        if self.kind == "template":
            if self.external is None:
                raise ValueError("a template test needs its engine (TestDef.external)")
            ident = {"kind": "template", "engine": self.external.identity()}
            if self.external.measures_positions:
                ident["measurement"] = MEASUREMENT_VERSION
            return ident
        from demcal.virtual import fidelity_config

        # the test as resolved, not the fidelity's name: a stored run is reused only by a
        # test that is the same (a fidelity whose definition changed does not reuse it; one
        # renamed does)
        config = fidelity_config(self.fidelity, **self.overrides).model_dump(mode="json")
        out = {"kind": "aor", "config": config, "measurement": MEASUREMENT_VERSION}
        if self.engine != "demcal":  # demcal's identity (and its stored runs) unchanged
            out["engine"] = _engine_identity(self.engine)
        return out


def _engine_identity(engine: str) -> dict[str, Any]:
    """A LAMMPS run's engine as part of its identity: the name and the law mapping's
    version."""
    from demcal.virtual.lammps_laws import LAWS_VERSION

    return {"name": engine, "laws": LAWS_VERSION}


def _drum_identity(test: TestDef) -> dict[str, Any]:
    """The drum test as resolved (every setting, the particle's included)."""
    from demcal.virtual.drum_settings import WALL_PARAMETERS, drum_settings

    settings = drum_settings(test.fidelity, test.overrides)
    # a lining left unset is not part of the identity: runs stored before it existed reuse
    return {f.name: (v.model_dump(mode="json") if hasattr(v, "model_dump") else v)
            for f in dataclasses.fields(settings)
            for v in [getattr(settings, f.name)]
            if not (f.name in WALL_PARAMETERS and v is None)}


@dataclass(frozen=True)
class RunTask:
    """One run: its store key, full parameter set (SI), seed, time-step scale and, optionally,
    where to save a picture of its pile (``plot_path``, not part of the run's identity)."""

    key: str
    test: TestDef
    params: dict[str, float]
    seed: int
    dt_scale: float = 1.0
    plot_path: str | None = None


def _from_aor(key: str, r: Any) -> RunResult:
    """A lift test's :class:`~demcal.virtual.aor.AoRResult` as a run result."""
    return RunResult(key, r.outcome, responses=r.responses(), reason=r.reason,
                     wall_time_s=r.wall_time_s, detail=r.to_dict())


def _lammps_chunk(tasks: list[RunTask], emit: Callable[[RunResult], None]) -> None:
    """The runs on LAMMPS, one after another (each on ``test.lammps.np`` MPI ranks)."""
    from demcal.virtual import fidelity_config
    from demcal.virtual.lammps_run import RunReporting, run_aor_lammps

    test = tasks[0].test
    options = test.lammps
    for t in tasks:
        config = fidelity_config(test.fidelity, **test.overrides)
        if t.dt_scale != 1.0:
            config = config.model_copy(update={"dt_fraction": config.dt_fraction * t.dt_scale})

        def done(_i: int, r: Any, t: RunTask = t) -> None:
            emit(_from_aor(t.key, r))

        run_aor_lammps([t.params], config=config, seeds=[t.seed], options=options,
                       reporting=RunReporting(plot_paths=[t.plot_path], on_result=done))


def _aor_chunk(tasks: list[RunTask], emit: Callable[[RunResult], None]) -> None:
    from demcal.errors import SimulationUnstable
    from demcal.virtual import fidelity_config, run_aor

    test = tasks[0].test
    if test.engine == "lammps":
        _lammps_chunk(tasks, emit)
        return
    # one engine per time-step scale (worlds of a batch share the fraction)
    for scale in sorted({t.dt_scale for t in tasks}):
        group = [t for t in tasks if t.dt_scale == scale]
        config = fidelity_config(test.fidelity, **test.overrides)
        if scale != 1.0:
            config = config.model_copy(update={"dt_fraction": config.dt_fraction * scale})
        t0 = time.perf_counter()
        sent: set[int] = set()

        def world_done(i: int, r: Any, group: list[RunTask] = group,
                       sent: set[int] = sent) -> None:
            sent.add(i)
            emit(_from_aor(group[i].key, r))

        try:
            run_aor([t.params for t in group], config=config, seeds=[t.seed for t in group],
                    backend=test.backend, on_result=world_done,
                    plot_paths=[t.plot_path for t in group])
        except SimulationUnstable as exc:
            wall = time.perf_counter() - t0
            for i, t in enumerate(group):
                if i not in sent:
                    emit(RunResult(t.key, "unstable", reason=str(exc), wall_time_s=wall))


def _drum_chunk(tasks: list[RunTask], emit: Callable[[RunResult], None]) -> None:
    """The drum runs: on demcal's engine as worlds of one engine per time-step scale (the
    worlds of one engine share the fraction), as the lift test's; on LAMMPS one after
    another. Each run is emitted the moment it ends; an engine that goes unstable is the
    run's outcome ``unstable``, as :func:`demcal.virtual.drum.run_drum` and the LAMMPS drum
    report it."""
    from demcal.virtual.drum import DrumReporting, run_drum
    from demcal.virtual.drum_settings import drum_settings

    test = tasks[0].test
    settings = drum_settings(test.fidelity, test.overrides)
    if test.engine == "lammps":
        _lammps_drum_chunk(tasks, settings, emit)
        return
    for scale in sorted({t.dt_scale for t in tasks}):
        group = [t for t in tasks if t.dt_scale == scale]
        scaled = settings if scale == 1.0 else dataclasses.replace(
            settings, dt_fraction=settings.dt_fraction * scale)

        def world_done(i: int, r: DrumResult, group: list[RunTask] = group) -> None:
            emit(r.run_result(group[i].key))

        run_drum([t.params for t in group], settings=scaled, seeds=[t.seed for t in group],
                 backend=test.backend, reporting=DrumReporting(on_result=world_done))


def _lammps_drum_chunk(tasks: list[RunTask], settings: DrumSettings,
                       emit: Callable[[RunResult], None]) -> None:
    """The drum runs on LAMMPS, one after another (each its own ``mpirun``)."""
    from demcal.virtual.lammps_drum import run_drum_lammps

    options = tasks[0].test.lammps
    for t in tasks:
        scaled = settings if t.dt_scale == 1.0 else dataclasses.replace(
            settings, dt_fraction=settings.dt_fraction * t.dt_scale)
        (res,) = run_drum_lammps([t.params], settings=scaled, seeds=[t.seed], options=options)
        emit(res.run_result(t.key))


def run_chunk(tasks: list[RunTask],
              on_result: Callable[[RunResult], None] | None = None) -> list[RunResult]:
    """Run a chunk of tasks (same test) and return one :class:`RunResult` per task.

    ``on_result(result)`` (in the same process) is called the moment each run ends, before
    the chunk ends (worlds of one batched engine end at different times). Each result also
    names the ``worker`` that ran it: ``{"pid", "numba_threads"}``.
    """
    if not tasks:
        return []
    worker = {"pid": os.getpid(), "numba_threads": os.environ.get("NUMBA_NUM_THREADS")}
    out: list[RunResult] = []

    def emit(r: RunResult) -> None:
        r = r.with_worker(worker)
        out.append(r)
        if on_result is not None:
            on_result(r)

    if tasks[0].test.kind == "analytic":
        from demcal.execute.analytic import analytic_aor

        for t in tasks:
            t0 = time.perf_counter()
            r = analytic_aor(t.params, t.seed, t.test.analytic, dt_scale=t.dt_scale)
            pile = r["outcome"] == "pile"
            responses = {"aor_deg": r["aor_deg"], **r.get("responses", {})} if pile else {}
            emit(RunResult(t.key, r["outcome"], responses=responses, reason=r["reason"],
                           wall_time_s=time.perf_counter() - t0, detail=r))
    elif tasks[0].test.kind == "drum":
        _drum_chunk(tasks, emit)
    elif tasks[0].test.kind == "template":
        from demcal.execute.template_engine import run_template

        for t in tasks:
            emit(run_template(t, t.plot_path))
    else:
        _aor_chunk(tasks, emit)
    return out
