"""Outcome criteria of the virtual AoR test, on constructed particle states."""

import numpy as np
import pytest

from demcal.virtual.config import OutcomeCriteria
from demcal.virtual.outcome import Outcome, classify_after_lift, classify_settled, mass_in_tube

CRIT = OutcomeCriteria()
R_TUBE = 0.015


def _cloud(n, rho_max, z_lo, z_hi, seed=0):
    rng = np.random.default_rng(seed)
    rho = rho_max * np.sqrt(rng.random(n))
    phi = rng.uniform(0, 2 * np.pi, n)
    return np.stack([rho * np.cos(phi), rho * np.sin(phi), rng.uniform(z_lo, z_hi, n)], 1)


def test_plug_when_most_mass_rose_with_the_tube():
    pos = _cloud(200, 0.9 * R_TUBE, 0.05, 0.10)  # inside a tube lifted to z = 0.04
    out, reason = classify_after_lift(pos, np.ones(200), tube_bottom=0.04, tube_height=0.15,
                                      tube_radius=R_TUBE, criteria=CRIT)
    assert out is Outcome.PLUG and "rose with the cylinder" in reason


def test_no_plug_when_material_left_the_tube():
    pos = _cloud(200, 0.05, 0.0, 0.02)  # spread on the plate, tube above it
    out, _ = classify_after_lift(pos, np.ones(200), tube_bottom=0.04, tube_height=0.15,
                                 tube_radius=R_TUBE, criteria=CRIT)
    assert out is None


def test_plug_threshold_is_the_mass_fraction():
    inside = _cloud(30, 0.9 * R_TUBE, 0.05, 0.1)
    outside = _cloud(70, 0.05, 0.0, 0.02, seed=1)
    pos = np.vstack([inside, outside])
    masses = np.ones(100)
    args = dict(tube_bottom=0.04, tube_height=0.15, tube_radius=R_TUBE)
    assert classify_after_lift(pos, masses, criteria=OutcomeCriteria(plug_mass_fraction=0.25),
                               **args)[0] is Outcome.PLUG
    assert classify_after_lift(pos, masses, criteria=OutcomeCriteria(plug_mass_fraction=0.35),
                               **args)[0] is None


def test_column_when_material_stands_in_the_footprint():
    pos = _cloud(300, R_TUBE, 0.0, 0.06)
    out, reason = classify_settled(pos, np.ones(300), fill_height=0.062, material_top=0.061,
                                   tube_radius=R_TUBE, particle_length=0.0125, criteria=CRIT)
    assert out is Outcome.COLUMN and "still stands" in reason


def test_pile_when_material_spread():
    # a cone of base radius 45 mm: most of the mass lies outside the tube footprint
    rng = np.random.default_rng(3)
    rho = 0.045 * np.sqrt(rng.random(3000))
    keep = rng.random(3000) < (1 - rho / 0.045)  # denser near the axis, like a cone
    pos = np.stack([rho, np.zeros_like(rho), 0.5 * (0.045 - rho)], 1)[keep]
    out, _ = classify_settled(pos, np.ones(len(pos)), fill_height=0.06, material_top=0.025,
                              tube_radius=R_TUBE, particle_length=0.0125, criteria=CRIT)
    assert out is Outcome.PILE


def test_low_standing_material_is_not_a_column():
    pos = _cloud(300, R_TUBE, 0.0, 0.02)  # all inside the footprint but slumped to a third
    out, _ = classify_settled(pos, np.ones(300), fill_height=0.06, material_top=0.02,
                              tube_radius=R_TUBE, particle_length=0.0125, criteria=CRIT)
    assert out is Outcome.PILE


def test_empty_plate_is_scattered():
    out, reason = classify_settled(np.zeros((0, 3)), np.zeros(0), fill_height=0.06,
                                   material_top=0.0, tube_radius=R_TUBE, particle_length=0.01,
                                   criteria=CRIT)
    assert out is Outcome.SCATTERED and "no material" in reason


@pytest.mark.parametrize("value", [0.0, 1.5])
def test_criteria_bounds(value):
    with pytest.raises(ValueError, match="plug_mass_fraction"):
        OutcomeCriteria(plug_mass_fraction=value)


def test_an_unsettled_test_says_when_its_material_still_stands_as_a_column():
    """A test whose material never settles is 'unsettled'; the reason says what the moving
    material is (height against the fill, mass outside the cylinder's footprint) and, when it
    still stands in the footprint, that it is a column creeping on."""
    from types import SimpleNamespace

    from demcal.virtual.aor import _column_hint
    from demcal.virtual.config import fidelity_config

    config = fidelity_config("quick")  # a 30 mm tube: R_TUBE

    def hint(pos):
        sim = SimpleNamespace(spheres=lambda w: (pos, np.full(len(pos), 0.002), None),
                              clump_positions=lambda w: pos,
                              clump_masses=lambda w: np.ones(len(pos)))
        return _column_hint(sim, SimpleNamespace(index=0, fill_height=0.06), config)

    column = hint(_cloud(150, 0.9 * R_TUBE, 0.0, 0.058))
    assert column.startswith("; it still stands as a column, creeping (cohesion holds the "
                             "material up): 60 mm high (100% of the fill height), 0% of "
                             "the mass outside the cylinder's footprint")
    spread = hint(_cloud(150, 0.05, 0.0, 0.02))
    assert spread.startswith("; the material is still moving: 22 mm high (37% of the fill "
                             "height), ")
    outside = float(spread.split("), ")[1].split("%")[0])
    assert 70 < outside < 90  # uniform over a 50 mm disc: 1 - (20 mm / 50 mm)^2 = 84 %


def test_footprint_is_the_tube_radius_and_the_longest_particle():
    from demcal.virtual import fidelity_config
    from demcal.virtual.outcome import footprint, mass_outside

    config = fidelity_config("standard")
    fp = footprint(config)
    assert fp["tube_radius"] == pytest.approx(0.5 * config.geometry.cylinder_inner_diameter)
    assert fp["particle_length"] == pytest.approx(
        config.particle.length * config.particle.size_max)
    edge = fp["tube_radius"] + 0.5 * fp["particle_length"]
    pos = np.array([[0.99 * edge, 0.0, 0.0], [1.01 * edge, 0.0, 0.0]])
    assert mass_outside(pos, np.array([3.0, 1.0]), **fp) == pytest.approx(0.25)


def test_mass_in_tube_counts_the_clumps_the_lifted_cylinder_holds():
    """A hand-built state after a lift: the tube's rim at 0.1 m, 0.15 m long, radius 0.015 m.
    Held: centres within the radius and between the rim and the top; the pile below the rim,
    a clump beside the tube and one above its top are not."""
    pos = np.array([
        [0.0, 0.0, 0.12],      # held, on the axis            2.0 kg
        [0.01, -0.01, 0.24],   # held, rho 0.0141 < 0.015     0.5 kg
        [0.0, 0.0, 0.05],      # in the pile under the rim    4.0 kg
        [0.02, 0.0, 0.12],     # beside the tube (rho 0.02)   8.0 kg
        [0.0, 0.0, 0.26],      # above the tube's top (0.25)  16.0 kg
    ])
    mass = np.array([2.0, 0.5, 4.0, 8.0, 16.0])
    kw = {"tube_bottom": 0.1, "tube_height": 0.15, "tube_radius": 0.015}
    assert mass_in_tube(pos, mass, **kw) == 2.5
    assert mass_in_tube(np.empty((0, 3)), np.empty(0), **kw) == 0.0
    # before the lift (rim on the plate, top at 0.15 m): the two low clumps on the axis
    assert mass_in_tube(pos, mass, **{**kw, "tube_bottom": 0.0}) == 6.0
    # the plug rule reads the same mass as a fraction: 2.5 / 30.5 = 8 %, under 10 %
    crit = OutcomeCriteria(plug_mass_fraction=0.1)
    assert classify_after_lift(pos, mass, criteria=crit, **kw) == (None, None)
    assert classify_after_lift(pos, mass, criteria=OutcomeCriteria(plug_mass_fraction=0.08),
                               **kw)[0] == Outcome.PLUG
