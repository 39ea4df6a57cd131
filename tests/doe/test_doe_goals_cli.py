"""``demcal optimize RUNS.csv --goals GOALS.toml``: several responses from a run sheet."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from demcal import doe
from demcal.cli import app

REF = Path(__file__).parent / "reference" / "montgomery_conversion_activity.csv"
GOALS = """
[[responses]]
name = "conversion"
goal = "maximize"
low = 80.0
high = 97.0

[[responses]]
name = "activity"
goal = "target"
target = 57.5
low = 55.0
high = 60.0
"""


def _run(tmp_path: Path, goals: str, *extra: str):
    (tmp_path / "goals.toml").write_text(goals)
    return CliRunner().invoke(app, ["optimize", str(REF), "--goals", str(tmp_path / "goals.toml"),
                                    "--columns", "time,temperature,catalyst", "--units",
                                    "coded", *extra])


def test_goals_agree_with_a_brute_force_search(tmp_path: Path) -> None:
    out = _run(tmp_path, GOALS, "--json", str(tmp_path / "out.json"))
    assert out.exit_code == 0, out.output
    doc = json.loads((tmp_path / "out.json").read_text())
    best = doc["solutions"][0]
    assert set(best) >= {"desirability", "settings", "predicted", "individual"}
    assert set(best["settings"]) == {"time", "temperature", "catalyst"}
    runs = pd.read_csv(REF)
    names = ["time", "temperature", "catalyst"]
    models = {r: doe.fit(runs, runs[r], names=names, model="quadratic", units="coded")
              for r in ("conversion", "activity")}
    g = np.linspace(-1, 1, 61)
    grid = np.array(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1).T
    d = np.column_stack([
        doe.ResponseGoal("conversion", "maximize", 80, 97).desirability(
            models["conversion"].predict(grid, units="coded")),
        doe.ResponseGoal("activity", "target", 55, 60, target=57.5).desirability(
            models["activity"].predict(grid, units="coded"))])
    brute = doe.overall_desirability(d, [3, 3]).max()
    assert best["desirability"] == pytest.approx(brute, abs=0.01)
    assert best["predicted"]["activity"] == pytest.approx(57.5, abs=0.05)
    assert doc["reachable"] is True and doc["unmet"] == []
    assert "Settings of best overall desirability" in out.output


def test_an_unreachable_goal_is_said(tmp_path: Path) -> None:
    goals = GOALS.replace("low = 80.0\nhigh = 97.0", "low = 120.0\nhigh = 130.0")
    out = _run(tmp_path, goals)
    assert out.exit_code == 0, out.output
    assert "unreachable" in out.output and "conversion" in out.output


@pytest.mark.parametrize(("goals", "message"), [
    (GOALS.replace("low = 80.0", "low = 99.0"), "low must be < high"),
    (GOALS + "importance = 9\n", "importance"),
    (GOALS.replace('name = "activity"', 'name = "yield"'), "'yield' not found"),
    (GOALS.replace('goal = "maximize"', 'goal = "best"'), "goal"),
    ("[other]\nx = 1\n", "unknown table"),
])
def test_bad_goals_get_one_line_and_exit_2(tmp_path: Path, goals: str, message: str) -> None:
    out = _run(tmp_path, goals)
    assert out.exit_code == 2, out.output
    assert message in out.output and "Traceback" not in out.output


def test_goals_and_a_target_exclude_each_other(tmp_path: Path) -> None:
    out = _run(tmp_path, GOALS, "--response", "conversion")
    assert out.exit_code == 2 and "leave out" in out.output
