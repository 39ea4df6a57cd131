"""Screening with several responses (issue 37: every stage fits one model per response): each
response's main-effects model over the same Plackett-Burman runs, and a factor that moves only
another test's response is selected for the next stage; with the angle alone it is not."""

from __future__ import annotations

from pathlib import Path

import pytest

from demcal.calibrate.pipeline import open_study
from demcal.calibrate.stages import screening
from demcal.report.tables import screening_responses_table
from demcal.store import RunStore
from demcal.summaries import Screening

R, A, B, C = ("pp.restitution", "pp.static_friction", "pp.rolling_friction",
              "pw.static_friction")
FACTORS = {R: ("x2", 0.2, 0.6), A: ("x3", 0.2, 1.0), B: ("x4", 0.0, 0.4), C: ("x6", 0.3, 0.8)}
#: the angle moves with A and B only; the drum with C only
ANALYTIC = ('base_deg = 30.0\nnoise_deg = 0.1\n'
            f'centre = {{ "{A}" = 0.6, "{B}" = 0.2, "{C}" = 0.55 }}\n'
            f'linear = {{ "{A}" = 15.0, "{B}" = 25.0 }}\n'
            f'responses = {{ "drum_deg" = {{ "base" = 35.0, "noise" = 0.1, "linear" = '
            f'{{ "{C}" = 40.0 }} }} }}\n')


def _study(folder: Path, *, drum: bool) -> Path:
    lines = ['name = "screen every response"', "seed = 2", "replicates = 1", "",
             "[material]", 'preset = "corn_stalk"', "",
             "[target]", "aor_deg = 31.0", "std_deg = 0.5", "n = 5", ""]
    for name, (sym, lo, hi) in FACTORS.items():
        lines += ["[[factors]]", f'name = "{name}"', f'symbol = "{sym}"', f"low = {lo}",
                  f"high = {hi}", ""]
    if drum:
        lines += ["[[responses]]", 'name = "drum_deg"', "target = 36.0", "std = 0.5", "n = 5",
                  ""]
    lines += ["[test]", 'kind = "analytic"', "", "[test.analytic]", ANALYTIC,
              "[stages.rangefind]", "enabled = false", "",
              "[stages.screening]", "runs = 12", "alpha = 0.01", "max_factors = 3",
              "min_factors = 2", "",
              "[executor]", "workers = 1", ""]
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "study.toml").write_text("\n".join(lines))
    return folder / "study.toml"


def _screen(path: Path) -> Screening:
    ctx = open_study(path)
    try:
        return screening(ctx)
    finally:
        ctx.store.close()


@pytest.fixture(scope="module")
def both(tmp_path_factory) -> dict[str, Screening]:
    root = tmp_path_factory.mktemp("screen")
    return {name: _screen(_study(root / name, drum=drum))
            for name, drum in (("angle", False), ("two", True))}


def test_a_factor_only_the_drum_feels_is_selected_with_the_drum(both) -> None:
    angle, two = both["angle"], both["two"]
    assert set(angle.selected) == {A, B} and angle.responses is None
    assert set(two.selected) == {A, B, C}
    drum = two.responses["drum_deg"]  # type: ignore[index]
    assert drum.effects[0].term == C and drum.effects[0].p < 1e-6
    assert drum.effects[0].effect == pytest.approx(40.0 * 0.5, rel=0.05)  # +1 vs -1: 0.5 wide
    assert "drum_deg: pw.static_friction" in (two.message or "")
    # the lead's own model is the angle's, as alone
    assert [e.term for e in two.effects or []][:2] == [e.term for e in angle.effects or []][:2]


def test_the_stored_summary_reads_back_and_the_report_shows_every_response(both, tmp_path):
    two = both["two"]
    assert Screening.from_summary(two.to_summary()) == two
    table = screening_responses_table(two, {C: "x6"})
    assert list(table.frame.columns) == ["term", "AoR effect", "AoR p", "drum_deg effect",
                                         "drum_deg p"]
    row = table.frame[table.frame["term"] == "x6"].iloc[0]
    assert abs(row["drum_deg effect"]) > 10 > abs(row["AoR effect"])


def test_a_resumed_screening_runs_nothing_again(tmp_path) -> None:
    path = _study(tmp_path / "again", drum=True)
    first = _screen(path)
    with RunStore(path.parent) as store:
        n = store.count()
    assert _screen(path) == first
    with RunStore(path.parent) as store:
        assert store.count() == n
