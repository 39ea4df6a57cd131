"""Angle of repose from photos and from simulated piles.

One boundary and line-fit core serves both: a pile region's outer boundary is reduced to one
point per pixel row on each flank, and the straight part of each flank (a window of relative
heights, default (0.2, 0.8)) is fitted with ``x = slope * z + intercept``.

- :func:`photo_aor`: one front photo; :func:`photos_aor` + :func:`save_table`: repeated
  photos as a table like the paper's Table 2 (each, mean, standard deviation).
- :func:`pile_aor_silhouette`, :func:`pile_aor_profile`: settled piles of spheres.
- :func:`plot_photo_aor`, :func:`plot_pile_aor`: diagnostic figures.
"""

# The public names, imported on first use (demcal._lazy): scikit-image and scipy load when a
# photo is measured, not with every command.
from demcal._lazy import exports

__getattr__, __dir__, __all__ = exports(__name__, {
    "DEFAULT_FIT_WINDOW": "_checks",
    "FIT_METHODS": "_checks",
    "AoRTable": "batch",
    "photos_aor": "batch",
    "save_table": "batch",
    "Outline": "boundary",
    "find_base_row": "boundary",
    "largest_region": "boundary",
    "outline": "boundary",
    "binarise": "image",
    "flatten_illumination": "image",
    "load_gray": "image",
    "Flank": "linefit",
    "LineFit": "linefit",
    "fit_flank": "linefit",
    "fit_line": "linefit",
    "PhotoAoR": "photo",
    "photo_aor": "photo",
    "PileAoR": "pile",
    "ViewAoR": "pile",
    "pile_aor_profile": "pile",
    "pile_aor_silhouette": "pile",
    "pile_axis": "pile",
    "render_view": "pile",
    "sector_spheres": "pile",
    "plot_photo_aor": "plot",
    "plot_pile_aor": "plot",
    "Raster": "render",
    "render_discs": "render",
})
