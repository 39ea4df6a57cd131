"""A calibration aiming at several responses lands on the planted parameters.

The stand-in test plants three responses over three factors, each linear with its own
gradient, so the three lab values fix one point that no single response fixes: the angle alone
leaves a plane of settings that all hit it. Straight to the response surface (range finding,
screening and the steepest path disabled), the desirability optimum must land on the planted
point, and the verification must judge every response against its lab value.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from demcal.calibrate import calibrate
from demcal.cli import app
from demcal.execute.analytic import AnalyticOptions, true_aor, true_responses
from demcal.store import RunStore

FACTORS = {  # name: (symbol, low, high)
    "pp.static_friction": ("x3", 0.2, 1.0),
    "pp.rolling_friction": ("x4", 0.0, 0.4),
    "pw.static_friction": ("x6", 0.3, 0.8),
}
PLANTED = {"pp.static_friction": 0.7, "pp.rolling_friction": 0.15, "pw.static_friction": 0.65}
CENTRE = {"pp.static_friction": 0.6, "pp.rolling_friction": 0.2, "pw.static_friction": 0.55}
ANALYTIC = {
    "base_deg": 30.0, "centre": CENTRE, "noise_deg": 0.2,
    "linear": {"pp.static_friction": 15.0, "pp.rolling_friction": 25.0,
               "pw.static_friction": 2.0},
    "responses": {
        "drum_deg": {"base": 35.0, "noise": 0.2,
                     "linear": {"pp.static_friction": 5.0, "pp.rolling_friction": 60.0,
                                "pw.static_friction": 1.0}},
        "bulk_density_kg_m3": {"base": 200.0, "noise": 0.5,
                               "linear": {"pp.static_friction": -10.0,
                                          "pp.rolling_friction": 20.0,
                                          "pw.static_friction": 80.0}},
    },
}


def _toml_value(v) -> str:
    if isinstance(v, dict):
        return "{ " + ", ".join(f'"{k}" = {_toml_value(x)}' for k, x in v.items()) + " }"
    return repr(v)


def write_study(folder: Path, *, responses: bool = True, aor_only_extra: str = "") -> Path:
    opts = AnalyticOptions(**ANALYTIC)
    truth = true_responses(PLANTED, opts)
    lines = ['name = "three responses"', "seed = 3", "replicates = 1", "",
             "[material]", 'preset = "corn_stalk"', "",
             "[target]", f"aor_deg = {true_aor(PLANTED, opts)!r}", "std_deg = 0.5", "n = 5", ""]
    for name, (sym, lo, hi) in FACTORS.items():
        lines += ["[[factors]]", f'name = "{name}"', f'symbol = "{sym}"', f"low = {lo}",
                  f"high = {hi}", ""]
    if responses:
        for name, value in truth.items():
            lines += ["[[responses]]", f'name = "{name}"', f"target = {value!r}",
                      "std = 0.5", "n = 5", ""]
    lines += ["[test]", 'kind = "analytic"', "", "[test.analytic]"]
    lines += [f"{k} = {_toml_value(v)}" for k, v in ANALYTIC.items()]
    lines += ["", "[stages.rangefind]", "enabled = false", "",
              "[stages.screening]", "enabled = false", "",
              "[stages.steepest]", "enabled = false", "",
              "[stages.rsm]", 'design = "bbd"', "center_points = 3", "",
              "[stages.optimize]", "n_starts = 12", "",
              "[stages.verification]", "n = 4", "", "[executor]", "workers = 1", ""]
    path = folder / "study.toml"
    path.write_text("\n".join(lines) + aor_only_extra)
    return path


def _coded_error(optimum: dict[str, float]) -> dict[str, float]:
    return {n: abs(optimum[n] - PLANTED[n]) / (hi - lo) for n, (_s, lo, hi) in FACTORS.items()}


def test_three_responses_land_on_the_planted_parameters(tmp_path: Path) -> None:
    res = calibrate(write_study(tmp_path), workers=1)
    err = _coded_error(res["optimum"])
    assert max(err.values()) < 0.03, (res["optimum"], err)
    several = res["responses"]
    assert [g["name"] for g in several["goals"]] == ["aor_deg", "drum_deg",
                                                     "bulk_density_kg_m3"]
    assert several["desirability"] > 0.95
    for name in ("drum_deg", "bulk_density_kg_m3"):
        check = several["verification"][name]
        assert check["n"] == 4 and check["consistent"] is True, check
        assert check["relative_error_percent"] < 2.0
    assert res["n_runs_executed"] == 15 + 4  # the response surface and the verification
    # resumed: nothing runs again and the optimum stands
    again = calibrate(tmp_path / "study.toml", workers=1)
    assert again["n_runs_executed"] == 0 and again["optimum"] == res["optimum"]
    # the report builds from the store and has a section per response
    out = CliRunner().invoke(app, ["report", str(tmp_path)])
    assert out.exit_code == 0, out.output
    html = (tmp_path / "report" / "report.html").read_text()
    assert "drum_deg" in html and "bulk_density_kg_m3" in html
    assert "could not be drawn" not in html
    doc = json.loads((tmp_path / "report" / "report.json").read_text())
    assert doc["problems"] == []
    assert len([f for f in doc["figures"] if "overlay_" in f]) == 3  # each factor pair
    # the material card lists every response verified, and reads back
    from demcal.virtual.material_card import read_material_card

    card = read_material_card(tmp_path / "report" / "material.toml")
    drum = card.verification.responses["drum_deg"]
    assert drum.mean == several["verification"]["drum_deg"]["mean"] and drum.n == 4
    assert set(card.verification.responses) == {"aor_deg", "drum_deg",
                                                   "bulk_density_kg_m3"}
    assert doc["tables"]["responses_verified"]["columns"][:3] == ["response", "lab",
                                                                  "predicted"]
    # every other response's own ANOVA and adequacy (the angle's: the surface section's)
    for name in ("drum_deg", "bulk_density_kg_m3"):
        anova = doc["tables"][f"responses_anova_{name}"]
        assert anova["rows"][0][0] == "Model" and "Design-Expert's rules" in anova["note"]
    assert "responses_anova_aor_deg" not in doc["tables"]


def test_the_angle_alone_does_not_fix_the_point(tmp_path: Path) -> None:
    """The same study with the angle alone hits the angle but not the planted point: the
    other two responses are what pins it."""
    res = calibrate(write_study(tmp_path, responses=False), workers=1)
    assert "responses" not in res
    assert abs(res["verification"]["aor_mean_deg"] - res["target_aor_deg"]) < 1.0
    assert max(_coded_error(res["optimum"]).values()) > 0.05


def test_result_json_names_every_response(tmp_path: Path) -> None:
    study = write_study(tmp_path)
    out = CliRunner().invoke(app, ["calibrate", str(study), "--json", str(tmp_path / "r.json"),
                                   "--workers", "1"])
    assert out.exit_code == 0, out.output
    assert "drum_deg: lab 32.6" in out.output and "consistent with the lab" in out.output
    assert "overall desirability at the optimum" in out.output
    doc = json.loads((tmp_path / "r.json").read_text())
    assert set(doc["responses"]["predicted"]) == {"aor_deg", "drum_deg", "bulk_density_kg_m3"}
    assert np.isfinite(doc["responses"]["verification"]["drum_deg"]["mean"])
    with RunStore(study.parent) as store:  # the keys the desirability optimum always stored
        opt = store.stage("optimize").summary
        rsm = store.stage("rsm").summary
    # ... and the response surface: every other response's model after the replicates
    assert list(rsm)[:6] == ["design", "factors", "runs", "excluded_points", "replicates",
                             "responses"]
    assert list(rsm["responses"]["drum_deg"]) == [
        "model", "adequate", "adequacy", "warnings", "excluded_points", "anova",
        "coefficients_coded", "equation_actual"]
    assert list(opt) == ["target_aor_deg", "candidates", "chosen", "predicted_aor_deg",
                         "classifier", "opts", "responses"]
    assert list(opt["candidates"][0]) == ["params", "predicted_aor_deg", "pi_low_deg",
                                          "pi_high_deg", "p_pile", "desirability", "predicted",
                                          "individual"]
    assert list(opt["responses"]) == ["goals", "desirability", "reachable", "unmet"]
    assert doc["responses"]["goals"] == opt["responses"]["goals"]


@pytest.mark.parametrize(("extra", "message"), [
    ('\n[[responses]]\nname = "hopper_rate"\ntarget = 1.0\n', "'hopper_rate' is not reported"),
    ('\n[[responses]]\nname = "drum_deg"\ntarget = 1.0\nlow = 5.0\nhigh = 2.0\n',
     "low must be < high"),
    ('\n[[responses]]\nname = "x"\ntarget = 1.0\nimportance = 9\n', "importance"),
    ('\n[[responses]]\nname = "aor_deg"\ntarget = 40.0\n', "both give the angle"),
    ('\n[[responses]]\nname = "pile_formed"\ntarget = 1.0\n', "pile indicator"),
])
def test_bad_responses_get_one_line_and_exit_2(tmp_path: Path, extra: str, message: str
                                                ) -> None:
    study = write_study(tmp_path, responses=False, aor_only_extra="")
    text = study.read_text().replace("[test]\n", extra.lstrip("\n") + "\n[test]\n", 1)
    study.write_text(text)
    out = CliRunner().invoke(app, ["calibrate", str(study)])
    assert out.exit_code == 2, out.output
    assert message in out.output and "Traceback" not in out.output
    assert len(out.output.strip().splitlines()) <= 3


ENGINE = '''"""A three-response stand-in engine: reads key = value lines, writes result.json."""
import json, random, sys
p = {}
for line in open(sys.argv[1]):
    k, _, v = line.partition("=")
    if v.strip():
        p[k.strip()] = float(v)
rng = random.Random(int(p["seed"]))
d3, d4, d6 = p["mu"] - 0.6, p["mur"] - 0.2, p["muw"] - 0.55
json.dump({"aor_deg": 30 + 15 * d3 + 25 * d4 + 2 * d6 + 0.2 * rng.gauss(0, 1),
           "drum_deg": 35 + 5 * d3 + 60 * d4 + d6 + 0.2 * rng.gauss(0, 1),
           "bulk_density_kg_m3": 200 - 10 * d3 + 20 * d4 + 80 * d6 + 0.5 * rng.gauss(0, 1)},
          open("result.json", "w"))
'''


def test_a_template_engine_with_three_responses_lands_on_its_planted_point(tmp_path: Path
                                                                           ) -> None:
    """The issue's own check: an external engine reports three numbers (its JSON's keys
    become responses), three factors, straight to the response surface."""
    (tmp_path / "engine.py").write_text(ENGINE)
    (tmp_path / "input.txt.template").write_text(
        "seed = {seed}\nmu = {pp.static_friction}\nmur = {pp.rolling_friction}\n"
        "muw = {pw.static_friction}\n")
    d3, d4, d6 = (PLANTED[n] - CENTRE[n] for n in FACTORS)
    truth = {"aor_deg": 30 + 15 * d3 + 25 * d4 + 2 * d6,
             "drum_deg": 35 + 5 * d3 + 60 * d4 + d6,
             "bulk_density_kg_m3": 200 - 10 * d3 + 20 * d4 + 80 * d6}
    study = write_study(tmp_path, responses=False)
    text = study.read_text()
    text = text[:text.index("[test]")]  # the engine replaces the stand-in test
    text = text.replace(f"aor_deg = {true_aor(PLANTED, AnalyticOptions(**ANALYTIC))!r}",
                        f"aor_deg = {truth['aor_deg']!r}")
    for name in ("drum_deg", "bulk_density_kg_m3"):
        text += (f'[[responses]]\nname = "{name}"\ntarget = {truth[name]!r}\nstd = 0.5\n'
                 "n = 5\n\n")
    text += ('[engine]\nkind = "template"\ntemplate = "input.txt.template"\n'
             'command = ["{python}", "{template_dir}/engine.py", "{input}"]\ntimeout_s = 60\n'
             '\n[engine.result]\nkind = "value"\nfile = "result.json"\n\n'
             "[stages.rangefind]\nenabled = false\n\n[stages.screening]\nenabled = false\n\n"
             '[stages.steepest]\nenabled = false\n\n[stages.rsm]\ndesign = "bbd"\n'
             "center_points = 3\n\n[stages.verification]\nn = 4\n\n[executor]\nworkers = 1\n")
    study.write_text(text)
    res = calibrate(study, workers=1)
    err = _coded_error(res["optimum"])
    assert max(err.values()) < 0.03, (res["optimum"], err)
    for name in ("drum_deg", "bulk_density_kg_m3"):
        assert res["responses"]["verification"][name]["consistent"] is True


def test_dropping_the_other_responses_finds_the_angle_s_own_optimum(tmp_path: Path) -> None:
    """A study resumed with its [[responses]] removed does not keep the several-response
    optimum (it hits the angle too, but it is another problem's answer)."""
    study = write_study(tmp_path)
    several = calibrate(study, workers=1)
    text = study.read_text()
    study.write_text(text[:text.index("[[responses]]")] + text[text.index("[test]"):])
    alone = calibrate(study, workers=1)
    assert "responses" not in alone
    assert alone["optimum"] != several["optimum"]
    assert alone["n_runs_executed"] == 4  # the response surface's runs are kept
    out = CliRunner().invoke(app, ["report", str(tmp_path)])
    assert out.exit_code == 0 and "could not be drawn" not in out.output, out.output
