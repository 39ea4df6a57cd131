"""The engine's cached kernels are dropped when any engine source changes."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from demcal.dem import _jit_cache
from demcal.dem._jit_cache import STAMP_NAME, purge_stale_kernels, sources_digest


def _package(tmp_path: Path) -> Path:
    pkg = tmp_path / "engine"
    (pkg / "backends" / "__pycache__").mkdir(parents=True)
    (pkg / "__pycache__").mkdir()
    (pkg / "contact.py").write_text("LAW = 1\n")
    (pkg / "kernels.py").write_text("from contact import LAW\n")
    (pkg / "backends" / "cpu.py").write_text("pass\n")
    return pkg


def _cached(pkg: Path) -> list[Path]:
    files = [pkg / "__pycache__" / "kernels.pair_contacts-173.py311.nbi",
             pkg / "__pycache__" / "kernels.pair_contacts-173.py311.1.nbc",
             pkg / "backends" / "__pycache__" / "cpu.run_chunk-158.py311.1.nbc"]
    for f in files:
        f.write_bytes(b"compiled")
    return files


def test_an_edit_of_a_called_module_drops_every_cached_kernel(tmp_path):
    pkg = _package(tmp_path)
    files = _cached(pkg)
    assert purge_stale_kernels(pkg)  # no stamp yet: built by an unknown version
    assert not any(f.exists() for f in files)
    files = _cached(pkg)
    assert not purge_stale_kernels(pkg)  # unchanged sources keep the cache
    assert all(f.exists() for f in files)
    (pkg / "contact.py").write_text("LAW = 2\n")  # kernels.py itself is untouched
    assert purge_stale_kernels(pkg)
    assert not any(f.exists() for f in files)
    assert (pkg / "__pycache__" / STAMP_NAME).read_text() == sources_digest(pkg)


def test_python_bytecode_is_left_alone(tmp_path):
    pkg = _package(tmp_path)
    pyc = pkg / "__pycache__" / "contact.cpython-311.pyc"
    pyc.write_bytes(b"bytecode")
    purge_stale_kernels(pkg)
    assert pyc.exists()


def test_a_read_only_install_is_not_an_error(tmp_path, monkeypatch):
    pkg = _package(tmp_path)

    def refuse(*args, **kwargs):
        raise PermissionError("read-only")

    monkeypatch.setattr(_jit_cache.os, "replace", refuse)
    assert purge_stale_kernels(pkg) is False


def test_the_installed_engine_is_up_to_date_after_import():
    import demcal.dem  # noqa: F401  (the import runs the check)

    stamp = _jit_cache.PACKAGE_DIR / "__pycache__" / STAMP_NAME
    if not os.access(_jit_cache.PACKAGE_DIR, os.W_OK):
        pytest.skip("a read-only install keeps no stamp")
    assert stamp.read_text() == sources_digest()
