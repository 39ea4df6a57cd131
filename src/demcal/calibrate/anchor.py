"""Where the study's own test meets the target along a path run at a cheaper fidelity.

A study may run its path of steepest ascent at a cheaper test than its response surface
(``stages.steepest.fidelity = "small"`` in a ``standard`` study). One cheap pile per step is a
noisy guide (the ``small`` test scatters 4-5 deg between seeds at cohesive points) and may read
differently from the study's test: on the corn stalk's path the step called best read 43.9 deg
at ``small`` and ~38 deg at ``standard``, and the Box-Behnken design around it (30.7-43.3 deg)
did not contain the 44.1 deg target. A response surface then optimises at its corner,
extrapolating, and the verification misses (3.1-3.4 % in both standard corn-stalk studies
before this).

The *anchor* runs the study's own test at path points around the best step and puts the
centre of the response surface where that test crosses the target, interpolated between the
points (the path is a straight line in coded units). When the target lies outside the anchored
points, the cheaper path's shape, shifted by the mean offset between the two tests measured so
far, says which points to anchor next.

Steps are path indices (0 = the path's start); a fractional step lies between two points.
Angles in degrees.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence

__all__ = ["crossing", "first_pair", "next_pair", "offset", "path_point", "surface_centre"]


def path_point(path: Sequence[Mapping[str, float]], step: float) -> dict[str, float]:
    """The path's settings at a fractional ``step``, linear between its neighbouring points.

    Parameters
    ----------
    path : sequence of dict
        The path's points, each {factor name: actual value (SI)}.
    step : float
        0 <= step <= len(path) - 1.
    """
    if not 0.0 <= step <= len(path) - 1:
        raise ValueError(f"step {step} outside the path (0..{len(path) - 1})")
    i = min(math.floor(step), len(path) - 2) if len(path) > 1 else 0
    w = step - i
    if w == 0.0 or len(path) == 1:
        return dict(path[i])
    return {n: (1.0 - w) * float(path[i][n]) + w * float(path[i + 1][n]) for n in path[i]}


def crossing(points: Mapping[float, float], target: float) -> float | None:
    """The first step at which the angles, linear between neighbouring steps, reach ``target``.

    Parameters
    ----------
    points : dict
        step -> angle (deg); steps in any order.
    target : float
        The angle sought (deg).

    Returns
    -------
    float or None
        The interpolated step, or None when no two neighbouring points bracket the target
        (a point exactly at the target is its own crossing).
    """
    steps = sorted(points)
    for s in steps:
        if points[s] == target:
            return float(s)
    for a, b in itertools.pairwise(steps):
        ya, yb = points[a] - target, points[b] - target
        if ya * yb < 0:
            return float(a + (b - a) * ya / (ya - yb))
    return None


def first_pair(best: int, n_steps: int) -> tuple[int, ...]:
    """The first points to anchor: the neighbours of the best step (the design's low and high
    levels along the path), kept on the path; both points when the path has only two."""
    if n_steps < 3:
        return tuple(range(n_steps))
    lo = min(max(best - 1, 0), n_steps - 3)
    return (lo, lo + 2)


def offset(path_aor: Sequence[float], anchored: Mapping[int, float]) -> float | None:
    """Mean of (study's test - path's test) over the anchored steps where both formed a pile,
    deg; None when there is none."""
    d = [anchored[s] - path_aor[s] for s in anchored if math.isfinite(path_aor[s])]
    return sum(d) / len(d) if d else None


def next_pair(path_aor: Sequence[float], anchored: Mapping[int, float],
              target: float) -> tuple[int, ...] | None:
    """The next points to anchor when the anchored ones do not bracket the target.

    The path's own angles shifted by the measured :func:`offset` predict where the study's
    test crosses the target; the pair of points around that crossing (or at the path's end
    nearest to the target when the shifted path does not reach it) is returned, less the
    points already anchored. None when nothing new is left to anchor.
    """
    n = len(path_aor)
    d = offset(path_aor, anchored)
    if d is None:
        return None
    shifted = {i: y + d for i, y in enumerate(path_aor) if math.isfinite(y)}
    guess = crossing(shifted, target)
    if guess is None:
        if not shifted:
            return None
        guess = float(min(shifted, key=lambda i: abs(shifted[i] - target)))
    lo = max(0, min(math.floor(guess), n - 2))
    pair = tuple(s for s in (lo, lo + 1) if s not in anchored)
    return pair or None


def surface_centre(step: float, n_steps: int) -> float:
    """The response surface's centre step for a crossing at ``step``: kept one step inside
    the path's ends so that the design's levels (centre -/+ one step) stay on the path."""
    if n_steps < 3:
        return 0.5 * (n_steps - 1)
    return min(max(step, 1.0), n_steps - 2.0)
