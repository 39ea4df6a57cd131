"""How the lead response is named for people (demcal.lead): the angle's words and another
response's, from a result JSON as from a store."""

import pytest

from demcal.lead import ANGLE, LeadName


def test_the_angle_reads_as_the_aor_in_degrees():
    lead = LeadName()
    assert lead.name == ANGLE == "aor_deg" and lead.is_angle
    assert (lead.label, lead.words) == ("AoR", "the AoR")
    assert lead.after_number() == " deg"
    assert lead.after_number(degree_sign=True) == "°"


@pytest.mark.parametrize(("unit", "after"), [("deg", " deg"), ("kg/m^3", " kg/m^3"), ("", "")])
def test_another_lead_reads_as_its_name_and_unit(unit, after):
    lead = LeadName("drum_deg" if unit == "deg" else "shear_kpa", unit)
    assert not lead.is_angle
    assert lead.label == lead.words == lead.name
    assert lead.after_number() == lead.after_number(degree_sign=True) == after


def test_a_result_json_names_its_lead_only_when_it_is_not_the_angle():
    assert LeadName.of_result({"optimum": {}}) == LeadName()
    assert LeadName.of_result({"lead": None}) == LeadName()
    assert LeadName.of_result({"lead": {"name": "drum_deg", "unit": "deg"}}) == \
        LeadName("drum_deg", "deg")
    assert LeadName.of_result({"lead": {"name": "shear_kpa", "unit": None}}) == \
        LeadName("shear_kpa", "")
