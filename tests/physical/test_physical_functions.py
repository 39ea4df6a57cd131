"""Pure functions of demcal.physical against the paper's numbers, hand computations and
statsmodels (an independent implementation of the t interval)."""

from __future__ import annotations

import doctest
import math

import numpy as np
import pytest
from statsmodels.stats.weightstats import DescrStatsW

from demcal import physical
from demcal.errors import InputError
from demcal.physical import (
    angle_from_friction,
    compression_test,
    density_from_overflow,
    friction_from_angle,
    poisson_from_moduli,
    rayleigh_time_step,
    shear_modulus_from_youngs,
    suggest_range,
    summarize,
    summarize_range,
    youngs_modulus_from_shear,
)

PAPER_DENSITIES = [116.15, 126.14, 101.42, 112.35, 115.74]  # kg/m^3, 5 repeats
PAPER_AOR = [44.62, 45.21, 46.09, 41.89, 42.77]  # deg, Table 2


# ----------------------------------------------------------------------------- density
def test_paper_mean_density_is_reproduced():
    s = summarize(PAPER_DENSITIES, name="particle.density", unit="kg/m^3")
    assert round(s.mean, 2) == 114.36  # the paper's average
    assert (s.minimum, s.maximum) == (101.42, 126.14)
    assert s.n_repeats == 5


def test_overflow_density_from_mass_and_volume():
    # 5 g of stalk displacing 43.72 cm^3 of water: 5e-3 kg / 43.72e-6 m^3 = 114.364 kg/m^3
    rho = density_from_overflow([5e-3, 5e-3], [43.72e-6, 50e-6])
    np.testing.assert_allclose(rho, [5e-3 / 43.72e-6, 100.0], rtol=1e-12)
    # one volume shared by all repeats is broadcast
    np.testing.assert_allclose(density_from_overflow([1e-3, 2e-3], 1e-6), [1000.0, 2000.0])


def test_summary_statistics_match_statsmodels():
    for level in (0.9, 0.95, 0.99):
        s = summarize(PAPER_DENSITIES, level=level)
        ref = DescrStatsW(np.array(PAPER_DENSITIES))
        assert s.mean == pytest.approx(ref.mean, rel=1e-14)
        assert s.std == pytest.approx(ref.std * math.sqrt(5 / 4), rel=1e-12)  # ddof=1
        lo, hi = ref.tconfint_mean(alpha=1 - level)
        assert s.ci_low == pytest.approx(lo, rel=1e-10)
        assert s.ci_high == pytest.approx(hi, rel=1e-10)
    # and by hand: sample sd of the paper's densities is 8.8792 kg/m^3
    assert summarize(PAPER_DENSITIES).std == pytest.approx(8.879197598882458, rel=1e-12)


def test_single_repeat_has_no_deviation_or_interval():
    s = summarize([2.5e6])
    assert s.std is None and s.ci_low is None and s.ci_high is None
    assert s.mean == 2.5e6


def test_paper_aor_average():
    assert round(summarize(PAPER_AOR).mean, 2) == 44.12


# ----------------------------------------------------------------------------- elasticity
def test_young_shear_poisson_relations():
    # the paper: G = 2.5 MPa, v = 0.3 -> E = 2 * 2.5 * 1.3 = 6.5 MPa
    assert youngs_modulus_from_shear(2.5e6, 0.3)[0] == pytest.approx(6.5e6, rel=1e-14)
    assert shear_modulus_from_youngs(6.5e6, 0.3)[0] == pytest.approx(2.5e6, rel=1e-14)
    assert poisson_from_moduli(6.5e6, 2.5e6)[0] == pytest.approx(0.3, rel=1e-12)
    # 65Mn steel: G = 79 GPa, v = 0.3 -> E = 205.4 GPa
    assert youngs_modulus_from_shear(79e9, 0.3)[0] == pytest.approx(205.4e9, rel=1e-12)
    # repeats pair element-wise
    np.testing.assert_allclose(
        youngs_modulus_from_shear([1e6, 2e6], [0.25, 0.0]), [2.5e6, 4e6], rtol=1e-14
    )


def test_compression_test_strains():
    # h 10 -> 9.8 mm (axial strain 0.02), d 4 -> 4.024 mm (lateral 0.006): v = 0.3;
    # F = 10 N on pi * (2 mm)^2 = 12.566 mm^2 -> 0.7958 MPa / 0.02 = 39.79 MPa
    nu, e = compression_test(
        height_before=10e-3,
        height_after=9.8e-3,
        diameter_before=4e-3,
        diameter_after=4.024e-3,
        force=10.0,
    )
    assert nu[0] == pytest.approx(0.3, rel=1e-9)
    assert e[0] == pytest.approx(10.0 / (math.pi * 4e-6) / 0.02, rel=1e-12)
    assert e[0] == pytest.approx(39.79e6, rel=1e-3)


# ----------------------------------------------------------------------------- friction
def test_paper_inclination_ranges_give_its_friction_ranges():
    # particle-steel 21-35 deg -> 0.38-0.70 (the paper rounds to 0.4-0.7)
    mu = friction_from_angle([21.0, 35.0])
    np.testing.assert_allclose(mu, [0.3839, 0.7002], atol=5e-5)
    assert np.round(mu, 2).tolist() == [0.38, 0.70]
    # particle-particle 20-37 deg -> 0.36-0.75 (the paper rounds to 0.35-0.75)
    mu = friction_from_angle([20.0, 37.0])
    assert np.round(mu, 2).tolist() == [0.36, 0.75]
    # and through the range-only summary
    s = summarize_range(21.0, 35.0, name="angle", unit="deg", n_repeats=10)
    m = s.map(friction_from_angle, name="mu", unit="-")
    assert (round(m.minimum, 2), round(m.maximum, 2)) == (0.38, 0.70)
    assert m.mean is None and m.std is None and m.ci_low is None
    assert m.n_repeats == 10


def test_friction_of_45_degrees_is_one_and_inverse():
    assert friction_from_angle(45.0)[0] == pytest.approx(1.0, rel=1e-14)
    np.testing.assert_allclose(angle_from_friction(friction_from_angle([0.0, 30.0, 80.0])),
                               [0.0, 30.0, 80.0], atol=1e-12)


def test_friction_from_repeats_summarised_per_repeat():
    angles = [25.0, 27.5, 30.0, 26.0]
    s = summarize(angles).map(friction_from_angle, name="mu", unit="-")
    mus = np.tan(np.radians(angles))
    assert s.mean == pytest.approx(mus.mean(), rel=1e-14)  # mean of tan, not tan of mean
    assert s.std == pytest.approx(mus.std(ddof=1), rel=1e-12)


# ----------------------------------------------------------------------------- Rayleigh
def test_rayleigh_time_step_by_hand():
    # R = 2 mm, rho = 114.36 kg/m^3, G = 2.5 MPa, v = 0.3:
    # sqrt(rho/G) = sqrt(4.5744e-5) = 6.76343e-3 s/m; pi R = 6.28319e-3 m;
    # 0.1631 * 0.3 + 0.8766 = 0.92553; T_R = 6.28319e-3 * 6.76343e-3 / 0.92553 = 4.59152e-5 s
    t = rayleigh_time_step(2e-3, density=114.36, shear_modulus=2.5e6, poisson=0.3)
    assert t == pytest.approx(4.59152e-5, rel=1e-5)
    # scales linearly with R and with sqrt(rho)
    assert rayleigh_time_step(
        1e-3, density=4 * 114.36, shear_modulus=2.5e6, poisson=0.3
    ) == pytest.approx(t, rel=1e-12)


# ----------------------------------------------------------------------------- range rule
def test_suggested_range_rules():
    s = summarize([0.40, 0.45, 0.50, 0.55, 0.60])
    assert suggest_range(s) == (0.40, 0.60)
    lo, hi = suggest_range(s, rule="mean_std", k=2.0)
    sd = np.std([0.40, 0.45, 0.50, 0.55, 0.60], ddof=1)
    assert (lo, hi) == pytest.approx((0.5 - 2 * sd, 0.5 + 2 * sd), rel=1e-12)
    assert suggest_range(s, rule="ci") == pytest.approx((s.ci_low, s.ci_high), rel=1e-14)
    # clipped to physical bounds
    wide = summarize([0.02, 0.05, 0.3])
    lo, hi = suggest_range(wide, rule="mean_std", k=3.0, bounds=(0.0, math.inf))
    assert lo == 0.0 and hi > 0.3


def test_range_rules_needing_repeats_refuse_a_range_only_record():
    s = summarize_range(20.0, 37.0, name="pp angle", unit="deg")
    assert suggest_range(s) == (20.0, 37.0)
    with pytest.raises(InputError, match=r"mean_std.*pp angle.*range only"):
        suggest_range(s, rule="mean_std")
    with pytest.raises(InputError, match="rule must be one of"):
        suggest_range(s, rule="iqr")  # type: ignore[arg-type]


# ----------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: density_from_overflow([5e-3, -5e-3], 40e-6), r"mass\[1\] must be in|mass\[1\]"),
        (lambda: density_from_overflow(5e-3, 0.0), "volume"),
        (lambda: density_from_overflow([1e-3, 2e-3, 3e-3], [1e-6, 2e-6]), "same number"),
        (lambda: friction_from_angle([30.0, 90.0]), r"angle_deg\[1\] must be in \[0, 90\)"),
        (lambda: friction_from_angle(-1.0), "angle_deg"),
        (lambda: friction_from_angle([]), "angle_deg needs at least one value"),
        (lambda: youngs_modulus_from_shear(2.5e6, 0.5), r"poisson must be in \[0, 0.5\)"),
        (lambda: youngs_modulus_from_shear(2.5e6, -0.1), "poisson"),
        (lambda: youngs_modulus_from_shear(-1.0, 0.3), "shear_modulus"),
        (lambda: poisson_from_moduli(1e6, 1e6), "poisson"),
        (lambda: summarize([]), "needs at least one value"),
        (lambda: summarize([1.0, float("nan")], name="density"), r"density\[1\]"),
        (lambda: summarize([1.0, 2.0], level=1.0), "level"),
        (lambda: summarize_range(5.0, 1.0, name="angle"), "minimum must be <= maximum"),
        (lambda: rayleigh_time_step(0.0, density=1.0, shear_modulus=1.0, poisson=0.3), "radius"),
        (lambda: rayleigh_time_step(1e-3, density=1.0, shear_modulus=1.0, poisson=0.5), "poisson"),
        (lambda: rayleigh_time_step(1e-3, density=-1.0, shear_modulus=1.0, poisson=0.2), "density"),
        (
            lambda: compression_test(
                height_before=10e-3, height_after=11e-3, diameter_before=4e-3, diameter_after=4e-3
            ),
            "height_after must be < height_before",
        ),
        (
            lambda: compression_test(
                height_before=10e-3, height_after=9e-3, diameter_before=4e-3, diameter_after=5e-3
            ),
            "poisson from the compression test must be < 0.5",
        ),
    ],
)
def test_bad_input_is_refused_naming_the_field(call, message):
    with pytest.raises(InputError, match=message):
        call()


def test_docstring_examples_run():
    from demcal.physical import conversions, stats

    for module in (conversions, stats, physical):
        result = doctest.testmod(module)
        assert result.failed == 0, module.__name__
        assert result.attempted > 0, module.__name__


def test_std_interval_matches_the_chi_square_table_and_covers_at_its_level():
    """The 95 % interval of a std from 6 repeats is s x (0.6242, 2.4526): sqrt(5 / 12.833)
    and sqrt(5 / 0.8312), with chi-square quantiles from a printed table (5 degrees of
    freedom: 12.833 at 0.975, 0.8312 at 0.025); and over many normal samples it holds the
    true std about 95 % of the time."""
    from demcal.physical import std_interval

    lo, hi = std_interval(2.0, 6)
    assert lo == pytest.approx(2.0 * 0.6242, abs=2e-3)
    assert hi == pytest.approx(2.0 * 2.4526, abs=2e-3)
    rng = np.random.default_rng(7)
    samples = rng.normal(40.0, 1.7, size=(4000, 6))
    covered = [lo <= 1.7 <= hi for lo, hi in (std_interval(s, 6) for s in
                                               samples.std(axis=1, ddof=1))]
    assert np.mean(covered) == pytest.approx(0.95, abs=0.015)
    with pytest.raises(InputError, match="n must be an integer >= 2"):
        std_interval(1.0, 1)
    with pytest.raises(InputError, match="std"):
        std_interval(-1.0, 6)
