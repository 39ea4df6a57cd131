"""Measuring a settled virtual pile the way a photo is measured (adapter to demcal.measure)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from demcal import measure
from demcal.errors import InputError
from demcal.virtual.config import MeasurementOptions

__all__ = ["measure_pile"]


def _finite(value: float) -> float | None:
    """``value`` as a float, or None when it is NaN or infinite (strict JSON)."""
    v = float(value)
    return v if math.isfinite(v) else None


def measure_pile(centres: np.ndarray, radii: np.ndarray, options: MeasurementOptions,
                 figure: str | Path | None = None) -> dict[str, Any]:
    """Angle of repose of a settled pile on the plate z = 0 by both measure methods.

    Parameters
    ----------
    centres : (n_spheres, 3) float ndarray
        Sphere centres, m.
    radii : (n_spheres,) float ndarray
        Sphere radii, m.
    options : MeasurementOptions
        Views, the method whose angle is reported as ``aor_deg``, the fit window.
    figure : path, optional
        If given and the pile was measured, a side view of the first view with the fitted
        flank lines is saved there (PNG) and its path returned as ``figure`` (or why not, as
        ``figure_error``).

    Returns a dict with ``aor_deg`` (the chosen method's mean over views), ``aor_left_deg``,
    ``aor_right_deg``, ``aor_std_deg``, ``aor_silhouette_deg``, ``aor_profile_deg``,
    ``pile_height_m``, ``base_diameter_m`` and ``views`` (per-view results of the chosen
    method), every number finite or None; ``measure_errors`` (method -> message) when the
    other method failed (the profile method may fail on a flat-topped column while the
    silhouette still measures it); or ``{"error": message}`` when the chosen method cannot
    measure the pile.
    """
    kwargs: dict[str, Any] = {"plate_z": 0.0}
    if options.fit_window is not None:
        kwargs["fit_window"] = tuple(options.fit_window)
    results: dict[str, measure.PileAoR] = {}
    errors: dict[str, str] = {}
    for method in ("silhouette", "profile"):
        try:
            if method == "silhouette":
                results[method] = measure.pile_aor_silhouette(
                    centres, radii, n_views=options.n_views, **kwargs)
            else:
                results[method] = measure.pile_aor_profile(centres, radii, **kwargs)
        except InputError as exc:
            errors[method] = str(exc)
    main = results.get(options.method)
    if main is None:
        return {"error": f"no measurable pile: {errors[options.method]}"}
    sil, prof = results.get("silhouette"), results.get("profile")
    out: dict[str, Any] = {
        "aor_deg": _finite(main.aor_deg),
        "aor_left_deg": _finite(main.left_deg),
        "aor_right_deg": _finite(main.right_deg),
        "aor_std_deg": _finite(main.std_deg),
        "aor_silhouette_deg": _finite(sil.aor_deg) if sil is not None else None,
        "aor_profile_deg": _finite(prof.aor_deg) if prof is not None else None,
        "n_flanks": main.n_flanks,
        "n_rejected": main.n_rejected,
        "rejected": main.rejections(),
        "pile_height_m": _finite(main.pile_height),
        "base_diameter_m": _finite(main.base_diameter),
        "views": main.views_as_dicts(),
    }
    if errors:
        out["measure_errors"] = errors
    if figure is not None:
        try:  # a picture that cannot be written must not cost the measurement
            measure.plot_pile_aor(main, figure, centres, radii)
            out["figure"] = str(figure)
        except InputError as exc:
            out["figure_error"] = str(exc)
    return out
