"""A test's replicates on the CPU: lone single-thread tests, one process per core.

On the CPU a batch of worlds on N threads is slower than the same runs as lone tests in N
single-thread processes (the pair pass evaluates each pair once within a thread's block of
spheres, twice across blocks; processes share nothing). Each run's pile depends on its
parameters, test and seed only (every world is checked at its own interval, and the CPU's
trajectories do not depend on the thread count), so both give the same piles bit for bit.
Measured on the 2-core VM (2026-11-27): 4 `small` tests 181 s in two processes against 205 s
as one two-thread batch, the same outcomes and angles.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from demcal.execute.local import default_workers, run_local
from demcal.execute.tasks import RunTask, TestDef

__all__ = ["lone_test_workers", "run_lone_tests"]


def lone_test_workers(backend: str, n_runs: int) -> int:
    """Processes for ``n_runs`` replicates on ``backend``: 1 (run them in this process, as
    one batch) on a GPU or with one core, else up to one per core."""
    from demcal.dem.backends import resolve_backend

    if n_runs <= 1 or resolve_backend(backend) != "cpu":
        return 1
    return max(1, min(n_runs, default_workers()))


def run_lone_tests(params: dict[str, float], test: TestDef,
                   runs: Sequence[tuple[int, str | None]], *, workers: int,
                   on_result: Callable[[int, Any], None] | None = None) -> list[Any]:
    """Run the test once per seed, each a lone single-thread test, ``workers`` at a time.

    Parameters
    ----------
    params : dict
        The complete parameter set (SI units).
    test : TestDef
        The test (``kind`` "aor" on demcal's engine).
    runs : sequence of (int, str or None)
        One run per entry: its seed and where to save its pile picture (or None).
    workers : int
        Worker processes (spawned, ``NUMBA_NUM_THREADS=1``).
    on_result : callable, optional
        ``on_result(run_index, AoRResult)`` in this process as each run ends.

    Returns
    -------
    list of AoRResult
        One per run, in order.

    Raises
    ------
    SimulationUnstable
        When a run blew up (as a batch in this process would).
    """
    from demcal.errors import SimulationUnstable
    from demcal.virtual.aor import AoRResult

    tasks = [[RunTask(key=str(i), test=test, params=dict(params), seed=int(seed),
                      plot_path=None if plot is None else str(plot))]
             for i, (seed, plot) in enumerate(runs)]
    results: dict[int, AoRResult] = {}
    unstable: list[str] = []

    def done(r: dict[str, Any]) -> None:
        i = int(r["key"])
        if r["outcome"] == "unstable" and not r["result"]:
            unstable.append(str(r["reason"]))
            return
        results[i] = AoRResult(**r["result"])
        if on_result is not None:
            on_result(i, results[i])

    run_local(tasks, done, workers=workers)
    if unstable:
        raise SimulationUnstable(unstable[0])
    return [results[i] for i in range(len(runs))]
