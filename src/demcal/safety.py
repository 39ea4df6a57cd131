"""Safe handling of files named by user data: images, file names, CSV cells.

A study's store is data: a path it names, a symbol used in a file name, or a text that ends
up in a CSV cell must not make demcal read a file outside the study, write outside the
output folder, or hand a spreadsheet a formula. This module imports nothing of demcal but
:mod:`demcal.errors`, so every layer may use it.

Bounds
------
:data:`MAX_IMAGE_BYTES`
    Largest image file read (50 MB).
:data:`MAX_IMAGE_PIXELS`
    Largest image decoded (100 megapixels; a decompression bomb is refused before decoding).
:data:`MEASURE_BYTES_PER_PIXEL`
    Memory a photo's measurement takes per pixel; a photo needing more than is available
    is refused before decoding (:func:`memory_problem`).
"""

from __future__ import annotations

import math
import os
import re
import stat
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pandas loads with the caller's frame, not with every command
    import pandas as pd

__all__ = ["MAX_IMAGE_BYTES", "MAX_IMAGE_PIXELS", "MEASURE_BYTES_PER_PIXEL", "available_memory",
           "csv_cell", "csv_safe", "image_problem", "memory_problem", "not_regular",
           "photo_too_large", "regular_input", "repeated_column", "safe_filename",
           "study_image"]

MAX_IMAGE_BYTES = 50 * 1024 * 1024
MAX_IMAGE_PIXELS = 100_000_000
#: memory the measurement of a photo takes per pixel, bytes (probe 2026-11-27: a 48 MP JPEG
#: peaked at 6.6 GB, 137 bytes a pixel): the 100 MP bound needs ~14 GB, within 24 GiB
MEASURE_BYTES_PER_PIXEL = 140
_MAGIC = {b"\x89PNG\r\n\x1a\n": "PNG", b"\xff\xd8\xff": "JPEG"}
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r", "|", "%")
_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")


def not_regular(path: str | Path) -> str | None:
    """Why ``path`` (links followed) is not a regular file demcal may read, else None.

    A named pipe (FIFO) blocks its reader until a writer comes, forever when none does; a
    device may never end (``/dev/zero``, ``/dev/urandom``). Neither is an input file, so
    every input is refused unless it is a regular file. A missing file passes: its reader
    says "not found" as it always did.
    """
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "a folder, not a file"
    kind = "a named pipe (FIFO)" if stat.S_ISFIFO(mode) else \
        "a device" if stat.S_ISCHR(mode) or stat.S_ISBLK(mode) else \
        "a socket" if stat.S_ISSOCK(mode) else "not a regular file"
    return f"{kind}, not a regular file: reading it could block forever"


def regular_input(path: str | Path, what: str) -> Path:
    """``path`` as a Path if it is a regular file (or missing: its reader says so), else
    InputError naming ``what`` and why (see :func:`not_regular`)."""
    from demcal.errors import InputError

    if why := not_regular(path):
        raise InputError(f"{what} {path}: {why}")
    return Path(path)


def read_text_input(path: str | Path, what: str) -> str:
    """The text of a small input file (a study's template, a goals or repeats file): refused
    in one InputError starting with ``what`` when it is missing, not a regular file, larger
    than :data:`demcal.limits.MAX_INPUT_FILE_BYTES` or not UTF-8."""
    from demcal.errors import InputError
    from demcal.limits import MAX_INPUT_FILE_BYTES

    p = Path(path)
    if not p.is_file():
        raise InputError(f"{what}: file not found (or not a file): {p}")
    regular_input(p, what)
    if p.stat().st_size > MAX_INPUT_FILE_BYTES:
        raise InputError(f"{what}: {p} is larger than {MAX_INPUT_FILE_BYTES // 2**20} MB")
    try:
        return p.read_bytes().decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{what}: {p} is not a text (UTF-8) file") from None


def safe_filename(text: str, max_len: int = 100) -> str:
    """``text`` as one safe file-name part: only letters, digits, ``.``, ``_`` and ``-``.

    Parameters
    ----------
    text : str
        Any text (a factor symbol, a table key).
    max_len : int
        Longest result.

    Returns
    -------
    str
        Never empty, never ``.``/``..``, no path separator.
    """
    name = _UNSAFE.sub("_", str(text)).strip("._") or "_"
    return name[:max_len]


def repeated_column(path: str | Path) -> str | None:
    """The first column name a CSV file's header repeats (spaces stripped; empty names, as a
    spreadsheet's trailing commas leave, not counted), or None. A reader that renames the
    second (pandas: ``x3.1``) would otherwise use one of the two without a word."""
    import csv

    with open(path, newline="", encoding="utf-8", errors="replace") as fh:
        header = next(csv.reader(fh), [])
    seen: set[str] = set()
    for name in (c.strip() for c in header):
        if name and name in seen:
            return name
        seen.add(name)
    return None


def csv_cell(value: Any) -> Any:
    """A CSV cell that a spreadsheet will not run: text starting with ``=+-@`` etc. is quoted.

    Numbers, and text that reads as a number (``-1.5``), are kept as they are.
    """
    if not isinstance(value, str) or not value.startswith(_FORMULA_START) or value == "-":
        return value  # a lone "-" (the unit of a dimensionless value) is no formula
    try:
        float(value)
        return value
    except ValueError:
        return "'" + value


def csv_safe(frame: pd.DataFrame) -> pd.DataFrame:
    """A copy of ``frame`` whose text cells and column names pass :func:`csv_cell`."""
    out = frame.copy()
    out.columns = [csv_cell(c) for c in out.columns]
    for i in range(out.shape[1]):
        if out.iloc[:, i].dtype.kind not in "biufc":  # numbers are never formulas
            out.iloc[:, i] = out.iloc[:, i].map(csv_cell)
    return out


def image_problem(path: Path) -> str | None:
    """Why ``path`` is not an image demcal will read (None: a PNG or JPEG within bounds)."""
    return not_regular(path) or _image_problem(path)  # a named pipe is never opened


def _image_problem(path: Path) -> str | None:
    """:func:`image_problem` of a regular file."""
    try:
        size = path.stat().st_size
        with path.open("rb") as fh:
            head = fh.read(8)
    except OSError as exc:
        return f"cannot be read ({exc.strerror or exc})"
    if size > MAX_IMAGE_BYTES:
        return f"larger than {MAX_IMAGE_BYTES // (1024 * 1024)} MB"
    if not any(head.startswith(m) for m in _MAGIC):
        return "not a PNG or JPEG image"
    try:
        import warnings

        from PIL import Image

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a bomb warning: refused below by pixel count
            with Image.open(path) as im:
                w, h = im.size
    except Exception as exc:  # any decoder complaint: not an image we read
        return f"not a readable image ({type(exc).__name__})"
    if w * h > MAX_IMAGE_PIXELS or not math.isfinite(w * h):
        return f"{w} x {h} pixels, more than {MAX_IMAGE_PIXELS:,} (a decompression bomb?)"
    return None


def photo_too_large(path: str | Path) -> str | None:
    """Why a photo must not be decoded (too many pixels or bytes), else None.

    Only the header is read, so a decompression bomb is refused before it takes memory. A
    file that is not an image passes: its reader says so.
    """
    return not_regular(path) or _photo_too_large(Path(path))  # a named pipe is never opened


def _photo_too_large(p: Path) -> str | None:
    """:func:`photo_too_large` of a regular file."""
    try:
        if p.stat().st_size > MAX_IMAGE_BYTES:
            return f"larger than {MAX_IMAGE_BYTES // (1024 * 1024)} MB"
    except OSError:
        return None
    try:
        import warnings

        from PIL import Image

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with Image.open(p) as im:
                w, h = im.size
    except Exception as exc:
        if type(exc).__name__ == "DecompressionBombError":
            return f"more than {MAX_IMAGE_PIXELS:,} pixels (a decompression bomb?)"
        return None
    if w * h > MAX_IMAGE_PIXELS:
        return f"{w} x {h} pixels, more than {MAX_IMAGE_PIXELS:,} (a decompression bomb?)"
    return memory_problem(w * h)


def available_memory() -> int | None:
    """Bytes of memory this process may still take (Linux: ``MemAvailable``, capped by a
    cgroup's ``memory.max``); None where unknown."""
    avail = None
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                avail = int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    try:
        cap = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        current = Path("/sys/fs/cgroup/memory.current").read_text().strip()
        if cap.isdigit() and current.isdigit():
            left = int(cap) - int(current)
            avail = left if avail is None else min(avail, left)
    except OSError:
        pass
    return avail


def memory_problem(pixels: int) -> str | None:
    """Why measuring a photo of ``pixels`` would not fit in memory now, else None.

    The measurement takes about :data:`MEASURE_BYTES_PER_PIXEL` bytes a pixel (grey levels,
    thresholds, masks and labels of the whole frame); a photo that needs more than the
    memory available is refused before it is decoded, rather than taking the machine.
    """
    need = int(pixels) * MEASURE_BYTES_PER_PIXEL
    avail = available_memory()
    if avail is None or need <= avail:
        return None
    return (f"{pixels / 1e6:.1f} megapixels need about {need / 2**30:.1f} GiB to measure, "
            f"{max(avail, 0) / 2**30:.1f} GiB is available: scale the photo down or free "
            "memory")


def study_image(path: str | Path | None, study_dir: str | Path) -> tuple[Path | None, str]:
    """Resolve an image path stored by a study; only images inside the study folder pass.

    Parameters
    ----------
    path : str or Path or None
        As stored (absolute, or relative to the study folder).
    study_dir : str or Path
        The study folder.

    Returns
    -------
    (Path or None, str)
        The resolved file and "" when it may be read; else None and why not.
    """
    if not path:
        return None, "no image"
    root = Path(study_dir).resolve()
    p = Path(path)
    if not p.is_absolute():
        p = root / p
    try:
        p = p.resolve()
    except (OSError, RuntimeError):
        return None, "cannot be resolved"
    if not p.is_relative_to(root):
        return None, "outside the study folder, not read"
    if not p.is_file():
        return None, "image not found"
    why = image_problem(p)
    return (None, why) if why else (p, "")
