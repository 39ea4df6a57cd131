"""Angle of repose of synthetic sphere piles of known slope (silhouette and profile methods)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from aor_synth import skirt_and_strays, sphere_cone

from demcal import measure
from demcal.errors import InputError

METHODS = {"silhouette": measure.pile_aor_silhouette, "profile": measure.pile_aor_profile}
BASE_RADIUS = 0.02
RADIUS = 0.0005


@pytest.fixture(scope="module")
def cones() -> dict[float, tuple[np.ndarray, np.ndarray]]:
    rng = np.random.default_rng(1234)
    return {a: sphere_cone(a, base_radius=BASE_RADIUS, radius=RADIUS, rng=rng)
            for a in (25.0, 35.0, 45.0, 60.0)}


@pytest.mark.parametrize("method", sorted(METHODS))
@pytest.mark.parametrize("angle", [25.0, 35.0, 45.0, 60.0])
def test_rough_sphere_cone_angle_recovered_within_1_deg(cones, method, angle):
    centres, radii = cones[angle]
    res = METHODS[method](centres, radii)
    assert res.method == method
    assert abs(res.mean_deg - angle) < 1.0, res.mean_deg
    assert abs(res.left_deg - angle) < 1.5 and abs(res.right_deg - angle) < 1.5
    assert 0 <= res.std_deg < 1.5
    assert len(res.views) == 8 and all(v.error is None for v in res.views)
    # Height: the apex sphere's top; base: the cone's, widened by about a particle radius.
    height = BASE_RADIUS * math.tan(math.radians(angle))
    assert abs(res.pile_height - height) < 4 * RADIUS
    assert 2 * BASE_RADIUS < res.base_diameter < 2 * BASE_RADIUS + 8 * RADIUS


def test_result_independent_of_plate_height_and_axis_position(cones):
    centres, radii = cones[35.0]
    ref = measure.pile_aor_silhouette(centres, radii)
    moved = centres + np.array([0.3, -0.2, 0.05])
    for method, func in METHODS.items():
        res = func(moved, radii, plate_z=0.05)
        assert abs(res.mean_deg - 35.0) < 1.0, method
        assert abs(res.pile_height - ref.pile_height) < 2 * RADIUS
    # Spheres sunk into the plate are cut at the plate, not drawn below it.
    sunk = measure.pile_aor_silhouette(centres - [0, 0, 0.002], radii)
    assert sunk.pile_height == pytest.approx(ref.pile_height - 0.002, abs=2 * RADIUS)


def test_single_view_and_fit_window_options(cones):
    centres, radii = cones[45.0]
    one = measure.pile_aor_silhouette(centres, radii, n_views=1, fit_window=(0.3, 0.7))
    assert len(one.views) == 1 and one.fit_window == (0.3, 0.7)
    assert abs(one.mean_deg - 45.0) < 1.5
    coarse = measure.pile_aor_silhouette(centres, radii, pixel_size=2 * RADIUS)
    assert coarse.pixel_size == 2 * RADIUS
    assert abs(coarse.mean_deg - 45.0) < 1.0


@pytest.fixture(scope="module")
def mesa() -> tuple[np.ndarray, np.ndarray]:
    """A flat-topped pile (cut at 60 % of its cone), a one-layer skirt and stray particles."""
    rng = np.random.default_rng(1234)
    radius = 0.0007
    c, r = sphere_cone(35.0, base_radius=BASE_RADIUS, radius=radius, rng=rng, top_fraction=0.6)
    c2, r2 = skirt_and_strays(BASE_RADIUS, radius, rng=rng)
    return np.vstack([c, c2]), np.concatenate([r, r2])


@pytest.mark.parametrize("method", sorted(METHODS))
@pytest.mark.parametrize("fit", ["theil_sen", "ransac"])
def test_mesa_with_skirt_and_strays_measured_by_robust_fits(mesa, method, fit):
    res = METHODS[method](*mesa, fit=fit)
    assert abs(res.mean_deg - 35.0) < 1.0, res.mean_deg
    # The height is the mesa's, not skewed by strays; the base excludes the skirt.
    assert res.pile_height == pytest.approx(0.6 * BASE_RADIUS * math.tan(math.radians(35)),
                                            abs=0.003)
    assert res.base_diameter < 2.2 * BASE_RADIUS


def column() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(1234)
    g = np.arange(-0.01, 0.0101, 0.0015)
    x, y, z = np.meshgrid(g, g, np.arange(0.001, 0.04, 0.0015), indexing="ij")
    pts = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    pts = pts[np.hypot(pts[:, 0], pts[:, 1]) <= 0.01]
    pts += rng.uniform(-3e-4, 3e-4, pts.shape)
    return pts, np.full(len(pts), 0.001)


@pytest.mark.parametrize("method", sorted(METHODS))
def test_column_is_refused_by_the_gates_and_measures_steep_without(method):
    with pytest.raises(InputError, match="no flank of the pile passed the quality gates"):
        METHODS[method](*column())
    res = METHODS[method](*column(), gates=None)
    assert res.mean_deg > 85.0 and res.aor_deg > 85.0 and res.n_rejected == 0


def test_views_as_dicts_json_ready_with_failed_view():
    good = measure.ViewAoR(0, 0.0, error=None)
    bad = measure.ViewAoR(1, 22.5, error="right flank: too few boundary points")
    for v in (good, bad):
        d = v.to_dict()
        json.dumps(d, allow_nan=False)
        assert d["left_deg"] is None and d["mean_deg"] is None
    assert bad.to_dict()["error"].startswith("right flank")


def test_pile_result_to_dict_is_strict_json(cones):
    res = measure.pile_aor_profile(*cones[25.0])
    d = res.to_dict()
    text = json.dumps(d, allow_nan=False)
    assert '"method": "profile"' in text
    assert len(d["views"]) == 8
    # A profile sector files its flank under the side it faces: left XOR right.
    for v in d["views"]:
        assert (v["left_deg"] is None) != (v["right_deg"] is None)


_C = np.zeros((3, 3))
_R = np.full(3, 0.001)


@pytest.mark.parametrize("method", sorted(METHODS))
@pytest.mark.parametrize(
    ("args", "kwargs", "field"),
    [
        ((np.zeros((0, 3)), np.zeros(0)), {}, "centres"),
        ((np.zeros((3, 2)), _R), {}, "centres"),
        ((np.zeros(3), _R), {}, "centres"),
        ((_C, np.full(2, 0.001)), {}, "radii"),
        ((_C, np.array([0.001, -0.001, 0.001])), {}, "radii"),
        ((np.full((3, 3), np.nan), _R), {}, "centres"),
        ((_C, _R), {"fit_window": (0.5, 1.2)}, "fit_window"),
        ((_C, _R), {"fit_window": (-0.1, 0.5)}, "fit_window"),
        ((_C, _R), {"fit_window": (0.8, 0.2)}, "fit_window"),
        ((_C, _R), {"fit_window": 0.5}, "fit_window"),
        ((_C, _R), {"fit": "spline"}, "fit"),
        ((_C, _R), {"pixel_size": -1.0}, "pixel_size"),
        ((_C, _R), {"plate_z": math.nan}, "plate_z"),
        ((_C, _R), {"plate_z": 1.0}, "plate"),
    ],
)
def test_bad_input_names_the_field(method, args, kwargs, field):
    with pytest.raises(InputError, match=field):
        METHODS[method](*args, **kwargs)


def test_bad_view_and_sector_counts():
    with pytest.raises(InputError, match="n_views"):
        measure.pile_aor_silhouette(_C, _R, n_views=0)
    with pytest.raises(InputError, match="n_sectors"):
        measure.pile_aor_profile(_C, _R, n_sectors=2.5)


def test_too_small_pile_raises_naming_the_views():
    """Three spheres stacked one particle high: too few rows for a flank fit in any view."""
    c = np.array([[0.0, 0.0, 0.001], [0.002, 0.0, 0.001], [0.0, 0.002, 0.001]])
    with pytest.raises(InputError, match="too few boundary points"):
        measure.pile_aor_silhouette(c, _R, pixel_size=0.001)
