"""Angle of repose from photos and from simulated piles.

One boundary and line-fit core serves both: a pile region's outer boundary is reduced to one
point per pixel row on each flank, and the straight part of each flank (a window of relative
heights, default (0.2, 0.8)) is fitted with ``x = slope * z + intercept``.

- :func:`photo_aor`: one front photo; :func:`photos_aor` + :func:`save_table`: repeated
  photos as a table like the paper's Table 2 (each, mean, standard deviation).
- :func:`pile_aor_silhouette`, :func:`pile_aor_profile`: settled piles of spheres.
- :func:`plot_photo_aor`, :func:`plot_pile_aor`: diagnostic figures.
"""

from demcal.measure._checks import DEFAULT_FIT_WINDOW, FIT_METHODS
from demcal.measure.batch import AoRTable, photos_aor, save_table
from demcal.measure.boundary import Outline, find_base_row, largest_region, outline
from demcal.measure.image import binarise, flatten_illumination, load_gray
from demcal.measure.linefit import Flank, LineFit, fit_flank, fit_line
from demcal.measure.photo import PhotoAoR, photo_aor
from demcal.measure.pile import (
    PileAoR,
    ViewAoR,
    pile_aor_profile,
    pile_aor_silhouette,
    pile_axis,
    render_view,
    sector_spheres,
)
from demcal.measure.plot import plot_photo_aor, plot_pile_aor
from demcal.measure.render import Raster, render_discs

__all__ = [
    "DEFAULT_FIT_WINDOW",
    "FIT_METHODS",
    "AoRTable",
    "Flank",
    "LineFit",
    "Outline",
    "PhotoAoR",
    "PileAoR",
    "Raster",
    "ViewAoR",
    "binarise",
    "find_base_row",
    "fit_flank",
    "fit_line",
    "flatten_illumination",
    "largest_region",
    "load_gray",
    "outline",
    "photo_aor",
    "photos_aor",
    "pile_aor_profile",
    "pile_aor_silhouette",
    "pile_axis",
    "plot_photo_aor",
    "plot_pile_aor",
    "render_discs",
    "render_view",
    "save_table",
    "sector_spheres",
]
