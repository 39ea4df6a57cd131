"""Response-surface fits against statsmodels OLS and against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
import statsmodels.api as sm
from statsmodels.stats.outliers_influence import variance_inflation_factor

from demcal import doe
from demcal.errors import InputError


def _random_case(seed: int, model: str, k: int, n: int):
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1.2, 1.2, size=(n, k))
    # replicate a few rows so lack of fit / pure error exist
    x[-3:] = x[:3]
    y = rng.normal(10, 3, size=n)
    return x, y


@pytest.mark.parametrize(
    ("seed", "model", "k", "n"),
    [(1, "linear", 4, 12), (2, "2fi", 3, 14), (3, "quadratic", 3, 18), (4, "quadratic", 4, 25)],
)
def test_matches_statsmodels_ols(seed, model, k, n):
    x, y = _random_case(seed, model, k, n)
    rs = doe.fit(x, y, model=model)
    X = rs.model_matrix
    ols = sm.OLS(y, X).fit()
    np.testing.assert_allclose(rs.params, ols.params, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(rs.bse.to_numpy(), ols.bse, rtol=1e-9)
    np.testing.assert_allclose(rs.pvalues.to_numpy(), ols.pvalues, rtol=1e-7, atol=1e-14)
    assert rs.r2 == pytest.approx(ols.rsquared, rel=1e-12)
    assert rs.adj_r2 == pytest.approx(ols.rsquared_adj, rel=1e-12)
    assert rs.ss_resid == pytest.approx(ols.ssr, rel=1e-12)
    assert rs.f_value == pytest.approx(ols.fvalue, rel=1e-9)
    assert rs.f_pvalue == pytest.approx(ols.f_pvalue, rel=1e-7)
    # partial (Type III) SS: drop one column, compare residual sums of squares
    for j, name in enumerate(rs.term_names[1:], start=1):
        reduced = sm.OLS(y, np.delete(X, j, axis=1)).fit()
        assert rs.ss_partial[name] == pytest.approx(reduced.ssr - ols.ssr, rel=1e-8)
        row = rs.anova()[name]
        f = (reduced.ssr - ols.ssr) / ols.mse_resid
        assert row.f == pytest.approx(f, rel=1e-8)
    # PRESS from statsmodels' influence (leave-one-out residuals)
    infl = ols.get_influence()
    press = float(np.sum(infl.resid_press**2))
    assert rs.press == pytest.approx(press, rel=1e-9)
    np.testing.assert_allclose(rs.leverage, infl.hat_matrix_diag, rtol=1e-10)
    # VIF: statsmodels regresses each column on all the others (intercept included)
    vif = [variance_inflation_factor(X, j) for j in range(1, X.shape[1])]
    np.testing.assert_allclose(rs.vif.to_numpy(), vif, rtol=1e-8)


def test_prediction_intervals_match_statsmodels():
    x, y = _random_case(5, "quadratic", 3, 20)
    rs = doe.fit(x, y, model="quadratic")
    ols = sm.OLS(y, rs.model_matrix).fit()
    pts = np.array([[0.0, 0.0, 0.0], [0.5, -0.3, 0.9], [-1.0, 1.0, 1.0]])
    got = rs.predict_interval(pts, alpha=0.1)
    frame = ols.get_prediction(doe.model_matrix(pts, rs.terms)).summary_frame(alpha=0.1)
    np.testing.assert_allclose(got["predicted"], frame["mean"], rtol=1e-10)
    np.testing.assert_allclose(got["se_mean"], frame["mean_se"], rtol=1e-9)
    np.testing.assert_allclose(got["ci_low"], frame["mean_ci_lower"], rtol=1e-9)
    np.testing.assert_allclose(got["pi_high"], frame["obs_ci_upper"], rtol=1e-9)
    np.testing.assert_allclose(rs.predict(pts), frame["mean"], rtol=1e-10)


def test_confirmation_interval_for_the_mean_of_n_runs_matches_statsmodels():
    # Design-Expert's confirmation: the PI for the mean of n new runs; statsmodels gives it
    # as the observation interval with weights n (residual variance / n)
    x, y = _random_case(5, "quadratic", 3, 20)
    rs = doe.fit(x, y, model="quadratic")
    ols = sm.OLS(y, rs.model_matrix).fit()
    pts = np.array([[0.2, -0.4, 0.7]])
    x0 = doe.model_matrix(pts, rs.terms)
    for n in (1, 4, 12):
        got = rs.predict_interval(pts, n_new=n)
        frame = ols.get_prediction(x0, weights=n).summary_frame(alpha=0.05)
        np.testing.assert_allclose(got["pi_low"], frame["obs_ci_lower"], rtol=1e-9)
        np.testing.assert_allclose(got["pi_high"], frame["obs_ci_upper"], rtol=1e-9)
    wide, narrow = rs.predict_interval(pts), rs.predict_interval(pts, n_new=12)
    width = (narrow["pi_high"] - narrow["pi_low"]).iloc[0]
    assert width < (wide["pi_high"] - wide["pi_low"]).iloc[0]
    with pytest.raises(InputError, match="n_new"):
        rs.predict_interval(pts, n_new=0)


def test_lack_of_fit_and_pure_error_by_hand():
    d = doe.box_behnken(3, center_points=4, randomize=False)
    rng = np.random.default_rng(3)
    y = rng.normal(size=d.n_runs)
    rs = doe.fit(d, y, model="quadratic")
    centre = y[-4:]
    ss_pe = float(np.sum((centre - centre.mean()) ** 2))
    table = rs.anova()
    assert table["Pure Error"].ss == pytest.approx(ss_pe)
    assert table["Pure Error"].df == 3
    assert table["Lack of Fit"].df == rs.df_resid - 3
    assert table["Lack of Fit"].ss + table["Pure Error"].ss == pytest.approx(rs.ss_resid)
    assert table["Cor Total"].ss == pytest.approx(np.sum((y - y.mean()) ** 2))


def test_no_replicates_means_no_lack_of_fit_rows():
    d = doe.box_behnken(3, center_points=1, randomize=False)
    rs = doe.fit(d, np.arange(d.n_runs, dtype=float) ** 1.5, model="quadratic")
    assert "Lack of Fit" not in rs.anova().sources
    assert "Pure Error" not in rs.anova().sources


def test_actual_coefficients_reproduce_the_coded_polynomial():
    space = doe.FactorSpace(
        [doe.Factor("a", 0.35, 0.7), doe.Factor("b", 10.0, 30.0), doe.Factor("c", -2.0, 4.0)]
    )
    d = doe.central_composite(space, randomize=False)
    rng = np.random.default_rng(0)
    y = rng.normal(size=d.n_runs)
    rs = doe.fit(d, y, model="quadratic")
    act = rs.coefficients_actual
    pts = space.to_actual(rng.uniform(-1.5, 1.5, size=(7, 3)))
    by_actual = doe.model_matrix(pts, rs.terms) @ act[list(rs.term_names)].to_numpy()
    np.testing.assert_allclose(by_actual, rs.predict(pts, units="actual"), rtol=1e-9)
    # a case by hand: y = 1 + 2 A with A = (a - 0.525) / 0.175 -> slope 2 / 0.175
    rs1 = doe.fit(d, 1 + 2 * d.coded[:, 0], model="linear")
    assert rs1.coefficients_actual["a"] == pytest.approx(2 / 0.175)
    assert rs1.coefficients_actual["intercept"] == pytest.approx(1 - 2 * 0.525 / 0.175)


def test_fit_from_actual_dataframe_equals_fit_from_coded():
    space = doe.FactorSpace([doe.Factor("p", 1.0, 3.0), doe.Factor("q", 0.0, 10.0)])
    d = doe.central_composite(space, kind="face", randomize=False)
    y = 5 + d.coded[:, 0] - 2 * d.coded[:, 1] ** 2
    frame = pd.DataFrame(d.actual, columns=["p", "q"])
    rs_a = doe.fit(frame, y, model="quadratic", factors=space)
    rs_c = doe.fit(d, y, model="quadratic")
    np.testing.assert_allclose(rs_a.params, rs_c.params, atol=1e-12)
    assert rs_a.coefficients_coded["q^2"] == pytest.approx(-2.0)


def test_nan_responses_are_excluded_and_reported():
    d = doe.box_behnken(3, center_points=3, randomize=False)
    y = 40 + d.coded @ np.array([1.0, 2.0, 3.0])
    y = y + np.random.default_rng(1).normal(0, 0.1, d.n_runs)
    y[[2, 9]] = np.nan
    frame = pd.DataFrame(d.coded, columns=d.names, index=pd.Index(range(101, 116)))
    rs = doe.fit(frame, y, model="linear")
    assert rs.excluded_runs == (103, 110)
    assert rs.n_runs == 13
    assert rs.anova()["Cor Total"].df == 12
    ref = sm.OLS(y[~np.isnan(y)], sm.add_constant(d.coded[~np.isnan(y)])).fit()
    np.testing.assert_allclose(rs.params, ref.params, rtol=1e-10)


def test_too_few_runs_singular_and_bad_input_are_input_errors():
    d = doe.plackett_burman(3, n_runs=8, randomize=False)
    with pytest.raises(InputError, match="too few runs for the quadratic model"):
        doe.fit(d, np.arange(8.0), model="quadratic")
    ff = doe.factorial(3, randomize=False)
    # two-level design: squares are all 1 -> aliased with the intercept
    with pytest.raises(InputError, match=r"singular .* x1\^2 is aliased"):
        doe.fit(np.vstack([ff.coded, ff.coded]), np.arange(16.0), model="quadratic")
    with pytest.raises(InputError, match="model must be one of"):
        doe.fit(ff, np.arange(8.0), model="cubic")
    with pytest.raises(InputError, match="response has 7 values"):
        doe.fit(ff, np.arange(7.0), model="linear")
    frame = pd.DataFrame({"a": ["1", "x", "2"], "b": [1, 2, 3]})
    with pytest.raises(InputError, match="column 'a' is not numeric"):
        doe.fit(frame, [1.0, 2.0, 3.0], model="linear")


def test_saturated_fit_has_nan_statistics_not_errors():
    d = doe.plackett_burman(7, n_runs=8, randomize=False)
    rs = doe.fit(d, np.arange(8.0) ** 2, model="linear")
    assert rs.df_resid == 0
    assert math.isnan(rs.mse) and math.isnan(rs.anova()["Model"].p)
    eff = rs.effects()
    assert list(eff["rank"]) == sorted(eff["rank"])


def _by_hand_backward(x, y, names, alpha_out):
    """Independent reference: statsmodels p-values, remove the worst removable term."""
    terms = list(doe.model_terms(x.shape[1], "quadratic"))
    while True:
        X = doe.model_matrix(x, terms)
        p = sm.OLS(y, X).fit().pvalues
        cands = [
            (p[j], t)
            for j, t in enumerate(terms)
            if sum(t) > 0
            and not any(o != t and all(a <= b for a, b in zip(t, o, strict=True)) for o in terms)
        ]
        worst = max(cands, key=lambda c: c[0])
        if worst[0] <= alpha_out:
            return {doe.term_name(t, names) for t in terms}
        terms.remove(worst[1])


@pytest.mark.parametrize("seed", [11, 12, 13])
def test_backward_elimination_keeps_hierarchy_and_drops_noise(seed):
    d = doe.box_behnken(3, center_points=5, randomize=False)
    rng = np.random.default_rng(seed)
    x = d.coded
    # x2 has no effect of its own, only through x1*x2
    y = 10 + 3 * x[:, 0] + 2 * x[:, 0] * x[:, 1] + rng.normal(0, 0.2, d.n_runs)
    rs = doe.fit(d, y, model="quadratic").reduce(alpha_out=0.1)
    names = set(rs.term_names)
    assert {"x1", "x2", "x1*x2"} <= names  # x2 stays because x1*x2 contains it
    assert names == _by_hand_backward(x, y, d.names, 0.1)
    assert rs.model == "custom"
    free = doe.fit(d, y, model="quadratic").reduce(alpha_out=0.1, hierarchical=False)
    pv = free.pvalues.drop("intercept")
    assert (pv <= 0.1).all()


def test_explicit_terms_and_equation():
    d = doe.box_behnken(3, center_points=3, randomize=False)
    y = 1 + d.coded[:, 0] * d.coded[:, 2]
    rs = doe.fit(d, y, terms=["intercept", "x1", "x3", "x1*x3"])
    assert rs.term_names == ("intercept", "x1", "x3", "x1*x3")
    assert rs.coefficients_coded["x1*x3"] == pytest.approx(1.0)
    assert rs.equation().startswith("response = +1")
    with pytest.raises(InputError, match="unknown factor 'x9'"):
        doe.fit(d, y, terms=["intercept", "x9"])


def test_response_surface_is_immutable():
    d = doe.box_behnken(3, center_points=3, randomize=False)
    rs = doe.fit(d, np.arange(15.0), model="linear")
    with pytest.raises(AttributeError):
        rs.model = "quadratic"  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        rs.response[0] = 3.0
