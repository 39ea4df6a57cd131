"""The dynamic angle of repose from frames of a rotating drum, seen through its end wall.

Per frame: the drum's circle (given, or found as the strongest circle of the frame's edges),
the material inside it (thresholded; the tone whose largest region lies on the circle's
bottom), the free surface (the top edge of that region in each pixel column across the
drum), a straight line fitted over the central part of the surface's chord (default 60 %:
the ends bend where the material climbs the rising wall and where the avalanches stop), and
its angle to the horizontal. Over the frames: the mean angle and its standard error (the
frames' standard deviation over the square root of their number, which holds for frames
taken far enough apart to be independent).

A frame that cannot give an honest angle is refused with its reason, never measured
wrongly: no circle found, no material or no free surface in the circle, a surface too short
to fit, a surface that is not straight (its line's rms residual above ``max_rms_px``), or a
bed that reaches the top of the drum.

Angles are positive when the surface rises to the right of the frame, deg.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from demcal.errors import InputError
from demcal.measure.boundary import largest_region
from demcal.measure.image import flatten_illumination, load_gray, threshold_value
from demcal.measure.video import is_video, video_frames

__all__ = ["DrumCircle", "DrumFrame", "DrumFrames", "drum_frame", "drum_frames",
           "find_circle"]


@dataclass(frozen=True)
class DrumCircle:
    """The drum's inner circle in a frame: centre ``(row, col)`` and radius, px."""

    row: float
    col: float
    radius: float


@dataclass(frozen=True)
class DrumFrame:
    """One frame: its angle (deg; None when refused) and why it was refused."""

    source: str
    angle_deg: float | None
    refused: str | None = None
    circle: DrumCircle | None = None
    n_columns: int = 0
    rms_px: float | None = None


@dataclass(frozen=True)
class DrumFrames:
    """Frames of one drum: each frame, and the measured ones' mean angle (deg), standard
    deviation and standard error (None with fewer than two)."""

    frames: list[DrumFrame] = field(default_factory=list)

    @property
    def angles(self) -> list[float]:
        return [f.angle_deg for f in self.frames if f.angle_deg is not None]

    @property
    def mean_deg(self) -> float | None:
        return float(np.mean(self.angles)) if self.angles else None

    @property
    def std_deg(self) -> float | None:
        return float(np.std(self.angles, ddof=1)) if len(self.angles) > 1 else None

    @property
    def sem_deg(self) -> float | None:
        std = self.std_deg
        return None if std is None else std / math.sqrt(len(self.angles))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary with every frame."""
        return {"dynamic_aor_deg": self.mean_deg, "std_deg": self.std_deg,
                "sem_deg": self.sem_deg, "n_frames": len(self.frames),
                "n_measured": len(self.angles),
                "frames": [{"source": f.source, "angle_deg": f.angle_deg, "refused": f.refused,
                            "n_columns": f.n_columns, "rms_px": f.rms_px,
                            "circle": None if f.circle is None else
                            [f.circle.row, f.circle.col, f.circle.radius]}
                           for f in self.frames]}


def find_circle(gray: np.ndarray) -> DrumCircle | None:
    """The strongest circle of the frame's edges (Canny, then a circular Hough transform over
    radii of 25-50 % of the frame's smaller side, on a frame shrunk to ~200 px): the drum's
    rim. None when no circle stands out."""
    from skimage import feature, transform

    scale = max(1, min(gray.shape) // 200)
    small = gray[::scale, ::scale]
    edges = feature.canny(small, sigma=2.0)
    if not edges.any():
        return None
    side = min(small.shape)
    radii = np.arange(max(4, int(0.25 * side)), int(0.5 * side) + 1)
    hough = transform.hough_circle(edges, radii)
    _, cols, rows, found = transform.hough_circle_peaks(hough, radii, total_num_peaks=1)
    if len(found) == 0:
        return None
    return DrumCircle(float(rows[0] * scale), float(cols[0] * scale), float(found[0] * scale))


def _material(gray: np.ndarray, inside: np.ndarray, threshold: Any, circle: DrumCircle
              ) -> np.ndarray | None:
    """The material's largest region inside the circle: of the two tones, the one whose
    largest region reaches lowest in the drum (the bed lies on the bottom)."""
    from skimage import filters

    if isinstance(threshold, str) and threshold == "adaptive":
        level, t = flatten_illumination(gray)
    elif isinstance(threshold, str) and threshold in ("otsu", "auto"):
        level, t = gray, float(filters.threshold_otsu(gray[inside]))
    else:
        level, t = gray, threshold_value(gray, threshold)
    best, lowest = None, -math.inf
    for mask in (level < t, level > t):
        region = largest_region(mask & inside)
        if not region.any():
            continue
        bottom = float(np.nonzero(region.any(axis=1))[0].max())
        if bottom > lowest:
            best, lowest = region, bottom
    if best is None or lowest < circle.row + 0.8 * circle.radius:
        return None
    return best


def drum_frame(image_or_path: Any, *, circle: DrumCircle | None = None,
               threshold: Any = "otsu", central_fraction: float = 0.6,
               max_rms_px: float | None = None) -> DrumFrame:
    """The dynamic angle of one frame, or the reason it was refused.

    Parameters
    ----------
    image_or_path : path or array
        The frame (any format :func:`demcal.measure.image.load_gray` reads).
    circle : DrumCircle, optional
        The drum's inner circle, px (default: found, :func:`find_circle`).
    threshold : {"otsu", "adaptive"} or float
        How the material is told from the background: Otsu's level inside the circle,
        ``adaptive`` (lighting falling off across the frame:
        :func:`~demcal.measure.image.flatten_illumination`) or a grey level in (0, 1).
    central_fraction : float
        Central part of the surface's chord fitted, in (0, 1].
    max_rms_px : float, optional
        Largest rms residual of the fitted line, px (default: 2 % of the drum's radius).

    Returns
    -------
    DrumFrame
        ``angle_deg`` positive when the surface rises to the right.
    """
    if not 0 < central_fraction <= 1:
        raise InputError(f"central_fraction must be in (0, 1]; got {central_fraction}")
    try:
        gray, name = load_gray(image_or_path)
    except InputError as exc:
        return DrumFrame(str(image_or_path) if not hasattr(image_or_path, "shape")
                         else "<array>", None, str(exc))
    found = circle if circle is not None else find_circle(gray)
    if found is None:
        return DrumFrame(name, None, "no drum circle found: give it (--circle ROW COL RADIUS)")
    rows, cols = np.mgrid[0:gray.shape[0], 0:gray.shape[1]]
    # the rim is neither material nor background, and a found circle may be its inner or
    # its outer edge: a ring of 7 % of the radius is left out (the fit's central part lies
    # far from it)
    inside = np.hypot(rows - found.row, cols - found.col) < 0.93 * found.radius
    bed = _material(gray, inside, threshold, found)
    if bed is None:
        return DrumFrame(name, None, "no material found on the drum's bottom", found)
    return _fit(name, bed, found, central_fraction, max_rms_px)


def _fit(name: str, bed: np.ndarray, circle: DrumCircle, central_fraction: float,
         max_rms_px: float | None) -> DrumFrame:
    """The line through the top edge of ``bed`` over the central part of its chord."""
    occupied = np.nonzero(bed.any(axis=0))[0]
    top = np.argmax(bed, axis=0).astype(float)  # first material row of each column
    if top[occupied].min() <= circle.row - 0.9 * circle.radius:
        return DrumFrame(name, None, "the material reaches the top of the drum (overfilled "
                         "or centrifuging): no free surface", circle)
    lo, hi = occupied.min(), occupied.max() + 1
    mid, half = 0.5 * (lo + hi), 0.5 * central_fraction * (hi - lo)
    cols = occupied[np.abs(occupied + 0.5 - mid) <= half]
    if len(cols) < 5:
        return DrumFrame(name, None, f"the free surface spans {len(cols)} columns in the "
                         "fitted part (fewer than 5)", circle, len(cols))
    slope, intercept = np.polyfit(cols, top[cols], 1)
    rms = float(np.sqrt(np.mean((top[cols] - (slope * cols + intercept)) ** 2)))
    limit = 0.02 * circle.radius if max_rms_px is None else max_rms_px
    if rms > limit:
        return DrumFrame(name, None, f"the free surface is not straight (rms {rms:.1f} px "
                         f"from the line, limit {limit:.1f} px)", circle, len(cols), rms)
    # image rows grow downwards: a surface rising to the right has a negative row slope
    return DrumFrame(name, -math.degrees(math.atan(slope)), None, circle, len(cols), rms)


def drum_frames(frames: Iterable[Any], *, every: int = 1, **options: Any) -> DrumFrames:
    """:func:`drum_frame` of every frame (same options), with their mean and standard
    error. A path to a video file (:func:`demcal.measure.video.is_video`) stands for its
    frames, every ``every``-th of them, each named ``VIDEO#K``."""
    out = []
    for item in frames:
        if isinstance(item, str | Path) and is_video(item):
            out += [replace(drum_frame(gray, **options), source=name)
                    for name, gray in video_frames(item, every=every)]
        else:
            out.append(drum_frame(item, **options))
    return DrumFrames(out)
