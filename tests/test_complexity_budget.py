"""Complexity budgets: C901 and PLR09 violations per file may only go down.

``pyproject.toml`` lists, per file, the complexity rules it may break
(``[tool.ruff.lint.per-file-ignores]``, so that ``ruff check`` passes) and how many times
(``[tool.demcal.complexity-budget]``). This test runs ruff on those rules with the
per-file ignores switched off and compares the counts with the budget.
"""

from __future__ import annotations

import collections
import json
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RULES = "C901,PLR09"


def _counts() -> dict[str, collections.Counter]:
    proc = subprocess.run(
        [sys.executable, "-m", "ruff", "check", "src", "tests", "benchmarks", "examples",
         "--select", RULES, "--output-format", "json", "--no-cache", "--exit-zero",
         "--config", "lint.per-file-ignores = {}"],
        cwd=ROOT, capture_output=True, text=True, timeout=120)
    if proc.returncode != 0:
        pytest.skip(f"ruff did not run: {proc.stderr[-500:]}")
    counts: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    for item in json.loads(proc.stdout):
        rel = Path(item["filename"]).resolve().relative_to(ROOT).as_posix()
        counts[rel][item["code"]] += 1
    return counts


def test_no_file_exceeds_its_complexity_budget():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    budget = config["tool"]["demcal"]["complexity-budget"]
    ignores = config["tool"]["ruff"]["lint"]["per-file-ignores"]
    over = []
    below = []
    for path, codes in sorted(_counts().items()):
        for code, n in sorted(codes.items()):
            allowed = budget.get(path, {}).get(code, 0)
            if n > allowed:
                over.append(f"{path}: {n} x {code} (budget {allowed})")
            elif n < allowed:
                below.append(f"{path}: {code} {allowed} -> {n}")
    assert not over, ("complexity over budget (split the function; budgets never go up):\n"
                      + "\n".join(over))
    for path, codes in budget.items():
        assert sorted(ignores.get(path, [])) == sorted(codes), (
            f"{path}: per-file-ignores and complexity-budget list different rules")
    if below:
        print("budgets that may be lowered in pyproject.toml:\n" + "\n".join(below))
