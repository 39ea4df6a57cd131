"""Dask executor: every chunk of runs a task on a Dask cluster (``distributed.Client``).

Results come back in completion order and are handed to ``on_result`` at once, so a lost
worker (Dask re-runs its tasks elsewhere) or an interrupted client loses no stored run.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from demcal.errors import InputError
from demcal.execute.tasks import RunTask, run_chunk

__all__ = ["check_address", "run_dask"]


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
             address: Any) -> None:
    """Run the chunks on the Dask scheduler at ``address`` (a string, or a Client/cluster)."""
    from distributed import Client, as_completed

    own = False
    if isinstance(address, Client):
        client = address
    else:
        address = check_address(address)
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
