"""Engine backends: launchers of the shared kernel bodies (CPU with numba, CUDA).

A backend implements :class:`Backend`; :class:`~demcal.dem.simulation.Simulation` holds one
as :attr:`~demcal.dem.simulation.Simulation.runner` and asks nothing else of it. The host
arrays (``Simulation.arrays``) are the simulation's; a backend may mirror them (CUDA) and
copies named arrays on ``pull``/``push``. Neighbour-list parity and the growth of the
neighbour and bucket arrays live in the backend.
"""

from __future__ import annotations

from typing import Protocol

__all__ = ["Backend", "cuda_available", "import_numba_cuda", "make_backend", "resolve_backend"]

from demcal.errors import InputError

BACKENDS = ("auto", "cpu", "cuda")


class Backend(Protocol):
    """What a :class:`~demcal.dem.simulation.Simulation` asks of a backend."""

    #: which neighbour buffer holds the current list: 0 ("a") or 1 ("b")
    parity: int

    @property
    def neighbor_side(self) -> str:
        """The neighbour buffer holding the current list: "a" or "b"."""
        ...

    def pull(self, *names: str) -> None:
        """Make the host copies of the named arrays current (device -> host)."""
        ...

    def push(self, *names: str) -> None:
        """The host changed the named arrays in place or replaced them: take them."""
        ...

    def push_all(self, parity: int = 0) -> None:
        """The host replaced every array (a snapshot whose current buffer is ``parity``)."""
        ...

    def run_steps(self, n_steps: int) -> None:
        """Advance every active world by ``n_steps`` steps (growing arrays as needed)."""
        ...

    def grow(self, neighbors: int = 0, buckets: int = 0) -> None:
        """Make room for ``neighbors`` slots per sphere and ``buckets`` spheres per bucket."""
        ...


def cuda_available() -> bool:
    """True when numba can use a real CUDA GPU (never under the CUDA simulator)."""
    if _simulating():
        return False
    try:
        return bool(import_numba_cuda().is_available())
    except Exception as exc:  # no driver, no numba-cuda: the CPU it is, and why
        import logging

        logging.getLogger("demcal.dem").info("no CUDA GPU usable: %r", exc)
        return False


def import_numba_cuda():
    """``numba.cuda``, imported the one way both the GPU probe and the CUDA backend use.

    numba-cuda 0.30 calls ``np.row_stack`` (gone in numpy 2.4+: patched in) and, on numpy >=
    2.5, warns at import (``np.timedelta64("nat")``): where warnings are errors (a test suite)
    the import failed and a real H100 read as "no GPU" (2026-11-27), so that warning is
    ignored here.
    """
    import warnings

    import numpy as np

    if not hasattr(np, "row_stack"):
        setattr(np, "row_stack", np.vstack)  # noqa: B010
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        from numba import cuda
    return cuda


def _simulating() -> bool:
    import os

    return os.environ.get("NUMBA_ENABLE_CUDASIM", "0") == "1"


def resolve_backend(backend: str) -> str:
    """Map ``"auto"`` to ``"cuda"`` when a GPU is present, else ``"cpu"``; validate names."""
    if backend not in BACKENDS:
        raise InputError(f"backend must be one of {', '.join(BACKENDS)}; got {backend!r}")
    if backend == "auto":
        return "cuda" if cuda_available() else "cpu"
    return backend


def make_backend(sim) -> Backend:
    """The backend named by ``sim.backend`` ("cpu" or "cuda") for simulation ``sim``."""
    if sim.backend == "cuda":
        from demcal.dem.backends.cuda import CudaBackend

        return CudaBackend(sim)
    from demcal.dem.backends.cpu_runner import CpuBackend

    return CpuBackend(sim)
