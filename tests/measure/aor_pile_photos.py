"""Synthetic pile photos with known flank angles."""

from __future__ import annotations

import math

import numpy as np


def pile_photo(left_deg: float, right_deg: float, *, rng: np.random.Generator,
               shape: tuple[int, int] = (260, 420), noise: float = 0.03, blur: float = 1.0,
               lighting: float = 0.0, texture: float = 0.0, clutter: bool = False,
               plate: str | None = "dark", dark_pile: bool = True, supersample: int = 4,
               round_px: float = 3.0, plate_span: float = 0.92) -> tuple[np.ndarray, dict]:
    """A grey photo (H, W) float in [0, 1] of a pile with known flank angles.

    The pile's height over column x is ``Hc - sqrt((tan(a) (x - xa))^2 + c^2)`` on each side
    (a hyperbola: rounded top of radius ~ ``round_px``, straight flanks of angle ``a`` as
    asymptotes), blended smoothly into the plate (a rounded toe); rendered at
    ``supersample`` x resolution and block-averaged, so edges are anti-aliased. Options:
    Gaussian ``noise`` (sigma, grey levels), ``blur`` (px), ``lighting`` (amplitude of a
    left-right and top-bottom brightness gradient), ``texture`` (amplitude of grain on the
    pile and of a blotchy background), ``clutter`` (dark objects in the background),
    ``plate`` ("dark": a plate of the pile's tone, wider than the pile; "light": lighter than
    the pile; None: none) spanning ``plate_span`` of the width. Returns the image and a dict
    with the base row and the apex.
    """
    from scipy import ndimage as ndi

    h, w = shape
    s = supersample
    tl, tr = math.tan(math.radians(left_deg)), math.tan(math.radians(right_deg))
    base_row = int(0.8 * h)
    height = min(0.62 * h, 0.72 * w / (1 / tl + 1 / tr))
    # Apex column such that the pile is centred.
    half_l, half_r = height / tl, height / tr
    xa = 0.5 * w - 0.5 * (half_r - half_l)
    c = round_px
    xs = (np.arange(w * s) + 0.5) / s - 0.5
    ys = (np.arange(h * s) + 0.5) / s - 0.5
    tan = np.where(xs < xa, tl, tr)
    hc = height + c
    prof = hc - np.sqrt((tan * (xs - xa)) ** 2 + c**2)
    toe = 2.0
    prof = toe * np.logaddexp(0.0, prof / toe)  # smooth max(prof, 0): a rounded toe
    z = (base_row - 0.5) - ys  # height of each sub-row above the base line
    pile_mask = (z[:, None] >= 0) & (z[:, None] <= prof[None, :])
    tone_pile, tone_bg = (0.22, 0.78) if dark_pile else (0.8, 0.2)
    img = np.full((h * s, w * s), tone_bg)
    img[pile_mask] = tone_pile
    if plate is not None:
        p0, p1 = int(0.5 * (1 - plate_span) * w * s), int(0.5 * (1 + plate_span) * w * s)
        plate_rows = (z < 0) & (z >= -0.06 * h)
        img[np.ix_(plate_rows, np.arange(p0, p1))] = (
            tone_pile if plate == "dark" else 0.5 * (tone_pile + tone_bg) + 0.15)
    img = img.reshape(h, s, w, s).mean(axis=(1, 3))
    if texture:
        grain = ndi.gaussian_filter(rng.normal(0, 1, (h, w)), 0.7)
        blotch = ndi.gaussian_filter(rng.normal(0, 1, (h, w)), 6.0)
        blotch /= blotch.std()
        pile_part = np.abs(img - tone_pile) < 0.5 * abs(tone_bg - tone_pile)
        img = img + texture * np.where(pile_part, grain / grain.std(), blotch)
    if clutter:
        yy, xx = np.mgrid[0:h, 0:w]
        for cy, cx, rr in ((0.12 * h, 0.1 * w, 0.05 * h), (0.1 * h, 0.88 * w, 0.04 * h),
                           (0.25 * h, 0.05 * w, 0.03 * h)):
            img[(yy - cy) ** 2 + (xx - cx) ** 2 < rr**2] = tone_pile
        img[int(0.05 * h):int(0.09 * h), int(0.3 * w):int(0.45 * w)] = tone_pile
    if blur:
        img = ndi.gaussian_filter(img, blur)
    if lighting:
        yy, xx = np.mgrid[0:h, 0:w]
        img = img * (1.0 + lighting * (xx / w - 0.5) + 0.5 * lighting * (yy / h - 0.5))
    img = img + rng.normal(0, noise, img.shape)
    return np.clip(img, 0, 1), {"base_row": base_row, "apex_col": xa, "height": height}
