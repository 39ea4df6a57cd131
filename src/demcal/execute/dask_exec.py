"""Dask executor: every chunk of runs a task on a Dask cluster (``distributed.Client``).

Results come back in completion order and are handed to ``on_result`` at once, so a lost
worker (Dask re-runs its tasks elsewhere) or an interrupted client loses no stored run.
"""

from __future__ import annotations

import contextlib
import logging
import math
import time
from collections.abc import Callable, Sequence
from concurrent.futures import CancelledError
from typing import Any

from demcal.errors import InputError, StudyError
from demcal.execute.tasks import RunTask, run_chunk

__all__ = ["check_address", "run_dask"]

log = logging.getLogger("demcal")


def check_address(address: str) -> str:
    """A Dask scheduler address with its port (``tcp://host:8786``), else InputError.

    ``host:port`` gets the ``tcp://`` scheme; a missing host or port, or a port outside
    1-65535, is refused with one line before any run starts.
    """
    text = str(address).strip()
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, rest = "tcp", text
    if scheme not in ("tcp", "tls", "ws", "wss", "inproc", "ucx"):
        raise InputError(f"dask: unknown scheme {scheme!r} in {text!r}; e.g. tcp://host:8786")
    if scheme == "inproc":
        return text
    host, colon, port = rest.rpartition(":")
    if not colon or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise InputError(f"dask: address {text!r} needs a host and a port, e.g. "
                         "tcp://scheduler:8786")
    return f"{scheme}://{rest}"


def run_dask(chunks: Sequence[list[RunTask]], on_result: Callable[[dict[str, Any]], None], *,
             address: Any, idle_timeout: float | None = None, poll_s: float = 5.0) -> None:
    """Run the chunks on the Dask scheduler at ``address`` (a string, or a Client/cluster).

    Parameters
    ----------
    chunks : sequence of list of RunTask
        One Dask task per chunk.
    on_result : callable
        Called with each run's result as soon as its task ends.
    address : str or distributed.Client
        The scheduler (``tcp://host:port``) or a client.
    idle_timeout : float, optional
        Give up (:class:`demcal.errors.StudyError`) after this many seconds with no Dask
        worker, or with the scheduler lost; default: wait, and say so every minute.
    poll_s : float
        How often, s, the scheduler's workers are checked while nothing finishes.

    Raises
    ------
    InputError
        The address is malformed or no scheduler answers there.
    StudyError
        No worker (or no scheduler) for ``idle_timeout`` seconds, or the scheduler was lost;
        every finished run is already stored.
    """
    from distributed import wait

    client, own = _client(address)
    where = getattr(client, "scheduler", None)
    where = getattr(where, "address", None) or address
    try:
        futures = [client.submit(run_chunk, list(c), pure=False, retries=1) for c in chunks]
        pending = set(futures)
        watch = _IdleWatch(idle_timeout, str(where))
        try:
            while pending:
                try:
                    done, pending = wait(pending, timeout=poll_s, return_when="FIRST_COMPLETED")
                except TimeoutError:
                    done = set()
                if done:
                    watch.busy()
                    _deliver(done, on_result, where)
                else:
                    watch.check(_stalled(client), len(pending))
        except BaseException:
            with contextlib.suppress(Exception):
                client.cancel(futures)
            raise
    finally:
        if own:
            with contextlib.suppress(Exception):
                client.close()


def _client(address: Any) -> tuple[Any, bool]:
    """A Dask client for ``address`` (a Client is used as it is) and whether it is this
    call's own (closed at the end)."""
    from distributed import Client

    if isinstance(address, Client):
        return address, False
    address = check_address(address)
    try:
        return Client(address, timeout="30s"), True
    except OSError as exc:
        raise InputError(f"--dask: cannot reach a Dask scheduler at {address!r}: {exc}") \
            from None


def _deliver(done: Any, on_result: Callable[[dict[str, Any]], None], where: Any) -> None:
    """Hand every run of the finished tasks to ``on_result``; a task lost with the
    scheduler is a :class:`StudyError` (what was handed over is stored)."""
    for fut in done:
        try:
            results = fut.result()
        except (OSError, CancelledError) as exc:
            raise StudyError(f"dask: lost the scheduler at {where} ({type(exc).__name__}); "
                             "the finished runs are stored: run again to resume") from None
        for r in results:
            on_result(r)


class _IdleWatch:
    """How long the cluster has made no progress: a warning every minute, a
    :class:`StudyError` after ``timeout`` seconds (None: wait)."""

    def __init__(self, timeout: float | None, where: str) -> None:
        self.timeout, self.where = timeout, where
        self.since: float | None = None
        self.said = -math.inf

    def busy(self) -> None:
        """A task ended: the cluster works."""
        self.since = None

    def check(self, why: str | None, waiting: int) -> None:
        """Nothing ended in a poll; ``why``: the cluster's stall (None: it works, slowly)."""
        if why is None:
            self.since = None
            return
        now = time.monotonic()
        self.since = self.since or now
        if self.timeout is not None and now - self.since >= self.timeout:
            raise StudyError(f"dask: {why} at {self.where} for {now - self.since:.0f} s "
                             f"(timeout {self.timeout:g} s); the finished runs are "
                             "stored: run again to resume")
        if now - self.said >= 60:
            self.said = now
            log.warning("dask: %s at %s; %d tasks wait%s", why, self.where, waiting,
                        "" if self.timeout is None else
                        f" (giving up after {self.timeout:g} s)")


def _stalled(client: Any) -> str | None:
    """Why the cluster cannot make progress (no scheduler, no worker), or None."""
    if getattr(client, "status", "running") not in ("running", "newly-created"):
        return "no connection to the Dask scheduler"
    try:
        workers = client.scheduler_info().get("workers") or {}
        if not workers:  # the cached info may be stale: ask the scheduler itself
            workers = client.run_on_scheduler(
                lambda dask_scheduler: list(dask_scheduler.workers))
    except Exception:
        return "no connection to the Dask scheduler"
    return None if workers else "no Dask worker connected"
