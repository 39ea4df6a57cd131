"""The material card: exact round trip (TOML and JSON), validation, `simulate aor --material`."""

from __future__ import annotations

import json
import math
import re
from dataclasses import replace
from pathlib import Path

import pytest
from typer.testing import CliRunner

import demcal.virtual
from demcal.cli import app
from demcal.errors import InputError
from demcal.virtual import PARAMETERS
from demcal.virtual.card_blocks import CardEngine, CardShape, CardTest, CardVerification
from demcal.virtual.material_card import (
    CARD_FORMAT,
    MaterialCard,
    parse_material_card,
    read_material_card,
)
from demcal.virtual.presets import preset_parameters

# floats whose shortest decimal is long, tiny, huge or not what was typed
AWKWARD = {"pp.static_friction": 0.1 + 0.2, "pp.rolling_friction": 1.0 / 3.0,
           "pp.surface_energy": 1.2345678901234567e-05, "wall.shear_modulus": 7.9e10 + 0.5,
           "particle.shear_modulus": 2.5e6 / 3.0, "pp.restitution": math.nextafter(0.4, 1.0)}


def _card(**kw) -> MaterialCard:
    params = {**preset_parameters("corn_stalk"), **AWKWARD}
    return MaterialCard(parameters=params, calibrated=tuple(AWKWARD), study="t",
                        engine=CardEngine(version="0.1.0", backend="cpu", rolling_model="C"),
                        test=CardTest(kind="aor", fidelity="quick",
                                      overrides={"fill": {"count": 80}, "dt_fraction": 0.15}),
                        verification=CardVerification(line="verified AoR 40.00 ± 1.00° (n = 3)",
                                                      aor_mean_deg=40.0, n=3),
                        shape=CardShape(template="stalk", length_m=0.01, n_spheres=7), **kw)


@pytest.mark.parametrize("fmt", ["toml", "json"])
def test_card_round_trips_bit_exactly(fmt, tmp_path):
    card = _card()
    toml_path, json_path = card.write(tmp_path)
    back = read_material_card(toml_path if fmt == "toml" else json_path)
    assert list(back.parameters) == list(PARAMETERS)
    for name, value in card.parameters.items():
        assert back.parameters[name].hex() == float(value).hex(), name
    assert set(back.calibrated) == set(AWKWARD)
    assert back.rolling_model == "C"
    assert back.test.fidelity == "quick"
    assert back.test.overrides == {"fill": {"count": 80}, "dt_fraction": 0.15}
    assert back.verification.line.startswith("verified AoR")
    assert back.symbols["pp.static_friction"] == "x3"
    assert back.shape == CardShape(template="stalk", length_m=0.01, n_spheres=7)


def test_card_text_names_units_laws_and_engine(tmp_path):
    text = _card().to_toml()
    assert f'format = "{CARD_FORMAT}"' in text
    assert '[parameters."particle.shear_modulus"]' in text and 'unit = "Pa"' in text
    assert 'unit = "J/m^2"' in text and 'law = "normal"' in text
    assert "JKR" in text and "rolling_model = \"C\"" in text and "EPSD" in text
    assert f"value = {AWKWARD['pp.static_friction']!r}" in text  # repr, every digit
    doc = json.loads(_card().to_json())
    assert doc["parameters"]["pp.static_friction"]["role"] == "calibrated"
    assert doc["parameters"]["particle.density"]["role"] == "fixed"
    assert doc["engine"]["contact_laws"]["tangential"].startswith("Mindlin")


def _replace(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


GOOD = _card().to_toml()


@pytest.mark.parametrize(("edit", "field"), [
    (lambda t: _replace(t, f'format = "{CARD_FORMAT}"', 'format = "edem"'), "card.format"),
    (lambda t: _replace(t, "version = 1", "version = 2"), "card.version"),
    (lambda t: _replace(t, '[parameters."pw.surface_energy"]', '[parameters."pw.glue"]'),
     "pw.glue"),
    (lambda t: t[:t.index('[parameters."pw.surface_energy"]')], "pw.surface_energy"),
    (lambda t: _replace(t, "value = 114.36", 'value = "114.36"'), "particle.density"),
    (lambda t: _replace(t, "value = 114.36", "value = true"), "particle.density"),
    (lambda t: _replace(t, "value = 0.45", "value = 1.5"), "pw.restitution"),
    (lambda t: _replace(t, 'unit = "Pa"', 'unit = "MPa"'), "particle.shear_modulus"),
    (lambda t: _replace(t, 'rolling_model = "C"', 'rolling_model = "B"'), "rolling_model"),
    (lambda t: _replace(t, 'role = "fixed"', 'role = "guessed"'), "role"),
    (lambda t: t.replace("[card]", "[card"), "not a valid material card"),
    (lambda t: t.replace("[card]", "[cart]"), "[card]"),
])
def test_bad_cards_are_one_line_input_errors(edit, field):
    with pytest.raises(InputError) as info:
        parse_material_card(edit(GOOD), "m.toml")
    msg = str(info.value)
    assert field in msg and msg.startswith("m.toml") and "\n" not in msg


def test_a_missing_card_file_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="no file"):
        read_material_card(tmp_path / "none.toml")


def test_non_finite_values_are_not_written():
    card = MaterialCard(parameters={"pp.static_friction": math.inf})
    with pytest.raises(InputError, match=r"pp\.static_friction"):
        card.to_toml()


# ------------------------------------------------------------------- simulate aor --material
@pytest.fixture
def captured(monkeypatch):
    """Replace the engine run by a recorder (the CLI's inputs are what is tested)."""
    seen: dict = {}

    def fake_run_aor(params_list, *, config, seeds, **kw):
        seen.update(params=params_list, config=config, seeds=seeds)
        class R:
            outcome, aor_deg, aor_left_deg, aor_right_deg, aor_std_deg = "column", None, \
                None, None, None
            aor_profile_deg, views_deg, n_particles, particles_lost, settled = \
                None, [], 80, 0, True
            time_step_s, sim_time_s, wall_time_s, reason, seed = 1e-5, 0.1, 0.1, "test", 0
            def __init__(self, p):
                self.params = dict(p)
                self.artefacts: dict = {}

            def to_dict(self):
                return {"params": self.params}

        return [R(p) for p in params_list]

    monkeypatch.setattr(demcal.virtual, "run_aor", fake_run_aor)
    return seen


def test_simulate_reads_the_card_exactly(captured, tmp_path):
    toml_path, json_path = _card().write(tmp_path)
    for path in (toml_path, json_path):
        out = tmp_path / "r.json"
        res = CliRunner().invoke(app, ["simulate", "aor", "--material", str(path),
                                       "--json", str(out), "--backend", "cpu"])
        assert res.exit_code == 0, res.output
        params = captured["params"][0]
        for name, value in _card().parameters.items():
            assert params[name].hex() == value.hex(), name
        cfg = captured["config"]
        assert cfg.rolling_model == "C" and cfg.fill.count == 80 and cfg.dt_fraction == 0.15
        assert cfg.geometry.cylinder_inner_diameter == 0.030  # the card's quick fidelity
        data = json.loads(out.read_text())
        assert data["params"] == params and data["material"] == str(path)


def test_a_pinned_card_runs_its_pile_and_fidelity_still_picks_another(captured, tmp_path):
    """A card written by the report repeats its fidelity's tube and fill in its overrides:
    they hold under the card's fidelity and give way to another --fidelity."""
    card = replace(_card(), test=CardTest(kind="aor", fidelity="small", overrides={
        "geometry": {"cylinder_inner_diameter": 0.035},
        "fill": {"method": "packing", "count": 300}, "dt_fraction": 0.15}))
    path, _ = card.write(tmp_path)
    res = CliRunner().invoke(app, ["simulate", "aor", "--material", str(path), "--seeds", "1"])
    assert res.exit_code == 0, res.output
    cfg = captured["config"]
    assert (cfg.fill.count, cfg.geometry.cylinder_inner_diameter) == (300, 0.035)
    res = CliRunner().invoke(app, ["simulate", "aor", "--material", str(path), "--seeds", "1",
                                   "--fidelity", "standard"])
    assert res.exit_code == 0, res.output
    cfg = captured["config"]
    assert (cfg.fill.count, cfg.geometry.cylinder_inner_diameter) == (1200, 0.056)
    assert cfg.dt_fraction == 0.15  # the study's own override stays


def test_simulate_set_and_test_override_the_card(captured, tmp_path):
    path, _ = _card().write(tmp_path)
    res = CliRunner().invoke(app, ["simulate", "aor", "--material", str(path), "--set",
                                   "pp.static_friction=0.5", "--test", "fill.count=90",
                                   "--fidelity", "paper"])
    assert res.exit_code == 0, res.output
    assert captured["params"][0]["pp.static_friction"] == 0.5
    assert captured["params"][0]["pp.rolling_friction"] == AWKWARD["pp.rolling_friction"]
    assert captured["config"].fill.count == 90 and captured["config"].dt_fraction == 0.15


@pytest.mark.parametrize(("args", "field"), [
    (["--material", "{bad}"], "card.format"),
    (["--material", "{bad}", "--preset", "corn_stalk"], "--preset"),
    (["--material", "/no/such/card.toml"], "no file"),
])
def test_simulate_refuses_bad_cards(captured, tmp_path, args, field):
    bad = tmp_path / "bad.toml"
    bad.write_text(GOOD.replace(f'format = "{CARD_FORMAT}"', 'format = "x"'))
    args = [a.replace("{bad}", str(bad)) for a in args]
    res = CliRunner().invoke(app, ["simulate", "aor", *args])
    assert res.exit_code == 2, res.output
    assert field in res.output and "Traceback" not in res.output
    assert not captured  # nothing ran


def test_simulate_refuses_a_card_from_an_external_engine(captured, tmp_path):
    """A template engine's values mean that engine's laws: demcal does not run them."""
    card = replace(_card(), engine=CardEngine(name="template", command="liggghts -in in.aor",
                                              template="in.aor.template", template_sha256="0" * 64))
    toml_path, _ = card.write(tmp_path)
    assert read_material_card(toml_path).is_external
    res = CliRunner().invoke(app, ["simulate", "aor", "--material", str(toml_path)])
    assert res.exit_code == 2, res.output
    assert "external engine (liggghts -in in.aor)" in res.output
    assert "Traceback" not in res.output and not captured  # nothing ran


def test_a_card_names_only_known_engines(tmp_path):
    lammps = CardEngine(name="lammps", rolling_model="C")
    toml_path, _ = replace(_card(), engine=lammps).write(tmp_path)
    assert read_material_card(toml_path).engine_name == "lammps"
    text = toml_path.read_text().replace('name = "lammps"', 'name = "edem"')
    with pytest.raises(InputError, match=r"engine\.name must be one of demcal, lammps, template"):
        parse_material_card(text)


@pytest.mark.slow
def test_simulate_material_on_the_engine_runs_the_card_exactly(tmp_path):
    """The real engine (tiny fill): the run's parameters are the card's, bit for bit."""
    card = MaterialCard(parameters={**preset_parameters("corn_stalk"), **AWKWARD,
                                    "pp.surface_energy": 0.0},
                        test=CardTest(kind="aor", fidelity="quick",
                                      overrides={"fill": {"count": 80},
                                                 "phases": {"pile_settle_max_time": 1.0}}))
    path, _ = card.write(tmp_path)
    out = tmp_path / "r.json"
    res = CliRunner().invoke(app, ["simulate", "aor", "--material", str(path), "--json",
                                   str(out), "--backend", "cpu"])
    assert res.exit_code == 0, res.output
    data = json.loads(out.read_text())
    assert data["n_particles"] == 80
    assert {k: float(v).hex() for k, v in data["params"].items()} == \
        {k: v.hex() for k, v in card.parameters.items()}


@pytest.mark.parametrize("module", ["demcal.virtual.material_card", "demcal.report.material",
                                    "demcal.report.diagnostics",
                                    "demcal.report.model_figures"])
def test_docstrings(module):
    import doctest
    import importlib

    mod = importlib.import_module(module)
    assert doctest.testmod(mod).failed == 0
    assert mod.__doc__
    for name in mod.__all__:
        obj = getattr(mod, name)
        if callable(obj):
            assert obj.__doc__ and len(obj.__doc__) > 30, f"{module}.{name}"


@pytest.mark.parametrize("name", ["material_bayes_standard.toml", "material_lammps_small.toml",
                                  "material_lammps_low_cohesion.toml",
                                  "material_lammps_low_cohesion_standard.toml"])
def test_a_committed_card_reads_and_writes_back_byte_for_byte(name):
    # every block is typed (CardEngine, CardTest, CardVerification, CardPosterior, ...): their
    # keys and order are the card format, so a renamed or reordered field fails here
    path = Path(__file__).parents[2] / "examples" / "corn_stalk" / name
    card = read_material_card(path)
    assert card.to_toml() == path.read_text(encoding="utf-8")
    assert list(card.engine.to_table())[:2] == ["name", "version"]
    assert card.test.fidelity_name == card.test.fidelity


@pytest.mark.parametrize(("line", "edit", "message"), [
    (r'backend = "cpu"', 'backend = "cpu"\ndt_fraction = "fast"',
     r"engine\.dt_fraction must be a number; got 'fast'"),
    (r'version = "0.1.0"', "version = 3", r"engine\.version must be a string; got 3"),
    (r'rolling_model = "C"', 'rolling_model = "B"',
     r"engine\.rolling_model must be one of A, C, none"),
    (r'fidelity = "quick"', "fidelity = 1", r"test\.fidelity must be a string; got 1"),
    (r"n_spheres = 7", "n_spheres = 7.5",
     r"particle_shape\.n_spheres must be a whole number; got 7\.5"),
    (r"length_m = 0.01", 'length_m = "1 cm"',
     r"particle_shape\.length_m must be a number; got '1 cm'"),
    (r"\[test.overrides\]", '[test.overrides]\n"fill" = 1',
     r"'fill\.count' sets a key of 'fill', which is a value"),
    (r"(?m)^n = 3$", 'n = "three"', r"verification\.n must be a whole number; got 'three'"),
    (r"aor_mean_deg = 40.0", 'aor_mean_deg = "40"',
     r"verification\.aor_mean_deg must be a number; got '40'"),
])
def test_a_bad_engine_or_test_block_is_one_line_naming_the_key(line, edit, message):
    text = _card().to_toml()
    assert re.search(line, text), line
    text = re.sub(line, lambda _: edit, text, count=1)
    with pytest.raises(InputError, match=message):
        parse_material_card(text, "m.toml")


@pytest.mark.parametrize(("line", "edit", "message"), [
    ("identifiable = false", 'identifiable = "no"',
     r"posterior\.identifiable must be true or false; got 'no'"),
    ("ridge = [", "ridge = [1, ", r"posterior\.ridge must be a list of strings"),
    ("median = 0.5218556771970133", 'median = "0.52"',
     r"posterior\.parameters\.pp\.static_friction\.median must be a number"),
    ('"pp.rolling_friction" = -0.6483126566400635', '"pp.rolling_friction" = true',
     r"posterior\.correlation\.pp\.static_friction\.pp\.rolling_friction must be a number"),
])
def test_a_bad_posterior_is_one_line_naming_the_key(line, edit, message):
    path = Path(__file__).parents[2] / "examples" / "corn_stalk" / "material_bayes_standard.toml"
    text = path.read_text(encoding="utf-8")
    assert line in text, line
    with pytest.raises(InputError, match=message):
        parse_material_card(text.replace(line, edit, 1), "m.toml")


def test_the_card_names_a_law_for_every_rolling_model_of_the_engine():
    from demcal.virtual.config import ROLLING_MODELS
    from demcal.virtual.material_card import ROLLING_LAWS

    assert tuple(ROLLING_LAWS) == ROLLING_MODELS == ("A", "C", "none")
