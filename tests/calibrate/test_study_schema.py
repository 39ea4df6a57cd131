"""Study schema: every error names the field and the allowed values; `demcal init` is valid."""

from __future__ import annotations

import copy
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from demcal.calibrate import EXAMPLE_STUDY, load_study, parse_study
from demcal.cli import app
from demcal.errors import InputError
from demcal.virtual.config import FIDELITIES, FIDELITY_REPLICATES


def _bad(data: dict, *parts: str) -> None:
    with pytest.raises(InputError) as exc:
        parse_study(data)
    for p in parts:
        assert p in str(exc.value), str(exc.value)


def test_example_parses(example_data):
    s = parse_study(example_data)
    assert s.test.kind == "analytic"
    assert [f.symbol for f in s.factors] == ["x2", "x3", "x4", "x6", "x8"]
    assert s.factor("x8").name == "pp.surface_energy"


def test_unknown_factor_name(example_data):
    d = copy.deepcopy(example_data)
    d["factors"][0]["name"] = "pp.friction"
    _bad(d, "factors.0.name", "pp.static_friction", "pp.friction")


def test_low_not_below_high(example_data):
    d = copy.deepcopy(example_data)
    d["factors"][1]["low"] = 2.0
    _bad(d, "factors.1", "low must be < high")


def test_out_of_parameter_range(example_data):
    d = copy.deepcopy(example_data)
    d["factors"][0]["high"] = 1.5  # restitution must be <= 1
    _bad(d, "factors.0", "pp.restitution must be in")


def test_rsm_design_choices(example_data):
    d = copy.deepcopy(example_data)
    d["stages"]["rsm"]["design"] = "doehlert"
    _bad(d, "stages.rsm.design", "'bbd'", "'ccd'")


def test_target_needs_one_source(example_data):
    d = copy.deepcopy(example_data)
    d["target"] = {"std_deg": 1.0}
    _bad(d, "target", "aor_deg, photos or measurements")


def test_unknown_key_and_bad_reference(example_data):
    d = copy.deepcopy(example_data)
    d["stages"]["screening"]["alpah"] = 0.1
    _bad(d, "stages.screening.alpah", "Extra inputs")
    d = copy.deepcopy(example_data)
    d["stages"]["rangefind"]["factors"] = ["x9"]
    _bad(d, "stages.rangefind.factors", "'x9'", "x8")


def test_bad_aor_test_override(example_data):
    d = copy.deepcopy(example_data)
    d["test"] = {"kind": "aor", "fidelity": "quick", "overrides": {"fill": {"count": -3}}}
    _bad(d, "test", "fill.count")


@pytest.mark.parametrize("fidelity", sorted(FIDELITIES))
def test_every_fidelity_is_a_study_fidelity_with_its_replicates(example_data, fidelity):
    d = copy.deepcopy(example_data)
    d["test"] = {"kind": "aor", "fidelity": fidelity}
    d.pop("replicates", None)  # the default follows the fidelity
    assert parse_study(d).replicates == FIDELITY_REPLICATES[fidelity]


def test_an_unknown_fidelity_is_refused_naming_the_field(example_data):
    d = copy.deepcopy(example_data)
    d["test"] = {"kind": "aor", "fidelity": "medium"}
    _bad(d, "test.fidelity", "'small'", "'standard'")


def test_init_writes_a_valid_study(tmp_path):
    out = tmp_path / "s.toml"
    res = CliRunner().invoke(app, ["init", str(out)])
    assert res.exit_code == 0, res.output
    assert out.read_text() == EXAMPLE_STUDY
    s = load_study(out)
    assert s.test.kind == "aor" and s.stages.rsm.design == "bbd"
    res = CliRunner().invoke(app, ["init", str(out)])
    assert res.exit_code == 2 and "--force" in res.output


def test_cli_reports_schema_error_in_one_line(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text(EXAMPLE_STUDY.replace('design = "bbd"', 'design = "xyz"'))
    res = CliRunner().invoke(app, ["calibrate", str(p)])
    assert res.exit_code == 2
    assert "stages.rsm.design" in res.output
    assert "Traceback" not in res.output


@pytest.mark.parametrize(("line", "field"), [('model = "cubic"', "stages.rsm.model"),
                                             ("alpha_out = 1.5", "stages.rsm.alpha_out")])
def test_cli_names_a_bad_rsm_model_option(tmp_path, line, field):
    p = tmp_path / "s.toml"
    key = line.split(" = ")[0]
    text = re.sub(rf"^{key} = .*$", line, EXAMPLE_STUDY, count=1, flags=re.MULTILINE)
    assert line in text
    p.write_text(text)
    res = CliRunner().invoke(app, ["calibrate", str(p)])
    assert res.exit_code == 2 and field in res.output and "Traceback" not in res.output


def test_the_result_json_leaves_out_a_disabled_steepest_stage():
    """With stages.steepest.enabled = false the stage holds only the RSM's levels (no path)."""
    from types import SimpleNamespace

    from demcal.calibrate.context import StageResults
    from demcal.calibrate.pipeline import _stage_json
    from demcal.summaries import Steepest

    ctx = SimpleNamespace(results=StageResults(steepest=Steepest(levels={
        "pp.static_friction": [0.3, 0.6, 0.9]})))
    assert "steepest" not in _stage_json(ctx)  # type: ignore[arg-type]


@pytest.mark.parametrize(("line", "message"), [
    ("seed = true", "seed"),
    ('name = "' + "x" * 300 + '"', "name"),
])
def test_a_boolean_seed_and_a_huge_name_are_refused(tmp_path, line, message):
    from demcal.calibrate.study import load_study

    text = (Path(__file__).resolve().parents[2] / "examples" / "analytic" / "study.toml"
            ).read_text()
    key = line.split(" = ")[0]
    text = "\n".join(ln for ln in text.splitlines() if not ln.startswith(f"{key} = "))
    (tmp_path / "study.toml").write_text(line + "\n" + text)
    with pytest.raises(InputError, match=message):
        load_study(tmp_path / "study.toml")
