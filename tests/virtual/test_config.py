"""Validation of the virtual test's parameters and configuration (before anything runs)."""

import pytest
from pydantic import ValidationError

from demcal.errors import InputError
from demcal.virtual import fidelity_config, parse_assignments, preset_parameters


@pytest.mark.parametrize(("item", "field"), [
    ("pp.static_friction=-0.1", "pp.static_friction"),
    ("pw.static_friction=-1", "pw.static_friction"),
    ("pp.restitution=0", "pp.restitution"),
    ("pw.restitution=1.2", "pw.restitution"),
    ("particle.poisson=0.5", "particle.poisson"),
    ("pp.surface_energy=-0.01", "pp.surface_energy"),
    ("pp.rolling_friction=abc", "pp.rolling_friction"),
])
def test_bad_parameters_are_refused_naming_the_field(item, field):
    with pytest.raises(InputError, match=field.replace(".", r"\.")):
        parse_assignments([item])


def test_unknown_parameter_lists_known_names():
    with pytest.raises(InputError, match=r"unknown parameter 'pp.friction'.*pp.static_friction"):
        parse_assignments(["pp.friction=0.5"])


def test_preset_overrides_apply():
    p = preset_parameters("corn_stalk", {"pp.static_friction": 0.7})
    assert p["pp.static_friction"] == 0.7 and p["particle.density"] == 114.36


def test_cylinder_narrower_than_a_particle_is_refused():
    with pytest.raises(ValidationError, match="cylinder_inner_diameter"):
        fidelity_config("quick", geometry={"cylinder_inner_diameter": 0.008})


def test_time_step_fraction_above_one_is_refused():
    with pytest.raises(ValidationError, match="dt_fraction"):
        fidelity_config("quick", dt_fraction=1.2)


def test_packing_needs_a_count():
    with pytest.raises(ValidationError, match=r"fill\.count is required"):
        fidelity_config("paper", fill={"method": "packing"})


def test_fidelities_share_time_step_and_plate():
    quick, paper = fidelity_config("quick"), fidelity_config("paper")
    assert quick.dt_fraction == paper.dt_fraction == 0.2
    assert quick.geometry.plate_size == paper.geometry.plate_size
    assert quick.phases == paper.phases
    assert paper.geometry.cylinder_inner_diameter == 0.050
    assert paper.fill.rate == 5000 and paper.fill.filling_time == 0.6


@pytest.mark.parametrize("name", ["quick", "small", "standard", "paper"])
def test_every_fidelity_has_default_replicates_and_the_paper_physics(name):
    """The fidelities differ in fill and tube only: time step, plate, phases and laws are
    the paper's, so a parameter set means the same at every fidelity."""
    from demcal.virtual import FIDELITY_REPLICATES

    config, paper = fidelity_config(name), fidelity_config("paper")
    assert FIDELITY_REPLICATES[name] >= 1
    assert config.dt_fraction == paper.dt_fraction and config.phases == paper.phases
    assert config.geometry.plate_size == paper.geometry.plate_size
    assert config.rolling_model == paper.rolling_model and config.particle == paper.particle


def test_standard_fidelity_keeps_the_small_fill_aspect():
    """1200 stalks in 56 mm: the fill's count per tube volume ratio N / D^3 of 300 in 35 mm,
    within 5 %, so the pile forms the same way at four times the size."""
    small, std = fidelity_config("small"), fidelity_config("standard")
    ratio = (std.fill.count / std.geometry.cylinder_inner_diameter ** 3) / (
        small.fill.count / small.geometry.cylinder_inner_diameter ** 3)
    assert std.fill.count == 4 * small.fill.count and abs(ratio - 1) < 0.05


def test_the_old_name_large_says_what_it_is_called_now():
    with pytest.raises(InputError, match="now called 'standard'"):
        fidelity_config("large")


def test_a_stored_run_is_keyed_by_the_test_itself_not_the_fidelity_name():
    """Renaming a fidelity keeps its stored runs; changing what a fidelity means does not
    reuse runs of the old meaning (the key holds the resolved test configuration)."""
    from demcal.execute.tasks import TestDef

    same = TestDef(fidelity="paper", overrides={
        "geometry": {"cylinder_inner_diameter": 0.056},
        "fill": {"method": "packing", "count": 1200}})
    assert same.identity() == TestDef(fidelity="standard").identity()
    assert TestDef(fidelity="small").identity() != TestDef(fidelity="standard").identity()
    other = TestDef(fidelity="standard", overrides={"fill": {"count": 1201}})
    assert other.identity() != TestDef(fidelity="standard").identity()


def test_unknown_fidelity():
    with pytest.raises(InputError, match="fidelity must be one of"):
        fidelity_config("medium")
