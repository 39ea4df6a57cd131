"""Engine backends: launchers of the shared kernel bodies (CPU with numba, CUDA)."""

from __future__ import annotations

__all__ = ["cuda_available", "resolve_backend"]

from demcal.errors import InputError

BACKENDS = ("auto", "cpu", "cuda")


def cuda_available() -> bool:
    """True when numba can use a real CUDA GPU (never under the CUDA simulator)."""
    if _simulating():
        return False
    try:
        from numba import cuda

        return bool(cuda.is_available())
    except Exception:
        return False


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
