"""Diagnostic figures: a photo with its boundary and fitted flanks; a simulated pile's view."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from demcal.errors import InputError
from demcal.measure._checks import check_spheres
from demcal.measure.photo import PhotoAoR
from demcal.measure.pile import PileAoR, ViewAoR, render_view, sector_spheres
from demcal.measure.render import render_discs

__all__ = ["plot_photo_aor", "plot_pile_aor"]

_COLOURS = {"left": "tab:orange", "right": "tab:cyan"}


def _axes(path_or_ax: Any, figsize: tuple[float, float]) -> tuple[Any, Any]:
    """``(figure, axes)``: a new Agg figure for a path, or the given axes (figure None)."""
    if isinstance(path_or_ax, str | Path):
        from matplotlib.figure import Figure

        fig = Figure(figsize=figsize, layout="constrained")
        return fig, fig.add_subplot()
    if hasattr(path_or_ax, "plot") and hasattr(path_or_ax, "imshow"):
        return None, path_or_ax
    raise InputError(f"path_or_ax must be a file path or matplotlib Axes; got {path_or_ax!r}")


def _save(fig: Any, path_or_ax: Any, dpi: int) -> None:
    if fig is None:
        return
    try:
        fig.savefig(path_or_ax, dpi=dpi)
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot write figure {path_or_ax}: {exc}") from None


def plot_photo_aor(result: PhotoAoR, path_or_ax: Any, *, dpi: int = 120) -> Any:
    """Draw the photo with the pile boundary, base line, fitted flank lines and angles.

    Parameters
    ----------
    result : PhotoAoR
        A :func:`~demcal.measure.photo_aor` result.
    path_or_ax : str, Path or matplotlib Axes
        Output file (PNG, PDF, SVG, ...) or axes to draw on.
    dpi : int
        Resolution of a saved figure.

    Returns
    -------
    matplotlib Axes
    """
    h, w = result.image.shape
    fig, ax = _axes(path_or_ax, (7.0, 7.0 * h / w + 0.6))
    ax.imshow(result.image, cmap="gray", vmin=0, vmax=1, interpolation="nearest")
    b = result.boundary
    ax.plot(b[:, 1], b[:, 0], color="yellow", lw=0.8, label="boundary")
    ax.axhline(result.base_row - 0.5, color="tab:red", lw=1.0, ls=":", label="base line")
    for side, flank in (("left", result.left), ("right", result.right)):
        # Dashed over the whole pile height, solid over the fit window.
        z_full = np.array([0.0, result.height_px])
        rows_full = result.base_row - 0.5 - z_full / result.pixel_aspect
        cols_full = np.asarray(flank.fit.x_at(z_full)) + result.offset[1]
        ax.plot(cols_full, rows_full, color=_COLOURS[side], lw=1.0, ls="--")
        seg = result.line_points(side)
        ax.plot(seg[:, 1], seg[:, 0], color=_COLOURS[side], lw=2.2,
                label=f"{side}: {flank.angle_deg:.2f}° ± {flank.angle_stderr_deg:.2f}°")
        mid = seg.mean(axis=0)
        ax.annotate(f"{flank.angle_deg:.1f}°", (mid[1], mid[0]), color=_COLOURS[side],
                    fontsize=11, fontweight="bold", xytext=(-40 if side == "left" else 12, -4),
                    textcoords="offset points")
    ax.set_xlim(-0.5, w - 0.5)
    ax.set_ylim(h - 0.5, -0.5)
    ax.set_title(f"{Path(result.source).name}: AoR {result.mean_deg:.2f}° "
                 f"(fit window {result.fit_window[0]:g}-{result.fit_window[1]:g} of height)",
                 fontsize=10)
    ax.legend(loc="upper right", fontsize=8, framealpha=0.8)
    ax.set_axis_off()
    _save(fig, path_or_ax, dpi)
    return ax


def plot_pile_aor(result: PileAoR, path_or_ax: Any, centres: np.ndarray, radii: np.ndarray, *,
                  view: int = 0, dpi: int = 120) -> Any:
    """Side view of a simulated pile (silhouette or sector profile) with its fitted flanks.

    Parameters
    ----------
    result : PileAoR
        A :func:`~demcal.measure.pile_aor_silhouette` or
        :func:`~demcal.measure.pile_aor_profile` result of these spheres.
    path_or_ax : str, Path or matplotlib Axes
        Output file or axes to draw on.
    centres : (n_spheres, 3) float ndarray
        Sphere centres, m.
    radii : (n_spheres,) float ndarray
        Sphere radii, m.
    view : int
        Which view (silhouette) or sector (profile) to draw.

    Returns
    -------
    matplotlib Axes
        Axes in millimetres: horizontal position (silhouette) or distance from the axis
        (profile) against height.
    """
    c, r = check_spheres(centres, radii)
    if not 0 <= view < len(result.views):
        raise InputError(f"view must be in 0..{len(result.views) - 1}; got {view}")
    v: ViewAoR = result.views[view]
    p, pz = result.pixel_size, result.plate_z
    if result.method == "profile":
        if result.axis is None:
            raise InputError("a profile result needs its pile axis")
        sel, rho = sector_spheres(c, result.axis, len(result.views), view)
        above = sel & (c[:, 2] + r > pz)
        if not above.any():
            raise InputError(f"sector {view} holds no sphere")
        raster = render_discs(rho[above], c[above, 2], r[above], pixel_size=p, plate_z=pz)
        xlabel = "distance from the pile axis (mm)"
        title = f"profile, sector {view} (azimuth {v.azimuth_deg:.1f}°)"
    else:
        raster = render_view(c, r, v.azimuth_deg, pixel_size=p, plate_z=pz)
        xlabel = f"horizontal position along azimuth {v.azimuth_deg:.1f}° (mm)"
        title = f"silhouette, view {view}"
    n_rows, n_cols = raster.mask.shape
    extent = np.array([raster.u0, raster.u0 + n_cols * p, pz, pz + n_rows * p]) * 1e3
    aspect = (extent[3] - extent[2]) / (extent[1] - extent[0])
    fig, ax = _axes(path_or_ax, (8.0, min(8.0, max(2.6, 8.0 * aspect + 1.2))))
    ax.imshow(raster.mask, cmap="Greys", extent=tuple(extent), interpolation="nearest",
              aspect="equal", alpha=0.8)
    ax.axhline(pz * 1e3, color="tab:red", lw=1.0, ls=":")
    flanks = [(s, f) for s, f in (("left", v.left), ("right", v.right)) if f is not None]
    for side, flank in flanks:
        fit = flank.fit
        if result.method == "profile" and side == "left":
            fit = type(fit)(-fit.slope, -fit.intercept, fit.slope_stderr, fit.residual,
                            fit.n_points, fit.n_inliers, fit.method)
        z_full = np.array([0.0, v.pile_height])
        z_win = np.array([flank.z_lo, flank.z_hi])
        ax.plot(np.asarray(fit.x_at(z_full)) * 1e3, (z_full + pz) * 1e3,
                color=_COLOURS[side], lw=1.0, ls="--")
        ax.plot(np.asarray(fit.x_at(z_win)) * 1e3, (z_win + pz) * 1e3, color=_COLOURS[side],
                lw=2.2, label=f"{side}: {flank.angle_deg:.2f}°")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("height (mm)")
    status = f"; {v.error}" if v.error else ""
    ax.set_title(f"{title}: pile mean {result.mean_deg:.2f}° ± {result.std_deg:.2f}°{status}",
                 fontsize=9)
    if flanks:
        ax.legend(loc="upper right", fontsize=8)
    _save(fig, path_or_ax, dpi)
    return ax
