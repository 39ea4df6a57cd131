"""``demcal design / analyze / optimize``: the example README's commands and bad input."""

from __future__ import annotations

import json
import re
import shlex
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from demcal.cli import app

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "examples" / "corn_stalk"
REF = Path(__file__).parent / "reference"

runner = CliRunner()


def _invoke(args: list[str]):
    return runner.invoke(app, args, catch_exceptions=False)


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    for p in EXAMPLE.iterdir():
        if p.suffix in (".csv", ".toml"):
            shutil.copy(p, tmp_path / p.name)
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _readme_commands() -> list[list[str]]:
    text = (EXAMPLE / "README.md").read_text()
    cmds = []
    for block in re.findall(r"```bash\n(.*?)```", text, flags=re.S):
        for line in block.strip().splitlines():
            args = shlex.split(line)
            assert args[:3] == ["uv", "run", "demcal"], line
            # the engine calibration (~14 min) is the README's main command; its CLI is
            # tested on the analytic stand-in in tests/calibrate
            if args[3] != "calibrate":
                cmds.append(args[3:])
    return cmds


def test_example_tables_are_the_reference_tables():
    for name in ("table4_pb.csv", "table6_steepest.csv", "table7_bbd.csv"):
        pd.testing.assert_frame_equal(pd.read_csv(EXAMPLE / name), pd.read_csv(REF / name))


def test_every_readme_command_runs(workdir):
    cmds = _readme_commands()
    assert len(cmds) >= 6
    for args in cmds:
        result = _invoke(args)
        assert result.exit_code == 0, (args, result.output)


def test_readme_reproduces_table5(workdir):
    (args,) = [c for c in _readme_commands() if "table4_pb.csv" in c and c[0] == "analyze"]
    result = _invoke(args)
    assert result.exit_code == 0, result.output
    doc = json.loads((workdir / "table5.json").read_text())
    ref = pd.read_csv(REF / "table5_pb_anova.csv").set_index("term")
    rows = {r["term"]: r for r in doc["anova"]}
    for term in ref.index:
        assert rows[term]["ss"] == pytest.approx(ref.loc[term, "ss"], rel=5e-3, abs=5e-3)
        assert rows[term]["p"] == pytest.approx(ref.loc[term, "p"], abs=1e-3)
    ranks = {e["term"]: e["rank"] for e in doc["effects"]}
    assert ranks == ref["rank"].dropna().astype(int).to_dict()
    assert doc["excluded_runs"] == []
    assert set(doc["coefficients_coded"]) == {"intercept", *(f"x{i}" for i in range(1, 9))}
    assert "Pareto" in result.output and "x8" in result.output


def test_readme_reproduces_table8_and_equation_9(workdir):
    (args,) = [c for c in _readme_commands() if "table7_bbd.csv" in c and c[0] == "analyze"]
    assert _invoke(args).exit_code == 0
    doc = json.loads((workdir / "table8.json").read_text())
    ref = pd.read_csv(REF / "table8_bbd_anova.csv").set_index("term")
    rows = {r["term"]: r for r in doc["anova"]}
    assert list(rows) == [*ref.index, "Cor Total"]
    for term in ref.index:
        assert round(rows[term]["ss"], 2) == ref.loc[term, "ss"]
        assert rows[term]["df"] == ref.loc[term, "df"]
        if not np.isnan(ref.loc[term, "p"]):
            assert round(max(rows[term]["p"], 1e-4), 4) == ref.loc[term, "p"]
    for key in ("ms", "f"):
        assert key in rows["x3"]
    eq9 = pd.read_csv(REF / "eq9_coefficients.csv").set_index("term")["coefficient"]
    assert {k: round(v, 2) for k, v in doc["coefficients_coded"].items()} == eq9.to_dict()
    fit = doc["fit"]
    assert round(fit["r2"], 4) == 0.9918 and round(fit["adj_r2"], 4) == 0.9770
    assert round(fit["cv_percent"], 2) == 1.23 and round(fit["adeq_precision"], 3) == 26.586
    assert {"pred_r2", "std_dev", "mean"} <= set(fit)
    # actual-unit equation predicts like the coded one at the paper's optimum
    act = doc["coefficients_actual"]
    x3, x4, x8 = 0.55, 0.14, 0.12
    y = (
        act["intercept"]
        + act["x3"] * x3
        + act["x4"] * x4
        + act["x8"] * x8
        + act["x3*x4"] * x3 * x4
        + act["x3*x8"] * x3 * x8
        + act["x4*x8"] * x4 * x8
        + act["x3^2"] * x3**2
        + act["x4^2"] * x4**2
        + act["x8^2"] * x8**2
    )
    assert round(y, 2) == 44.69


def test_readme_reproduces_table6_path(workdir):
    (args,) = [c for c in _readme_commands() if c[:2] == ["design", "steepest"]]
    assert _invoke(args).exit_code == 0
    path = pd.read_csv(workdir / "path.csv")
    t6 = pd.read_csv(REF / "table6_steepest.csv")
    np.testing.assert_allclose(path[["x3", "x4", "x8"]], t6[["x3", "x4", "x8"]], atol=1e-9)
    assert (path["x1"] == 0.3).all()  # centre of Table 1's 0.2-0.4


def test_optimize_with_fixed_factors_json(workdir):
    result = _invoke(
        ["optimize", "table7_bbd.csv", "--response", "aor_deg", "--target", "44.12",
         "--factors", "factors_bbd.toml", "--units", "coded", "--fix", "x3=0.55,x8=0.12",
         "--json", "opt.json"]
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    doc = json.loads((workdir / "opt.json").read_text())
    best = doc["solutions"][0]
    assert best["x3"] == 0.55 and best["x8"] == 0.12
    assert round(best["x4"], 3) == 0.134
    assert best["predicted"] == pytest.approx(44.12, abs=1e-3)


def test_optimize_says_a_target_it_only_approaches_and_an_extrapolation(workdir):
    # a target far above every prediction: the best desirability is tiny but not 0
    far = _invoke(["optimize", "table7_bbd.csv", "--response", "aor_deg", "--target", "1e6",
                   "--factors", "factors_bbd.toml", "--units", "coded"])
    assert far.exit_code == 0, far.output
    text = " ".join(far.output.split())
    assert "is not reached within the factors' ranges" in text
    assert "predicted to give" not in text
    # a factor held far outside the design (x3 spans 0.55-0.75): the model extrapolates
    out = _invoke(["optimize", "table7_bbd.csv", "--response", "aor_deg", "--target", "44.12",
                   "--factors", "factors_bbd.toml", "--units", "coded", "--fix", "x3=1.5",
                   "--json", "far.json"])
    assert out.exit_code == 0, out.output
    assert "x3 held or searched outside the design's range" in " ".join(out.output.split())
    assert json.loads((workdir / "far.json").read_text())["outside_design"] == ["x3"]
    inside = _invoke(["optimize", "table7_bbd.csv", "--response", "aor_deg", "--target",
                      "44.12", "--factors", "factors_bbd.toml", "--units", "coded", "--fix",
                      "x3=0.75", "--json", "in.json"])
    assert "outside the design" not in inside.output
    assert json.loads((workdir / "in.json").read_text())["outside_design"] == []


def test_a_run_sheet_column_named_twice_is_one_line(workdir):
    text = (workdir / "table7_bbd.csv").read_text().splitlines()
    names = text[0].split(",")
    names[names.index("x8")] = " x3"  # spaces around a name do not make it another
    text[0] = ",".join(names) + ",,"  # a spreadsheet's trailing empty names are no repeat
    (workdir / "twice.csv").write_text("\n".join([text[0], *(r + ",," for r in text[1:])]))
    res = runner.invoke(app, ["analyze", "twice.csv", "--response", "aor_deg"])
    assert res.exit_code == 2, res.output
    assert "the column 'x3' appears twice in the header" in " ".join(res.output.split())


def test_design_then_analyze_round_trip_with_excluded_runs(workdir):
    assert _invoke(
        ["design", "bbd", "--factors", "factors_bbd.toml", "--center-points", "3", "--seed", "2",
         "--out", "bbd.csv"]
    ).exit_code == 0  # fmt: skip
    sheet = pd.read_csv(workdir / "bbd.csv")
    assert list(sheet["run"]) == list(range(1, 16))
    assert {"x3", "x3_coded", "x1"} <= set(sheet.columns) and (sheet["x1"] == 0.3).all()
    c = sheet[["x3_coded", "x4_coded", "x8_coded"]].to_numpy()
    sheet["aor_deg"] = 40 + 2 * c[:, 0] + c[:, 1] - c[:, 2] ** 2 + 0.01 * np.sin(sheet["std"])
    sheet.loc[[4, 8], "aor_deg"] = np.nan
    sheet.to_csv(workdir / "bbd.csv", index=False)
    # with the factors file: actual columns x3, x4, x8
    result = _invoke(
        ["analyze", "bbd.csv", "--response", "aor_deg", "--factors", "factors_bbd.toml",
         "--json", "a.json"]
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    assert "excluded 2 run(s) without a response: 5, 9" in result.output
    doc = json.loads((workdir / "a.json").read_text())
    assert doc["excluded_runs"] == [5, 9] and doc["n_runs"] == 13
    assert doc["coefficients_coded"]["x3"] == pytest.approx(2.0, abs=0.05)
    assert doc["coefficients_actual"]["x3"] != pytest.approx(doc["coefficients_coded"]["x3"])
    # without it: the coded columns of the sheet are used
    assert (
        _invoke(["analyze", "bbd.csv", "--response", "aor_deg", "--json", "b.json"]).exit_code == 0
    )
    doc_b = json.loads((workdir / "b.json").read_text())
    assert doc_b["coefficients_coded"] == pytest.approx(doc["coefficients_coded"])


@pytest.mark.parametrize(
    "design_args",
    [
        ["pb", "--factors", "factors_pb.toml", "--runs", "12"],
        ["ccd", "--factors", "factors_bbd.toml", "--alpha", "orthogonal"],
        ["factorial", "--factors", "factors_pb.toml", "--fraction", "4"],
        ["lhs", "--factors", "factors_bbd.toml", "--runs", "7"],
        ["sobol", "--factors", "factors_bbd.toml", "--runs", "8"],
    ],
)
def test_design_commands_write_run_sheets(workdir, design_args):
    result = _invoke(["design", *design_args, "--seed", "1", "--out", "runs.csv"])
    assert result.exit_code == 0, result.output
    sheet = pd.read_csv(workdir / "runs.csv")
    assert sheet.columns[0] == "run" and sorted(sheet["run"]) == list(range(1, len(sheet) + 1))
    assert any(c.endswith("_coded") for c in sheet.columns)
    if design_args[0] == "factorial":
        assert len(sheet) == 16 and "resolution: 4" in result.output


def _error_line(result) -> str:
    lines = [ln for ln in result.output.strip().splitlines() if ln.strip()]
    assert len(lines) == 1, result.output
    return lines[0]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["analyze", "table7_bbd.csv", "--response", "aoR"], "--response: column 'aoR' not found"),
        (["analyze", "table7_bbd.csv", "--response", "aor_deg", "--model", "cubic"],
         "--model must be one of linear, 2fi, quadratic"),
        (["analyze", "table7_bbd.csv", "--response", "aor_deg", "--columns", "x3,x5"],
         "column(s) x5 not found"),
        (["analyze", "bad.csv", "--response", "aor_deg"], "column 'x4' is not numeric"),
        (["analyze", "few.csv", "--response", "aor_deg"], "too few runs for the quadratic model"),
        (["analyze", "table4_pb.csv", "--response", "aor_deg", "--model", "2fi"],
         "too few runs for the 2fi model"),
        (["analyze", "twolevel.csv", "--response", "y"], "design is singular for the quadratic"),
        (["design", "bbd", "--factors", "inverted.toml"], "low must be < high for factor x3"),
        (["design", "pb", "--factors", "missing.toml"], "does not exist"),
        (["analyze", "nofile.csv", "--response", "y"], "does not exist"),
        (["optimize", "table7_bbd.csv", "--response", "aor_deg", "--target", "44",
          "--fix", "x3=abc"], "--fix: value of 'x3' must be a number"),
    ],
)  # fmt: skip
def test_bad_input_is_one_line_and_exit_code_2(workdir, args, message):
    t7 = pd.read_csv(workdir / "table7_bbd.csv")
    bad = t7.astype({"x4": object})
    bad.loc[3, "x4"] = "high"
    bad.to_csv(workdir / "bad.csv", index=False)
    t7.head(8).to_csv(workdir / "few.csv", index=False)
    pd.DataFrame(
        {"a": [-1, 1, -1, 1, -1, 1, -1, 1], "b": [-1, -1, 1, 1, -1, -1, 1, 1],
         "y": [1.0, 2, 3, 4, 5, 6, 7, 9]}
    ).to_csv(workdir / "twolevel.csv", index=False)  # fmt: skip
    (workdir / "inverted.toml").write_text(
        "[factors.x3]\nlow = 0.7\nhigh = 0.35\n[factors.x4]\nlow = 0\nhigh = 1\n"
        "[factors.x8]\nlow = 0\nhigh = 1\n"
    )
    result = runner.invoke(app, args)
    assert result.exit_code == 2, result.output
    line = _error_line(result)
    assert line.startswith("error:") and message in line


def test_analyze_reduce_gives_a_hierarchical_model_of_significant_terms(workdir):
    args = ["analyze", "table7_bbd.csv", "--response", "aor_deg", "--reduce", "0.1"]
    result = _invoke([*args, "--json", "r.json"])
    assert result.exit_code == 0, result.output
    doc = json.loads((workdir / "r.json").read_text())
    terms = doc["terms"]
    assert "x4*x8" not in terms and {"x3", "x4", "x8", "x3*x4", "x3^2", "x8^2"} <= set(terms)
    rows = {r["term"]: r for r in doc["anova"]}
    # x4 may stay for hierarchy (x3*x4); every other remaining term is significant at 0.1
    for t in terms[1:]:
        contained = any(t != o and set(t.split("*")) < set(o.split("*")) for o in terms)
        if not contained:
            assert rows[t]["p"] <= 0.1, t


def test_steepest_from_given_coefficients_proportional(workdir):
    result = _invoke(
        ["design", "steepest", "--factors", "factors_table1.toml", "--coef", "x3=1.0,x4=0.5",
         "--step", "0.1", "--points", "3", "--out", "p.csv"]
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    p = pd.read_csv(workdir / "p.csv")
    # x3 (largest) moves 0.1 per run from its centre 0.55; x4 half as far in coded units:
    # 0.5 * (0.1 / 0.2) coded * 0.06 half range = 0.015 per run from 0.09
    np.testing.assert_allclose(p["x3"], [0.55, 0.65, 0.75])
    np.testing.assert_allclose(p["x4"], [0.09, 0.105, 0.12])
    bad = runner.invoke(app, ["design", "steepest", "--factors", "factors_table1.toml"])
    assert bad.exit_code == 2 and "--from-runs" in _error_line(bad)


def test_analyze_with_a_block_column(tmp_path):
    """`demcal analyze --block day`: a Block row first, the day offsets out of the residual."""
    d = pd.read_csv(EXAMPLE / "table7_bbd.csv")
    factor_cols = [c for c in d.columns if c.startswith("x") and c[1:].isdigit()]
    rng = np.random.default_rng(1)
    frames = []
    for day, offset in ((1, -2.0), (2, 3.0)):
        f = d[factor_cols].copy()
        f["aor"] = d["aor_deg"] + offset + rng.normal(0, 0.3, len(d))
        f["day"] = day
        frames.append(f)
    sheet = tmp_path / "blocked.csv"
    pd.concat(frames).to_csv(sheet, index=False)
    out = tmp_path / "a.json"
    res = _invoke(["analyze", str(sheet), "--response", "aor", "--block", "day",
                   "--json", str(out)])
    assert res.exit_code == 0, res.output
    assert "Block" in res.output
    anova = json.loads(out.read_text())["anova"]
    assert anova[0]["term"] == "Block" and anova[0]["df"] == 1
    bad = _invoke(["analyze", str(sheet), "--response", "aor", "--block", "shift"])
    assert bad.exit_code == 2 and "--block: column 'shift' not found" in bad.output
