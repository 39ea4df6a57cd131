"""Clump templates: union volume, centre of mass and inertia against independent references.

References used here (none of them calls the code under test):
- analytic sphere (4/3 pi r^3, 2/5 m r^2) and the parallel-axis theorem;
- the union of collinear spheres integrated by slicing with scipy.integrate.quad (each
  cross-section is the disc of the largest member chord);
- Monte Carlo point sampling of the union (numpy, seeded);
- the analytic capsule (cylinder + two hemispheres).
"""

from __future__ import annotations

import doctest
import itertools
import math

import numpy as np
import pytest
from scipy import integrate
from scipy.spatial.transform import Rotation

from demcal.dem import shapes
from demcal.dem.shapes import (
    ClumpTemplate,
    chain_volume,
    cylinder_template,
    cylinder_volume_error,
    sphere_template,
    stalk_template,
    template_from_spheres,
    union_mass_properties,
)
from demcal.errors import InputError


# ----------------------------------------------------------------------------- references
def slicing_reference(xs: np.ndarray, radius: float) -> tuple[float, float, float, float]:
    """Union of equal spheres centred on the x axis, integrated slice by slice.

    Returns volume, x of the centre of mass, I_axis and I_transverse (about the centre of
    mass) per unit density.
    """
    xs = np.asarray(xs, dtype=float)

    def rho2(x: float) -> float:  # squared radius of the union's cross-section at x
        return max(0.0, float(np.max(radius**2 - (x - xs) ** 2)))

    breaks = np.unique(
        np.concatenate([xs - radius, xs + radius, xs, 0.5 * (xs[:-1] + xs[1:])])
    )

    def integral(fun) -> float:
        total = 0.0
        for a, b in itertools.pairwise(breaks):
            total += integrate.quad(fun, a, b, epsabs=0.0, epsrel=1e-11, limit=200)[0]
        return total

    volume = integral(lambda x: math.pi * rho2(x))
    x_com = integral(lambda x: math.pi * rho2(x) * x) / volume
    i_axis = integral(lambda x: math.pi / 2.0 * rho2(x) ** 2)
    i_trans = integral(
        lambda x: math.pi / 4.0 * rho2(x) ** 2 + math.pi * rho2(x) * (x - x_com) ** 2
    )
    return volume, x_com, i_axis, i_trans


def monte_carlo_reference(centres, radii, *, n_points: int, seed: int = 1234):
    """Volume, centre of mass and inertia tensor (per unit density) by uniform sampling."""
    centres = np.asarray(centres, float)
    radii = np.asarray(radii, float)
    rng = np.random.default_rng(seed)
    lo = np.min(centres - radii[:, None], axis=0)
    hi = np.max(centres + radii[:, None], axis=0)
    box = float(np.prod(hi - lo))
    inside_pts = []
    batch = 500_000
    for _ in range(n_points // batch):
        p = rng.uniform(lo, hi, size=(batch, 3))
        d2 = ((p[:, None, :] - centres[None, :, :]) ** 2).sum(axis=2)
        inside_pts.append(p[(d2 <= radii**2).any(axis=1)])
    pts = np.concatenate(inside_pts)
    volume = box * pts.shape[0] / n_points
    com = pts.mean(axis=0)
    q = pts - com
    second = q.T @ q / pts.shape[0] * volume
    inertia = np.trace(second) * np.eye(3) - second
    return volume, com, inertia


# ----------------------------------------------------------------------------- sphere
def test_single_sphere_union_matches_analytic_volume_and_two_fifths_m_r2():
    r = 3e-3
    centre = [0.01, -0.02, 0.005]
    volume, com, inertia = union_mass_properties([centre], [r])
    v_exact = 4.0 / 3.0 * math.pi * r**3
    assert volume == pytest.approx(v_exact, rel=2e-4)
    np.testing.assert_allclose(com, centre, rtol=0, atol=1e-9 * r)
    np.testing.assert_allclose(np.diag(inertia), 0.4 * v_exact * r * r, rtol=5e-4)
    off = inertia - np.diag(np.diag(inertia))
    assert np.max(np.abs(off)) < 1e-9 * inertia[0, 0]


def test_sphere_template_is_exact_and_mass_scales_with_density():
    t = sphere_template(2e-3)
    v = 4.0 / 3.0 * math.pi * 8e-9
    assert t.n_spheres == 1
    assert t.volume == pytest.approx(v, rel=1e-14)
    assert t.mass(1000.0) == pytest.approx(1000.0 * v, rel=1e-14)
    np.testing.assert_allclose(t.inertia(1000.0), 0.4 * 1000.0 * v * 4e-6, rtol=1e-14)
    assert t.bounding_radius == pytest.approx(2e-3)


# ----------------------------------------------------------------------------- parallel axis
def test_two_disjoint_spheres_follow_parallel_axis_theorem():
    r1, r2 = 1.0e-3, 0.5e-3
    c1 = np.array([0.0, 0.0, 0.0])
    c2 = np.array([2.0e-3, 1.5e-3, -1.0e-3])  # |c2 - c1| = 2.69 mm > r1 + r2
    v1, v2 = (4.0 / 3.0 * math.pi * r**3 for r in (r1, r2))
    com_exact = (v1 * c1 + v2 * c2) / (v1 + v2)
    inertia_exact = np.zeros((3, 3))
    for v, r, c in ((v1, r1, c1), (v2, r2, c2)):
        d = c - com_exact
        inertia_exact += 0.4 * v * r * r * np.eye(3) + v * (d @ d * np.eye(3) - np.outer(d, d))

    volume, com, inertia = union_mass_properties([c1, c2], [r1, r2])
    assert volume == pytest.approx(v1 + v2, rel=1e-3)
    np.testing.assert_allclose(com, com_exact, atol=1e-3 * r2)
    np.testing.assert_allclose(inertia, inertia_exact, atol=2e-3 * np.max(inertia_exact))


def test_overlapping_spheres_are_not_counted_twice():
    # two unit spheres 1 apart: union = 2 V - lens, lens = pi (4r + d)(2r - d)^2 / 12
    volume, _, _ = union_mass_properties([[0, 0, 0], [1.0, 0, 0]], [1.0, 1.0])
    lens = math.pi * (4 + 1) * (2 - 1) ** 2 / 12
    assert volume == pytest.approx(2 * 4 / 3 * math.pi - lens, rel=2e-4)
    assert volume < 2 * 4 / 3 * math.pi * 0.9  # the naive sum is far off


# ----------------------------------------------------------------------------- stalk
def test_stalk_geometry_matches_the_paper():
    t = stalk_template()
    assert t.n_spheres == 7
    np.testing.assert_allclose(t.radii, 2e-3)
    # centres from -(L/2 - r) to +(L/2 - r) along body x, evenly spread
    np.testing.assert_allclose(np.sort(t.offsets[:, 0]), np.linspace(-3e-3, 3e-3, 7), atol=1e-12)
    np.testing.assert_allclose(t.offsets[:, 1:], 0.0, atol=1e-12)
    # end to end length = 10 mm
    ends = t.offsets[:, 0] + t.radii, t.offsets[:, 0] - t.radii
    assert np.max(ends[0]) - np.min(ends[1]) == pytest.approx(10e-3, rel=1e-12)
    assert t.bounding_radius == pytest.approx(5e-3, rel=1e-12)
    assert t.metadata["overlap"] == pytest.approx(0.75)


def test_stalk_volume_and_inertia_match_slicing_reference():
    t = stalk_template()
    volume, x_com, i_axis, i_trans = slicing_reference(np.linspace(-3e-3, 3e-3, 7), 2e-3)
    assert x_com == pytest.approx(0.0, abs=1e-12)
    assert t.volume == pytest.approx(volume, rel=1e-3)
    np.testing.assert_allclose(t.inertia_per_density, [i_axis, i_trans, i_trans], rtol=1e-3)
    # and it is indeed far from the naive sum of 7 spheres
    assert t.volume < 0.5 * 7 * 4 / 3 * math.pi * 8e-9


def test_stalk_matches_monte_carlo_reference_within_one_percent():
    t = stalk_template()
    centres = np.column_stack([np.linspace(-3e-3, 3e-3, 7), np.zeros(7), np.zeros(7)])
    v_mc, com_mc, i_mc = monte_carlo_reference(centres, np.full(7, 2e-3), n_points=2_000_000)
    assert t.volume == pytest.approx(v_mc, rel=0.01)
    np.testing.assert_allclose(com_mc, 0.0, atol=2e-5)
    np.testing.assert_allclose(t.inertia_per_density, np.sort(np.diag(i_mc)), rtol=0.01)


def test_chain_volume_closed_form_matches_slicing():
    for n, length in ((2, 6e-3), (3, 10e-3), (7, 10e-3), (12, 30e-3), (4, 25e-3)):
        xs = np.linspace(-(length / 2 - 2e-3), length / 2 - 2e-3, n)
        assert chain_volume(length, 4e-3, n) == pytest.approx(
            slicing_reference(xs, 2e-3)[0], rel=1e-9
        )


# ----------------------------------------------------------------------------- cylinders
def capsule_properties(length: float, diameter: float) -> tuple[float, float, float]:
    """Analytic volume and principal moments (per unit density) of a capsule of total
    length ``length`` (cylinder of length L - d plus two hemispheres)."""
    r = diameter / 2.0
    h = length - diameter
    v_cyl = math.pi * r * r * h
    v_sph = 4.0 / 3.0 * math.pi * r**3
    i_axis = v_cyl * r * r / 2.0 + 0.4 * v_sph * r * r
    # hemisphere centroid 3r/8 from its flat face; I about own centroid = (2/5 - 9/64) m r^2
    i_cyl_t = v_cyl * (3 * r * r + h * h) / 12.0
    i_hemi_c = (0.4 - 9.0 / 64.0) * (v_sph / 2.0) * r * r
    arm = h / 2.0 + 3.0 * r / 8.0
    i_trans = i_cyl_t + 2.0 * (i_hemi_c + v_sph / 2.0 * arm * arm)
    return v_cyl + v_sph, i_axis, i_trans


def test_many_sphere_chain_approaches_the_capsule():
    length, diameter = 20e-3, 4e-3
    v_cap, i_axis, i_trans = capsule_properties(length, diameter)
    errors = []
    for n in (5, 15, 61):
        t = cylinder_template(length, diameter, n, resolution=160)
        errors.append(abs(t.volume / v_cap - 1.0))
        assert t.volume < v_cap
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 2e-3
    np.testing.assert_allclose(t.inertia_per_density, [i_axis, i_trans, i_trans], rtol=4e-3)


def test_cylinder_volume_error_is_bounded_by_rounded_ends():
    length, diameter = 20e-3, 4e-3
    t = cylinder_template(length, diameter, 41, resolution=160)
    err = cylinder_volume_error(t, length, diameter)
    v_cyl = math.pi * 4e-6 * length
    assert err == pytest.approx((t.volume - v_cyl) / v_cyl, rel=1e-12)
    # the rounded ends alone miss d / (3 L) of the cylinder; ridges add a little more
    assert -diameter / (3 * length) - 0.003 < err < -diameter / (3 * length)


def test_automatic_sphere_count_gives_paper_stalk_and_respects_tolerance():
    t = cylinder_template(10e-3, 4e-3)
    assert t.n_spheres == 7  # ridge loss 1.44 % <= 2 %, 6 spheres would give 2.08 %
    assert t.metadata["ridge_loss"] == pytest.approx(0.5 / (24 + 32 / 3), rel=1e-9)
    tight = cylinder_template(10e-3, 4e-3, max_volume_error=0.005)
    assert tight.metadata["ridge_loss"] <= 0.005
    looser = cylinder_template(10e-3, 4e-3, tight.n_spheres - 1)
    assert looser.metadata["ridge_loss"] > 0.005
    assert cylinder_template(4e-3, 4e-3).n_spheres == 1


# ----------------------------------------------------------------------------- principal axes
def asymmetric_spheres():
    centres = np.array(
        [[0.0, 0.0, 0.0], [3e-3, 0.0, 0.0], [0.0, 1.5e-3, 0.0], [1e-3, 1e-3, 1.2e-3]]
    )
    radii = np.array([1.5e-3, 1.0e-3, 1.2e-3, 0.6e-3])
    return centres, radii


def test_principal_axis_rotation_of_asymmetric_template():
    centres, radii = asymmetric_spheres()
    t = template_from_spheres(centres, radii)
    # reference: Monte Carlo inertia tensor in the input frame, diagonalised by numpy
    v_mc, _, i_mc = monte_carlo_reference(centres, radii, n_points=2_000_000)
    moments_mc = np.linalg.eigvalsh(i_mc)
    assert t.volume == pytest.approx(v_mc, rel=0.01)
    np.testing.assert_allclose(t.inertia_per_density, moments_mc, rtol=0.015)
    assert np.all(np.diff(t.inertia_per_density) > 0)  # ascending, distinct
    # in the body frame the union has its centre of mass at the origin and a diagonal tensor
    _, com_b, i_b = monte_carlo_reference(t.offsets, t.radii, n_points=2_000_000, seed=99)
    np.testing.assert_allclose(com_b, 0.0, atol=3e-3 * t.bounding_radius)
    off = i_b - np.diag(np.diag(i_b))
    assert np.max(np.abs(off)) < 0.01 * np.max(i_b)
    np.testing.assert_allclose(np.diag(i_b), t.inertia_per_density, rtol=0.015)
    # distances between sphere centres are preserved (a rigid motion)
    d_in = np.linalg.norm(centres[:, None] - centres[None], axis=2)
    d_out = np.linalg.norm(t.offsets[:, None] - t.offsets[None], axis=2)
    np.testing.assert_allclose(d_out, d_in, atol=1e-12)
    rot = np.array(t.metadata["rotation_to_body"])
    assert np.linalg.det(rot) == pytest.approx(1.0)  # proper rotation, no mirror


def test_template_is_independent_of_the_input_pose():
    centres, radii = asymmetric_spheres()
    t0 = template_from_spheres(centres, radii)
    rot = Rotation.from_euler("zyx", [37.0, -21.0, 64.0], degrees=True).as_matrix()
    moved = centres @ rot.T + np.array([0.3, -0.1, 2.0])
    t1 = template_from_spheres(moved, radii)
    np.testing.assert_allclose(t1.inertia_per_density, t0.inertia_per_density, rtol=2e-3)
    assert t1.volume == pytest.approx(t0.volume, rel=1e-3)
    # same body-frame offsets up to the sign of each axis (and the numerical error)
    signs = np.sign(np.sum(t0.offsets * t1.offsets, axis=0))
    np.testing.assert_allclose(t1.offsets * signs, t0.offsets, atol=2e-3 * t0.bounding_radius)


def test_collinear_chain_in_any_direction_lies_exactly_on_body_x():
    direction = np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5])
    centres = np.outer(np.linspace(-3e-3, 3e-3, 7), direction) + np.array([0.1, 0.2, 0.3])
    t = template_from_spheres(centres, np.full(7, 2e-3))
    assert np.all(t.offsets[:, 1:] == 0.0)
    np.testing.assert_allclose(np.sort(t.offsets[:, 0]), np.linspace(-3e-3, 3e-3, 7), atol=1e-15)
    assert t.inertia_per_density[1] == t.inertia_per_density[2]
    v_ref, _, i_axis, i_trans = slicing_reference(np.linspace(-3e-3, 3e-3, 7), 2e-3)
    np.testing.assert_allclose(t.inertia_per_density, [i_axis, i_trans, i_trans], rtol=1e-3)
    assert t.volume == pytest.approx(v_ref, rel=1e-3)


def test_sphere_inside_another_adds_nothing():
    t = template_from_spheres([[0, 0, 0], [1e-3, 0, 0]], [3e-3, 0.5e-3])
    v = 4.0 / 3.0 * math.pi * 27e-9
    assert t.volume == pytest.approx(v, rel=2e-4)
    np.testing.assert_allclose(t.inertia_per_density, 0.4 * v * 9e-6, rtol=5e-4)
    np.testing.assert_allclose(t.offsets[0], 0.0, atol=1e-9)


# ----------------------------------------------------------------------------- scaling
def test_scaled_follows_length_volume_and_inertia_laws():
    centres, radii = asymmetric_spheres()
    t = template_from_spheres(centres, radii)
    f = 0.75
    s = t.scaled(f)
    np.testing.assert_allclose(s.offsets, t.offsets * f, rtol=1e-14)
    np.testing.assert_allclose(s.radii, t.radii * f, rtol=1e-14)
    assert s.volume == pytest.approx(t.volume * f**3, rel=1e-14)
    np.testing.assert_allclose(s.inertia_per_density, t.inertia_per_density * f**5, rtol=1e-14)
    assert s.bounding_radius == pytest.approx(t.bounding_radius * f, rel=1e-14)
    # and the scaled template agrees with integrating the scaled spheres afresh
    fresh = template_from_spheres(centres * 1.25, radii * 1.25)
    np.testing.assert_allclose(
        t.scaled(1.25).inertia_per_density, fresh.inertia_per_density, rtol=2e-3
    )


def test_template_arrays_are_read_only():
    t = stalk_template()
    with pytest.raises(ValueError, match="read-only"):
        t.offsets[0, 0] = 1.0


# ----------------------------------------------------------------------------- validation
@pytest.mark.parametrize(
    ("call", "field"),
    [
        (lambda: sphere_template(-1e-3), "radius"),
        (lambda: sphere_template(float("nan")), "radius"),
        (lambda: union_mass_properties([[0, 0, 0]], [0.0]), "radii"),
        (lambda: union_mass_properties([[0, 0]], [1.0]), "centres"),
        (lambda: union_mass_properties([[0, 0, float("inf")]], [1.0]), "centres"),
        (lambda: union_mass_properties([[0, 0, 0], [1, 0, 0]], [1.0]), "radii"),
        (lambda: union_mass_properties([[0, 0, 0]], [1.0], resolution=2), "resolution"),
        (lambda: cylinder_template(-10e-3, 4e-3), "length"),
        (lambda: cylinder_template(10e-3, 0.0), "diameter"),
        (lambda: cylinder_template(3e-3, 4e-3), "length must be >= diameter"),
        (lambda: cylinder_template(10e-3, 4e-3, 0), "n_spheres"),
        (lambda: cylinder_template(10e-3, 4e-3, 1), "n_spheres"),
        (lambda: cylinder_template(10e-3, 4e-3, max_volume_error=1.5), "max_volume_error"),
        (lambda: cylinder_template(1.0, 1e-3), "max_spheres"),
        (lambda: stalk_template(length=0.0), "length"),
        (lambda: stalk_template().scaled(0.0), "factor"),
        (lambda: stalk_template().mass(-5.0), "density"),
        (lambda: template_from_spheres([[0, 0, 0]], [-1.0]), "radii"),
    ],
)
def test_invalid_input_is_refused_naming_the_field(call, field):
    with pytest.raises(InputError, match=field):
        call()


def test_template_constructor_validates():
    with pytest.raises(InputError, match="inertia_per_density"):
        ClumpTemplate("x", np.zeros((1, 3)), np.ones(1), 1.0, np.array([1.0, -1.0, 1.0]))
    with pytest.raises(InputError, match="volume"):
        ClumpTemplate("x", np.zeros((1, 3)), np.ones(1), 0.0, np.ones(3))


def test_docstring_examples_run():
    result = doctest.testmod(shapes, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0
    assert result.failed == 0
