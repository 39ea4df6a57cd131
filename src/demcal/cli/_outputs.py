"""Output paths that would eat an input: refused before any work starts.

:func:`demcal.cli._common.check_output_file` checks that an output *can* be written; this
module checks that it *may*: a command's ``--json``, ``--plot``, ``--csv`` or ``--out`` must
not be one of the files the command reads or keeps (the study file, its run store and the
store's SQLite side files, a measurements file, an engine template or hook, an input photo),
nor the same file as another of its outputs. Written after a study of hours, such an output
would replace the store (every run lost) or the study file; written after a measurement, it
would replace the photo.

A path is the same file when it resolves to the same place (``./a/../b``, a symlink) or, for
an existing file, is the same inode (a hard link).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from pathlib import Path

from demcal.errors import InputError

__all__ = ["STORE_SIDE_FILES", "refuse_overwrites", "store_files", "study_inputs"]

#: SQLite's side files of a store (write-ahead log, shared memory, rollback journal)
STORE_SIDE_FILES = ("-wal", "-shm", "-journal")


def _same(a: Path, b: Path) -> bool:
    """Whether ``a`` and ``b`` name one file (after resolving links, or the same inode)."""
    try:
        if a.resolve() == b.resolve():
            return True
    except (OSError, RuntimeError):  # a symlink loop: compare as typed
        if os.path.abspath(a) == os.path.abspath(b):
            return True
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def store_files(store: Path) -> list[tuple[Path, str]]:
    """The run store ``store`` and its SQLite side files, each with what it is."""
    store = Path(store)
    return [(store, "the study's run store")] + [
        (store.with_name(store.name + s), "the run store's SQLite side file")
        for s in STORE_SIDE_FILES]


def study_inputs(study_file: Path, study: object | None = None) -> list[tuple[Path, str]]:
    """The files a study reads or keeps: its file, its store, its measurement files,
    photos, engine template and hook.

    Parameters
    ----------
    study_file : Path
        The study TOML.
    study : Study, optional
        The loaded study (its relative paths already resolved); without it only the study
        file and its store are named.

    Returns
    -------
    list of (Path, str)
        Each protected file and a few words saying what it is (for the refusal).
    """
    from demcal.calibrate.study import study_folder
    from demcal.store import STORE_NAME

    out = [(Path(study_file), "the study file")]
    out += store_files(study_folder(study_file) / STORE_NAME)
    if study is None:
        return out
    material = getattr(study, "material", None)
    target = getattr(study, "target", None)
    for p in (getattr(material, "measurements", None), getattr(target, "measurements", None)):
        if p:
            out.append((Path(p), "a measurements file of the study"))
    out += [(Path(p), "a photo of the study") for p in getattr(target, "photos", None) or []]
    engine = getattr(study, "_engine", None)  # a ResolvedEngine, read with the study
    if engine is not None:
        out.append((Path(engine.template_path), "the engine's template"))
        if engine.hook_file is not None:
            out.append((engine.hook_file, "the engine's hook"))
    return out


def refuse_overwrites(outputs: Mapping[str, Path | None],
                      inputs: Iterable[tuple[Path | None, str]]) -> None:
    """Refuse an output that is one of the command's inputs, or another of its outputs.

    Parameters
    ----------
    outputs : mapping of str to Path or None
        Each output option (``"--json"``) and the file it names (None: not given).
    inputs : iterable of (Path or None, str)
        The files the command reads or keeps, each with what it is (``"the study file"``).

    Raises
    ------
    InputError
        One line naming the option, the file and what it would replace.
    """
    given = [(opt, Path(p)) for opt, p in outputs.items() if p is not None]
    protected = [(Path(p), what) for p, what in inputs if p is not None]
    for opt, path in given:
        for p, what in protected:
            if _same(path, p):
                raise InputError(f"{opt}: {path} is {what}; writing there would replace it: "
                                 "give another file name")
    for i, (opt, path) in enumerate(given):
        for other, p in given[i + 1:]:
            if _same(path, p):
                raise InputError(f"{opt} and {other} name the same file {path}; give each "
                                 "its own file name")
