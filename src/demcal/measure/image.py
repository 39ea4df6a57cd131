"""Photo to binary pile mask: load, grayscale, level, crop, denoise, threshold, clean up."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy import ndimage as ndi

from demcal.errors import InputError
from demcal.measure.boundary import largest_region

__all__ = ["Binarised", "binarise", "flatten_illumination", "load_gray", "threshold_value"]


def load_gray(image_or_path: Any) -> tuple[np.ndarray, str]:
    """Read a photo (path or array) as a float grey image in [0, 1] and a name for it.

    Accepts a path to a JPEG/PNG/TIFF/BMP file, or an array: ``(H, W)`` grey,
    ``(H, W, 3)`` RGB or ``(H, W, 4)`` RGBA, of any integer or float dtype (floats taken as
    [0, 1]).

    Raises
    ------
    InputError
        Missing or unreadable file, wrong array shape, an empty or uniform image.
    """
    if isinstance(image_or_path, str | Path):
        path = Path(image_or_path)
        name = str(path)
        img = _read_photo(path)
    else:
        name = "<array>"
        img = image_or_path
    img = _checked_pixels(img, name)
    gray = _unit_gray(img, name)
    if float(np.ptp(gray)) < 1e-3:
        raise InputError(f"photo {name}: the image is uniform (no contrast); no pile to find")
    return gray, name


def _read_photo(path: Path) -> np.ndarray:
    """The pixels of the image file at ``path`` (16-bit grey already scaled to [0, 1])."""
    from PIL import Image, UnidentifiedImageError

    if not path.is_file():
        raise InputError(f"photo {path}: no such file")
    try:
        with Image.open(path) as im:
            im.load()
            if im.mode not in ("L", "RGB", "RGBA", "I;16", "I", "F"):
                im = im.convert("RGBA" if "A" in im.mode else "RGB")
            img = np.asarray(im)
    except (UnidentifiedImageError, OSError, ValueError) as exc:
        raise InputError(f"photo {path}: not a readable image ({type(exc).__name__}: "
                         f"{str(exc).splitlines()[0] if str(exc) else 'unknown format'})"
                         ) from None
    if img.dtype == np.int32:  # 16-bit greyscale read as 32-bit integers
        img = img.astype(np.float64) / (65535.0 if img.max() > 255 else 255.0)
    return img


def _checked_pixels(img: Any, name: str) -> np.ndarray:
    """``img`` as a numeric (H, W), (H, W, 3) or (H, W, 4) array of at least 8 x 8 pixels."""
    try:
        img = np.asarray(img)
    except (TypeError, ValueError):
        raise InputError(f"photo {name}: not an image array") from None
    if img.dtype == object or not (np.issubdtype(img.dtype, np.number) or img.dtype == bool):
        raise InputError(f"photo {name}: image must be numeric; got dtype {img.dtype}")
    if img.ndim == 3 and img.shape[2] == 1:
        img = img[:, :, 0]
    if img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] not in (3, 4)):
        raise InputError(f"photo {name}: image must have shape (H, W), (H, W, 3) or "
                         f"(H, W, 4); got {img.shape}")
    if img.shape[0] < 8 or img.shape[1] < 8:
        raise InputError(f"photo {name}: image is empty or too small ({img.shape[:2]}; "
                         "need at least 8 x 8 pixels)")
    return img


def _unit_gray(img: np.ndarray, name: str) -> np.ndarray:
    """A checked pixel array as float grey in [0, 1] (floats are taken as [0, 1] already)."""
    from skimage import color, util

    if img.dtype == bool:
        img = img.astype(np.float64)
    elif np.issubdtype(img.dtype, np.floating):
        if not np.all(np.isfinite(img)):
            raise InputError(f"photo {name}: image has NaN or infinite pixels")
        img = np.clip(img.astype(np.float64), 0.0, 1.0)
    else:
        img = util.img_as_float64(img)
    if img.ndim == 3:
        if img.shape[2] == 4:
            img = color.rgba2rgb(img)
        img = color.rgb2gray(img)
    return img


def flatten_illumination(gray: np.ndarray, *, n_iter: int = 3) -> tuple[np.ndarray, float]:
    """Remove smooth uneven lighting, then threshold by Otsu; returns ``(level, threshold)``.

    Model: observed grey = illumination(x, y) * reflectance, with a quadratic surface for
    log(illumination) and two reflectances (pile, background). Alternating ``n_iter`` times,
    the surface and the pile/background step are fitted by least squares to log grey (on a
    subsample of ~20 000 pixels) given the current classes, and the classes are re-found by
    Otsu on the corrected log image. Returns the corrected image (log grey minus the
    surface's non-constant part) and its Otsu threshold.
    """
    from skimage import filters

    h, w = gray.shape
    logi = np.log(np.clip(gray, 1.0 / 255.0, None))
    yy, xx = np.mgrid[0:h, 0:w]
    x = (2.0 * xx / max(w - 1, 1) - 1.0).ravel()
    y = (2.0 * yy / max(h - 1, 1) - 1.0).ravel()
    basis = np.column_stack([x, y, x * x, x * y, y * y])
    step = max(1, int(math.sqrt(h * w / 20000.0)))
    sub = (yy[::step, ::step] * w + xx[::step, ::step]).ravel()
    level = logi
    t = float(filters.threshold_otsu(level))
    for _ in range(n_iter):
        cls = (level.ravel()[sub] < t).astype(np.float64)
        design = np.column_stack([np.ones(sub.size), cls, basis[sub]])
        coef, *_ = np.linalg.lstsq(design, logi.ravel()[sub], rcond=None)
        level = logi - (basis @ coef[2:]).reshape(h, w)
        t = float(filters.threshold_otsu(level))
    return level, t


def threshold_value(gray: np.ndarray, threshold: Any) -> float:
    """Global threshold of a grey image in [0, 1]: ``"otsu"`` or a number in (0, 1)."""
    from skimage import filters

    if isinstance(threshold, str):
        if threshold == "otsu":
            return float(filters.threshold_otsu(gray))
        raise InputError(f"threshold must be 'otsu', 'adaptive' or a number in (0, 1); "
                         f"got {threshold!r}")
    try:
        t = float(threshold)
    except (TypeError, ValueError):
        raise InputError(f"threshold must be 'otsu', 'adaptive' or a number in (0, 1); "
                         f"got {threshold!r}") from None
    if not (0.0 < t < 1.0):
        raise InputError(f"threshold must be in (0, 1) (grey level of a [0, 1] image); "
                         f"got {t:g}")
    return t


@dataclass(frozen=True)
class Binarised:
    """A levelled, cropped grey photo and its pile mask.

    Attributes
    ----------
    gray : (H, W) float ndarray
        The grey image after roll correction (full frame, not cropped), [0, 1].
    mask : (h, w) bool ndarray
        Pile pixels inside the region of interest.
    level : (h, w) float ndarray
        The image that was thresholded (denoised crop; log grey with the lighting removed
        for ``threshold="adaptive"``).
    offset : (int, int)
        Row and column of the region of interest's top-left pixel in ``gray``.
    threshold : float
        Threshold applied to ``level``.
    pile : {"dark", "light"}
        Tone of the pile.
    """

    gray: np.ndarray
    mask: np.ndarray
    level: np.ndarray
    offset: tuple[int, int]
    threshold: float
    pile: str


def _check_roi(roi: Any, shape: tuple[int, ...]) -> tuple[int, int, int, int]:
    try:
        r0, r1, c0, c1 = (int(v) for v in roi)
    except (TypeError, ValueError):
        raise InputError(f"roi must be four integers (row0, row1, col0, col1); got {roi!r}"
                         ) from None
    if not (0 <= r0 < r1 <= shape[0] and 0 <= c0 < c1 <= shape[1]):
        raise InputError(f"roi must satisfy 0 <= row0 < row1 <= {shape[0]} and "
                         f"0 <= col0 < col1 <= {shape[1]}; got {roi!r}")
    if r1 - r0 < 8 or c1 - c0 < 8:
        raise InputError(f"roi is too small ({r1 - r0} x {c1 - c0} px; need at least 8 x 8)")
    return r0, r1, c0, c1


def _checked_roll(roll_deg: Any) -> float:
    """The camera's roll in deg, a finite number within [-45, 45]."""
    try:
        roll = float(roll_deg)
    except (TypeError, ValueError):
        raise InputError(f"roll_deg must be a number of degrees; got {roll_deg!r}") from None
    if not (math.isfinite(roll) and abs(roll) <= 45):
        raise InputError(f"roll_deg must be within [-45, 45] deg; got {roll_deg!r}")
    return roll


def _cleaned(mask: np.ndarray, clean_px: int) -> np.ndarray:
    """``mask`` opened then closed by a disc of radius ``clean_px`` (none when 0)."""
    from skimage import morphology

    if clean_px <= 0:
        return mask
    foot = morphology.disk(clean_px)
    padded = np.pad(mask, 2 * clean_px, mode="edge")  # the frame's edge is not a pile edge
    padded = ndi.binary_closing(ndi.binary_opening(padded, foot), foot)
    return padded[2 * clean_px:-2 * clean_px, 2 * clean_px:-2 * clean_px]


def _pile_tone(candidates: dict[str, np.ndarray], name: str) -> str:
    """The tone whose largest region stays off the frame's top (the background's reaches it).

    The larger such region when both do.
    """
    regions = {tone: largest_region(m) for tone, m in candidates.items()}
    ok = {tone: reg for tone, reg in regions.items() if not reg[0].any()}
    if not ok:
        raise InputError(
            f"photo {name}: cannot tell the pile from the background (both tones reach "
            "the top of the frame); pass pile='dark' or 'light', or an roi")
    return max(ok, key=lambda k: int(ok[k].sum()))


def binarise(image_or_path: Any, *, threshold: Any = "otsu", roi: Any = None,
             roll_deg: float = 0.0, pile: str = "auto", smooth_px: float = 1.5,
             clean_px: int = 2) -> tuple[Binarised, str]:
    """Photo to pile mask; returns the result and the photo's name.

    Steps: grayscale; roll correction (the image is rotated by ``-roll_deg`` about its
    centre, edges replicated); crop to ``roi``; Gaussian denoising (sigma ``smooth_px``);
    threshold (``"otsu"``, a grey level in (0, 1), or ``"adaptive"``:
    :func:`flatten_illumination`); morphological opening then closing with a disc of radius
    ``clean_px``; hole filling. ``pile="auto"`` takes as the pile the tone whose largest
    region does not reach the top border of the frame (the background does), the larger such
    region if both.
    """
    from skimage import filters, transform

    gray, name = load_gray(image_or_path)
    roll = _checked_roll(roll_deg)
    if pile not in ("auto", "dark", "light"):
        raise InputError(f"pile must be 'auto', 'dark' or 'light'; got {pile!r}")
    if roll:
        gray = transform.rotate(gray, -roll, mode="edge", order=1)
    r0, r1, c0, c1 = (0, gray.shape[0], 0, gray.shape[1]) if roi is None else _check_roi(
        roi, gray.shape)
    crop = gray[r0:r1, c0:c1]
    if float(np.ptp(crop)) < 1e-3:
        raise InputError(f"photo {name}: the region of interest is uniform; no pile to find")
    smooth = filters.gaussian(crop, sigma=float(smooth_px)) if smooth_px > 0 else crop
    if isinstance(threshold, str) and threshold == "adaptive":
        level, t = flatten_illumination(smooth)
    else:
        level, t = smooth, threshold_value(smooth, threshold)
    candidates = {}
    for tone in ("dark", "light") if pile == "auto" else (pile,):
        m = _cleaned(level < t if tone == "dark" else level > t, int(clean_px))
        if m.any():
            candidates[tone] = m
    if not candidates:
        raise InputError(f"photo {name}: no pile found after thresholding (threshold "
                         f"{threshold!r}); try another threshold or pile tone")
    tone = _pile_tone(candidates, name) if pile == "auto" else pile
    return Binarised(gray, candidates[tone], level, (r0, c0), float(t), tone), name
