"""What a camera sees of a rotating drum through its end wall, and what the frames add up to.

Pure functions of particle positions (tested on constructed beds), in the drum's side view:
``u`` across the drum, positive towards the side the bed rises on (the side the wall carries
the material up), and ``v`` up, both from the drum's axis (m).

- :func:`surface_line`: the free surface of one frame. The view is cut into columns across
  the drum (about one particle diameter wide); the surface in a column is the top of its
  highest sphere, as the silhouette's top edge in a photo. A line is fitted through the
  columns of the central part of the bed's chord (the ends bend: the material climbs the
  rising wall and the avalanches pile up at the foot), and its angle to the horizontal is the
  dynamic angle of that frame. The highest sphere in a column of width ``b`` lies on average
  at the same offset from a straight surface in every column, so it shifts the line without
  tilting it.
- :func:`com_angle`: the angle from the vertical of the line from the axis to the bed's
  centre of mass: a second reading of the bed's tilt that needs no surface.
- :func:`classify_frames`: the typed outcome of the steady frames (rolling, slumping,
  cataracting, centrifuging; see :class:`DrumOutcome`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

__all__ = ["DrumOutcome", "FrameStats", "SurfaceLine", "classify_frames", "com_angle",
           "surface_line", "wall_coverage"]


class DrumOutcome(StrEnum):
    """Outcome of one rotating-drum test.

    - ``rolling``: a steady flowing layer on a flat surface (a surface layer flows in almost
      every frame);
    - ``slumping``: intermittent avalanches: in many frames nothing flows (the bed turns as
      a solid with the drum, then slumps);
    - ``cataracting``: particles thrown off the rising side fly over the surface;
    - ``centrifuging``: the material is carried round the whole wall;
    - ``slipping``: the bed slides on the wall instead of being carried up with it (the
      wall's friction is too low to lift it): its tilt is the wall's friction's, not the
      material's;
    - ``unsettled``: the fill did not come to rest, or the angle's running mean kept
      drifting, within the time limit, or no surface could be measured;
    - ``unstable``: numerical failure of the engine.

    ``rolling`` and ``slumping`` carry the dynamic angle (a slumping bed's is the mean
    between its avalanches' start and stop angles, as a camera averages it).
    """

    ROLLING = "rolling"
    SLUMPING = "slumping"
    CATARACTING = "cataracting"
    CENTRIFUGING = "centrifuging"
    SLIPPING = "slipping"
    UNSETTLED = "unsettled"
    UNSTABLE = "unstable"


#: the outcomes whose frames carry a dynamic angle
MEASURED = (DrumOutcome.ROLLING, DrumOutcome.SLUMPING)


@dataclass(frozen=True)
class SurfaceLine:
    """A frame's free surface: ``v = slope * u + intercept`` (m), its angle (deg), the
    number of columns fitted."""

    slope: float
    intercept: float
    angle_deg: float
    n_columns: int


def surface_line(uv: np.ndarray, radii: np.ndarray, *, bin_width: float,
                 central_fraction: float = 0.6) -> SurfaceLine | None:
    """The free surface of one side view, fitted over the central part of its chord.

    Parameters
    ----------
    uv : (n, 2) ndarray
        Sphere centres in the side view, m (``u`` across, towards the rising side; ``v`` up).
    radii : (n,) ndarray
        Sphere radii, m.
    bin_width : float
        Width of a column, m (about one particle diameter: narrower columns see the gaps
        between particles as the surface).
    central_fraction : float
        Part of the occupied chord (from the first to the last column holding a sphere)
        over which the line is fitted, centred on its middle.

    Returns
    -------
    SurfaceLine or None
        None when fewer than three columns lie in the central part.
    """
    uv = np.asarray(uv, dtype=float).reshape(-1, 2)
    r = np.asarray(radii, dtype=float).reshape(-1)
    if len(r) == 0 or not bin_width > 0:
        return None
    cols = np.floor(uv[:, 0] / bin_width).astype(np.int64)
    lo, hi = int(cols.min()), int(cols.max())
    tops = np.full(hi - lo + 1, -np.inf)
    np.maximum.at(tops, cols - lo, uv[:, 1] + r)
    centres = (np.arange(lo, hi + 1) + 0.5) * bin_width
    # the chord spans the occupied columns' outer edges
    a, b = lo * bin_width, (hi + 1) * bin_width
    mid, half = 0.5 * (a + b), 0.5 * central_fraction * (b - a)
    keep = np.isfinite(tops) & (np.abs(centres - mid) <= half)
    if np.count_nonzero(keep) < 3:
        return None
    slope, intercept = np.polyfit(centres[keep], tops[keep], 1)
    return SurfaceLine(float(slope), float(intercept), math.degrees(math.atan(slope)),
                       int(np.count_nonzero(keep)))


def com_angle(uv: np.ndarray, masses: np.ndarray) -> float | None:
    """Angle from the vertical of the line from the axis to the bed's centre of mass, deg
    (positive towards the rising side); None for an empty bed. ``uv`` (n, 2) clump centres
    in the side view, m; ``masses`` (n,) kg."""
    m = np.asarray(masses, dtype=float).reshape(-1)
    total = float(m.sum())
    if total <= 0:
        return None
    u, v = (np.asarray(uv, dtype=float).reshape(-1, 2) * m[:, None]).sum(axis=0) / total
    return math.degrees(math.atan2(u, -v))


def wall_coverage(uv: np.ndarray, *, radius: float, reach: float, sectors: int = 12) -> float:
    """Fraction of ``sectors`` equal sectors of the drum's wall (``radius``, m) that hold a
    clump centre within ``reach`` (m) of the wall; ``uv`` (n, 2) clump centres, m."""
    uv = np.asarray(uv, dtype=float).reshape(-1, 2)
    near = np.hypot(uv[:, 0], uv[:, 1]) >= radius - reach
    if not near.any():
        return 0.0
    phi = np.arctan2(uv[near, 1], uv[near, 0])
    k = np.floor((phi + math.pi) / (2 * math.pi) * sectors).astype(np.int64) % sectors
    return len(np.unique(k)) / sectors


@dataclass(frozen=True)
class FrameStats:
    """What the steady frames showed, each entry one frame.

    Attributes
    ----------
    flowing : ndarray
        Fraction of the clumps moving off the drum's solid-body rotation (the flowing layer).
    airborne : ndarray
        Fraction of the clumps above the fitted surface by more than a particle size.
    coverage : ndarray
        Fraction of the wall's sectors with material against them (:func:`wall_coverage`).
    carried : ndarray
        Fraction of the clumps against the wall that move with it (NaN: none against it).
    """

    flowing: np.ndarray
    airborne: np.ndarray
    coverage: np.ndarray
    carried: np.ndarray


#: a frame is "still" (nothing flows: the bed turns with the drum) below this flowing fraction
STILL_FLOWING = 0.03
#: slumping: at least this fraction of the frames is still
SLUMP_FRAMES = 0.25
#: cataracting: at least this mean fraction of the clumps flies above the surface
CATARACT_AIRBORNE = 0.05
#: centrifuging: the wall is covered all round in at least this fraction of the frames
CENTRIFUGE_FRAMES = 0.5
#: slipping: on average fewer than this fraction of the clumps against the wall move with it
SLIP_CARRIED = 0.2


def classify_frames(stats: FrameStats, fill_fraction: float) -> tuple[DrumOutcome, str | None]:
    """The outcome of a steadily turning drum's frames, with its reason when it is not
    ``rolling``: centrifuging, slipping, cataracting, slumping, else rolling, in this order.

    Parameters
    ----------
    stats : FrameStats
        The frames' flowing and airborne fractions and wall coverage.
    fill_fraction : float
        The drum's fill fraction: a bed that fills half the drum or more covers the whole
        wall without centrifuging, so coverage counts only below one half.
    """
    covered = float(np.mean(stats.coverage >= 1.0))
    if fill_fraction < 0.5 and covered >= CENTRIFUGE_FRAMES:
        return DrumOutcome.CENTRIFUGING, (
            f"the material covered the whole wall in {covered:.0%} of the frames "
            f"(centrifuging threshold {CENTRIFUGE_FRAMES:.0%})")
    carried = float(np.nanmean(stats.carried)) if np.isfinite(stats.carried).any() else 1.0
    if carried < SLIP_CARRIED:
        return DrumOutcome.SLIPPING, (
            f"only {carried:.0%} of the particles against the wall moved with it on average "
            f"(slipping threshold {SLIP_CARRIED:.0%}): the bed slides on the wall; raise the "
            "wall friction")
    airborne = float(np.mean(stats.airborne))
    if airborne >= CATARACT_AIRBORNE:
        return DrumOutcome.CATARACTING, (
            f"{airborne:.1%} of the particles flew above the surface on average (cataracting "
            f"threshold {CATARACT_AIRBORNE:.0%})")
    still = float(np.mean(stats.flowing < STILL_FLOWING))
    if still >= SLUMP_FRAMES:
        return DrumOutcome.SLUMPING, (
            f"nothing flowed in {still:.0%} of the frames (fewer than {STILL_FLOWING:.0%} of "
            f"the particles off the drum's rotation; slumping threshold {SLUMP_FRAMES:.0%})")
    return DrumOutcome.ROLLING, None
