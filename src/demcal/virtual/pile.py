"""Measuring a settled virtual pile the way a photo is measured (adapter to demcal.measure)."""

from __future__ import annotations

from typing import Any

import numpy as np

from demcal.errors import InputError
from demcal.virtual.config import MeasurementOptions

__all__ = ["measure_pile"]


def measure_pile(centres: np.ndarray, radii: np.ndarray,
                 options: MeasurementOptions) -> dict[str, Any]:
    """Angle of repose of a settled pile on the plate z = 0 by both measure methods.

    Returns a dict with ``aor_deg`` (the chosen method's mean over views), ``aor_left_deg``,
    ``aor_right_deg``, ``aor_std_deg``, ``aor_profile_deg`` (surface-profile method),
    ``pile_height_m``, ``base_diameter_m`` and ``views`` (per-view left/right angles); or
    ``{"error": message}`` when no pile can be measured.
    """
    from demcal import measure

    kwargs: dict[str, Any] = {"plate_z": 0.0}
    if options.fit_window is not None:
        kwargs["fit_window"] = tuple(options.fit_window)
    try:
        sil = measure.pile_aor_silhouette(centres, radii, n_views=options.n_views, **kwargs)
        prof = measure.pile_aor_profile(centres, radii, **kwargs)
    except InputError as exc:
        return {"error": f"no measurable pile: {exc}"}
    main = sil if options.method == "silhouette" else prof
    out = {
        "aor_deg": float(main.mean_deg),
        "aor_left_deg": float(main.left_deg),
        "aor_right_deg": float(main.right_deg),
        "aor_std_deg": float(main.std_deg),
        "aor_silhouette_deg": float(sil.mean_deg),
        "aor_profile_deg": float(prof.mean_deg),
        "pile_height_m": float(main.pile_height),
        "base_diameter_m": float(main.base_diameter),
        "views": [v for v in main.views_as_dicts()] if hasattr(main, "views_as_dicts") else [],
    }
    return out
