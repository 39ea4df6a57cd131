"""Range finding with several responses: the ranges follow the lead, and every other
response's span over the scans is said with whether its lab value lies in it (a lab value no
scan reached is named, not hidden); a study of one response stores what it always did."""

from __future__ import annotations

from pathlib import Path

import pytest

from demcal.calibrate.pipeline import open_study
from demcal.calibrate.rangefind import rangefind
from demcal.report.tables import rangefind_responses_table
from demcal.summaries import RangeFind

A, B = "pp.static_friction", "pp.rolling_friction"
#: the angle 30 + 15 (a - 0.6) + 25 (b - 0.2); the drum 35 + 40 (b - 0.2); the density
#: 200 - 10 (a - 0.6): over the scans the drum spans 27..43 and the density 196..204
ANALYTIC = ('base_deg = 30.0\nnoise_deg = 0.05\n'
            f'centre = {{ "{A}" = 0.6, "{B}" = 0.2 }}\n'
            f'linear = {{ "{A}" = 15.0, "{B}" = 25.0 }}\n'
            f'responses = {{ "drum_deg" = {{ "base" = 35.0, "noise" = 0.05, "linear" = '
            f'{{ "{B}" = 40.0 }} }}, "bulk_density_kg_m3" = {{ "base" = 200.0, "noise" = 0.05, '
            f'"linear" = {{ "{A}" = -10.0 }} }} }}\n')


def _study(folder: Path, *, others: bool) -> Path:
    lines = ['name = "scan every response"', "seed = 4", "replicates = 1", "",
             "[material]", 'preset = "corn_stalk"', "",
             "[target]", "aor_deg = 31.0", "std_deg = 0.5", "n = 5", "",
             "[[factors]]", f'name = "{A}"', 'symbol = "x3"', "low = 0.2", "high = 1.0", "",
             "[[factors]]", f'name = "{B}"', 'symbol = "x4"', "low = 0.0", "high = 0.4", ""]
    if others:  # the drum's lab value inside its span, the density's beyond it
        lines += ["[[responses]]", 'name = "drum_deg"', "target = 36.0", "std = 0.5", "n = 5",
                  "", "[[responses]]", 'name = "bulk_density_kg_m3"', "target = 230.0",
                  "std = 1.0", "n = 5", ""]
    lines += ["[test]", 'kind = "analytic"', "", "[test.analytic]", ANALYTIC,
              "[stages.rangefind]", "points = 5", "",
              "[executor]", "workers = 1", ""]
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "study.toml").write_text("\n".join(lines))
    return folder / "study.toml"


def _scan(path: Path) -> tuple[RangeFind, dict]:
    ctx = open_study(path)
    try:
        found = rangefind(ctx)
        return found, ctx.store.stage("rangefind").summary
    finally:
        ctx.store.close()


@pytest.fixture(scope="module")
def both(tmp_path_factory) -> dict[str, tuple[RangeFind, dict]]:
    root = tmp_path_factory.mktemp("scan")
    return {name: _scan(_study(root / name, others=others))
            for name, others in (("angle", False), ("three", True))}


def test_each_other_response_s_span_and_lab_value_are_said(both) -> None:
    found, stored = both["three"]
    drum, density = found.responses  # type: ignore[misc]
    assert drum.name == "drum_deg" and drum.in_range is True and drum.lab == 36.0
    assert drum.low == pytest.approx(35.0 - 40 * 0.2, abs=0.3)
    assert drum.high == pytest.approx(35.0 + 40 * 0.2, abs=0.3)
    assert density.name == "bulk_density_kg_m3" and density.in_range is False
    assert density.low == pytest.approx(196.0, abs=0.3) and density.high == pytest.approx(
        204.0, abs=0.3)
    assert "bulk_density_kg_m3 195.94..203.96" in found.message
    assert "(lab 230 outside: no scan reached it)" in found.message
    assert "drum_deg 27.05..42.99" in found.message and "(lab 36 inside)" in found.message
    # stored and read back; the report's table
    assert RangeFind.from_summary(stored) == found
    assert [r["name"] for r in stored["responses"]] == ["drum_deg", "bulk_density_kg_m3"]
    table = rangefind_responses_table(found)
    assert table is not None and list(table.frame["lab inside"]) == ["yes", "no"]


def test_the_ranges_follow_the_lead_alone(both) -> None:
    angle, _ = both["angle"]
    three, _ = both["three"]
    assert [(f.new_low, f.new_high) for f in three.factors] == \
        [(f.new_low, f.new_high) for f in angle.factors]


def test_one_response_stores_no_other_responses(both) -> None:
    found, stored = both["angle"]
    assert found.responses is None and "responses" not in stored
    assert "other responses" not in found.message
    assert rangefind_responses_table(found) is None
