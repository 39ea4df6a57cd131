"""Model diagnostics: checked against leave-one-out refits and known transforms."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from demcal import doe
from demcal.report.diagnostics import (
    adequacy_checks,
    model_diagnostics,
    refit,
    verdict,
)
from demcal.report.model_figures import (
    boxcox_figure,
    pair_contours_figure,
    pair_surface_figure,
    perturbation_figure,
    residual_figure,
    target_reached,
)
from demcal.report.surface import StoredSurface
from demcal.summaries import FitStatistics, Screening, Surface


def _bbd(y_of, seed=0, noise=0.3):
    d = doe.box_behnken(3, center_points=3, randomize=False)
    rng = np.random.default_rng(seed)
    y = y_of(d.coded) + noise * rng.standard_normal(d.n_runs)
    return d, y


def test_studentized_residuals_and_cooks_distance_match_leave_one_out():
    d, y = _bbd(lambda x: 40 + 2 * x[:, 0] - x[:, 1] + 0.5 * x[:, 0] * x[:, 2] - x[:, 1] ** 2)
    y[4] += 3.0  # one odd run
    rs = doe.fit(d, y, model="quadratic")
    diag = model_diagnostics(rs)
    n, p = rs.n_runs, rs.n_params
    x = rs.model_matrix
    for i in range(n):
        keep = np.arange(n) != i
        b, *_ = np.linalg.lstsq(x[keep], y[keep], rcond=None)
        s_i = math.sqrt(np.sum((y[keep] - x[keep] @ b) ** 2) / (n - 1 - p))
        t_i = (y[i] - rs.fitted[i]) / (s_i * math.sqrt(1 - rs.leverage[i]))
        assert diag.studentized[i] == pytest.approx(t_i, rel=1e-9)
        cook = np.sum((x @ b - rs.fitted) ** 2) / (p * rs.mse)
        assert diag.cooks[i] == pytest.approx(cook, rel=1e-9)
    assert diag.leverage_limit == pytest.approx(2 * p / n)
    assert np.argmax(np.abs(diag.studentized)) == 4
    # normal plot positions: sorted residuals get increasing quantiles
    order = np.argsort(diag.studentized)
    assert np.all(np.diff(diag.normal_quantile[order]) > 0)


def test_box_cox_recommends_log_for_a_multiplicative_response_and_none_for_additive():
    d = doe.central_composite(2, kind="face", center_points=5, randomize=False)
    rng = np.random.default_rng(3)
    lin = 1.5 * d.coded[:, 0] + 0.8 * d.coded[:, 1]
    y_mult = np.exp(lin + 0.03 * rng.standard_normal(d.n_runs))
    diag = model_diagnostics(doe.fit(d, y_mult, model="linear"))
    assert diag.boxcox_low <= 0.0 <= diag.boxcox_high and not diag.boxcox_high >= 1.0
    assert diag.recommended.startswith("natural log")
    y_add = 40 + 3 * lin + 0.3 * rng.standard_normal(d.n_runs)
    diag = model_diagnostics(doe.fit(d, y_add, model="linear"))
    assert diag.boxcox_low <= 1.0 <= diag.boxcox_high and diag.recommended == "none"


def _summary(d, y, rs, **fit) -> Surface:
    return Surface.from_summary(_stored(d, y, rs, **fit))


def _stored(d, y, rs, **fit):
    return {"factors": [{"name": n, "symbol": n, "low": -1.0, "high": 1.0} for n in d.names],
            "runs": [{"point": i, "coded": dict(zip(d.names, map(float, row), strict=True)),
                      "actual": dict(zip(d.names, map(float, row), strict=True)),
                      "aor_deg": float(v)} for i, (row, v) in enumerate(zip(d.coded, y,
                                                                             strict=True))],
            "coefficients_coded": {k: float(v) for k, v in rs.coefficients_coded.items()},
            "fit": {**rs.anova().fit.to_dict(), **fit}, "lack_of_fit_p": None}


def test_refit_rebuilds_the_stored_model_and_the_checks_decide_the_verdict():
    d, y = _bbd(lambda x: 40 + 2 * x[:, 0] - x[:, 1] ** 2)
    rs = doe.fit(d, y, model="quadratic")
    s = _summary(d, y, rs)
    again = refit(s, "rsm")
    assert np.allclose(again.fitted, rs.fitted) and again.term_names == rs.term_names
    checks = adequacy_checks(s, again, model_diagnostics(again))
    assert verdict(checks)
    bad = adequacy_checks(replace(s, fit=replace(s.fit, pred_r2=0.06)), again,
                          model_diagnostics(again))
    assert not verdict(bad)
    assert [c.name for c in bad if c.result == "FAIL"] == ["predicted R²"]
    # the stage's stored statistics of the means take precedence over the rows' fit
    stated = FitStatistics(p_model=1e-6, r2=s.fit.r2, adj_r2=s.fit.adj_r2, pred_r2=-0.3,
                           adeq_precision=s.fit.adeq_precision)
    means = adequacy_checks(replace(s, adequacy=stated), again,
                            model_diagnostics(again))
    assert [c.name for c in means if c.result == "FAIL"] == ["predicted R²"]
    lof = adequacy_checks(replace(s, lack_of_fit_p=0.01), again, model_diagnostics(again))
    assert not verdict(lof)


def test_screening_refit_is_the_linear_main_effects_model():
    d = doe.plackett_burman(5, n_runs=12, randomize=False)
    y = 30 + 3 * d.coded[:, 0] + np.linspace(-0.2, 0.2, d.n_runs)
    s = {"factors": [{"name": n} for n in d.names],
         "runs": [{"point": i, "coded": dict(zip(d.names, map(float, r), strict=True)),
                   "aor_deg": float(v)} for i, (r, v) in enumerate(zip(d.coded, y,
                                                                      strict=True))]}
    s["runs"][2]["aor_deg"] = None  # no pile: excluded
    rs = refit(Screening.from_summary(s), "screening")
    assert rs.n_params == 6 and rs.n_runs == d.n_runs - 1
    assert list(model_diagnostics(rs).labels) == [i for i in range(d.n_runs) if i != 2]


def test_figures_draw_and_the_target_contour_is_only_drawn_when_reached():
    d, y = _bbd(lambda x: 40 + 2 * x[:, 0] + x[:, 1])
    rs = doe.fit(d, y, model="quadratic")
    s = StoredSurface.from_surface(_summary(d, y, rs))
    diag = model_diagnostics(rs)
    assert len(residual_figure(diag).axes) == 6
    assert len(boxcox_figure(diag).axes) == 1
    fig = perturbation_figure(s, {"x1": 0.5, "x2": -0.4}, 40.0)
    curves = fig.axes[0].get_lines()[:3]  # one per factor, then the reference and target
    at_ref = [np.interp(0.0, c.get_xdata(), c.get_ydata()) for c in curves]
    assert max(at_ref) - min(at_ref) < 1e-3  # all through the reference point
    assert [c.get_xdata()[0] for c in curves] == pytest.approx([-1.5, -0.6, -1.0])
    assert target_reached(s, ("x1", "x2"), None, 40.0)
    assert not target_reached(s, ("x1", "x2"), None, 90.0)
    reached = pair_surface_figure(s, ("x1", "x2"), None, 40.0)
    missed = pair_surface_figure(s, ("x1", "x2"), None, 90.0)
    assert "target reached" in reached.get_suptitle()
    assert "target not reached" in missed.get_suptitle()
    red = [c for c in reached.axes[1].collections if getattr(c, "get_linewidths", None)
           and max(c.get_linewidths(), default=0) >= 2]
    assert red
    grid = pair_contours_figure(s, [("x1", "x2"), ("x1", "x3"), ("x2", "x3")], None, 40.0)
    assert len([a for a in grid.axes if a.get_xlabel()]) == 3


def test_the_rsm_table_shows_each_points_replicates_and_their_spread():
    from demcal.report.tables import rsm_design_table
    from demcal.summaries import Surface

    s = {"design": "box_behnken", "factors": [{"name": "a", "symbol": "x1"}],
         "runs": [{"point": 0, "coded": {"a": -1.0}, "actual": {"a": 0.1}, "aor_deg": 41.0,
                   "aor_runs_deg": [40.0, 42.0], "aor_std_deg": 1.4142, "outcome": "pile"}]}
    frame = rsm_design_table(Surface.from_summary(s), {}).frame
    assert list(frame["replicates (deg)"]) == ["40.00, 42.00"]
    assert abs(frame["std (deg)"][0] - 1.4142) < 1e-9
    s["runs"][0].update(aor_runs_deg=[41.0], aor_std_deg=None)
    assert "std (deg)" not in rsm_design_table(Surface.from_summary(s), {}).frame
