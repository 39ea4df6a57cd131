"""Render sphere silhouettes (discs in a vertical plane) onto a pixel grid."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Raster", "render_discs"]


@dataclass(frozen=True)
class Raster:
    """A rendered silhouette.

    Attributes
    ----------
    mask : (n_rows, n_cols) bool ndarray
        Covered pixels; row 0 is the top, the plate lies on the bottom edge of the last row.
    u0 : float
        Horizontal coordinate of the left edge of column 0, m.
    plate_z : float
        Height of the plate (the bottom edge of the grid), m.
    pixel_size : float
        Side of a square pixel, m.
    chord_rows, chord_lo, chord_hi : (m,) ndarray
        Each disc's chord through each pixel row it covers: the row and the chord's ends, m
        (for exact, sub-pixel edges).
    """

    mask: np.ndarray
    u0: float
    plate_z: float
    pixel_size: float
    chord_rows: np.ndarray = field(repr=False)
    chord_lo: np.ndarray = field(repr=False)
    chord_hi: np.ndarray = field(repr=False)

    @property
    def base_row(self) -> int:
        """First row below the pile (one past the last row)."""
        return int(self.mask.shape[0])

    def to_x(self, col_edge: np.ndarray | float) -> np.ndarray | float:
        """Pixel-edge column coordinate (``col - 0.5`` convention) to horizontal position, m."""
        return self.u0 + (np.asarray(col_edge) + 0.5) * self.pixel_size

    def exact_edges(self, region: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exact left and right silhouette edges (m) of ``region`` in each of ``rows``.

        The ends of the outermost disc chords whose pixels belong to ``region`` (a mask of
        the raster's shape), free of pixel quantisation.
        """
        p = self.pixel_size
        n_cols = self.mask.shape[1]
        col = np.clip(np.ceil((self.chord_lo - self.u0) / p - 0.5).astype(np.int64), 0,
                      n_cols - 1)
        inside = region[self.chord_rows, col]
        r, lo, hi = self.chord_rows[inside], self.chord_lo[inside], self.chord_hi[inside]
        n_rows = self.mask.shape[0]
        left = np.full(n_rows, np.inf)
        right = np.full(n_rows, -np.inf)
        np.minimum.at(left, r, lo)
        np.maximum.at(right, r, hi)
        return left[rows], right[rows]


def render_discs(u: np.ndarray, z: np.ndarray, r: np.ndarray, *, pixel_size: float,
                 plate_z: float = 0.0, margin_px: int = 3) -> Raster:
    """Silhouette of spheres seen along a horizontal direction, cut at the plate.

    Parameters
    ----------
    u : (n,) float ndarray
        Horizontal coordinate of each sphere centre in the image plane, m.
    z : (n,) float ndarray
        Height of each centre, m.
    r : (n,) float ndarray
        Radii, m.
    pixel_size : float
        Pixel side, m.
    plate_z : float
        Plate height, m; only the parts of spheres above it are drawn.
    margin_px : int
        Empty pixels left around the silhouette (left, right and top).

    A pixel is covered when its centre lies inside a disc. Each disc is filled row by row
    with a difference array, so the cost is O(n * rows per disc), all vectorised.
    """
    p = float(pixel_size)
    above = z + r > plate_z
    u, z, r = u[above], z[above], r[above]
    u0 = float(np.min(u - r)) - margin_px * p
    n_cols = math.ceil((float(np.max(u + r)) - u0) / p) + margin_px
    n_rows = math.ceil((float(np.max(z + r)) - plate_z) / p) + margin_px
    # Row index of pixel centres z_row = plate_z + (n_rows - row - 0.5) p inside (z-r, z+r).
    top = np.ceil(n_rows - 0.5 - (z + r - plate_z) / p).astype(np.int64)
    k = math.ceil(2.0 * float(np.max(r)) / p) + 2
    rows = top[:, None] + np.arange(k)[None, :]
    zc = plate_z + (n_rows - rows - 0.5) * p
    dz = zc - z[:, None]
    half2 = r[:, None] ** 2 - dz**2
    ok = (half2 > 0) & (rows >= 0) & (rows < n_rows)
    half = np.sqrt(np.where(ok, half2, 0.0))
    uc = u[:, None]
    # Columns with centres u0 + (col + 0.5) p inside [u - half, u + half].
    c0 = np.ceil((uc - half - u0) / p - 0.5).astype(np.int64)
    c1 = np.floor((uc + half - u0) / p - 0.5).astype(np.int64)
    ok &= c1 >= c0
    chord_lo, chord_hi = (uc - half)[ok], (uc + half)[ok]
    rows, c0, c1 = rows[ok], np.clip(c0[ok], 0, n_cols), np.clip(c1[ok] + 1, 0, n_cols)
    width = n_cols + 1
    diff = np.bincount(rows * width + c0, minlength=n_rows * width)
    diff -= np.bincount(rows * width + c1, minlength=n_rows * width)
    mask = np.cumsum(diff.reshape(n_rows, width), axis=1)[:, :n_cols] > 0
    return Raster(mask, u0, float(plate_z), p, rows, chord_lo, chord_hi)
