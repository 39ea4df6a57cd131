"""Angle of repose from a front photo of a pile (the paper's Fig. 5 procedure)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from demcal.errors import InputError
from demcal.measure._checks import (
    DEFAULT_FIT_WINDOW,
    check_fit_method,
    check_fit_window,
    check_positive,
)
from demcal.measure.boundary import Outline, outline, subpixel_edges
from demcal.measure.image import Binarised, binarise
from demcal.measure.linefit import Flank, fit_flank
from demcal.measure.quality import DEFAULT_GATES, FlankGates, flank_rejection

#: A base line found automatically is doubted when the connected pile region goes on below
#: it for more than this fraction of the measured pile height (a plate seen from the front is
#: a thin band; a region that continues far below means the base line was put inside the
#: pile, e.g. where a background darkening towards the bottom joins the pile's tone).
MAX_BELOW_FRACTION = 0.5

__all__ = ["PhotoAoR", "photo_aor"]


@dataclass(frozen=True)
class PhotoAoR:
    """Angle of repose measured on one photo.

    Lengths are in pixels (widths; heights are scaled by ``pixel_aspect``). Image
    coordinates ``(row, col)`` refer to the roll-corrected full frame :attr:`image`.

    Attributes
    ----------
    source : str
        File name, or ``"<array>"``.
    left, right : Flank
        Fitted flanks: lines ``x(z)`` with z the height above the base line and x the column
        relative to the region of interest's left edge.
    base_row, apex_row : int
        Row of the base line (first row below the pile) and of the pile's top.
    height_px : float
        Pile height above the base line, pixel widths.
    boundary : (m, 2) float ndarray
        Outer contour of the pile region, (row, col).
    threshold : float
        Threshold used: a grey level in [0, 1], or for ``"adaptive"`` a level of the
        lighting-corrected log grey image.
    pile : {"dark", "light"}
        Tone taken as the pile.
    fit_window : (float, float)
        Fractions of the pile height fitted.
    pixel_aspect : float
        Physical height / width of a pixel.
    offset : (int, int)
        Top-left (row, col) of the region of interest in :attr:`image`.
    image : (H, W) float ndarray
        The roll-corrected grey photo, [0, 1] (for figures).
    threshold_method : str
        ``"otsu"``, ``"adaptive"`` or ``"fixed"``: how the threshold was found.
    notes : tuple of str
        What the measurement decided on its own (e.g. a threshold given up and why).
    """

    source: str
    left: Flank
    right: Flank
    base_row: int
    apex_row: int
    height_px: float
    boundary: np.ndarray = field(repr=False)
    threshold: float
    pile: str
    fit_window: tuple[float, float]
    pixel_aspect: float
    offset: tuple[int, int]
    image: np.ndarray = field(repr=False)
    threshold_method: str = "otsu"
    notes: tuple[str, ...] = ()

    @property
    def left_deg(self) -> float:
        """Left flank angle, deg."""
        return self.left.angle_deg

    @property
    def right_deg(self) -> float:
        """Right flank angle, deg."""
        return self.right.angle_deg

    @property
    def mean_deg(self) -> float:
        """Mean of the left and right angle, deg (the photo's angle of repose)."""
        return 0.5 * (self.left_deg + self.right_deg)

    @property
    def left_stderr_deg(self) -> float:
        """Standard error of the left angle from its slope's standard error, deg."""
        return self.left.angle_stderr_deg

    @property
    def right_stderr_deg(self) -> float:
        """Standard error of the right angle, deg."""
        return self.right.angle_stderr_deg

    @property
    def left_residual_px(self) -> float:
        """RMS horizontal residual of the left fit, px."""
        return self.left.fit.residual

    @property
    def right_residual_px(self) -> float:
        """RMS horizontal residual of the right fit, px."""
        return self.right.fit.residual

    def line_points(self, side: str) -> np.ndarray:
        """End points ``(2, 2)`` (row, col) in :attr:`image` of a fitted line over the window."""
        flank = self.left if side == "left" else self.right
        z = np.array([flank.z_lo, flank.z_hi])
        rows = self.base_row - z / self.pixel_aspect - 0.5
        cols = np.asarray(flank.fit.x_at(z)) + self.offset[1]
        return np.column_stack([rows, cols])

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (NaN becomes None)."""
        out: dict[str, Any] = {
            "photo": self.source,
            "mean_deg": self.mean_deg,
            "left_deg": self.left_deg,
            "right_deg": self.right_deg,
            "left_stderr_deg": self.left_stderr_deg,
            "right_stderr_deg": self.right_stderr_deg,
            "left_residual_px": self.left_residual_px,
            "right_residual_px": self.right_residual_px,
            "left_points": self.left.fit.n_points,
            "right_points": self.right.fit.n_points,
            "fit": self.left.fit.method,
            "base_row": self.base_row,
            "apex_row": self.apex_row,
            "height_px": self.height_px,
            "threshold": self.threshold,
            "threshold_method": self.threshold_method,
            "notes": list(self.notes),
            "pile": self.pile,
            "fit_window": list(self.fit_window),
        }
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                for k, v in out.items()}


def _base_line_doubt(ol: Outline, automatic: bool) -> str | None:
    """Why an automatically found base line is not the plate, or None when it is plausible."""
    if not automatic or ol.below_px <= MAX_BELOW_FRACTION * ol.height_px:
        return None
    return (f"the base line (row {ol.base_row}) lies inside the object: its region goes on "
            f"{ol.below_px} px below it, more than {MAX_BELOW_FRACTION:.0%} of the "
            f"{ol.height_px:.0f} px measured above it")


def _measure(binar: Binarised, name: str, base: int | None, aspect: float,
             window: tuple[float, float], method: str,
             gates: FlankGates | None) -> tuple[Outline, Flank, Flank]:
    try:
        ol = outline(binar.mask, base_row=base)
        ol = subpixel_edges(ol, binar.level, binar.threshold, binar.pile == "dark")
    except InputError as exc:
        raise InputError(f"photo {name}: {exc}") from None
    z = ol.z(aspect)
    height = ol.height_px * aspect
    lo, hi = window
    try:
        left = fit_flank(z, ol.left, "left", lo * height, hi * height, method)
        right = fit_flank(z, ol.right, "right", lo * height, hi * height, method)
    except InputError as exc:
        raise InputError(f"photo {name}: {exc}") from None
    for flank in (left, right):
        why = flank_rejection(flank, gates)
        if why is not None:
            raise InputError(f"photo {name}: the {flank.side} flank fails the quality gates "
                             f"({why}); check the threshold, roi and base_line")
    return ol, left, right


def photo_aor(image_or_path: Any, *, threshold: str | float = "auto",
              base_line: int | None = None, roi: tuple[int, int, int, int] | None = None,
              roll_deg: float = 0.0, pixel_aspect: float = 1.0,
              fit_window: tuple[float, float] = DEFAULT_FIT_WINDOW, fit: str = "theil_sen",
              pile: str = "auto", smooth_px: float = 1.5, clean_px: int = 2,
              gates: FlankGates | None = DEFAULT_GATES) -> PhotoAoR:
    """Angle of repose of the pile in a front photo.

    Pipeline: grayscale, roll correction, region of interest, Gaussian denoising, threshold,
    morphological clean-up, largest connected region with holes filled, base line, outer
    boundary (the outermost pile pixel of each row on each side, refined to the sub-pixel
    threshold crossing), robust line fit of each flank over the fit window.

    Parameters
    ----------
    image_or_path : str, Path or ndarray
        A JPEG/PNG/TIFF/BMP file, or an ``(H, W)`` grey / ``(H, W, 3|4)`` colour array.
    threshold : "auto", "otsu", "adaptive" or float
        Otsu's global threshold; Otsu after removing a smooth lighting gradient
        (:func:`~demcal.measure.image.flatten_illumination`, for uneven lighting); or a grey
        level in (0, 1). ``"auto"`` (default) tries Otsu, and when the automatic base line
        is implausible (the region goes on below it for more than half the measured height:
        a background darkening towards the bottom taken for the pile) the adaptive
        threshold; if neither gives a plausible base line the photo is refused. The choice
        and why are in :attr:`PhotoAoR.notes`. With ``"otsu"``, ``"adaptive"`` or a number
        an implausible base line is refused, never measured.
    base_line : int, optional
        Image row of the plate surface (the first row below the pile), in the roll-corrected
        full frame. Default: found automatically, where the region widens abruptly into a
        visible plate of the pile's tone, else just below the pile region.
    roi : (row0, row1, col0, col1), optional
        Region of interest (rows row0..row1-1, columns col0..col1-1) of the roll-corrected
        frame; the pile must lie inside it with a margin.
    roll_deg : float
        Camera roll, deg: the angle by which a true horizontal appears rotated
        counter-clockwise in the photo. The photo is rotated back before measuring.
    pixel_aspect : float
        Physical height / width of a pixel (1 for square pixels).
    fit_window : (float, float)
        Heights fitted, fractions of the pile height above the base line (default (0.2, 0.8):
        drops the toe and the rounded top).
    fit : {"theil_sen", "least_squares", "ransac"}
        Line-fit method (default Theil-Sen, robust to stray grains on the boundary).
    pile : {"auto", "dark", "light"}
        Tone of the pile against the background (auto: see :func:`~demcal.measure.binarise`).
    smooth_px : float
        Sigma of the Gaussian denoising, px (0: none).
    clean_px : int
        Radius of the morphological opening/closing disc, px (0: none).
    gates : FlankGates or None
        Quality gates each flank must pass (:class:`~demcal.measure.quality.FlankGates`:
        e.g. steeper than 80 deg, too few points, poor fit); a photo with a failing flank is
        refused. None: no gates.

    Returns
    -------
    PhotoAoR

    Raises
    ------
    InputError
        Unreadable or uniform image, no pile, a pile touching the image border, too few
        boundary points in the window, an implausible base line, a flank failing the gates,
        or an invalid option (the message names it).

    Examples
    --------
    A dark 45-degree pile, 60 px high, on a light background with its base on row 100:

    >>> import numpy as np
    >>> img = np.full((120, 200), 0.9)
    >>> rows, cols = np.mgrid[0:120, 0:200]
    >>> img[(rows < 100) & (100 - rows <= 60 - np.abs(cols - 100))] = 0.1
    >>> res = photo_aor(img)
    >>> round(res.left_deg, 2), round(res.right_deg, 2), res.base_row
    (45.0, 45.0, 100)
    """
    window = check_fit_window(fit_window)
    method = check_fit_method(fit)
    aspect = check_positive(pixel_aspect, "pixel_aspect")
    smooth = float(smooth_px)
    if not (math.isfinite(smooth) and smooth >= 0):
        raise InputError(f"smooth_px must be >= 0 px; got {smooth_px!r}")
    if isinstance(clean_px, bool) or not isinstance(clean_px, int | np.integer) or clean_px < 0:
        raise InputError(f"clean_px must be an integer >= 0 px; got {clean_px!r}")
    if isinstance(threshold, str) and threshold == "auto":
        tries: list[Any] = ["otsu", "adaptive"]
    else:
        tries = [threshold]
    doubts: list[str] = []
    for t in tries:
        binar, name = binarise(image_or_path, threshold=t, roi=roi, roll_deg=roll_deg,
                               pile=pile, smooth_px=smooth, clean_px=int(clean_px))
        r0, c0 = binar.offset
        base = _base_row(base_line, r0, binar.mask.shape[0])
        ol, left, right = _measure(binar, name, base, aspect, window, method, gates)
        doubt = _base_line_doubt(ol, base is None)
        if doubt is not None:
            doubts.append(f"threshold {t}: {doubt}")
            continue
        notes = tuple(f"{d}; used threshold {t}" for d in doubts)
        return PhotoAoR(
            source=name, left=left, right=right, base_row=ol.base_row + r0,
            apex_row=ol.apex_row + r0, height_px=ol.height_px * aspect,
            boundary=ol.contour() + np.array([r0, c0]), threshold=binar.threshold,
            pile=binar.pile, fit_window=window, pixel_aspect=aspect, offset=(r0, c0),
            image=binar.gray, threshold_method=t if isinstance(t, str) else "fixed",
            notes=notes)
    raise InputError(f"photo {name}: no plausible base line ({'; '.join(doubts)}); give "
                     "base_line (the plate's image row), an roi that ends at the plate, or "
                     "another threshold")


def _base_row(base_line: Any, r0: int, n_rows: int) -> int | None:
    """The base line as a row of the region of interest (None: find it)."""
    if base_line is None:
        return None
    if isinstance(base_line, bool) or not isinstance(base_line, int | np.integer):
        raise InputError(f"base_line must be an integer image row; got {base_line!r}")
    base = int(base_line) - r0
    if not 0 < base <= n_rows:
        raise InputError(f"base_line must be a row inside the region of interest "
                         f"({r0 + 1}..{r0 + n_rows}); got {base_line}")
    return base
