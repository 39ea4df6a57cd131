"""Measurements file -> derived parameters: the paper's Table 1 and bad input."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from demcal.errors import InputError
from demcal.physical import (
    PARAMETERS,
    derive_parameters,
    load_measurements,
    parse_measurements,
)

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "corn_stalk" / "measurements.toml"


@pytest.fixture(scope="module")
def paper():
    return derive_parameters(load_measurements(EXAMPLE))


# ----------------------------------------------------------------------------- the paper
def test_example_reproduces_the_papers_fixed_parameters(paper):
    fixed = paper.fixed_values()
    assert round(fixed["particle.density"], 2) == 114.36
    assert fixed["particle.shear_modulus"] == 2.5e6
    assert fixed["wall.poisson"] == 0.3
    assert fixed["wall.shear_modulus"] == 79e9
    assert fixed["wall.density"] == 7865.0
    assert fixed["pw.surface_energy"] == 0.0
    assert paper.missing == ()


def test_example_reproduces_the_papers_factor_ranges(paper):
    bounds = paper.factor_bounds()
    # measured: inclined plane 20-37 deg (pp) and 21-35 deg (pw), range of 10 repeats each
    assert tuple(round(x, 2) for x in bounds["pp.static_friction"]) == (0.36, 0.75)
    assert tuple(round(x, 2) for x in bounds["pw.static_friction"]) == (0.38, 0.70)
    assert bounds["pp.static_friction"] == pytest.approx(
        (math.tan(math.radians(20)), math.tan(math.radians(37))), rel=1e-12
    )
    # literature ranges of Table 1, carried through
    assert bounds["particle.poisson"] == (0.2, 0.4)
    assert bounds["pp.restitution"] == (0.2, 0.4)
    assert bounds["pp.rolling_friction"] == (0.03, 0.15)
    assert bounds["pw.restitution"] == (0.3, 0.6)
    assert bounds["pw.rolling_friction"] == (0.01, 0.3)
    assert bounds["pp.surface_energy"] == (0.04, 0.12)
    # range-only records carry no invented statistics
    mu = paper.summaries["pp.static_friction"]
    assert mu.range_only and mu.mean is None and mu.std is None and mu.n_repeats == 10
    assert "range of 10 repeats" in paper.factors["pp.static_friction"].source
    # the measured 0.3 is kept next to the literature range of x1
    assert "measured 0.3" in paper.factors["particle.poisson"].source


def test_table_rows_follow_the_papers_table_1(paper):
    rows = paper.table_rows()
    assert [r["symbol"] for r in rows][:6] == ["x1", "G1", "rho1", "v2", "G2", "rho2"]
    by_name = {r["name"]: r for r in rows}
    assert by_name["particle.shear_modulus"]["display"] == "2.5"
    assert by_name["particle.shear_modulus"]["display_unit"] == "MPa"
    assert by_name["wall.shear_modulus"]["display"] == "79000"  # the paper's 79000 MPa
    assert by_name["particle.density"]["display"] == "114.36"
    assert by_name["pp.static_friction"]["display"] == "0.364-0.754"
    assert {r["symbol"] for r in rows if r["kind"] == "factor"} == {f"x{i}" for i in range(1, 9)}


def test_template_and_its_volume_error(paper):
    t = paper.template
    assert t.template.n_spheres == 7
    assert not t.automatic
    # by hand: 7 spheres r = 2 mm, spacing s = 1 mm; each cross-section is the nearest
    # sphere's disc: V = 6 pi (r^2 s - s^3/12) + 4/3 pi r^3 = 34.1667 pi mm^3;
    # cylinder 10 x 4 mm: 40 pi mm^3 -> error 34.1667/40 - 1 = -14.58 %
    assert t.cylinder_volume == pytest.approx(40 * math.pi * 1e-9, rel=1e-12)
    assert t.volume_error == pytest.approx(34.1666667 / 40 - 1, abs=5e-4)
    d = t.to_dict()
    assert d["overlap"] == pytest.approx(0.75)
    assert d["spacing_m"] == pytest.approx(1e-3)


def test_automatic_template_matches_paper_choice():
    res = derive_parameters({"shape": {"length_mm": [9.0, 10.0, 11.0], "diameter_mm": 4.0}})
    assert res.template.automatic
    assert res.template.template.n_spheres == 7
    assert res.template.length == pytest.approx(10e-3)
    assert res.rayleigh is None  # no density or moduli yet
    assert "particle.density" in res.missing


def test_rayleigh_step_of_the_example(paper):
    # smallest sphere 2 mm x 0.75 = 1.5 mm, v = 0.4 (top of x1's range), rho 114.36, G 2.5 MPa:
    # pi * 1.5e-3 * sqrt(114.36 / 2.5e6) / (0.1631 * 0.4 + 0.8766) = 3.3840e-5 s
    r = paper.rayleigh
    assert r.radius == pytest.approx(1.5e-3)
    assert r.poisson == 0.4
    assert r.time_step == pytest.approx(3.3840e-5, rel=1e-4)
    assert r.suggested_step == pytest.approx(0.2 * r.time_step)


def test_target_aor_of_the_example(paper):
    assert round(paper.target_aor.mean, 2) == 44.12
    assert paper.target_aor.n_repeats == 5


def test_to_dict_records_raw_and_derived_as_json(paper):
    d = json.loads(json.dumps(paper.to_dict()))
    assert d["raw"]["density"]["density_kg_m3"] == [116.15, 126.14, 101.42, 112.35, 115.74]
    assert d["raw"]["friction"]["particle_wall"]["angle_min_deg"] == 21.0
    derived = d["derived"]
    assert round(derived["fixed"]["particle.density"]["value"], 2) == 114.36
    assert derived["factors"]["pw.static_friction"]["unit"] == "-"
    assert derived["template"]["n_spheres"] == 7
    assert derived["rayleigh"]["rayleigh_time_step_s"] == pytest.approx(3.384e-5, rel=1e-3)
    assert derived["settings"] == {"ci_level": 0.95, "range_rule": "minmax", "range_k": 2.0}
    assert len(derived["table"]) == len(PARAMETERS)


# ----------------------------------------------------------------------------- other forms
def test_overflow_raw_readings_give_densities():
    res = derive_parameters({"density": {"mass_g": [5.0, 5.0], "volume_cm3": [40.0, 50.0]}})
    s = res.summaries["particle.density"]
    np.testing.assert_allclose(s.values, [125.0, 100.0], rtol=1e-12)
    assert res.fixed["particle.density"].value == pytest.approx(112.5)


def test_angle_repeats_with_each_rule():
    angles = [22.0, 25.0, 28.0, 31.0, 34.0]
    mus = np.tan(np.radians(angles))
    data = {"friction": {"particle_wall": {"angle_deg": angles}}}
    res = derive_parameters(data)
    assert res.factor_bounds()["pw.static_friction"] == pytest.approx(
        (mus.min(), mus.max()), rel=1e-12
    )
    res = derive_parameters(data, range_rule="mean_std", range_k=1.0)
    sd = mus.std(ddof=1)
    assert res.factor_bounds()["pw.static_friction"] == pytest.approx(
        (mus.mean() - sd, mus.mean() + sd), rel=1e-12
    )
    assert "mean +- 1 sd" in res.factors["pw.static_friction"].source
    res = derive_parameters({**data, "range_rule": "ci", "ci_level": 0.9})
    s = res.summaries["pw.static_friction"]
    assert res.factor_bounds()["pw.static_friction"] == (s.ci_low, s.ci_high)
    assert s.level == 0.9


def test_range_only_record_falls_back_to_minmax_with_a_note():
    res = derive_parameters(
        {"friction": {"particle_particle": {"angle_min_deg": 20, "angle_max_deg": 37}}},
        range_rule="mean_std",
    )
    assert res.factors["pp.static_friction"].rule == "minmax"
    assert any("pp.static_friction" in n and "minmax" in n for n in res.notes)


def test_poisson_repeats_become_a_factor_and_overrides_are_recorded():
    res = derive_parameters(
        {"elasticity": {"shear_modulus_pa": 2.5e6, "poisson": [0.28, 0.31, 0.33]}}
    )
    assert res.factor_bounds()["particle.poisson"] == (0.28, 0.33)
    assert res.fixed["particle.shear_modulus"].value == 2.5e6
    res = derive_parameters(
        {
            "elasticity": {"shear_modulus_pa": 2.5e6, "poisson": [0.28, 0.31, 0.33]},
            "fixed": {"particle.poisson": 0.3},
        }
    )
    assert res.fixed["particle.poisson"].value == 0.3
    assert "particle.poisson" not in res.factors
    assert any("overrides measured 0.28-0.33" in n for n in res.notes)


def test_youngs_modulus_and_compression_forms():
    res = derive_parameters({"elasticity": {"youngs_modulus_pa": 6.5e6, "poisson": 0.3}})
    assert res.fixed["particle.shear_modulus"].value == pytest.approx(2.5e6, rel=1e-12)
    comp = {
        "height_before_mm": 10.0,
        "height_after_mm": 9.8,
        "diameter_before_mm": 4.0,
        "diameter_after_mm": 4.024,
        "force_n": 10.0,
    }
    res = derive_parameters({"elasticity": {"compression": [comp, comp]}})
    e = 10.0 / (math.pi * 4e-6) / 0.02
    assert res.summaries["particle.youngs_modulus"].mean == pytest.approx(e, rel=1e-9)
    assert res.fixed["particle.poisson"].value == pytest.approx(0.3, rel=1e-9)
    assert res.fixed["particle.shear_modulus"].value == pytest.approx(e / 2.6, rel=1e-9)


def test_study_file_section_and_standalone_file(tmp_path):
    study = tmp_path / "study.toml"
    study.write_text(
        '[study]\nname = "x"\n\n[measurements]\nmaterial = "sand"\n'
        "[measurements.density]\ndensity_kg_m3 = [1500, 1520]\n",
        encoding="utf-8",
    )
    assert load_measurements(study).material == "sand"
    standalone = tmp_path / "m.toml"
    standalone.write_text("[density]\ndensity_kg_m3 = 1500\n", encoding="utf-8")
    assert derive_parameters(load_measurements(standalone)).fixed_values() == {
        "particle.density": 1500.0
    }


def test_photo_paths_resolve_relative_to_the_file(tmp_path):
    m = parse_measurements({"aor": {"photos": ["pics/a.jpg", "/abs/b.jpg"]}})
    assert m.aor.photo_paths(tmp_path) == [tmp_path / "pics/a.jpg", Path("/abs/b.jpg")]
    assert derive_parameters(m).target_aor is None


# ----------------------------------------------------------------------------- bad input
BAD = [
    ({"density": {"mass_g": [5.0, -5.0], "volume_cm3": [40.0, 40.0]}}, "density.mass_g.1"),
    ({"density": {"density_kg_m3": []}}, "density.density_kg_m3"),
    ({"density": {"mass_g": [5.0]}}, "density: give density_kg_m3, or both mass_g"),
    (
        {"density": {"density_kg_m3": [1.0], "mass_g": [1.0], "volume_cm3": [1.0]}},
        "not both",
    ),
    ({"friction": {"particle_wall": {"angle_deg": [30.0, 90.0]}}},
     "friction.particle_wall.angle_deg.1: Input should be less than 90"),
    ({"friction": {"particle_wall": {"angle_deg": [95.0]}}}, "friction.particle_wall.angle_deg.0"),
    ({"friction": {"particle_particle": {"angle_min_deg": 20.0, "angle_max_deg": 90.0}}},
     "friction.particle_particle.angle_max_deg"),
    ({"friction": {"particle_particle": {"angle_min_deg": 37.0, "angle_max_deg": 20.0}}},
     "angle_min_deg must be <= angle_max_deg"),
    ({"friction": {"particle_particle": {"angle_min_deg": 20.0}}}, "friction.particle_particle"),
    ({"friction": {"particle_wall": {"angle_deg": []}}}, "friction.particle_wall.angle_deg"),
    ({"friction": {"particle_wall": {"angle_deg": [20.0, 30.0], "n_repeats": 10}}}, "n_repeats"),
    ({"elasticity": {"shear_modulus_pa": 2.5e6, "poisson": 0.5}},
     "elasticity.poisson.0: Input should be less than 0.5"),
    ({"elasticity": {"shear_modulus_pa": 2.5e6, "poisson": -0.1}}, "elasticity.poisson.0"),
    ({"elasticity": {"shear_modulus_pa": 2.5e6}}, "elasticity: give exactly two"),
    ({"elasticity": {"shear_modulus_pa": 1e6, "youngs_modulus_pa": 1.5e6}}, "elasticity: poisson"),
    ({"wall": {"density_kg_m3": 7865, "shear_modulus_pa": 79e9, "poisson": 0.7}},
     "wall.poisson.0"),
    ({"wall": {"shear_modulus_pa": 79e9, "poisson": 0.3}}, "wall.density_kg_m3: Field required"),
    ({"shape": {"length_mm": 10.0, "diameter_mm": 0.0}}, "shape.diameter_mm.0"),
    ({"shape": {"length_mm": 10.0, "diameter_mm": 4.0, "size_scale": [1.25, 0.75]}},
     "shape.size_scale"),
    ({"moisture_percent": [11.0, 120.0]}, "moisture_percent.1"),
    ({"aor": {"angle_deg": [44.0, 0.0]}}, "aor.angle_deg.1"),
    ({"aor": {}}, "aor: give angle_deg values and/or photos"),
    ({"factor_ranges": {"pp.static_friction": [0.7, 0.35]}},
     "low must be < high for factor pp.static_friction; got low=0.7, high=0.35"),
    ({"factor_ranges": {"pp.restitution": [0.2, 1.4]}}, "high of factor pp.restitution"),
    ({"factor_ranges": {"pp.friction": [0.2, 0.4]}}, "unknown parameter 'pp.friction'"),
    ({"fixed": {"wall.poisson": 0.5}}, r"wall.poisson must be in \[0, 0.5\)"),
    ({"fixed": {"pw.surface_energy": 0.0}, "factor_ranges": {"pw.surface_energy": [0, 0.1]}},
     "either fixed or a factor range"),
    ({"range_rule": "iqr"}, "measurements.range_rule"),
    ({"ci_level": 1.0}, "measurements.ci_level"),
    ({"densty": {}}, "measurements.densty: Extra inputs are not permitted"),
]


@pytest.mark.parametrize(("data", "message"), BAD)
def test_bad_measurements_are_refused_naming_the_field(data, message):
    with pytest.raises(InputError, match=message):
        derive_parameters(data)


def test_every_error_line_names_the_measurements_field():
    with pytest.raises(InputError) as info:
        parse_measurements(
            {"density": {"density_kg_m3": [-1.0]}, "elasticity": {"poisson": 0.6,
                                                                   "shear_modulus_pa": 1e6}}
        )
    lines = str(info.value).splitlines()
    assert len(lines) == 2
    assert all(line.startswith("measurements.") for line in lines)
    assert "got -1.0" in lines[0]


def test_particle_shorter_than_wide_is_refused_naming_shape():
    with pytest.raises(InputError, match=r"measurements\.shape: length must be >= diameter"):
        derive_parameters({"shape": {"length_mm": 3.0, "diameter_mm": 4.0}})


def test_bad_settings_overrides_are_refused():
    with pytest.raises(InputError, match="range_rule"):
        derive_parameters({}, range_rule="iqr")
    with pytest.raises(InputError, match="ci_level"):
        derive_parameters({}, ci_level=0.0)
    with pytest.raises(InputError, match="range_k"):
        derive_parameters({}, range_k=-1.0)


def test_file_errors(tmp_path):
    with pytest.raises(InputError, match="not found"):
        load_measurements(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[density\n", encoding="utf-8")
    with pytest.raises(InputError, match="invalid TOML"):
        load_measurements(bad)
