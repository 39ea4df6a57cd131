"""Studies that use the noise: replicate rows in the fit, Design-Expert's adequacy rules,
extra replicates within a run budget, verification sized to a 95 % interval, common seeds."""

from __future__ import annotations

import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest

from demcal import doe
from demcal.calibrate import calibrate
from demcal.calibrate.stages import adequacy, choose_model
from demcal.calibrate.verify import verification_size
from demcal.store import RunStore

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "analytic" / "study.toml"


def _write(tmp_path: Path, edit) -> Path:
    text = EXAMPLE.read_text()
    path = tmp_path / "study.toml"
    shutil.copy(EXAMPLE, path)
    path.write_text(edit(text))
    tomllib.loads(path.read_text())  # still valid TOML
    return path


def _bbd(y_fn, noise: float, seed: int = 0):
    d = doe.box_behnken(3, center_points=3, randomize=False)
    rng = np.random.default_rng(seed)
    y = np.array([y_fn(row) for row in d.coded]) + noise * rng.standard_normal(d.n_runs)
    return doe.fit(d, y, model="quadratic")


def test_adequacy_rejects_a_model_that_does_not_predict():
    clean = _bbd(lambda x: 40 + 5 * x[0] - 3 * x[1] + 2 * x[0] ** 2, noise=0.3)
    verdict = adequacy(clean, None)
    assert verdict.adequate and verdict.failed == () and verdict.statistics.pred_r2 > 0.9
    assert list(verdict.statistics.to_summary()) == [  # the stored keys (rsm_adequacy)
        "p_model", "lack_of_fit_p", "r2", "adj_r2", "pred_r2", "adeq_precision"]
    noisy = _bbd(lambda x: 40 + 0.5 * x[0], noise=4.0, seed=3)
    verdict = adequacy(noisy, None)
    assert not verdict.adequate
    assert any("predicted R^2" in f for f in verdict.failed)
    stats = verdict.statistics
    assert stats.pred_r2 < stats.adj_r2 - 0.2 or stats.pred_r2 < 0


def test_verification_size_reaches_the_half_width():
    v = np.array([40.0, 42.0, 38.0])  # s = 2: t(n-1) 2 / sqrt(n) <= 1.5 first at n = 10
    assert verification_size(v, 1.5, 50) == 10
    assert verification_size(v, 1.5, 6) == 6
    assert verification_size(np.array([40.0, 40.1, 39.9]), 1.5, 12) == 3
    # three runs that happen to agree do not stop a test known to scatter 4 deg (the
    # response surface's pure error): t(n-1) 4 / sqrt(n) <= 1.5 first at n = 30
    assert verification_size(np.array([40.0, 40.1, 39.9]), 1.5, 50, sigma=4.0) == 30
    assert verification_size(np.array([40.0, 40.1, 39.9]), 1.5, 20, sigma=4.0) == 20
    assert verification_size(v, 1.5, 50, sigma=1.0) == 10  # the runs' own 2 deg rules
    # with the pure error's degrees of freedom the two are pooled, each weighted by its df:
    # a pure error of 4 deg from 32 df still holds three agreeing runs back (pooled 3.9 deg:
    # t(n-1) 3.9 / sqrt(n) <= 1.5 first at n = 29) ...
    assert verification_size(np.array([40.0, 40.1, 39.9]), 1.5, 50, sigma=4.0,
                             sigma_df=32) == 29
    # ... but three centre points (2 df) do not outweigh the LAMMPS standard study's first
    # 8 verification piles (std 2.07, 7 df): pooled 2.61 deg, +/- 2 deg at 10 runs, not 18
    piles = np.array([45.19, 49.17, 49.87, 43.72, 45.77, 47.76, 45.82, 47.06])
    assert verification_size(piles, 2.0, 20, sigma=3.94, sigma_df=2) == 10
    assert verification_size(piles, 2.0, 20, sigma=3.94) == 18  # sigma taken as exact


@pytest.fixture(scope="module")
def noisy_study(tmp_path_factory):
    """The analytic study with 3 deg of noise: the BBD at one replicate is not adequate, so
    the stage adds replicates within its budget of 3 x 15 runs; verification grows too."""
    def edit(text: str) -> str:
        text = text.replace("noise_deg = 0.3", "noise_deg = 3.0")
        text = text.replace("center_points = 3", "center_points = 3\nmax_runs = 45")
        return text.replace("[stages.verification]\nn = 3",
                            "[stages.verification]\nn = 3\nhalf_width_deg = 1.5\nmax_n = 10")
    path = _write(tmp_path_factory.mktemp("noisy"), edit)
    return calibrate(path), path


def test_rsm_adds_replicates_until_adequate_or_the_budget_is_spent(noisy_study):
    res, path = noisy_study
    with RunStore(path.parent) as store:
        rsm = store.stage("rsm").summary
        rounds = rsm["rounds"]
        assert [r["replicates"] for r in rounds] == list(range(1, len(rounds) + 1))
        assert len(rounds) >= 2 and not rounds[0]["adequate"]
        assert rounds[-1]["adequate"] or rounds[-1]["runs"] == 45
        reps = rsm["replicates"]
        assert len(store.runs(stage="rsm")) == 15 * reps
        # every replicate is a row: pure error has 15 (reps - 1) + 2 df
        pe = next(r for r in rsm["anova"] if r["term"] == "Pure Error")
        assert pe["df"] == 15 * (reps - 1) + 2
        spreads = [row["aor_std_deg"] for row in rsm["runs"]]
        assert all(s is not None and s >= 0 for s in spreads)
    assert res["rsm_adequate"] == rsm["adequate"]


def test_verification_adds_runs_for_its_interval(noisy_study):
    res, path = noisy_study
    v = res["verification"]
    with RunStore(path.parent) as store:
        ver = store.stage("verification").summary
    assert v["n"] == len(ver["aor_deg"]) and 3 < v["n"] <= 10
    assert ver["half_width_reached"] == (ver["half_width_deg"] <= 1.5)
    assert ver["half_width_reached"] or v["n"] == 10


def test_common_seeds_share_the_seed_set_but_not_between_centre_points(tmp_path):
    def edit(text: str) -> str:
        text = text.replace("replicates = 1", "replicates = 2\ncommon_seeds = true")
        return text.replace("runs = 12", "runs = 12\nreplicates = 1")  # screening: its own

    path = _write(tmp_path, edit)
    calibrate(path)
    with RunStore(path.parent) as store:
        assert len(store.runs(stage="screening")) == 12
        assert len(store.runs(stage="steepest")) == 2 * 5
        runs = store.runs(stage="rsm")
        by_point: dict[int, set[int]] = {}
        for r in runs:
            by_point.setdefault(r.point, set()).add(r.seed)
        seed_sets = {frozenset(s) for s in by_point.values()}
        # 12 edge points share {1, 1001}; the 3 centre points take copies 0, 1, 2
        assert frozenset({1, 1001}) in seed_sets and len(seed_sets) == 3
        ver = store.runs(stage="verification")
        assert all(r.seed >= 10_000 for r in ver)  # verification keeps fresh seeds
        # each replicate round (a seed set) is a block of the rows' ANOVA, as Design-Expert's
        rsm = store.stage("rsm").summary
        assert rsm["anova"][0]["term"] == "Block" and rsm["anova"][0]["df"] == 1
        assert rsm["rounds"][-1]["blocks"] == 2
        pe = next(r for r in rsm["anova"] if r["term"] == "Pure Error")
        assert pe["df"] == 15 * (2 - 1) + 2 - 1


def _replicated_bbd(truth, noise: float, reps: int, seed: int):
    """A 3-factor Box-Behnken run ``reps`` times: (rows fit, means fit) of the full model."""
    d = doe.box_behnken(3, center_points=3, randomize=False)
    rng = np.random.default_rng(seed)
    y = np.array([[truth(x) for x in d.coded]] * reps)
    y = y + noise * rng.standard_normal(y.shape)
    rows = doe.fit(np.vstack([d.coded] * reps), y.ravel(), names=d.names, units="coded")
    return rows, doe.fit(d, y.mean(axis=0))


def _linear(x):
    return 40 + 4 * x[0] - 2 * x[1]


def test_auto_model_reduces_a_full_model_that_does_not_predict():
    rows, means = _replicated_bbd(_linear, noise=3.0, reps=3, seed=5)
    full = choose_model("quadratic", 0.1, rows, means)
    assert full.kind == "quadratic" and not full.adequacy.adequate
    assert any("predicted R^2" in f for f in full.adequacy.failed)
    auto = choose_model("auto", 0.1, rows, means)
    assert auto.kind == "reduced" and auto.adequacy.adequate
    assert auto.adequacy.statistics.pred_r2 > 0.5
    # every square and interaction of a linear truth leaves; the true main effects stay
    assert {"x1^2", "x2^2", "x3^2", "x1*x2", "x1*x3", "x2*x3"} <= set(auto.removed_terms)
    assert {"x1", "x2"} <= set(auto.chosen.rows.term_names)
    assert auto.full.adequacy == full.adequacy
    assert auto.notes and "reduced model" in auto.notes[0]


def test_auto_model_keeps_an_adequate_full_model():
    rows, means = _replicated_bbd(
        lambda x: 40 + 5 * x[0] - 3 * x[1] + 2 * x[0] ** 2 + 2 * x[0] * x[2], 0.3, 2, 0)
    auto = choose_model("auto", 0.1, rows, means)
    assert auto.adequacy.adequate and auto.kind == "quadratic" and auto.removed_terms == ()
    assert auto.full is auto.chosen
    assert choose_model("reduced", 0.1, rows, means).kind == "reduced"


def test_the_reduced_model_predicts_new_runs_better():
    """Over 12 noisy replicated designs of a linear truth, the model 'auto' chooses predicts
    the truth on a grid with a smaller mean squared error than the full quadratic (measured:
    0.84 of it; 0.78 over 40 designs) and does so for most designs."""
    grid = np.array(np.meshgrid(*[np.linspace(-1, 1, 5)] * 3)).reshape(3, -1).T
    truth = np.array([_linear(x) for x in grid])
    err_full, err_auto = [], []
    for seed in range(12):
        rows, means = _replicated_bbd(_linear, noise=3.0, reps=3, seed=seed)
        auto = choose_model("auto", 0.1, rows, means).chosen.rows
        err_full.append(np.mean((rows.predict(grid, units="coded") - truth) ** 2))
        err_auto.append(np.mean((auto.predict(grid, units="coded") - truth) ** 2))
    assert np.mean(err_auto) < 0.9 * np.mean(err_full)
    assert np.mean(np.array(err_auto) < np.array(err_full)) > 0.5


def test_a_study_reads_its_optimum_from_the_reduced_model_and_reports_both(tmp_path):
    from demcal.report import build_report

    def edit(text: str) -> str:
        return text.replace("center_points = 3",
                            'center_points = 3\nmodel = "reduced"\nalpha_out = 0.05')
    path = _write(tmp_path, edit)
    res = calibrate(path)
    with RunStore(path.parent) as store:
        rsm = store.stage("rsm").summary
    assert rsm["model"] == res["rsm_model"] == "reduced"
    assert rsm["removed_terms"] and rsm["removed_terms"] == res["rsm_removed_terms"]
    kept = set(rsm["coefficients_coded"])
    assert not kept & set(rsm["removed_terms"])
    full_terms = {r["term"] for r in rsm["anova_full"]}
    assert set(rsm["removed_terms"]) <= full_terms
    assert any("reduced model" in w for w in rsm["warnings"])
    html = Path(build_report(path.parent)).read_text()
    assert "ANOVA of the full quadratic model" in html
    assert "ANOVA of the reduced response surface" in html


def test_common_seed_blocks_fall_back_to_no_blocks_when_a_run_failed():
    from demcal.calibrate.surface_fit import fit_rows as _fit_rows
    from demcal.calibrate.surface_fit import replicated as _replicated

    d = doe.box_behnken(3, center_points=3, randomize=False)
    rng = np.random.default_rng(2)
    runs = [[_linear(x) + rng.normal() for _ in range(3)] for x in d.coded]
    rep, y = _replicated(d, runs, 3)
    blocked, notes = _fit_rows(rep, y, 3, common_seeds=True)
    assert blocked.block_df == 2 and notes == []
    plain, notes = _fit_rows(rep, y, 3, common_seeds=False)
    assert plain.block_df == 0 and notes == []
    y[4] = np.nan  # one run without a pile
    fallback, notes = _fit_rows(rep, y, 3, common_seeds=True)
    assert fallback.block_df == 0
    assert len(notes) == 1 and "not used as blocks" in notes[0]


def test_an_inadequate_surface_says_how_many_replicates_would_resolve_it(tmp_path):
    """The budget allows one replicate of a 6-deg-noise test: the stage says how far the
    largest main effect was from seen, and what would see it."""
    def edit(text: str) -> str:
        text = text.replace("noise_deg = 0.3", "noise_deg = 6.0")
        text = text.replace("[stages.verification]\nn = 3", "[stages.verification]\nn = 3\n"
                            "max_rounds = 2\ntolerance_percent = 0.5")  # a second round
        return text.replace("center_points = 3", "center_points = 3\nmax_runs = 15")

    path = _write(tmp_path, edit)
    res = calibrate(path)
    with RunStore(path.parent) as store:
        rsm = store.stage("rsm").summary
    assert not rsm["adequate"]
    note = rsm["resolution"]
    assert note.startswith("its largest main effect, ") and "standard errors from zero" in note
    assert "replicates of each design point" in note
    assert res["rsm_resolution"] == note  # the result says it, and so the command line
    from demcal.report import build_report
    from demcal.summaries import CalibrationResult

    assert CalibrationResult.from_summary(res).surface.resolution == note
    html = build_report(path.parent).read_text()
    assert "Not resolved: its largest main effect" in html
    # and the command line, resuming (nothing runs): the note, and what its confirmation is worth
    from typer.testing import CliRunner

    from demcal.cli import app

    out = CliRunner().invoke(app, ["calibrate", str(path), "--no-report"])
    text = " ".join(out.output.split())
    assert out.exit_code == 0, out.output
    assert note in text
    assert res["verification"]["confirmed"]  # the 6 deg test's wide interval holds the mean
    assert "its wide interval confirms little" in text
    # the second round was aimed by that surface: the command says what the aim is worth
    assert len(res["rounds"]) == 2
    assert "the surface is not adequate, so each aim moved the optimum within the noise" in text


def test_the_resolution_note_counts_the_runs_and_knows_its_limits():
    from demcal.calibrate.surface_fit import MANY_REPLICATES, resolution_note

    weak = _bbd(lambda x: 40 + 1.0 * x[0], noise=3.0, seed=5)
    note = resolution_note(weak, 1, 15)
    assert note is not None and "from the centre to the high level" in note
    need = int(note.split("about ")[1].split(" replicates")[0])
    assert f"({need * 15} runs)" in note and need > 1
    # the same t seen at 2 replicates of each point: twice the replicates (the noise is
    # larger than the fit at one replicate suggested)
    twice = resolution_note(weak, 2, 15)
    assert twice is not None and f"about {2 * need} replicates" in twice
    strong = _bbd(lambda x: 40 + 8 * x[0], noise=0.3)
    assert resolution_note(strong, 1, 15) is None
    # a main effect of 0.05 deg in 3 deg of noise (the residual orthogonal to every term)
    d = doe.box_behnken(3, center_points=3, randomize=False)
    X = doe.fit(d, d.coded[:, 0], model="quadratic").model_matrix
    e = np.random.default_rng(2).standard_normal(d.n_runs)
    e -= X @ np.linalg.lstsq(X, e, rcond=None)[0]
    e *= 3.0 * np.sqrt(5 / (e @ e))
    flat = doe.fit(d, 40 + 0.05 * d.coded[:, 0] + e, model="quadratic")
    far = resolution_note(flat, 1, 15)
    assert far is not None and f"more than {MANY_REPLICATES} replicates" in far
