"""``[strategy] kind = "bayes"``: a study calibrated by a posterior (the analytic stand-in).

The planted three-response, three-factor study of test_several_responses: with the three
lab values the posterior must close around the planted point; with the angle alone it must
say that the tests leave a ridge along which the two frictions trade, and that the drum
(a response the runs report but the study does not aim at) would remove it.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from test_several_responses import ANALYTIC, FACTORS, PLANTED, write_study
from typer.testing import CliRunner

from demcal.calibrate import calibrate
from demcal.cli import app
from demcal.store import RunStore
from demcal.summaries.bayes import BayesSummary

FRICTIONS = {"pp.static_friction", "pp.rolling_friction"}


def bayes_study(folder: Path, *, responses: bool = True, strategy: str = "") -> Path:
    return write_study(folder, responses=responses,
                       aor_only_extra='\n[strategy]\nkind = "bayes"\nbatch = 6\n' + strategy)


def _far_corner() -> dict[str, float]:
    """Each factor at the end of its range farther from the planted value."""
    return {n: lo if PLANTED[n] - lo > hi - PLANTED[n] else hi
            for n, (_s, lo, hi) in FACTORS.items()}


def _inline(values: dict[str, float]) -> str:
    return "{ " + ", ".join(f'"{k}" = {v!r}' for k, v in values.items()) + " }"


#: points held against the posterior: the planted one, a far corner of the box, and a
#: result JSON whose optimum is the planted point
MARKS = (f'\n[[strategy.marks]]\nlabel = "planted"\nvalues = {_inline(PLANTED)}\n'
         f'\n[[strategy.marks]]\nlabel = "a far corner"\nvalues = {_inline(_far_corner())}\n'
         '\n[[strategy.marks]]\nlabel = "a DOE result"\nresult = "doe_result.json"\n')


@pytest.fixture(scope="module")
def three(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    folder = tmp_path_factory.mktemp("three")
    (folder / "doe_result.json").write_text(json.dumps({"optimum": PLANTED}))
    return folder, calibrate(bayes_study(folder, strategy=MARKS), workers=1)


def test_marked_points_are_held_against_the_posterior(three: tuple[Path, dict]) -> None:
    """The planted point lies inside the 95 % credible region, a far corner outside it; a
    result JSON's optimum is read as a mark; the report marks them and tabulates them."""
    folder, res = three
    marks = {m["label"]: m for m in res["marks"]}
    assert list(marks) == ["planted", "a far corner", "a DOE result"]
    assert marks["planted"]["inside95"] is True and marks["planted"]["credibility"] < 0.95
    assert marks["a far corner"]["inside95"] is False
    assert marks["a far corner"]["credibility"] > 0.95
    assert marks["a DOE result"]["values"] == marks["planted"]["values"]
    assert marks["a DOE result"]["credibility"] == marks["planted"]["credibility"]
    out = CliRunner().invoke(app, ["report", str(folder)])
    assert out.exit_code == 0, out.output
    doc = json.loads((folder / "report" / "report.json").read_text())
    rows = doc["tables"]["bayes_marks"]["rows"]
    assert [r[0] for r in rows] == ["planted", "a far corner", "a DOE result"]
    assert "figures/bayes_corner.png" in doc["figures"]


@pytest.mark.parametrize(("mark", "words"), [
    ('label = "x"\nvalues = { "pp.static_friction" = 0.5 }\n', "no value for the factor(s)"),
    ('label = "x"\nresult = "missing.json"\n', "not a demcal result JSON"),
    ('label = "x"\n', "give values or result"),
])
def test_a_bad_mark_is_one_line_and_exit_2(tmp_path: Path, mark: str, words: str) -> None:
    path = bayes_study(tmp_path, strategy="\n[[strategy.marks]]\n" + mark)
    out = CliRunner().invoke(app, ["calibrate", str(path), "--no-report"])
    assert out.exit_code == 2, out.output
    text = " ".join(out.output.split())
    assert words in text and "Traceback" not in text, text


def test_three_responses_pin_the_planted_point(three: tuple[Path, dict]) -> None:
    _folder, res = three
    assert res["strategy"] == "bayes" and res["identifiable"] is True, res["reason"]
    assert res["n_runs_strategy"] <= 90
    for name, (_sym, lo, hi) in FACTORS.items():
        p = res["posterior"][name]
        assert p["ci95_low"] <= PLANTED[name] <= p["ci95_high"], (name, p)
        assert p["ci95_high"] - p["ci95_low"] <= 0.25 * (hi - lo), (name, p)
        assert p["ci95_low"] <= p["median"] <= p["ci95_high"]
    assert res["ridge"] == []
    assert not any(n.startswith("replicates") for n in res["notes"])  # replicates = 1
    assert set(res["correlation"]) == set(FACTORS)
    # verified at the best point on fresh seeds, every response judged against its lab
    ver = res["verification"]
    assert ver["n"] >= 4 and ver["consistent"] is True, ver
    assert set(res["responses"]["verification"]) == {"drum_deg", "bulk_density_kg_m3"}
    assert set(res["optimum_full"]) > set(FACTORS)
    assert res["optimum"] == {n: res["optimum_full"][n] for n in FACTORS}
    assert res["n_runs_executed"] == res["n_runs_strategy"] + ver["n"]


def test_the_command_prints_every_response_of_the_posterior(three: tuple[Path, dict]) -> None:
    folder, res = three
    assert set(res["responses"]["predicted"]) == {"drum_deg", "bulk_density_kg_m3"}
    out = CliRunner().invoke(app, ["calibrate", str(folder / "study.toml"), "--workers", "1"])
    assert out.exit_code == 0, out.output
    line = next(x for x in out.output.splitlines() if x.startswith("drum_deg: lab"))
    assert "predicted n/a" not in line and "with the lab" in out.output


def test_resume_runs_nothing_and_gives_the_same_result(three: tuple[Path, dict]) -> None:
    folder, res = three
    again = calibrate(folder / "study.toml", workers=1)
    assert again["n_runs_executed"] == 0
    for key in ("posterior", "correlation", "optimum", "verification", "reason"):
        assert again[key] == res[key], key


def test_the_stage_and_the_runs_are_stored(three: tuple[Path, dict]) -> None:
    folder, res = three
    store = RunStore(folder)
    try:
        stages = {s.name: s for s in store.stages()}
        runs = store.runs("bayes")
    finally:
        store.close()
    assert stages["bayes"].status == "done" and stages["verification"].status == "done"
    summary = stages["bayes"].summary
    assert summary["posterior"] == res["posterior"]
    # the optimum the strategy stores for the report and the card, in the order it always did
    opt = stages["optimize"].summary
    assert list(opt) == ["target_aor_deg", "chosen", "predicted_aor_deg", "candidates", "opts",
                         "source"]
    assert opt["opts"] == "bayes" and list(opt["candidates"][0]) == [
        "params", "predicted_aor_deg", "pi_low_deg", "pi_high_deg", "p_pile"]
    assert len(summary["samples"][next(iter(FACTORS))]) >= 100
    # the stage's keys, a file format, in the order they were always written; the result
    # JSON holds the same less the drawing data
    assert list(summary) == [*BAYES_KEYS, "samples", "slices"]
    assert [k for k in res if k in summary] == list(BAYES_KEYS)
    assert list(summary["history"][0]) == ["round", "n_runs", "half_widths_coded",
                                           "acceptance_fraction", "warnings"]
    assert list(summary["marks"][0]) == ["label", "values", "in_box", "credibility",
                                         "inside95"]
    assert BayesSummary.from_summary(summary).to_summary() == summary
    assert len(runs) == res["n_runs_strategy"]
    assert sorted(r.point for r in runs) == list(range(len(runs)))  # a stable index per run
    assert len({r.seed for r in runs}) == len(runs)


#: the stored keys of the stage "bayes" (and of the result JSON), in their order
BAYES_KEYS = ("posterior", "correlation", "acceptance_fraction", "map", "warnings",
              "identifiable", "reason", "n_runs", "verification_runs", "stopped", "ridges",
              "ridge", "shrinkage", "history", "optimum", "predicted", "labs", "notes",
              "settings", "units", "marks", "combinations", "advice", "surrogate_checks")


#: the analytic drum's own slopes (test_several_responses.ANALYTIC) stated as a test the study
#: could add, with the standard error the runs' candidate is given (noise 0.2 over the
#: angle's 5 lab repeats), and the drum itself stated too (the runs report it: not used)
STATED = ('\n[[strategy.candidates]]\nname = "stated_drum_deg"\n'
          'slopes = { "pp.static_friction" = 5.0, "pp.rolling_friction" = 60.0, '
          '"pw.static_friction" = 1.0 }\nstandard_error = 0.0894\nsource = "its planted slopes"\n'
          '\n[[strategy.candidates]]\nname = "drum_deg"\n'
          'slopes = { "pp.rolling_friction" = 1.0 }\nstandard_error = 1.0\n')


def test_the_angle_alone_leaves_the_friction_ridge(tmp_path: Path) -> None:
    res = calibrate(bayes_study(tmp_path, responses=False, strategy="max_runs = 33\n" + STATED),
                    workers=1)
    assert res["identifiable"] is False
    assert res["n_runs_strategy"] == 33 and res["stopped"] == "budget"
    friction = [r for r in res["ridges"] if FRICTIONS <= set(r["parameters"])]
    assert friction, res["reason"]
    assert friction[0]["text"] in res["ridge"] and "pp.static_friction down" in res["reason"]
    # the drum (planted: rolling friction 60, static 5) is what removes it
    shrink = {s["response"]: s["shrinkage"] for s in res["shrinkage"]
              if s["ridge"] == friction[0]["text"]}
    assert shrink["drum_deg"] > 0.5 and shrink["drum_deg"] > shrink["bulk_density_kg_m3"]
    assert list(friction[0]) == ["text", "parameters", "direction_coded", "fraction"]
    assert list(res["shrinkage"][0]) == ["response", "ridge", "shrinkage", "extent_before",
                                         "extent_after", "effective_samples", "basis", "source"]
    # a test known only by its slopes: the same drum stated gives the runs' drum's shrinkage
    stated = next(s for s in res["shrinkage"]
                  if s["response"] == "stated_drum_deg" and s["ridge"] == friction[0]["text"])
    assert stated["basis"] == "stated" and stated["source"] == "its planted slopes"
    assert abs(stated["shrinkage"] - shrink["drum_deg"]) < 0.1, (stated, shrink)
    drum = [s for s in res["shrinkage"] if s["response"] == "drum_deg"]
    assert {s["basis"] for s in drum} == {"runs"}  # the runs beat the statement
    assert any("candidate drum_deg: the runs report it" in n for n in res["notes"])
    # what to do next, per ridge, in a sentence (the command prints it)
    advice = next(a for a in res["advice"] if friction[0]["text"] in a)
    assert "would shrink it most" in advice and "drum_deg" in advice, res["advice"]
    # the planted drum and bulk density together pin all three factors (the three-response
    # study of test_three_responses_pin_the_planted_point does); one of them alone does not
    combos = {tuple(c["responses"]): c for c in res["combinations"]}
    assert combos[("bulk_density_kg_m3", "drum_deg")]["ridges"] == [], combos
    assert combos[("drum_deg",)]["ridges"], combos
    assert res["advice"][-1].startswith("adding ") and "would pin every parameter" in \
        res["advice"][-1], res["advice"]
    # the report says what each expectation is estimated from
    from demcal.report import build_report

    build_report(tmp_path)
    table = json.loads((tmp_path / "report" / "report.json").read_text())["tables"][
        "bayes_shrinkage"]
    basis = [row[table["columns"].index("estimated from")] for row in table["rows"]]
    assert "stated slopes (its planted slopes)" in basis and "the runs' surrogate" in basis
    pairs = json.loads((tmp_path / "report" / "report.json").read_text())["tables"][
        "bayes_combinations"]
    assert ["bulk_density_kg_m3 + drum_deg", "none: every parameter pinned"] in [
        row[:2] for row in pairs["rows"]]
    from demcal.virtual.material_card import read_material_card

    card = read_material_card(tmp_path / "report" / "material.toml")
    assert card.posterior.advice == res["advice"] and res["advice"]
    # and the command prints it (a resume: nothing runs)
    out = CliRunner().invoke(app, ["calibrate", str(tmp_path / "study.toml"), "--no-report",
                                   "--workers", "1"])
    text = " ".join(out.output.split())
    assert out.exit_code == 0 and "would pin every parameter" in text, out.output


def test_a_stable_ridge_stops_before_the_budget(tmp_path: Path) -> None:
    """With ``stable_rounds`` the angle alone stops once its intervals stop moving, and the
    study says so; the settings it ran with are in the result."""
    res = calibrate(bayes_study(tmp_path, responses=False, strategy=(
        "max_runs = 60\nstable_rounds = 2\nstable_change = 0.1\n")), workers=1)
    assert res["stopped"] == "stable" and res["n_runs_strategy"] < 60
    assert res["identifiable"] is False
    assert res["settings"]["stable_rounds"] == 2 and res["settings"]["stable_change"] == 0.1


def test_a_missed_verification_becomes_data_for_the_next_round(tmp_path: Path) -> None:
    """``max_rounds`` in Bayesian mode: a round that misses (here: a tolerance no mean can
    meet) conditions the posterior on its runs and verifies the new best point on seeds of
    its own; a resume runs nothing and ends where the first call did."""
    path = bayes_study(tmp_path, responses=False, strategy="n_start = 12\nmax_runs = 12\n")
    path.write_text(path.read_text().replace("replicates = 1", "replicates = 3").replace(
        "[stages.verification]\nn = 4\n",
        "[stages.verification]\nn = 4\nmax_rounds = 3\ntolerance_percent = 0.0001\n"))
    res = calibrate(path, workers=1)
    assert [r["round"] for r in res["rounds"]] == [1, 2, 3]
    assert res["verification_runs"] == 8 and res["n_runs_strategy"] == 12
    assert res["n_runs"] == res["n_runs_strategy"] + 8 + res["verification"]["n"]
    assert [h["n_runs"] for h in res["history"]] == [12, 16, 20]
    # the study's replicates are the DOE path's: one seed per point here, and it says so
    assert any(n.startswith("replicates = 3 (seeds per design point") for n in res["notes"])
    optima = [tuple(r["optimum"].values()) for r in res["rounds"]]
    assert len(set(optima)) == 3  # each round's posterior has its own best point
    assert res["optimum"] == res["rounds"][-1]["optimum"]
    with RunStore(tmp_path) as store:
        seeds = [r.seed for r in store.runs("verification")]
        summary = next(s for s in store.stages() if s.name == "bayes").summary
    assert len(seeds) == 12 and len(set(seeds)) == 12  # no pile of another round reused
    assert summary["verification_runs"] == 8
    again = calibrate(path, workers=1)
    assert again["n_runs_executed"] == 0
    for key in ("posterior", "optimum", "rounds", "verification"):
        assert again[key] == res[key], key
    out = CliRunner().invoke(app, ["calibrate", str(path), "--no-report", "--workers", "1"])
    text = " ".join(out.output.split())
    assert out.exit_code == 0, out.output
    assert "the posterior conditioned on the earlier rounds' piles" in text, text
    assert "(12 runs and 8 of the verification rounds', stopped by budget)" in text, text
    from demcal.report import build_report

    build_report(tmp_path)
    table = json.loads((tmp_path / "report" / "report.json").read_text())["tables"][
        "verification_rounds"]
    assert "predicted AoR (deg)" in table["columns"] and len(table["rows"]) == 3
    assert "offset" not in " ".join(table["columns"])  # no surface was aimed
    history = json.loads((tmp_path / "report" / "report.json").read_text())["tables"][
        "bayes_history"]
    assert [row[1] for row in history["rows"]] == [12, 16, 20]
    assert "after 12 runs; the rows after it are the posterior conditioned on the " \
        "verification rounds' piles as well (8 runs in all)" in history["note"], history


def test_a_lab_value_out_of_reach_is_a_printed_warning(tmp_path: Path) -> None:
    """The posterior's warnings reach the terminal, not only the result JSON."""
    path = bayes_study(tmp_path, responses=False, strategy="n_start = 12\nmax_runs = 12\n")
    text = path.read_text()
    path.write_text(text.replace(text[text.index("[target]"):].split("\n")[1],
                                 "aor_deg = 80.0", 1))
    out = CliRunner().invoke(app, ["calibrate", str(path), "--no-report", "--workers", "1"])
    assert out.exit_code == 0, out.output
    words = " ".join(out.output.split())
    assert "warning: aor_deg: the best point gives" in words, words
    assert "the lab value lies outside what the runs reach" in words
    assert "warning: pp.static_friction: the posterior piles at its high bound" in words


def test_a_run_the_surrogate_does_not_follow_is_said() -> None:
    """The surrogates' leave-one-out check in the summary: a response with a jump the
    kernel cannot follow is said, naming the run; the pile indicator is not judged."""
    from demcal.calibrate.bayes_strategy import PILE, _surrogate_checks
    from demcal.doe import Factor, FactorSpace, bayes

    space = FactorSpace([Factor("static_friction", 0.2, 0.8), Factor("rolling_friction", 0, 0.2),
                         Factor("restitution", 0.3, 0.7)])

    def evaluate(x):
        jump = 30 + 5 * np.sign(x[:, 0]) + 0.05 * np.sin(7 * x[:, 1] + 3 * x[:, 2])
        return {"aor_deg": jump, PILE: np.ones(len(x))}

    labs = [bayes.Response("aor_deg", 31.0, 0.2), bayes.Response(PILE, 1.0, 0.2)]
    res = bayes.calibrate_bayes(evaluate, space, labs, bayes.BayesSettings(
        max_runs=30, n_start=30, seed=0,
        sampler=bayes.SamplerSettings(n_steps=400, burn=100)))
    rows, warnings = _surrogate_checks(res)
    assert [r.response for r in rows] == ["aor_deg"]
    row = rows[0]
    assert row.n == 30 and row.misses_a_run and row.max_abs_z > row.limit, row
    assert abs(space.to_coded(np.array([list(row.worst.values())]))[0, 0]) < 0.3
    assert len(warnings) == 1 and warnings[0].startswith("aor_deg: the run at static_friction")
    assert "the surrogate does not follow the response there" in warnings[0]


def test_the_doe_path_is_unchanged_by_a_default_strategy(tmp_path: Path) -> None:
    """``kind = "doe"`` written out gives the very result of a study without the table."""
    (tmp_path / "plain").mkdir()
    (tmp_path / "doe").mkdir()
    plain = calibrate(write_study(tmp_path / "plain"), workers=1)
    doe = calibrate(write_study(tmp_path / "doe", aor_only_extra='\n[strategy]\nkind = "doe"\n'
                                ), workers=1)
    assert "posterior" not in doe and doe == plain


@pytest.mark.parametrize(("setting", "field"), [
    ('kind = "grid"', "strategy.kind"),
    ("max_runs = 5", "strategy.max_runs"),
    ("batch = 0", "strategy.batch"),
    ("tolerance = 0", "strategy.tolerance"),
    ("tolerance = 1.5", "strategy.tolerance"),
    ("seed = -1", "strategy.seed"),
    ("n_start = 50\nmax_runs = 40", "n_start"),
    ("max_runs = 20", "max_runs"),  # below the 27-run start of three factors
    ("runs = 3", "strategy.runs"),
    ("stable_rounds = -1", "strategy.stable_rounds"),
    ("stable_change = 0", "strategy.stable_change"),
    ('[[strategy.candidates]]\nname = "x"\nslopes = { "pw.rolling_friction" = 1.0 }\n'
     "standard_error = 0.5", "strategy.candidates 'x': slopes of pw.rolling_friction, not a "
     "factor"),
    ('[[strategy.candidates]]\nname = "x"\nslopes = { "pp.static_friction" = 0.0 }\n'
     "standard_error = 0.5", "every slope is 0"),
    ('[[strategy.candidates]]\nname = "x"\nslopes = { "pp.static_friction" = 1.0 }\n'
     "standard_error = 0", "strategy.candidates.0.standard_error"),
    ('[[strategy.candidates]]\nname = "aor_deg"\nslopes = { "pp.static_friction" = 1.0 }\n'
     "standard_error = 0.5", "already aims at this response"),
    ('[[strategy.candidates]]\nname = "pile_formed"\nslopes = { "pp.static_friction" = 1.0 }\n'
     "standard_error = 0.5", "keeps for its pile indicator"),
])
def test_bad_strategy_settings_are_one_line_and_exit_2(tmp_path: Path, setting: str,
                                                       field: str) -> None:
    path = write_study(tmp_path, aor_only_extra=f'\n[strategy]\nkind = "bayes"\n{setting}\n'
                       .replace('kind = "bayes"\nkind', "kind"))
    out = CliRunner().invoke(app, ["calibrate", str(path), "--no-report"])
    assert out.exit_code == 2, out.output
    text = " ".join(out.output.split())
    assert field in text and "Traceback" not in text, text
    assert RunStore(tmp_path).count() == 0 if (tmp_path / "demcal.sqlite").exists() else True


def test_the_report_has_the_bayesian_section(three: tuple[Path, dict]) -> None:
    folder, res = three
    out = CliRunner().invoke(app, ["report", str(folder)])
    assert out.exit_code == 0, out.output
    html = (folder / "report" / "report.html").read_text()
    assert 'id="bayes"' in html and "identifiable" in html
    doc = json.loads((folder / "report" / "report.json").read_text())
    table = doc["tables"]["bayes_posterior"]
    assert [r[0] for r in table["rows"]] == list(FACTORS)
    assert {"figures/bayes_corner.png", "figures/bayes_slices.png"} <= set(doc["figures"])
    assert doc["tables"]["bayes_history"]["rows"][-1][1] == res["n_runs_strategy"]


def test_the_posterior_keeps_to_where_piles_form(tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """Runs above the stand-in's ``no_pile_above`` form no pile (no angle): the pile
    indicator keeps the posterior out of that part of the box, which the angle alone (flat
    in the wall friction) would fill."""
    monkeypatch.setitem(ANALYTIC, "no_pile_above", {"pw.static_friction": 0.6})
    # the start alone (27 runs); without the indicator the interval reaches 0.79
    res = calibrate(bayes_study(tmp_path, responses=False, strategy="max_runs = 27\n"),
                    workers=1)
    runs = RunStore(tmp_path).runs("bayes")
    assert any(r.outcome == "column" for r in runs)  # the start saw the region
    wall = res["posterior"]["pw.static_friction"]
    assert wall["ci95_high"] < 0.62, wall
    assert "pile_formed" in res["labs"] and any("pile_formed" in n for n in res["notes"])


def test_a_malformed_summary_is_a_note_not_a_failed_report(three: tuple[Path, dict],
                                                           tmp_path: Path) -> None:
    from demcal.report import build_report

    folder, _res = three
    copy = tmp_path / "copy"
    copy.mkdir()
    (copy / "demcal.sqlite").write_bytes((folder / "demcal.sqlite").read_bytes())
    store = RunStore(copy)
    try:
        summary = next(s for s in store.stages() if s.name == "bayes").summary
        del summary["correlation"]
        store.set_stage("bayes", "done", summary)
    finally:
        store.close()
    build_report(copy)
    doc = json.loads((copy / "report" / "report.json").read_text())
    assert any("bayes: the stored summary could not be shown" in p for p in doc["problems"])
    assert "bayes_posterior" not in doc["tables"]
    assert 'id="bayes"' in (copy / "report" / "report.html").read_text()


def test_switching_strategy_keeps_each_path_to_itself(tmp_path: Path) -> None:
    """Bayes, then the DOE path in the same folder: the DOE result is a fresh study's and
    the report shows no stale Bayesian section; back to bayes: no stale DOE stage, and the
    loop's runs are found again."""
    (tmp_path / "fresh").mkdir()
    fresh = calibrate(write_study(tmp_path / "fresh"), workers=1)
    first = calibrate(bayes_study(tmp_path), workers=1)
    doe = calibrate(write_study(tmp_path), workers=1)
    assert doe["optimum"] == fresh["optimum"] and doe["verification"] == fresh["verification"]
    names = {s.name for s in RunStore(tmp_path).stages()}
    assert "bayes" not in names and "rsm" in names
    again = calibrate(bayes_study(tmp_path), workers=1)
    assert again["n_runs_executed"] == 0 and again["posterior"] == first["posterior"]
    names = {s.name for s in RunStore(tmp_path).stages()}
    assert "rsm" not in names and {"bayes", "optimize", "verification"} <= names


def test_external_round_trip_gives_the_internal_result(tmp_path: Path) -> None:
    """--external: the loop's runs go out as run sheets (the start, then each batch), come
    back through `demcal import`, and the study ends where the internal one does."""
    from test_external import _fill, run_externally

    from demcal.calibrate import load_study

    (tmp_path / "internal").mkdir()
    strategy = "max_runs = 33\n"
    expected = calibrate(bayes_study(tmp_path / "internal", responses=False,
                                     strategy=strategy), workers=1)
    study = bayes_study(tmp_path, responses=False, strategy=strategy)
    options = load_study(study).test.analytic
    sheets = [s[:2] for s in run_externally(study, lambda sheet: _fill(sheet, options), 8)]
    assert sheets[:2] == [("bayes", 27), ("bayes", 6)] and sheets[2][0] == "verification"
    with RunStore(tmp_path) as store:
        result = store.meta("result")
    for key in ("posterior", "optimum", "verification", "reason"):
        assert result[key] == expected[key], key


def test_a_start_without_piles_is_one_line_and_exit_3(tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(ANALYTIC, "no_pile_above", {"pp.static_friction": 0.21})
    out = CliRunner().invoke(app, ["calibrate", str(bayes_study(tmp_path, responses=False)),
                                   "--no-report", "--workers", "1"])
    text = " ".join(out.output.split())
    assert out.exit_code == 3, text
    assert "start runs gave aor_deg (outcomes: column" in text and "Traceback" not in text


def test_a_response_without_a_lab_value_is_refused(tmp_path: Path) -> None:
    extra = '[[responses]]\nname = "drum_deg"\ngoal = "maximize"\n'
    out = CliRunner().invoke(app, ["calibrate", str(bayes_study(tmp_path, responses=False,
                                                                strategy=extra)),
                                   "--no-report"])
    text = " ".join(out.output.split())
    assert out.exit_code == 2 and "responses 'drum_deg'" in text and "goal 'maximize'" in text


ENGINE = '''\
import json, random, sys
cfg = dict(line.split("=", 1) for line in open(sys.argv[1]) if "=" in line)
cfg = {k.strip(): v.strip() for k, v in cfg.items()}
d = [float(cfg[k]) - c for k, c in (("sf", 0.6), ("rf", 0.2), ("wf", 0.55))]
rng = random.Random(int(cfg["seed"]))
def planted(base, slopes, noise):
    return base + sum(s * x for s, x in zip(slopes, d)) + noise * rng.gauss(0.0, 1.0)
json.dump({"aor_deg": planted(30.0, (15.0, 25.0, 2.0), 0.2),
           "drum_deg": planted(35.0, (5.0, 60.0, 1.0), 0.2),
           "bulk_density_kg_m3": planted(200.0, (-10.0, 20.0, 80.0), 0.5)},
          open("result.json", "w"))
'''


def test_a_template_engine_with_three_responses(tmp_path: Path) -> None:
    """The issue's criterion on an external engine: a real process driven through a
    template, planted parameters, three responses reported in its JSON result."""
    (tmp_path / "engine.py").write_text(ENGINE)
    (tmp_path / "input.txt.template").write_text(
        "seed = {seed}\nsf = {pp.static_friction}\nrf = {pp.rolling_friction}\n"
        "wf = {pw.static_friction}\n")
    d = [PLANTED[n] - c for n, c in (("pp.static_friction", 0.6),
                                     ("pp.rolling_friction", 0.2),
                                     ("pw.static_friction", 0.55))]
    truth = {name: base + sum(s * x for s, x in zip(slopes, d, strict=True))
             for name, base, slopes in (("aor_deg", 30.0, (15.0, 25.0, 2.0)),
                                        ("drum_deg", 35.0, (5.0, 60.0, 1.0)),
                                        ("bulk_density_kg_m3", 200.0, (-10.0, 20.0, 80.0)))}
    lines = ['name = "template engine, three responses"', "seed = 3", "",
             "[material]", 'preset = "corn_stalk"', ""]
    for name, (sym, lo, hi) in FACTORS.items():
        lines += ["[[factors]]", f'name = "{name}"', f'symbol = "{sym}"', f"low = {lo}",
                  f"high = {hi}", ""]
    for name, value in truth.items():
        lines += ["[[responses]]", f'name = "{name}"', f"target = {value!r}", "std = 0.5",
                  "n = 5", ""]
    lines += ["[engine]", 'kind = "template"', 'template = "input.txt.template"',
              'command = ["{python}", "{template_dir}/engine.py", "{input}"]', "",
              "[engine.result]", 'kind = "value"', 'file = "result.json"', "",
              "[strategy]", 'kind = "bayes"', "batch = 6", "",
              "[stages.verification]", "n = 4", "", "[executor]", "workers = 1", ""]
    (tmp_path / "study.toml").write_text("\n".join(lines))
    res = calibrate(tmp_path / "study.toml", workers=1)
    assert res["identifiable"] is True and res["n_runs_strategy"] <= 90, res["reason"]
    for name, (_sym, lo, hi) in FACTORS.items():
        p = res["posterior"][name]
        assert p["ci95_low"] <= PLANTED[name] <= p["ci95_high"], (name, p)
        assert p["ci95_high"] - p["ci95_low"] <= 0.25 * (hi - lo), (name, p)
    assert res["verification"]["consistent"] is True
    assert "pile_formed" in res["labs"]  # an external engine may end without a pile
    # the same engine and the angle alone: a ridge, named in the two frictions
    alone = tmp_path / "alone"
    alone.mkdir()
    for name in ("engine.py", "input.txt.template"):
        (alone / name).write_text((tmp_path / name).read_text())
    text = "\n".join(lines).replace('kind = "bayes"', 'kind = "bayes"\nmax_runs = 33')
    for name in ("drum_deg", "bulk_density_kg_m3"):
        text = text.replace(f'[[responses]]\nname = "{name}"\ntarget = {truth[name]!r}\n'
                            'std = 0.5\nn = 5\n', "")
    (alone / "study.toml").write_text(text)
    res = calibrate(alone / "study.toml", workers=1)
    assert list(res["labs"]) == ["aor_deg", "pile_formed"]
    assert res["identifiable"] is False and res["n_runs_strategy"] == 33, res["reason"]
    assert any(FRICTIONS <= set(r["parameters"]) for r in res["ridges"]), res["reason"]


def test_the_material_card_holds_the_posterior(three: tuple[Path, dict]) -> None:
    from demcal.report.material import write_material_card
    from demcal.virtual.material_card import read_material_card

    folder, res = three
    toml_path, json_path = write_material_card(folder, folder / "card")
    card = read_material_card(toml_path)
    assert card == read_material_card(json_path)  # both files read back the same card
    post = card.posterior
    assert post is not None and post.identifiable is True and post.ridge == []
    assert post.advice == res["advice"]
    assert {n: p.to_table() for n, p in post.parameters.items()} == res["posterior"]
    assert post.correlation == res["correlation"]
    assert all(card.parameters[n] == res["optimum_full"][n] for n in FACTORS)
    assert '[posterior.parameters."pp.static_friction"]' in toml_path.read_text()
