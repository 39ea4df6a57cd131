"""Angle of repose from photos and from simulated piles.

One boundary and line-fit core serves both: a pile region's outer boundary is reduced to one
point per pixel row on each flank, and the straight part of each flank (a window of relative
heights, default (0.2, 0.8)) is fitted with ``x = slope * z + intercept``.

- :func:`pile_aor_silhouette`, :func:`pile_aor_profile`: settled piles of spheres.
"""

from demcal.measure._checks import DEFAULT_FIT_WINDOW, FIT_METHODS
from demcal.measure.boundary import Outline, find_base_row, largest_region, outline
from demcal.measure.linefit import Flank, LineFit, fit_flank, fit_line
from demcal.measure.pile import (
    PileAoR,
    ViewAoR,
    pile_aor_profile,
    pile_aor_silhouette,
    pile_axis,
    render_view,
)
from demcal.measure.render import Raster, render_discs

__all__ = [
    "DEFAULT_FIT_WINDOW",
    "FIT_METHODS",
    "Flank",
    "LineFit",
    "Outline",
    "PileAoR",
    "Raster",
    "ViewAoR",
    "find_base_row",
    "fit_flank",
    "fit_line",
    "largest_region",
    "outline",
    "pile_aor_profile",
    "pile_aor_silhouette",
    "pile_axis",
    "render_discs",
    "render_view",
]
