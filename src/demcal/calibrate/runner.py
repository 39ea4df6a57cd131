"""The runner: turns design points into stored runs, skipping those already done.

Every run is keyed by :func:`demcal.store.run_key` (stage, full parameter set, seed, hash of
the virtual test) and written to the store the moment it ends, so a second call with the same
points runs nothing, an interrupted call loses no finished run, and a changed study re-runs
only the points whose key changed. A run ending ``unstable`` or ``unsettled`` is stored with
its reason and retried once with half the time-step fraction (``attempts`` = 2).

With an external engine (``[engine]`` of the study), a run the engine did not finish
(``engine_error``, ``no_result``, ``timeout``: :data:`ENGINE_FAILURES`) is stored as failed
with its reason and log; once every run of the call has ended, :meth:`Runner.run` raises
:class:`demcal.errors.StudyError` naming the failures (the stage never fits around them),
and the next call re-runs exactly those runs.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from demcal.errors import StudyError
from demcal.execute.local import run_local
from demcal.execute.tasks import RunTask, TestDef
from demcal.execute.template_engine import ENGINE_FAILURES
from demcal.results import RunResult
from demcal.store import RunRecord, RunStore, params_hash, run_key

__all__ = ["ENGINE_FAILURES", "RETRY_DT_SCALE", "RETRY_OUTCOMES", "ExternalPending", "Point",
           "Runner", "RunnerOptions"]

RETRY_OUTCOMES = ("unstable", "unsettled")
RETRY_DT_SCALE = 0.5
#: what the drum retries: its ``unsettled`` (no steady flow in its time) is a result, not a
#: numerical failure a smaller time step would mend
DRUM_RETRY_OUTCOMES = ("unstable",)


def retry_outcomes(test: TestDef) -> tuple[str, ...]:
    """The outcomes of ``test`` that are run again once at a smaller time step."""
    return DRUM_RETRY_OUTCOMES if test.kind == "drum" else RETRY_OUTCOMES


class ExternalPending(Exception):
    """External mode: ``stage`` needs ``points`` run outside demcal before it can go on."""

    def __init__(self, stage: str, points: list[Point]) -> None:
        super().__init__(f"{stage}: {len(points)} runs to do externally")
        self.stage = stage
        self.points = points


#: Stages that run the study's test alone: range finding looks for the angle's pile region.
NOTHING_BESIDE = frozenset({"rangefind"})


def beside_stage(stage: str, name: str) -> str:
    """The stage name under which the runs of test ``name`` beside ``stage``'s are stored."""
    return f"{stage}+{name}"


def joined(main: RunRecord, beside: RunRecord) -> RunRecord:
    """``main`` with the responses of the run ``beside`` it (a done one) added; the main
    test's own responses win a name both report."""
    if beside.status != "done" or not beside.responses:
        return main
    return dataclasses.replace(main, responses={**beside.responses, **main.responses})


@dataclass(frozen=True)
class Point:
    """One run to do: design row ``point``, ``replicate``, full parameters (SI) and seed."""

    point: int
    replicate: int
    params: dict[str, float]
    seed: int


@dataclass(frozen=True)
class RunnerOptions:
    """How a :class:`Runner` makes its runs.

    Attributes
    ----------
    stage_tests : dict of str -> TestDef
        Another test for some stages (a screening at a lower fidelity); its identity enters
        those stages' run keys.
    workers : int
        Local worker processes (1 = in this process).
    dask : str or Client or None
        A Dask scheduler; replaces the local pool.
    chunk : int
        Runs per task (batched worlds of one engine).
    spread : bool
        On the local pool (``workers`` > 1), run one run per task in full rounds of the
        workers and the rest in this process on every thread, instead of chunks of
        ``chunk`` (the CPU's default: a single-thread worker runs a lone test as fast as a
        batch, `small` tests 8 % faster, and no worker waits while a last chunk runs).
    progress : callable or None
        ``progress(stage, done, total)`` after each run.
    external : bool
        Run nothing: :meth:`run` returns the missing points instead (external mode).
    figures_dir : path or None
        Engine runs that form a pile save a side view with the fitted flanks there
        (``<stage>_<hash>.png``, in the run's ``artefacts["pile_png"]``).
    beside : dict of str -> TestDef
        Tests run beside ``test`` on every point of every stage but range finding (the drum:
        ``{"drum": TestDef(kind="drum", ...)}``). Each is stored as its own run under the
        stage ``<stage>+<name>`` (so a failed drum run loses no lift run, and each resumes
        on its own); :meth:`run` returns the main test's runs with the responses of the
        runs beside them joined in.
    """

    workers: int = 1
    dask: Any = None
    chunk: int = 1
    progress: Callable[[str, int, int], None] | None = None
    external: bool = False
    figures_dir: str | Path | None = None
    stage_tests: dict[str, TestDef] = field(default_factory=dict)
    spread: bool = False
    beside: dict[str, TestDef] = field(default_factory=dict)


class Runner:
    """Runs points of a stage through an executor and stores each run as it ends.

    Parameters
    ----------
    store : RunStore
    test : TestDef
        The virtual test (its identity enters every run key).
    options : RunnerOptions, optional
        How the runs are made (workers, Dask, chunks, progress, external mode, figures, the
        stages' own tests and the tests beside them).
    """

    def __init__(self, store: RunStore, test: TestDef,
                 options: RunnerOptions | None = None) -> None:
        o = options or RunnerOptions()
        self.store = store
        self.test = test
        self.test_hash = params_hash(test.identity())
        self.beside = dict(o.beside)
        self.stage_tests = dict(o.stage_tests)
        self._stage_hashes = {s: params_hash(t.identity()) for s, t in self.stage_tests.items()}
        self._beside_hashes = {n: params_hash(t.identity()) for n, t in self.beside.items()}
        #: the keys of the runs beside the test that :meth:`run` returned (joined)
        self.beside_keys: set[str] = set()
        self.workers = o.workers
        self.dask = o.dask
        self.chunk = max(1, o.chunk)
        self.spread = o.spread
        self.progress = o.progress
        self.external = o.external
        self.figures_dir = None if o.figures_dir is None else Path(o.figures_dir)
        self.executed = 0
        #: with Dask: give up after this many seconds without a worker (None: wait)
        self.dask_timeout: float | None = None

    def test_for(self, stage: str) -> TestDef:
        """The virtual test a stage runs (the study's, unless the stage has its own; a test
        beside it for ``<stage>+<name>``)."""
        _, plus, name = stage.partition("+")
        if plus:
            return self.beside[name]
        return self.stage_tests.get(stage, self.test)

    def stage_hash(self, stage: str) -> str:
        """The identity hash of the test a stage runs."""
        _, plus, name = stage.partition("+")
        if plus:
            return self._beside_hashes[name]
        return self._stage_hashes.get(stage, self.test_hash)

    def key(self, stage: str, p: Point) -> str:
        """The store key of a point's run."""
        return run_key(stage, p.params, p.seed, self.stage_hash(stage))

    def missing(self, stage: str, points: Sequence[Point]) -> list[Point]:
        """Points with no finished run in the store (done, or failed after its retry); a run
        the external engine did not finish is missing (it is run again)."""
        out = []
        for p in points:
            r = self.store.get_run(self.key(stage, p))
            if r is None or (r.status == "failed" and (r.attempts < 2
                                                       or r.outcome in ENGINE_FAILURES)):
                out.append(p)
        return out

    def record(self, stage: str, p: Point, res: RunResult, attempts: int,
               started: float) -> RunRecord:
        """Store one run's result (as from :func:`demcal.execute.tasks.run_chunk`)."""
        outcome = res.outcome
        failed = outcome in retry_outcomes(self.test_for(stage)) or outcome in ENGINE_FAILURES
        reason = res.reason
        if failed and reason is None:
            reason = f"outcome {outcome}"
        key = self.key(stage, p)
        result = dict(res.detail)
        if attempts > 1:
            first = self.store.get_run(key)
            if first is not None:
                result["first_attempt"] = {"outcome": first.outcome, "reason": first.reason}
                reason = (f"retried with dt_fraction x{RETRY_DT_SCALE} after: {first.reason}"
                          + (f"; then: {reason}" if failed else ""))
        rec = RunRecord(
            key=key, stage=stage, point=p.point, replicate=p.replicate,
            params=dict(p.params), seed=p.seed, status="failed" if failed else "done",
            outcome=outcome, responses={} if failed else dict(res.responses),
            result=result, reason=reason, attempts=attempts,
            engine_version=self._engine_version(), started_at=started,
            finished_at=time.time(), wall_time_s=res.wall_time_s,
            artefacts=dict(res.detail.get("artefacts") or {}))
        self.store.record_run(rec)
        return rec

    def _engine_version(self) -> str:
        from importlib.metadata import PackageNotFoundError, version

        try:
            own = f"demcal {version('demcal')}"
        except PackageNotFoundError:  # pragma: no cover
            own = "demcal"
        engine = self.test.external
        if engine is None:
            return own
        return f"{own}; {engine.kind} {engine.template_sha256[:12]}: " + " ".join(engine.command)

    def _plot_path(self, stage: str, key: str) -> str | None:
        test = self.test_for(stage)
        if self.figures_dir is None or not (
                test.kind == "aor" or (test.external is not None and
                                       test.external.measures_positions)):
            return None
        digest = key.partition(":")[2]  # keys are "<stage>:<hash>"
        return str(self.figures_dir / f"{stage}_{digest[:12]}.png")

    def _execute(self, stage: str, points: list[Point], attempts: int, total: int,
                 done0: int) -> list[Point]:
        """Run points (``attempts``: 1 the first time, 2 a retry at :data:`RETRY_DT_SCALE`
        of the time step; ``done0`` of the stage's ``total`` runs are stored before them);
        return those to retry."""
        dt_scale = 1.0 if attempts == 1 else RETRY_DT_SCALE
        by_key = {self.key(stage, p): p for p in points}
        test = self.test_for(stage)
        tasks = [RunTask(k, test, p.params, p.seed, dt_scale, self._plot_path(stage, k))
                 for k, p in by_key.items()]
        chunks, rest = self._plan(tasks)
        retry: list[Point] = []
        started = time.time()
        count = [done0]

        def on_result(res: RunResult) -> None:
            p = by_key[res.key]
            rec = self.record(stage, p, res, attempts, started)
            self.executed += 1
            count[0] += 1
            if rec.outcome in retry_outcomes(test) and attempts < 2:
                retry.append(p)
            if self.progress is not None:
                self.progress(stage, count[0], total)

        if self.dask is not None:
            from demcal.execute.dask_exec import run_dask

            run_dask(chunks, on_result, address=self.dask, idle_timeout=self.dask_timeout)
        else:
            run_local(chunks, on_result, workers=self.workers)
            if rest:  # after the pool's rounds: one batch here, on every thread
                run_local([rest], on_result, workers=1)
        return retry

    def _plan(self, tasks: list[RunTask]) -> tuple[list[list[RunTask]], list[RunTask]]:
        """The chunks of a stage's runs for the pool (or Dask), and the runs left to batch in
        this process afterwards (``spread``)."""
        local = self.dask is None and self.workers > 1
        if local and self.spread and len(tasks) > 1:
            full = len(tasks) // self.workers * self.workers
            return [[t] for t in tasks[:full]], tasks[full:]
        size = self.chunk
        if local and len(tasks) > size:
            # several tasks on the pool: even them out so no worker idles while runs wait
            # (one task runs in this process on every thread instead)
            size = max(1, min(size, -(-len(tasks) // self.workers)))
        return [tasks[i:i + size] for i in range(0, len(tasks), size)], []

    def run(self, stage: str, points: Sequence[Point]) -> list[RunRecord]:
        """Make sure every point has a stored run of the test and of every test beside it;
        return the test's runs in ``points`` order, each with the responses of the runs
        beside it joined in (a failed run beside adds none).

        In external mode nothing runs: :class:`ExternalPending` is raised with the missing
        points (when every run is stored, the runs are returned as usual).
        """
        out = self._run_test(stage, points)
        if stage in NOTHING_BESIDE:
            return out
        for name in self.beside:
            runs = self._run_test(beside_stage(stage, name), points)
            self.beside_keys.update(r.key for r in runs)
            out = [joined(r, b) for r, b in zip(out, runs, strict=True)]
        return out

    def _run_test(self, stage: str, points: Sequence[Point]) -> list[RunRecord]:
        """:meth:`run` for one test (``stage`` names it: ``<stage>+<name>`` for one beside)."""
        todo = self.missing(stage, points)
        if todo and self.external:
            raise ExternalPending(stage, todo)
        total = len(points)
        if self.progress is not None:
            self.progress(stage, total - len(todo), total)
        fresh = [p for p in todo if self._fresh(self.store.get_run(self.key(stage, p)))]
        stale = [p for p in todo if p not in fresh]  # failed once, retry pending
        retry = self._execute(stage, fresh, 1, total, total - len(todo)) if fresh else []
        retry += stale
        if retry:
            self._execute(stage, retry, 2, total, total - len(retry))
        out = []
        for p in points:
            r = self.store.get_run(self.key(stage, p))
            assert r is not None
            out.append(r)
        self._check_engine_failures(stage, out)
        return out

    @staticmethod
    def _fresh(r: RunRecord | None) -> bool:
        """Run from scratch: never run, or not finished by the external engine."""
        return r is None or r.outcome in ENGINE_FAILURES

    @staticmethod
    def _check_engine_failures(stage: str, runs: list[RunRecord]) -> None:
        """StudyError when runs of the stage were not finished by the external engine."""
        failed = [r for r in runs if r.outcome in ENGINE_FAILURES]
        if not failed:
            return
        kinds = {k: sum(r.outcome == k for r in failed) for k in ENGINE_FAILURES}
        counts = ", ".join(f"{n} {k}" for k, n in kinds.items() if n)
        raise StudyError(
            f"{stage}: {len(failed)} of {len(runs)} runs failed in the external engine "
            f"({counts}); first: {failed[0].reason}. The {len(runs) - len(failed)} other runs "
            "are stored; fix the engine, its template or the time limit and run the study "
            "again: the failed runs are re-run (all runs, if the template or command changed)")

