"""What a reader sees is rounded for reading; what a program reads back keeps every digit."""

from __future__ import annotations

import math

import pytest

from demcal.cli import _common
from demcal.cli.calibrate_cmd import _print_result
from demcal.display import readable
from demcal.report.material import card_table
from demcal.summaries import CalibrationResult
from demcal.virtual.material_card import MaterialCard, read_material_card
from demcal.virtual.presets import preset_parameters

# floats one bit off the decimal a person typed or a calculation meant
OFF_BY_A_BIT = {"pp.static_friction": 0.1 + 0.2,                 # 0.30000000000000004
                "particle.density": 114.36000000000001,
                "pp.restitution": 0.44999999999999996}


@pytest.mark.parametrize(("value", "text"), [
    (0.1 + 0.2, "0.3"), (114.36000000000001, "114.36"), (0.44999999999999996, "0.45"),
    (1.05e-4, "0.000105"), (7.9e10 + 0.5, "7.9e+10"), (-0.0, "0"), (3, "3"), (True, "True"),
    (math.nextafter(0.4, 1.0), "0.4"), ("n/a", "n/a")])
def test_readable(value, text):
    assert readable(value) == text


def test_readable_keeps_the_digits_that_matter():
    assert readable(0.14126789) == "0.141268"
    assert readable(0.14126789, 4) == "0.1413"
    assert float(readable(44.123456789)) == pytest.approx(44.123456789, rel=1e-5)


def _card() -> MaterialCard:
    return MaterialCard(parameters={**preset_parameters("corn_stalk"), **OFF_BY_A_BIT},
                        calibrated=("pp.static_friction",), study="t")


def test_the_reports_material_table_is_rounded_and_the_card_is_exact(tmp_path):
    card = _card()
    table = card_table(card)
    shown = dict(zip(table.frame["parameter"], table.frame["value"], strict=True))
    assert shown["pp.static_friction"] == "0.3"
    assert shown["particle.density"] == "114.36"
    assert shown["pp.restitution"] == "0.45"
    assert "exact" in table.note
    toml_path, json_path = card.write(tmp_path)
    for path in (toml_path, json_path):
        back = read_material_card(path).parameters
        assert {k: back[k].hex() for k in OFF_BY_A_BIT} == \
            {k: v.hex() for k, v in OFF_BY_A_BIT.items()}


def test_the_console_prints_the_calibrated_parameters_rounded():
    result = {"study": "t", "optimum": dict(OFF_BY_A_BIT), "target_aor_deg": 44.12,
              "predicted_aor_deg": 44.12, "n_runs": 3, "n_runs_executed": 0,
              "verification": {"aor_mean_deg": None, "aor_std_deg": None,
                               "relative_error_percent": None, "n": 0}}
    with _common.console.capture() as cap:
        _print_result(CalibrationResult.from_summary(result))
    text = cap.get()
    assert "0.3 " in text and "114.36 " in text and "0.45 " in text
    assert "0.30000000000000004" not in text and "114.36000000000001" not in text
