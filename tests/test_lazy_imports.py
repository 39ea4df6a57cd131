"""The packages' lazy exports (demcal._lazy) and what a bare command line loads.

``demcal --help``, a usage error and every command's argument parsing import ``demcal.cli``;
before the lazy exports that pulled in scipy.stats, pandas, matplotlib, numba and scikit-image
(~15 s on the 2-core VM) before the first line was printed.
"""

from __future__ import annotations

import importlib
import subprocess
import sys
import types

import pytest

LAZY_PACKAGES = ("demcal.calibrate", "demcal.doe", "demcal.measure", "demcal.physical",
                 "demcal.report", "demcal.virtual")

#: what a command line must not load before a command runs
HEAVY = ("scipy.stats", "scipy.optimize", "pandas", "matplotlib", "numba", "skimage", "sklearn",
         "emcee", "dask")


@pytest.mark.parametrize("package", LAZY_PACKAGES)
def test_every_exported_name_is_the_object_its_module_defines(package):
    pkg = importlib.import_module(package)
    assert pkg.__all__ == sorted(pkg.__all__) and len(pkg.__all__) > 3
    for name in pkg.__all__:
        value = getattr(pkg, name)
        if isinstance(value, types.ModuleType):  # a submodule exported as itself
            assert value.__name__ == f"{package}.{name}"
            continue
        home = getattr(value, "__module__", None)  # classes and functions say where they live
        if home is not None and home.startswith(package):
            assert getattr(importlib.import_module(home), name) is value, (package, name)
    assert set(dir(pkg)) >= set(pkg.__all__)


def test_an_unknown_name_is_an_attribute_error_and_a_submodule_still_reads_as_one():
    import demcal.virtual

    with pytest.raises(AttributeError, match="no attribute 'run_aorr'"):
        demcal.virtual.run_aorr  # noqa: B018
    with pytest.raises(ImportError):
        from demcal.virtual import run_aorr  # noqa: F401
    assert demcal.virtual.outcome.Outcome is demcal.virtual.Outcome


def test_the_command_line_loads_no_numerical_library_before_a_command_runs():
    probe = ("import sys, demcal.cli; "
             f"print(' '.join(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         check=True, timeout=120)
    assert out.stdout.split() == [], f"demcal.cli loads {out.stdout.strip()}"
