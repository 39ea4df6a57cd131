"""A study that leads with another response than the angle (issue 37: nothing in the stages
names one response). Without ``[target]`` the first ``[[responses]]`` table leads: range
finding, screening, the path, the surface and the verification follow it, the result names it
(``lead``), and the report and the material card say it."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from demcal.calibrate import calibrate
from demcal.cli import app
from demcal.execute.analytic import AnalyticOptions, true_responses

FACTORS = {"pp.static_friction": ("x3", 0.2, 1.0), "pp.rolling_friction": ("x4", 0.0, 0.4),
           "pw.static_friction": ("x6", 0.3, 0.8)}
PLANTED = {"pp.static_friction": 0.7, "pp.rolling_friction": 0.15, "pw.static_friction": 0.65}
CENTRE = {"pp.static_friction": 0.6, "pp.rolling_friction": 0.2, "pw.static_friction": 0.55}
#: three responses with independent gradients (the angle is reported, but not aimed at)
RESPONSES = {
    "drum_deg": {"base": 35.0, "noise": 0.2, "linear": {
        "pp.static_friction": 5.0, "pp.rolling_friction": 60.0, "pw.static_friction": 1.0}},
    "bulk_density_kg_m3": {"base": 200.0, "noise": 0.5, "linear": {
        "pp.static_friction": -10.0, "pp.rolling_friction": 20.0, "pw.static_friction": 80.0}},
    "shear_kpa": {"base": 4.0, "noise": 0.02, "linear": {
        "pp.static_friction": 6.0, "pp.rolling_friction": -2.0, "pw.static_friction": 0.5}},
}
ANALYTIC = {"base_deg": 30.0, "centre": CENTRE, "noise_deg": 0.2,
            "linear": {"pp.static_friction": 15.0, "pp.rolling_friction": 25.0},
            "responses": RESPONSES}
UNITS = {"drum_deg": "deg", "bulk_density_kg_m3": "kg/m^3", "shear_kpa": "kPa"}


def _value(v) -> str:
    if isinstance(v, dict):
        return "{ " + ", ".join(f'"{k}" = {_value(x)}' for k, x in v.items()) + " }"
    return repr(v)


def _study(folder: Path, *, path: bool = False, lead_goal: str = "target") -> Path:
    truth = true_responses(PLANTED, AnalyticOptions(**ANALYTIC))
    lines = ['name = "the drum leads"', "seed = 4", "replicates = 1", "",
             "[material]", 'preset = "corn_stalk"', ""]
    for name, (sym, lo, hi) in FACTORS.items():
        lines += ["[[factors]]", f'name = "{name}"', f'symbol = "{sym}"', f"low = {lo}",
                  f"high = {hi}", ""]
    for i, (name, value) in enumerate(truth.items()):
        goal = lead_goal if i == 0 else "target"
        lines += ["[[responses]]", f'name = "{name}"', f'unit = "{UNITS[name]}"',
                  f'goal = "{goal}"', *([f"target = {value!r}", "std = 0.5", "n = 5"]
                                        if goal == "target" else []), ""]
    lines += ["[test]", 'kind = "analytic"', "", "[test.analytic]"]
    lines += [f"{k} = {_value(v)}" for k, v in ANALYTIC.items()]
    if path:  # the paper's path: a scan, screening and the steepest path before the surface
        lines += ["", "[stages.rangefind]", 'factors = ["x4"]', "points = 5", "",
                  "[stages.screening]", "runs = 8", "min_factors = 3", "",
                  "[stages.steepest]", "steps = 5"]
    else:
        lines += ["", "[stages.rangefind]", "enabled = false", "",
                  "[stages.screening]", "enabled = false", "",
                  "[stages.steepest]", "enabled = false"]
    lines += ["", "[stages.rsm]", 'design = "bbd"', "center_points = 3", "",
              "[stages.optimize]", "n_starts = 12", "", "[stages.verification]", "n = 4", "",
              "[executor]", "workers = 1", ""]
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "study.toml").write_text("\n".join(lines))
    return folder / "study.toml"


def test_the_drum_leads_and_three_responses_land_on_the_planted_point(tmp_path: Path) -> None:
    res = calibrate(_study(tmp_path), workers=1)
    err = {n: abs(res["optimum"][n] - PLANTED[n]) / (hi - lo)
           for n, (_s, lo, hi) in FACTORS.items()}
    assert max(err.values()) < 0.03, (res["optimum"], err)
    truth = true_responses(PLANTED, AnalyticOptions(**ANALYTIC))
    # the keys named for the angle hold the lead's values, and the result says which
    assert res["lead"] == {"name": "drum_deg", "unit": "deg"}
    assert res["target_aor_deg"] == pytest.approx(truth["drum_deg"])
    assert abs(res["verification"]["aor_mean_deg"] - truth["drum_deg"]) < 1.0
    assert [g["name"] for g in res["responses"]["goals"]] == list(RESPONSES)
    assert set(res["responses"]["verification"]) == {"bulk_density_kg_m3", "shear_kpa"}
    # the report and the material card name the lead, with no figure lost
    out = CliRunner().invoke(app, ["report", str(tmp_path)])
    assert out.exit_code == 0, out.output
    doc = json.loads((tmp_path / "report" / "report.json").read_text())
    assert doc["problems"] == []
    html = (tmp_path / "report" / "report.html").read_text()
    assert "This study leads with <b>drum_deg</b>" in html and "Measured drum_deg" in html
    # every stage table, figure and section names the drum where a study of the angle says AoR
    for key, table in doc["tables"].items():
        words = json.dumps([table["title"], table["columns"], table["note"]])
        assert "AoR" not in words and "°" not in words, (key, words)
    page = re.sub(r"data:image/png;base64,[A-Za-z0-9+/=]+", "", html)
    rsm = page[page.index('<section id="rsm">'):page.index("</section>",
                                                           page.index('<section id="rsm">'))]
    assert "AoR" not in rsm and "drum_deg over x3 and x4" in rsm, rsm[:500]
    card = (tmp_path / "report" / "material.toml").read_text()
    assert 'line = "verified drum_deg ' in card and 'lead = "drum_deg"' in card


def test_the_paper_s_path_follows_the_lead(tmp_path: Path) -> None:
    res = calibrate(_study(tmp_path, path=True), workers=1)
    scan = res["stages"]["rangefind"]["message"]
    assert " deg lies " in scan and "the AoR" not in scan, scan
    assert res["stages"]["steepest"]["followed"][0] == "drum_deg"
    assert res["verification"]["consistent"] is True, res["verification"]


def test_a_study_the_angle_leads_names_no_lead(tmp_path: Path) -> None:
    path = _study(tmp_path)
    path.write_text(path.read_text().replace(
        "[[factors]]", "[target]\naor_deg = 31.0\nstd_deg = 0.5\nn = 5\n\n[[factors]]", 1))
    res = calibrate(path, workers=1)
    assert "lead" not in res and res["target_aor_deg"] == 31.0


@pytest.mark.parametrize(("edit", "words"), [
    ({"lead_goal": "maximize"}, "'drum_deg' leads the study"),
    (None, "give [target]"),
])
def test_a_lead_without_a_target_is_one_line_and_exit_2(tmp_path: Path, edit, words) -> None:
    path = _study(tmp_path, **(edit or {}))
    if edit is None:  # no [target] and no [[responses]]
        path.write_text(re.sub(r"\[\[responses\]\]\n(?:[^\n]+\n)*\n", "", path.read_text()))
    out = CliRunner().invoke(app, ["calibrate", str(path), "--no-report"])
    assert out.exit_code == 2, out.output
    text = " ".join(out.output.split())
    assert words in text and "Traceback" not in text, text


ENGINE = '''"""A stand-in engine of another test: reads key = value lines, writes three
responses (no angle) to result.json."""
import json, random, sys
p = {}
for line in open(sys.argv[1]):
    k, _, v = line.partition("=")
    if v.strip():
        p[k.strip()] = float(v)
rng = random.Random(int(p["seed"]))
d3, d4, d6 = p["mu"] - 0.6, p["mur"] - 0.2, p["muw"] - 0.55
json.dump({"shear_kpa": 4 + 6 * d3 - 2 * d4 + 0.5 * d6 + 0.02 * rng.gauss(0, 1),
           "drum_deg": 35 + 5 * d3 + 60 * d4 + d6 + 0.2 * rng.gauss(0, 1),
           "bulk_density_kg_m3": 200 - 10 * d3 + 20 * d4 + 80 * d6 + 0.5 * rng.gauss(0, 1)},
          open("result.json", "w"))
'''


def test_the_user_s_own_engine_leads_with_its_own_response(tmp_path: Path) -> None:
    """An external engine that measures no angle at all: its JSON's lead (shear_kpa, the
    result's key by default) and two more responses pin the planted point."""
    (tmp_path / "engine.py").write_text(ENGINE)
    (tmp_path / "input.txt.template").write_text(
        "seed = {seed}\nmu = {pp.static_friction}\nmur = {pp.rolling_friction}\n"
        "muw = {pw.static_friction}\n")
    d3, d4, d6 = (PLANTED[n] - CENTRE[n] for n in FACTORS)
    truth = {"shear_kpa": 4 + 6 * d3 - 2 * d4 + 0.5 * d6,
             "drum_deg": 35 + 5 * d3 + 60 * d4 + d6,
             "bulk_density_kg_m3": 200 - 10 * d3 + 20 * d4 + 80 * d6}
    text = _study(tmp_path).read_text()
    text = text[:text.index("[[responses]]")]
    for name, value in truth.items():
        text += (f'[[responses]]\nname = "{name}"\nunit = "{UNITS[name]}"\n'
                 f"target = {value!r}\nstd = 0.05\nn = 5\n\n")
    text += ('[engine]\nkind = "template"\ntemplate = "input.txt.template"\n'
             'command = ["{python}", "{template_dir}/engine.py", "{input}"]\ntimeout_s = 60\n'
             '\n[engine.result]\nkind = "value"\nfile = "result.json"\n\n'
             "[stages.rangefind]\nenabled = false\n\n[stages.screening]\nenabled = false\n\n"
             '[stages.steepest]\nenabled = false\n\n[stages.rsm]\ndesign = "bbd"\n'
             "center_points = 3\n\n[stages.verification]\nn = 4\n\n[executor]\nworkers = 1\n")
    (tmp_path / "study.toml").write_text(text)
    res = calibrate(tmp_path / "study.toml", workers=1)
    assert res["lead"] == {"name": "shear_kpa", "unit": "kPa"}
    err = {n: abs(res["optimum"][n] - PLANTED[n]) / (hi - lo)
           for n, (_s, lo, hi) in FACTORS.items()}
    assert max(err.values()) < 0.03, (res["optimum"], err)
    assert abs(res["verification"]["aor_mean_deg"] - truth["shear_kpa"]) < 0.05
    # no run measured an angle, and none is excluded for it
    out = CliRunner().invoke(app, ["report", str(tmp_path)])
    assert out.exit_code == 0, out.output
    doc = json.loads((tmp_path / "report" / "report.json").read_text())
    assert doc["problems"] == [] and doc["tables"]["excluded_runs"]["rows"] == []
    # a pile demcal measures gives the angle only: refused for this lead, in one line
    (tmp_path / "study.toml").write_text(text.replace(
        'kind = "value"\nfile = "result.json"', 'kind = "positions"\nfile = "pile.csv"'))
    out = CliRunner().invoke(app, ["calibrate", str(tmp_path / "study.toml"), "--no-report"])
    assert out.exit_code == 2 and "needs kind 'value'" in " ".join(out.output.split()), \
        out.output


def test_run_sheets_carry_every_response_and_reach_the_same_result(tmp_path: Path) -> None:
    """External mode for a study of three responses led by the drum: each run sheet has a
    column per response (the lead first), the runs done 'outside' (the stand-in) are
    imported, and the study ends where it ends run inside demcal."""
    import pandas as pd
    from test_external import run_externally

    from demcal.execute.analytic import analytic_aor
    from demcal.virtual import PARAMETERS

    inside = calibrate(_study(tmp_path / "inside"), workers=1)
    path = _study(tmp_path / "outside")
    options = AnalyticOptions(**ANALYTIC)
    names = list(RESPONSES)

    def fill(sheet: Path) -> None:  # the runs 'outside': the stand-in's every response
        frame = pd.read_csv(sheet)
        assert [c for c in frame.columns if c in names or c == "outcome"] == [*names, "outcome"]
        runs = [analytic_aor({n: float(row[n]) for n in PARAMETERS if n in frame.columns},
                             int(row["seed"]), options) for _, row in frame.iterrows()]
        frame["outcome"] = [r["outcome"] for r in runs]
        for n in names:
            frame[n] = [r["responses"][n] for r in runs]
        frame.to_csv(sheet, index=False)

    sheets = run_externally(path, fill, 6)
    assert [s[0] for s in sheets] == ["rsm", "verification"]
    assert all(f"fill {', '.join(names)} (or outcome)" in " ".join(s[2].split())
               for s in sheets)
    outside = _result(path)
    assert outside["optimum"] == inside["optimum"]
    assert outside["verification"] == inside["verification"]
    assert outside["lead"] == {"name": "drum_deg", "unit": "deg"}


def _result(path: Path) -> dict:
    """The result a study's store holds."""
    from demcal.calibrate.study import study_folder
    from demcal.store import RunStore

    with RunStore(study_folder(path)) as store:
        return store.meta("result")


def test_a_sheet_row_without_the_lead_is_refused_in_one_line(tmp_path: Path) -> None:
    path = _study(tmp_path)
    out = CliRunner().invoke(app, ["calibrate", str(path), "--external", "--no-report"])
    assert out.exit_code == 0, out.output
    sheet = path.parent / "runsheet_rsm.csv"
    text = sheet.read_text().splitlines()
    head = text[0].split(",")
    row = text[1].split(",")
    row[head.index("bulk_density_kg_m3")] = "206.0"  # another response, the lead left empty
    sheet.write_text("\n".join([text[0], ",".join(row)]) + "\n")
    out = CliRunner().invoke(app, ["import", str(sheet), "--study", str(path)])
    assert out.exit_code == 2, out.output
    assert "bulk_density_kg_m3 given without drum_deg" in " ".join(out.output.split())
