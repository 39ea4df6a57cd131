"""Many photos of repeated tests -> one table (the paper's Table 2: each, mean, std)."""

from __future__ import annotations

import json
import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from demcal.errors import InputError
from demcal.measure.photo import PhotoAoR, photo_aor

__all__ = ["AoRTable", "photos_aor", "save_table"]

_COLUMNS = ("photo", "mean_deg", "left_deg", "right_deg", "left_stderr_deg",
            "right_stderr_deg", "left_residual_px", "right_residual_px")


@dataclass(frozen=True)
class AoRTable:
    """Angles of repose of repeated photos.

    Attributes
    ----------
    results : tuple of PhotoAoR
        One per photo, in the order given.
    """

    results: tuple[PhotoAoR, ...]

    @property
    def angles_deg(self) -> np.ndarray:
        """Each photo's mean (left/right) angle, deg."""
        return np.array([r.mean_deg for r in self.results])

    @property
    def mean_deg(self) -> float:
        """Mean angle over the photos, deg."""
        return float(np.mean(self.angles_deg))

    @property
    def std_deg(self) -> float:
        """Sample standard deviation (ddof=1) of the photos' angles, deg (NaN for one)."""
        a = self.angles_deg
        return float(np.std(a, ddof=1)) if a.size > 1 else math.nan

    def rows(self) -> list[dict[str, Any]]:
        """One dict per photo with the columns of the table (NaN as None)."""
        out = []
        for r in self.results:
            d = r.to_dict()
            out.append({k: d[k] for k in _COLUMNS})
        return out

    def to_frame(self) -> Any:
        """A pandas DataFrame: one row per photo, then rows ``mean`` and ``std``."""
        import pandas as pd

        frame = pd.DataFrame(self.rows(), columns=list(_COLUMNS))
        summary = pd.DataFrame([
            {"photo": "mean", "mean_deg": self.mean_deg,
             "left_deg": float(np.mean([r.left_deg for r in self.results])),
             "right_deg": float(np.mean([r.right_deg for r in self.results]))},
            {"photo": "std", "mean_deg": self.std_deg},
        ], columns=list(_COLUMNS))
        return pd.concat([frame.astype(object), summary.astype(object)], ignore_index=True)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: ``photos`` (per-photo results), ``n``, ``mean_deg``, ``std_deg``."""
        std = self.std_deg
        return {"photos": [r.to_dict() for r in self.results], "n": len(self.results),
                "mean_deg": self.mean_deg, "std_deg": std if math.isfinite(std) else None}


def photos_aor(paths: Iterable[Any], **options: Any) -> AoRTable:
    """Measure each photo with :func:`~demcal.measure.photo_aor` (same ``options``).

    Raises
    ------
    InputError
        No photos, or a photo that cannot be measured (the message names it).
    """
    items = list(paths)
    if not items:
        raise InputError("photos: give at least one photo")
    return AoRTable(tuple(photo_aor(p, **options) for p in items))


def save_table(table: AoRTable, *, csv: str | Path | None = None,
               json_path: str | Path | None = None, **kwargs: Any) -> None:
    """Write the table as CSV (per-photo rows then ``mean`` and ``std``) and/or JSON.

    ``json=PATH`` is accepted as an alias of ``json_path``.
    """
    if "json" in kwargs:
        json_path = kwargs.pop("json")
    if kwargs:
        raise InputError(f"save_table: unknown option(s) {', '.join(sorted(kwargs))}")
    if csv is None and json_path is None:
        raise InputError("save_table: give csv and/or json output paths")
    try:
        if csv is not None:
            table.to_frame().to_csv(csv, index=False, float_format="%.4f")
        if json_path is not None:
            Path(json_path).write_text(json.dumps(table.to_dict(), indent=2, allow_nan=False))
    except OSError as exc:
        raise InputError(f"save_table: cannot write output ({exc})") from None
