"""Angle of repose from synthetic pile photos of known angles, and bad photos."""

from __future__ import annotations

import json

import numpy as np
import pytest
from aor_pile_photos import pile_photo

from demcal import measure
from demcal.errors import InputError

ANGLES = [(25.0, 25.0), (30.0, 45.0), (44.0, 38.0), (60.0, 52.0)]
DISTURBANCES = {
    "clean": {},
    "noise_blur": {"noise": 0.06, "blur": 1.5},
    "texture": {"texture": 0.08},
    "clutter": {"clutter": True},
    "light_plate": {"plate": "light"},
    "no_plate": {"plate": None},
    "full_width_plate": {"plate_span": 1.0},
    "light_pile_dark_background": {"dark_pile": False},
}


def _check(res, left, right, tol=0.5):
    assert abs(res.left_deg - left) < tol, (res.left_deg, left)
    assert abs(res.right_deg - right) < tol, (res.right_deg, right)
    assert res.mean_deg == pytest.approx(0.5 * (res.left_deg + res.right_deg))


@pytest.mark.parametrize("threshold", ["otsu", "adaptive"])
@pytest.mark.parametrize("case", sorted(DISTURBANCES))
@pytest.mark.parametrize(("left", "right"), ANGLES)
def test_known_angles_recovered_within_half_degree(left, right, case, threshold):
    img, info = pile_photo(left, right, rng=np.random.default_rng(1234), **DISTURBANCES[case])
    res = measure.photo_aor(img, threshold=threshold)
    _check(res, left, right)
    assert abs(res.base_row - info["base_row"]) <= 2
    assert res.pile == ("light" if case.startswith("light_pile") else "dark")


@pytest.mark.parametrize(("left", "right"), ANGLES)
@pytest.mark.parametrize("seed", [1, 2])
def test_uneven_lighting_and_everything_at_once_with_adaptive_threshold(left, right, seed):
    img, _ = pile_photo(left, right, rng=np.random.default_rng(seed), shape=(300, 520),
                        lighting=0.5, texture=0.06, clutter=True, noise=0.05, blur=1.5)
    _check(measure.photo_aor(img, threshold="adaptive"), left, right)


def test_uneven_lighting_alone_with_otsu():
    img, _ = pile_photo(35.0, 40.0, rng=np.random.default_rng(1234), lighting=0.5)
    _check(measure.photo_aor(img), 35.0, 40.0)


@pytest.mark.parametrize("fit", measure.FIT_METHODS)
def test_every_fit_method_and_stderr(fit):
    img, _ = pile_photo(35.0, 40.0, rng=np.random.default_rng(1234), noise=0.05)
    res = measure.photo_aor(img, fit=fit)
    _check(res, 35.0, 40.0)
    assert 0 < res.left_stderr_deg < 0.5 and 0 < res.right_stderr_deg < 0.5
    assert 0 <= res.left_residual_px < 1.0 and 0 <= res.right_residual_px < 1.0
    d = res.to_dict()
    json.dumps(d, allow_nan=False)
    assert d["fit"] == fit and d["left_points"] > 20


def test_colour_rgba_and_uint8_inputs_and_files(tmp_path):
    from skimage import io, util

    img, _ = pile_photo(40.0, 33.0, rng=np.random.default_rng(1234))
    u8 = util.img_as_ubyte(img)
    rgb = np.stack([u8, (u8 * 0.8).astype(np.uint8), u8], axis=-1)
    rgba = np.concatenate([rgb, np.full((*u8.shape, 1), 255, np.uint8)], axis=-1)
    for arr in (u8, rgb, rgba, img.astype(np.float32)):
        _check(measure.photo_aor(arr), 40.0, 33.0)
    for suffix in (".png", ".jpg", ".tif", ".bmp"):
        path = tmp_path / f"pile{suffix}"
        io.imsave(path, rgb if suffix != ".tif" else u8, check_contrast=False)
        res = measure.photo_aor(path)
        assert res.source == str(path)
        _check(res, 40.0, 33.0, tol=0.5)


def test_roll_correction():
    from skimage import transform

    img, _ = pile_photo(38.0, 42.0, rng=np.random.default_rng(1234), noise=0.0)
    rolled = transform.rotate(img, 4.0, mode="edge")  # horizon appears 4 deg counter-clockwise
    uncorrected = measure.photo_aor(rolled)
    assert abs(uncorrected.left_deg - 38.0) > 2.5 and abs(uncorrected.right_deg - 42.0) > 2.5
    _check(measure.photo_aor(rolled, roll_deg=4.0), 38.0, 42.0)


def test_pixel_aspect():
    """Pixels twice as tall as wide: the image is squashed vertically by 2."""
    img, _ = pile_photo(50.0, 50.0, rng=np.random.default_rng(1234), shape=(520, 420),
                        noise=0.0, blur=0.0, supersample=2)
    squashed = img.reshape(260, 2, 420).mean(axis=1)
    raw = measure.photo_aor(squashed)
    assert raw.mean_deg < 35.0  # tan(50 deg) / 2 -> 30.8 deg
    _check(measure.photo_aor(squashed, pixel_aspect=2.0), 50.0, 50.0)


def test_roi_and_base_line():
    img, info = pile_photo(35.0, 35.0, rng=np.random.default_rng(1234), clutter=True)
    h, w = img.shape
    res = measure.photo_aor(img, roi=(40, h, 10, w - 10))
    _check(res, 35.0, 35.0)
    given = measure.photo_aor(img, base_line=info["base_row"])
    assert given.base_row == info["base_row"]
    _check(given, 35.0, 35.0)
    # A photo cut through the pile measures with a given base line.
    cut = measure.photo_aor(img[:180], base_line=180)
    _check(cut, 35.0, 35.0)
    # A base line given too high cuts the pile: its height shrinks accordingly.
    high = measure.photo_aor(img, base_line=info["base_row"] - 20)
    assert high.height_px == pytest.approx(given.height_px - 20, abs=1.0)


def test_fit_window_changes_the_rows_used():
    img, _ = pile_photo(35.0, 35.0, rng=np.random.default_rng(1234))
    narrow = measure.photo_aor(img, fit_window=(0.4, 0.6))
    wide = measure.photo_aor(img, fit_window=(0.1, 0.9))
    assert narrow.left.fit.n_points < wide.left.fit.n_points / 3
    _check(narrow, 35.0, 35.0)
    # The whole height includes the rounded top and toe: a visibly worse, biased fit.
    full = measure.photo_aor(img, fit_window=(0.0, 1.0), fit="least_squares")
    assert full.left.fit.residual > 2 * wide.left.fit.residual


def test_steep_column_is_refused_by_the_gates_and_measures_near_90_deg_without():
    img = np.full((200, 200), 0.8)
    img[40:170, 80:120] = 0.2
    with pytest.raises(InputError, match=r"left flank fails the quality gates \(90.0 deg is "
                       r"steeper than the limit \(80 deg\)\)"):
        measure.photo_aor(img)
    res = measure.photo_aor(img, gates=None)
    assert res.left_deg > 85 and res.right_deg > 85


def _photo(**kw):
    return pile_photo(35.0, 35.0, rng=np.random.default_rng(1234), **kw)[0]


@pytest.mark.parametrize(
    ("image", "kwargs", "match"),
    [
        (np.ones((100, 100)), {}, "uniform"),
        (np.zeros((0, 0)), {}, "empty or too small"),
        (np.zeros((100, 100, 2)), {}, "shape"),
        (np.full((50, 50), np.nan), {}, "NaN"),
        (np.array([["a"]]), {}, "numeric"),
        (_photo(), {"threshold": 1.5}, "threshold"),
        (_photo(), {"threshold": 0.01, "pile": "dark"}, "no pile found"),
        (_photo(), {"threshold": "median"}, "threshold"),
        (_photo(), {"fit_window": (0.5, 1.5)}, "fit_window"),
        (_photo(), {"fit_window": (0.6, 0.6)}, "fit_window"),
        (_photo(), {"fit": "huber"}, "fit"),
        (_photo(), {"pixel_aspect": 0}, "pixel_aspect"),
        (_photo(), {"roll_deg": 60}, "roll_deg"),
        (_photo(), {"roi": (0, 10)}, "roi"),
        (_photo(), {"roi": (50, 10, 0, 100)}, "roi"),
        (_photo(), {"base_line": 10_000}, "base_line"),
        (_photo(), {"pile": "grey"}, "pile"),
        (_photo(), {"smooth_px": -1}, "smooth_px"),
        (_photo(), {"fit_window": (0.0, 0.02)}, "too few boundary points"),
        (_photo()[:150], {}, "bottom border"),
        (_photo()[:, :200], {}, "touches the image border"),
    ],
)
def test_bad_photos_and_options_raise_input_error(image, kwargs, match):
    with pytest.raises(InputError, match=match):
        measure.photo_aor(image, **kwargs)


def test_no_pile_found_when_the_pile_fills_nothing():
    """A frame with only a horizontal edge: both tones reach the top or sides."""
    img = np.full((100, 100), 0.8)
    img[60:] = 0.2
    with pytest.raises(InputError, match="pile"):
        measure.photo_aor(img)


def test_bad_files(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        measure.photo_aor(tmp_path / "missing.png")
    text = tmp_path / "notes.png"
    text.write_text("this is not an image")
    with pytest.raises(InputError, match="not a readable image"):
        measure.photo_aor(text)


def _darkening_photo(k: float = 0.8):
    """A 44-degree dark pile on a grey plate in front of a background that darkens towards
    the bottom (lighting fall-off): Otsu takes the lower background for the pile."""
    img, info = pile_photo(44.0, 44.0, rng=np.random.default_rng(1), plate="light",
                           noise=0.02)
    rows = np.mgrid[0:img.shape[0], 0:img.shape[1]][0]
    return np.clip(img * (1.0 - k * rows / img.shape[0]), 0, 1), info


def test_darkening_background_is_detected_and_the_default_falls_back_to_adaptive():
    img, info = _darkening_photo()
    with pytest.raises(InputError, match=r"no plausible base line.*lies inside the object"):
        measure.photo_aor(img, threshold="otsu")
    res = measure.photo_aor(img)
    assert res.threshold_method == "adaptive"
    assert res.notes and "threshold otsu" in res.notes[0]
    assert abs(res.base_row - info["base_row"]) <= 2
    assert abs(res.mean_deg - 44.0) < 1.0
    assert res.to_dict()["notes"] == list(res.notes)


def test_an_ordinary_photo_keeps_otsu_with_no_note():
    res = measure.photo_aor(_photo(plate="dark"))
    assert res.threshold_method == "otsu" and res.notes == ()
