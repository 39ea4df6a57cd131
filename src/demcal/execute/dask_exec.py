"""Dask executor: every chunk of runs a task on a Dask cluster (``distributed.Client``).

Results come back in completion order and are handed to ``on_result`` at once, so a lost
worker (Dask re-runs its tasks elsewhere) or an interrupted client loses no stored run.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from demcal.errors import InputError
from demcal.execute.tasks import RunTask, run_chunk

__all__ = ["run_dask"]


def run_dask(chunks: Sequence[list[RunTask]], on_result: Callable[[dict[str, Any]], None], *,
             address: Any) -> None:
    """Run the chunks on the Dask scheduler at ``address`` (a string, or a Client/cluster)."""
    from distributed import Client, as_completed

    own = False
    if isinstance(address, Client):
        client = address
    else:
        try:
            client = Client(address, timeout="30s")
        except OSError as exc:
            raise InputError(f"--dask: cannot reach a Dask scheduler at {address!r}: {exc}") \
                from None
        own = True
    try:
        futures = [client.submit(run_chunk, list(c), pure=False, retries=1) for c in chunks]
        try:
            for fut in as_completed(futures):
                for r in fut.result():
                    on_result(r)
        except BaseException:
            client.cancel(futures)
            raise
    finally:
        if own:
            client.close()
