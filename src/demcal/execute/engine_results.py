"""Reading what an external engine left in its run folder: spheres, or an angle.

- :func:`read_positions`: sphere centres and radii (m) from a CSV file, a whitespace table
  or a LAMMPS/LIGGGHTS text dump (its last snapshot), per :class:`PositionsResult`;
- :func:`read_value`: an angle (deg) the engine measured itself, a bare number or a JSON
  object, per :class:`ValueResult`; the JSON may name an outcome instead.

Anything missing, unreadable or out of range raises :class:`ResultUnreadable` with one line
saying what and where; the caller stores that run as a ``no_result`` failure.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from demcal.limits import MAX_INPUT_FILE_BYTES, MAX_SPHERES

__all__ = ["NO_PILE_OUTCOMES", "ResultUnreadable", "read_positions", "read_value"]

#: outcomes an engine may report in a JSON value file instead of an angle
NO_PILE_OUTCOMES = ("column", "plug", "scattered", "unsettled", "unstable")

#: largest result file read, bytes (spheres: about 60 bytes a line)
MAX_RESULT_BYTES = max(MAX_INPUT_FILE_BYTES, 100 * MAX_SPHERES)
#: largest value file read, bytes: a number or a small JSON object (a 3M-number list took
#: 9 MB of every run's reason and result)
MAX_VALUE_BYTES = 1024 * 1024


#: longest quote of an engine's value in a reason (a 3M-number list was echoed whole: 9 MB)
QUOTE_CHARS = 60
#: longest reason an engine may give for a run without a pile
REASON_CHARS = 500
#: largest JSON of an engine's extra values kept with a run (in the store, per run)
MAX_EXTRA_BYTES = 64 * 1024


class ResultUnreadable(Exception):
    """The engine's result file is missing, unreadable or out of range (one-line message)."""


def _quote(value: Any, limit: int = QUOTE_CHARS) -> str:
    """``repr(value)`` cut to ``limit`` characters (a reason is one line, not a dump)."""
    text = repr(value) if not isinstance(value, list | dict) or len(value) < 1000 else \
        f"<a {type(value).__name__} of {len(value):,} items>"
    return text if len(text) <= limit else text[:limit] + f"... ({len(text):,} characters)"


def _inside(run_dir: Path, name: str) -> Path:
    """The result file ``name`` of the run folder; one outside it (an absolute or ``..``
    path, or a symlink out, made by the study or the engine) is never read."""
    path = run_dir / name
    try:
        inside = path.resolve().is_relative_to(run_dir.resolve())
    except (OSError, RuntimeError):  # a symlink loop
        inside = False
    if not inside:
        raise ResultUnreadable(f"result file {name!r} lies outside the run folder {run_dir} "
                               "(an absolute or '..' path, or a symlink out of it): not read")
    return path


def _text(path: Path, limit: int = MAX_RESULT_BYTES) -> str:
    """The result file's text, refused by its size before it is read (``limit`` bytes),
    and refused when it holds NUL bytes (a sparse or binary file, not text)."""
    if not path.is_file():
        raise ResultUnreadable(f"result file {path.name} not found in {path.parent}")
    if path.stat().st_size > limit:
        size = f"{limit // 2**20} MB" if limit >= 2**20 else f"{limit // 1024} KB"
        raise ResultUnreadable(f"result file {path} is larger than {size}")
    try:
        data = path.read_bytes()
        if b"\x00" in data:
            raise ResultUnreadable(f"result file {path} holds NUL bytes: not a text file")
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise ResultUnreadable(f"result file {path} is not a text (UTF-8) file") from None
    except OSError as exc:
        raise ResultUnreadable(f"result file {path}: {exc.strerror}") from None


def _numbers(rows: list[list[str]], path: Path, first_line: int) -> np.ndarray:
    if not rows:
        raise ResultUnreadable(f"result file {path.name}: no spheres in it")
    width = len(rows[0])
    for i, r in enumerate(rows):
        if len(r) != width:
            raise ResultUnreadable(f"result file {path.name} line {first_line + i}: "
                                   f"{len(r)} values, the first row has {width}")
    try:
        data = np.array(rows, dtype=float)
    except ValueError:
        raise ResultUnreadable(f"result file {path.name}: a value is not a number") from None
    return data


def _table_rows(text: str, skip: int) -> tuple[list[list[str]], int]:
    lines = text.splitlines()[skip:]
    rows = [ln.split() for ln in lines if ln.strip() and not ln.lstrip().startswith("#")]
    return rows, skip + 1


def _csv(text: str, path: Path) -> tuple[list[str], list[list[str]]]:
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise ResultUnreadable(f"result file {path.name} is empty")
    header = [h.strip() for h in lines[0].split(",")]
    if len(set(header)) != len(header):  # 'x,x,y,z,radius' read the first x in silence
        twice = sorted({h for h in header if header.count(h) > 1})
        raise ResultUnreadable(f"result file {path.name}: column(s) {', '.join(twice)} named "
                               "twice in its header")
    return header, [[v.strip() for v in ln.split(",")] for ln in lines[1:]]


def _lammps_dump(text: str, path: Path) -> tuple[list[str], list[list[str]]]:
    """Header fields and rows of the last ``ITEM: ATOMS`` section of a text dump."""
    lines = text.splitlines()
    starts = [i for i, ln in enumerate(lines) if ln.startswith("ITEM: ATOMS")]
    if not starts:
        raise ResultUnreadable(f"result file {path.name}: no 'ITEM: ATOMS' section (not a "
                               "LAMMPS/LIGGGHTS text dump)")
    i = starts[-1]
    header = lines[i].split()[2:]
    rows = []
    for ln in lines[i + 1:]:
        if ln.startswith("ITEM:"):
            break
        if ln.strip():
            rows.append(ln.split())
    return header, rows


def read_positions(run_dir: str | Path, spec: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """Sphere centres (n, 3) and radii (n,), m, on a plate at z = 0.

    Parameters
    ----------
    run_dir : path
        The run's folder (``spec["file"]`` is taken from it).
    spec : dict
        A dumped :class:`demcal.execute.engine_spec.PositionsResult`.

    Raises
    ------
    ResultUnreadable
        Missing file, missing column, a non-number, a non-finite value or a radius <= 0.
    """
    path = _inside(Path(run_dir), spec["file"])
    text = _text(path)
    if text.count("\n") > MAX_SPHERES + 100_000:  # refused before the lines are split
        raise ResultUnreadable(f"result file {path.name}: more than {MAX_SPHERES:,} lines of "
                               "spheres")
    cols: dict[str, str | int] = spec["columns"]
    fmt = spec["format"]
    if fmt == "table":
        rows, first = _table_rows(text, int(spec.get("skip_rows") or 0))
        data = _numbers(rows, path, first)
        need = max(int(c) for c in cols.values())
        if data.shape[1] <= need:
            raise ResultUnreadable(f"result file {path.name}: {data.shape[1]} columns, the "
                                   f"columns setting reads column {need} (0-based)")
        index = {k: int(v) for k, v in cols.items()}
    else:
        header, rows = _csv(text, path) if fmt == "csv" else _lammps_dump(text, path)
        missing = [f"{k} = {v!r}" for k, v in cols.items() if v not in header]
        if missing:
            raise ResultUnreadable(f"result file {path.name}: no column {', '.join(missing)}"
                                   f" in its header ({', '.join(header)})")
        data = _numbers(rows, path, 2)
        if data.shape[1] != len(header):
            raise ResultUnreadable(f"result file {path.name}: {data.shape[1]} values a row, "
                                   f"{len(header)} header fields")
        index = {k: header.index(str(v)) for k, v in cols.items()}
    if len(data) > MAX_SPHERES:
        raise ResultUnreadable(f"result file {path.name}: {len(data):,} spheres; at most "
                               f"{MAX_SPHERES:,}")
    scale = float(spec.get("length_scale") or 1.0)
    centres = data[:, [index["x"], index["y"], index["z"]]] * scale
    centres[:, 2] -= float(spec.get("plate_z") or 0.0)
    if "radius" in index:
        radii = data[:, index["radius"]] * scale
    else:
        radii = np.full(len(data), float(spec["radius"]))
    if not (np.all(np.isfinite(centres)) and np.all(np.isfinite(radii))):
        raise ResultUnreadable(f"result file {path.name}: a position or radius is not finite")
    if np.any(radii <= 0):
        raise ResultUnreadable(f"result file {path.name}: a radius is <= 0")
    return centres, radii


def _json_size(value: Any) -> int:
    """Characters of ``value``'s JSON (a structure nested too deeply to write: no bound)."""
    try:
        return len(json.dumps(value, default=str))
    except (RecursionError, ValueError):
        return 2**62


def _bounded_extra(extra: dict[str, Any]) -> dict[str, Any]:
    """An engine's extra JSON values, kept whole up to :data:`MAX_EXTRA_BYTES`; beyond,
    each value too large is replaced by a note of its size (the run is kept, not the dump)."""
    if _json_size(extra) <= MAX_EXTRA_BYTES:
        return extra
    out: dict[str, Any] = {}
    for k, v in extra.items():
        n = _json_size(v)
        out[str(k)[:100]] = v if n <= MAX_EXTRA_BYTES // 16 else \
            f"<not kept: {n:,} bytes of JSON, more than {MAX_EXTRA_BYTES // 16:,}>"
        if len(out) >= 100:
            out["..."] = f"<{len(extra) - 100:,} more values not kept>"
            break
    return out


def _parse_value(text: str, path: Path) -> Any:
    """A value file's JSON (None when empty), else its one number."""
    try:
        return json.loads(text) if text else None
    except RecursionError:  # this run's result, not the study's end
        raise ResultUnreadable(f"result file {path.name}: JSON nested too deeply") from None
    except json.JSONDecodeError:
        pass
    try:
        if "_" in text:  # Python reads '3_0' as 30.0; an engine's '3_0' is no number
            raise ValueError(text)
        return float(text)
    except ValueError:
        raise ResultUnreadable(f"result file {path.name}: neither a number nor a JSON "
                               f"object: {_quote(text)}") from None


def read_value(run_dir: str | Path, spec: dict[str, Any]) -> dict[str, Any]:
    """The engine's own answer: ``{"outcome", "aor_deg", "reason"}``.

    A file holding one number is a pile at that angle (deg); a JSON object gives the angle
    under ``spec["key"]``, or ``outcome`` (one of :data:`NO_PILE_OUTCOMES`, or ``pile``) and
    an optional ``reason``; its other keys are kept under ``"engine_values"``. With a key
    other than ``aor_deg`` (a study that leads with another response) the value is that
    response's, any finite number, and joins ``engine_values`` under its key (``aor_deg``
    None).

    Raises
    ------
    ResultUnreadable
        Missing file, not a number or JSON, an unknown outcome, an angle outside (0, 90).
    """
    path = _inside(Path(run_dir), spec["file"])
    text = _text(path, MAX_VALUE_BYTES).strip()
    key = spec.get("key") or "aor_deg"
    doc = _parse_value(text, path)
    extra: dict[str, Any] = {}
    if isinstance(doc, dict):
        outcome = doc.get("outcome", "pile")
        extra = _bounded_extra({k: v for k, v in doc.items()
                                if k not in (key, "outcome", "reason")})
        if outcome != "pile":
            if not isinstance(outcome, str) or outcome not in NO_PILE_OUTCOMES:
                raise ResultUnreadable(f"result file {path.name}: outcome must be pile or one"
                                       f" of {', '.join(NO_PILE_OUTCOMES)}; got "
                                       f"{_quote(outcome)}")
            reason = doc.get("reason")
            return {"outcome": outcome, "aor_deg": None, "engine_values": extra,
                    "reason": None if reason is None else str(reason)[:REASON_CHARS]}
        if key not in doc:
            raise ResultUnreadable(f"result file {path.name}: no {key!r} in its JSON object")
        doc = doc[key]
    if isinstance(doc, bool) or not isinstance(doc, int | float):
        what = "the angle" if key == "aor_deg" else repr(key)
        raise ResultUnreadable(f"result file {path.name}: {what} must be a number; "
                               f"got {_quote(doc)}")
    if key != "aor_deg":  # another response the study leads with: any finite number
        value = float(doc)
        if not math.isfinite(value):
            raise ResultUnreadable(f"result file {path.name}: {key!r} must be a finite "
                                   f"number; got {value!r}")
        return {"outcome": "pile", "aor_deg": None, "reason": None,
                "engine_values": {**extra, key: value}}
    aor = float(doc)
    if not (math.isfinite(aor) and 0 < aor < 90):
        raise ResultUnreadable(f"result file {path.name}: the angle must be in (0, 90) deg; "
                               f"got {aor!r}")
    return {"outcome": "pile", "aor_deg": aor, "reason": None, "engine_values": extra}
