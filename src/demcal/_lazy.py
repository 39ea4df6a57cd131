"""Lazy package exports (PEP 562): a package names its public API without importing it.

``import demcal.calibrate.study`` runs ``demcal/calibrate/__init__.py`` first; if that imported
the whole pipeline, every command -- ``demcal --help`` included -- would pay for scipy.stats,
pandas, matplotlib and numba (~15 s on a 2-core VM) before printing a line. With
:func:`exports`, a package's ``__init__`` maps each public name to the module defining it, and
the module is imported the first time the name is read.
"""

from __future__ import annotations

import importlib
import importlib.util
from collections.abc import Callable, Mapping
from typing import Any


def exports(
    package: str, where: Mapping[str, str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]], list[str]]:
    """Build a package's ``__getattr__``, ``__dir__`` and ``__all__``.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    where : mapping of str to str
        Public name -> the submodule (relative to ``package``) that defines it. A name that is
        itself a submodule maps to its own name.

    Returns
    -------
    tuple
        ``(__getattr__, __dir__, __all__)`` for the package's namespace.
    """
    names = sorted(where)

    def __getattr__(name: str) -> Any:
        module = where.get(name)
        if module is None:
            # a submodule read as an attribute (`demcal.virtual.aor` after `import demcal.virtual`)
            # worked while the package imported everything; it still does
            if importlib.util.find_spec(f"{package}.{name}") is None:
                raise AttributeError(f"module {package!r} has no attribute {name!r}")
            module = name
        loaded = importlib.import_module(f"{package}.{module}")
        return loaded if module == name else getattr(loaded, name)

    def __dir__() -> list[str]:
        return names

    return __getattr__, __dir__, names
