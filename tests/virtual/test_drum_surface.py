"""The drum's side view on constructed beds: the free surface's angle, the centre of mass'
angle, the wall coverage and the outcome rules."""

import math

import numpy as np
import pytest

from demcal.virtual.drum_surface import (
    CATARACT_AIRBORNE,
    DrumOutcome,
    FrameStats,
    classify_frames,
    com_angle,
    surface_line,
    wall_coverage,
)

R_DRUM = 0.045  # m
R_SPHERE = 0.002  # m


def bed(angle_deg: float, fill: float = 0.4, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Spheres filling a drum's cross-section below a straight surface through the drum's
    centre line's height set by ``fill`` (a jittered 1 mm grid, every sphere's top at or
    under the surface): ``(u, v)`` centres and radii, m."""
    rng = np.random.default_rng(seed)
    g = np.arange(-R_DRUM, R_DRUM, 1e-3)
    uu, vv = np.meshgrid(g, g)
    uv = np.column_stack([uu.ravel(), vv.ravel()]) + rng.uniform(-3e-4, 3e-4, (g.size**2, 2))
    level = -R_DRUM * math.cos(math.pi * fill)  # a rough fill height, m
    surface = math.tan(math.radians(angle_deg)) * uv[:, 0] + level
    keep = (np.hypot(uv[:, 0], uv[:, 1]) <= R_DRUM - R_SPHERE) & (uv[:, 1] + R_SPHERE <= surface)
    return uv[keep], np.full(np.count_nonzero(keep), R_SPHERE)


@pytest.mark.parametrize("angle", [0.0, 12.0, 30.0, 41.0, -35.0, 55.0])
def test_the_surface_angle_of_a_straight_bed_is_exact_within_half_a_degree(angle):
    # the steep bed lower, so that its surface meets the wall on both sides (not its top)
    uv, radii = bed(angle, fill=0.45 if abs(angle) < 50 else 0.3)
    line = surface_line(uv, radii, bin_width=2 * R_SPHERE, central_fraction=0.6)
    assert line is not None and line.n_columns >= 5
    assert line.angle_deg == pytest.approx(angle, abs=0.5)


def test_the_ends_of_the_chord_do_not_tilt_the_line():
    """Material climbing the rising wall (a heap against the wall at the chord's end) lies
    outside the central part and leaves the angle alone."""
    uv, _ = bed(35.0)
    u_max = uv[:, 0].max()
    climb = np.column_stack([np.full(8, u_max), np.linspace(0.0, 0.02, 8)])
    both = np.vstack([uv, climb])
    line = surface_line(both, np.full(len(both), R_SPHERE), bin_width=2 * R_SPHERE)
    assert line.angle_deg == pytest.approx(35.0, abs=0.5)


def test_no_line_without_three_columns():
    assert surface_line(np.zeros((0, 2)), np.zeros(0), bin_width=0.004) is None
    one_column = np.array([[0.0, 0.0], [0.001, 0.003]])
    assert surface_line(one_column, np.full(2, R_SPHERE), bin_width=0.004) is None


def test_com_angle_from_the_vertical_towards_the_rising_side():
    assert com_angle(np.array([[0.0, -0.03]]), np.ones(1)) == pytest.approx(0.0)
    assert com_angle(np.array([[0.01, -0.01]]), np.ones(1)) == pytest.approx(45.0)
    assert com_angle(np.array([[-0.01, -0.01 * math.sqrt(3)]]), np.ones(1)) == \
        pytest.approx(-30.0)
    assert com_angle(np.zeros((0, 2)), np.zeros(0)) is None
    # a bed tilted towards +u has its centre of mass on the +u side
    uv, _ = bed(30.0)
    assert com_angle(uv, np.ones(len(uv))) > 5.0


def test_wall_coverage_counts_the_sectors_with_material_against_the_wall():
    uv, _ = bed(0.0, fill=0.4)
    assert 0.2 < wall_coverage(uv, radius=R_DRUM, reach=0.005) < 0.6
    phi = np.linspace(0, 2 * math.pi, 48, endpoint=False)
    ring = (R_DRUM - 0.002) * np.column_stack([np.cos(phi), np.sin(phi)])
    assert wall_coverage(ring, radius=R_DRUM, reach=0.005) == 1.0
    assert wall_coverage(np.zeros((1, 2)), radius=R_DRUM, reach=0.005) == 0.0


def _stats(flowing, airborne=0.0, coverage=0.4, carried=0.8, n=20):
    return FrameStats(np.full(n, flowing, dtype=float), np.full(n, airborne),
                      np.full(n, coverage), np.full(n, carried))


def test_outcomes_of_the_frames():
    assert classify_frames(_stats(0.3), 0.4) == (DrumOutcome.ROLLING, None)
    flowing = np.r_[np.zeros(10), np.full(10, 0.3)]
    out, why = classify_frames(FrameStats(flowing, np.zeros(20), np.full(20, 0.4),
                                          np.full(20, 0.8)), 0.4)
    assert out is DrumOutcome.SLUMPING and "50%" in why
    out, why = classify_frames(_stats(0.3, airborne=CATARACT_AIRBORNE + 0.01), 0.4)
    assert out is DrumOutcome.CATARACTING and "flew" in why
    out, why = classify_frames(_stats(0.0, coverage=1.0), 0.4)
    assert out is DrumOutcome.CENTRIFUGING and "whole wall" in why
    out, why = classify_frames(_stats(1.0, carried=0.05), 0.4)
    assert out is DrumOutcome.SLIPPING and "slides on the wall" in why
    # no clump against the wall in any frame: nothing says it slips
    assert classify_frames(_stats(0.3, carried=np.nan), 0.4)[0] is DrumOutcome.ROLLING
    # a drum two-thirds full covers its wall without centrifuging
    assert classify_frames(_stats(0.3, coverage=1.0), 0.67)[0] is DrumOutcome.ROLLING
