"""From a binary pile mask to the outer boundary of its flanks (pixel coordinates).

Pixel ``(row, col)`` has its centre at integer coordinates; row 0 is the top of the image.
The base line ``base_row`` is the first row *below* the pile (the plate's top surface lies on
the upper edge of that row), so the centre of row ``r`` is ``base_row - r - 0.5`` pixel
heights above the base.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage as ndi
from skimage import measure as skm

from demcal.errors import InputError

__all__ = ["Outline", "find_base_row", "largest_region", "outline", "subpixel_edges"]


def largest_region(mask: np.ndarray) -> np.ndarray:
    """The largest 8-connected region of ``mask`` with its holes filled.

    Raises
    ------
    InputError
        The mask is empty (no pile found).
    """
    labels, n = ndi.label(mask, structure=np.ones((3, 3), dtype=bool))
    if n == 0:
        raise InputError("no pile found: the binarised image has no foreground region "
                         "(check threshold, pile polarity or roi)")
    sizes = np.bincount(labels.ravel())
    sizes[0] = 0
    region = labels == int(np.argmax(sizes))
    return ndi.binary_fill_holes(region)


def _row_extents(region: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows holding the region, with the leftmost and rightmost pixel column of each."""
    rows = np.flatnonzero(region.any(axis=1))
    sub = region[rows]
    ncol = region.shape[1]
    left = np.argmax(sub, axis=1)
    right = ncol - 1 - np.argmax(sub[:, ::-1], axis=1)
    return rows, left, right


def find_base_row(region: np.ndarray, *, jump_fraction: float = 0.15) -> int:
    """Find the base line of a pile region: the plate's top edge or the region's bottom.

    Scanning down from the apex, the width of a pile grows steadily; where a visible plate of
    the pile's tone joins the region, the width jumps. The first row whose width exceeds the
    row above by more than ``jump_fraction`` of the pile's apex-to-bottom height (in pixels,
    at least 4 px) is the base; without such a jump the base is just below the region.
    """
    rows, left, right = _row_extents(region)
    width = (right - left + 1).astype(np.float64)
    height = rows[-1] - rows[0] + 1
    jump = max(4.0, jump_fraction * height)
    steps = np.diff(width)
    gaps = np.diff(rows) > 1
    for k in np.flatnonzero((steps > jump) & ~gaps):
        if k + 1 >= 3:  # ignore jumps in the first rows below the apex
            return int(rows[k + 1])
    return int(rows[-1] + 1)


@dataclass(frozen=True)
class Outline:
    """Outer boundary of a pile region above its base line, in pixel coordinates.

    Attributes
    ----------
    rows : (n,) int ndarray
        Pixel rows holding the pile above the base, top to bottom.
    left, right : (n,) float ndarray
        Column of the outer edge of the leftmost / rightmost pile pixel in each row
        (``col - 0.5`` / ``col + 0.5``), px.
    base_row : int
        First row below the pile.
    region : (H, W) bool ndarray
        The pile region (largest connected component, holes filled, plate rows removed).
    below_px : int
        Rows of the connected region at and below the base line (a plate seen edge-on is a
        thin band; a region that goes on far below the base line means the base line was
        put inside the pile, e.g. on a background that darkens towards the bottom).
    """

    rows: np.ndarray
    left: np.ndarray
    right: np.ndarray
    base_row: int
    region: np.ndarray
    below_px: int = 0

    @property
    def apex_row(self) -> int:
        """Top row of the pile."""
        return int(self.rows[0])

    @property
    def height_px(self) -> float:
        """Pile height above the base line, pixel heights."""
        return float(self.base_row - self.rows[0])

    def z(self, pixel_aspect: float = 1.0) -> np.ndarray:
        """Height of each row's centre above the base, in pixel widths."""
        return (self.base_row - self.rows - 0.5) * pixel_aspect

    def contour(self) -> np.ndarray:
        """The region's outer contour as ``(m, 2)`` (row, col) points (for figures)."""
        padded = np.pad(self.region, 1).astype(np.float64)
        contours = skm.find_contours(padded, 0.5)
        best = max(contours, key=len)
        return best - 1.0


def _checked_base_row(region: np.ndarray, base_row: int | None) -> int:
    """The base line's row: ``base_row`` checked against the image, or found below the pile."""
    if base_row is None:
        base_row = find_base_row(region)
        if base_row >= region.shape[0]:
            raise InputError(
                "the pile reaches the bottom border of the image and no plate was found, so "
                "the base line is not visible; frame the pile with its base, or give base_line")
    if not 0 < base_row <= region.shape[0]:
        raise InputError(f"base_line must be a row in 1..{region.shape[0]}; got {base_row}")
    return base_row


def _check_clear_of_border(rows: np.ndarray, left: np.ndarray, right: np.ndarray,
                           width: int) -> None:
    """Raise if the pile's rows touch the top, left or right border of a ``width``-px image.

    A pile cut by the frame has no visible foot, so its flanks would be measured short.
    """
    sides = []
    if rows[0] == 0:
        sides.append("top")
    if np.any(left == 0):
        sides.append("left")
    if np.any(right == width - 1):
        sides.append("right")
    if sides:
        raise InputError(
            f"the pile touches the image border ({', '.join(sides)}); frame the whole pile "
            "with a margin, or set roi / threshold so that the background is excluded")


def outline(mask: np.ndarray, *, base_row: int | None = None,
            check_border: bool = True) -> Outline:
    """Outer boundary of the largest region of ``mask`` above the base line.

    Parameters
    ----------
    mask : (H, W) bool ndarray
        Pile pixels.
    base_row : int, optional
        First row below the pile; found by :func:`find_base_row` when omitted.
    check_border : bool
        Raise if the pile (above the base) touches the left, right or top image border.

    Raises
    ------
    InputError
        No pile, a pile touching the border, or a pile less than two rows high.
    """
    mask = np.asarray(mask, dtype=bool)
    region = largest_region(mask)
    base_row = _checked_base_row(region, base_row)
    full_rows = np.flatnonzero(region.any(axis=1))
    below = int(max(0, full_rows[-1] + 1 - base_row))
    region = region.copy()
    region[base_row:] = False
    if not region.any():
        raise InputError(f"no pile found above the base line (row {base_row})")
    region = largest_region(region)
    rows, left, right = _row_extents(region)
    if check_border:
        _check_clear_of_border(rows, left, right, region.shape[1])
    if rows.size < 2:
        raise InputError(f"the pile region is only {rows.size} pixel row(s) high; too small "
                         "to measure")
    return Outline(rows, left - 0.5, right + 0.5, int(base_row), region, below)


def subpixel_edges(ol: Outline, gray: np.ndarray, threshold: np.ndarray | float,
                   dark: bool) -> Outline:
    """Refine an outline's edges to where the grey level crosses the threshold.

    In each row, the edge between the outermost pile pixel and its outer neighbour is placed
    by linear interpolation of the grey level (``gray``, same frame as the outline) at the
    threshold (a scalar or a per-pixel array). Rows where the two pixels do not straddle the
    threshold (e.g. after morphological clean-up) keep the pixel edge. Pixel quantisation
    would otherwise bias a fit toward simple rational slopes (1, 1/2, ...).
    """
    t = np.broadcast_to(np.asarray(threshold, dtype=np.float64), gray.shape)
    sign = -1.0 if dark else 1.0  # pile where sign * (gray - t) > 0
    rows = ol.rows
    ncol = gray.shape[1]

    def refine(edge: np.ndarray, step: int) -> np.ndarray:
        inner = np.clip(np.rint(edge - 0.5 * step).astype(np.int64), 0, ncol - 1)
        outer = np.clip(inner + step, 0, ncol - 1)
        gi = sign * (gray[rows, inner] - t[rows, inner])
        go = sign * (gray[rows, outer] - t[rows, outer])
        ok = (gi > 0) & (go <= 0) & (outer != inner)
        frac = np.where(ok, gi / np.where(ok, gi - go, 1.0), 0.5)
        return np.where(ok, inner + step * frac, edge)

    return Outline(rows, refine(ol.left, -1), refine(ol.right, +1), ol.base_row, ol.region,
                   ol.below_px)
