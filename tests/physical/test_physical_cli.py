"""`demcal physical`: the derived table, the JSON record and exit code 2 on bad input."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from demcal.cli import app

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "corn_stalk" / "measurements.toml"


def run(*args: str):
    return CliRunner().invoke(app, ["physical", *args], env={"COLUMNS": "200"})


def test_example_prints_table_1_with_units(tmp_path):
    out = tmp_path / "derived.json"
    result = run(str(EXAMPLE), "--json", str(out))
    assert result.exit_code == 0, result.output
    text = result.output
    for expected in (
        "114.36",  # mean density
        "0.364 - 0.754",  # pp static friction from 20-37 deg
        "0.384 - 0.7",  # pw static friction from 21-35 deg
        "79000",  # steel shear modulus in MPa
        "kg/m^3",
        "MPa",
        "J/m^2",
        "7 spheres",
        "volume error -14.6%",
        "Rayleigh time step 3.384e-05 s",
        "Target angle of repose 44.12",
    ):
        assert expected in text, expected
    data = json.loads(out.read_text(encoding="utf-8"))
    assert set(data) == {"raw", "derived"}
    assert round(data["derived"]["fixed"]["particle.density"]["value"], 2) == 114.36
    low, high = (data["derived"]["factors"]["pw.static_friction"][k] for k in ("low", "high"))
    assert (round(low, 2), round(high, 2)) == (0.38, 0.70)


def test_range_rule_option_is_passed_through(tmp_path):
    m = tmp_path / "m.toml"
    m.write_text(
        "[friction.particle_wall]\nangle_deg = [22.0, 25.0, 28.0, 31.0, 34.0]\n", encoding="utf-8"
    )
    out = tmp_path / "o.json"
    result = run(str(m), "--range-rule", "mean_std", "--k", "1", "--json", str(out))
    assert result.exit_code == 0, result.output
    derived = json.loads(out.read_text(encoding="utf-8"))["derived"]
    assert derived["settings"]["range_rule"] == "mean_std"
    assert derived["factors"]["pw.static_friction"]["rule"] == "mean_std"
    assert "not set yet" in result.output


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("[density]\nmass_g = [5.0, -5.0]\nvolume_cm3 = [40.0, 40.0]\n", "density.mass_g.1"),
        ("[friction.particle_wall]\nangle_deg = [30.0, 90.0]\n",
         "friction.particle_wall.angle_deg.1"),
        ("[elasticity]\nshear_modulus_pa = 2.5e6\npoisson = 0.5\n", "elasticity.poisson.0"),
        ("[density]\ndensity_kg_m3 = []\n", "density.density_kg_m3"),
        ("[shape]\nlength_mm = 3.0\ndiameter_mm = 4.0\n", "length must be >= diameter"),
        ("[density\n", "invalid TOML"),
    ],
)
def test_bad_file_exits_2_naming_the_field(tmp_path, body, message):
    m = tmp_path / "m.toml"
    m.write_text(body, encoding="utf-8")
    result = run(str(m))
    assert result.exit_code == 2, result.output
    assert message in result.output
    assert "Traceback" not in result.output


def test_missing_file_and_bad_option_exit_2(tmp_path):
    result = run(str(tmp_path / "none.toml"))
    assert result.exit_code == 2
    assert "not found" in result.output
    result = run(str(EXAMPLE), "--range-rule", "iqr")
    assert result.exit_code == 2
    assert "range_rule must be one of" in result.output


def test_bulk_density_repeats_give_mean_std_and_n(tmp_path):
    """A cylinder of known volume filled loosely and weighed: the bulk density's repeats."""
    text = EXAMPLE.read_text(encoding="utf-8").replace(
        "[measurements.aor]",
        "[measurements.bulk_density]\nmass_g = [24.1, 25.0, 23.6, 24.4]\nvolume_cm3 = 500.0\n\n"
        "[measurements.aor]", 1)
    path = tmp_path / "m.toml"
    path.write_text(text, encoding="utf-8")
    out = tmp_path / "d.json"
    result = run(str(path), "--json", str(out))
    assert result.exit_code == 0, result.output
    assert "bulk_density_kg_m3" in out.read_text(encoding="utf-8")  # the console may wrap it
    from demcal.calibrate.responses import ResponseSpec

    lab = ResponseSpec(name="bulk_density_kg_m3", measurements=str(path)).lab()
    values = [24.1 / 500 * 1e3, 25.0 / 500 * 1e3, 23.6 / 500 * 1e3, 24.4 / 500 * 1e3]
    assert lab.n == 4 and lab.mean == pytest.approx(sum(values) / 4)
    import numpy as np

    assert lab.std == pytest.approx(float(np.std(values, ddof=1)))


def test_bulk_density_needs_its_volume(tmp_path):
    text = EXAMPLE.read_text(encoding="utf-8").replace(
        "[measurements.aor]", "[measurements.bulk_density]\nmass_g = [24.1]\n\n"
        "[measurements.aor]", 1)
    path = tmp_path / "m.toml"
    path.write_text(text, encoding="utf-8")
    result = run(str(path))
    assert result.exit_code == 2 and "bulk_density" in result.output
