"""Keeping numba's on-disk kernel cache in step with the engine's sources.

numba's cache (``@njit(cache=True)``) checks only the source file of the function it compiled.
A kernel in :mod:`demcal.dem.kernels` inlines the contact laws of :mod:`demcal.dem.contact`, so
after an edit of ``contact.py`` alone (a ``git pull``, a branch switch) the cached kernel would
still run the *old* law, silently. :func:`purge_stale_kernels` runs when :mod:`demcal.dem` is
imported: it hashes every engine source file and, when the hash differs from the one recorded
beside the cache, deletes the engine's cached kernels (they recompile once, ~30 s).

A read-only install keeps numba's user-wide cache instead (keyed by file times, which a
reinstall renews); nothing is deleted there.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

__all__ = ["STAMP_NAME", "purge_stale_kernels", "sources_digest"]

#: File in the package's ``__pycache__`` holding the digest the cached kernels were built from.
STAMP_NAME = "demcal_engine_sources.sha256"

PACKAGE_DIR = Path(__file__).resolve().parent


def sources_digest(package_dir: Path = PACKAGE_DIR) -> str:
    """SHA-256 over the relative paths and bytes of every ``.py`` file under ``package_dir``."""
    h = hashlib.sha256()
    for path in sorted(package_dir.rglob("*.py")):
        h.update(path.relative_to(package_dir).as_posix().encode())
        h.update(b"\0")
        h.update(path.read_bytes())
    return h.hexdigest()


def purge_stale_kernels(package_dir: Path = PACKAGE_DIR) -> bool:
    """Delete the cached kernels under ``package_dir`` if its sources changed since they were
    built; returns whether anything was purged (False when up to date or not writable)."""
    stamp = package_dir / "__pycache__" / STAMP_NAME
    try:
        digest = sources_digest(package_dir)
        if stamp.is_file() and stamp.read_text() == digest:
            return False
        for cached in package_dir.glob("**/__pycache__/*.nb[ic]"):
            cached.unlink(missing_ok=True)
        stamp.parent.mkdir(exist_ok=True)
        tmp = stamp.with_name(f"{STAMP_NAME}.{os.getpid()}.tmp")
        tmp.write_text(digest)
        os.replace(tmp, stamp)
    except OSError:  # a read-only install: numba keeps its own user-wide cache
        return False
    return True
