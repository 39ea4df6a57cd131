"""The verification's comparison with the measurement, against hand-computed t statistics."""

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy import stats

from demcal.calibrate.verify import compare_to_target


def test_welch_against_the_measurement_by_hand():
    sim = np.array([54.1, 37.3, 51.6])
    out = compare_to_target(sim, 44.12, 1.74, 5)
    m, s, n = sim.mean(), sim.std(ddof=1), 3
    se2 = s**2 / n + 1.74**2 / 5
    t = (m - 44.12) / math.sqrt(se2)
    dof = se2**2 / ((s**2 / n) ** 2 / (n - 1) + (1.74**2 / 5) ** 2 / 4)  # Welch-Satterthwaite
    p = 2 * stats.t.sf(abs(t), dof)
    assert out.p_value == pytest.approx(p, rel=1e-10)
    assert out.consistent is True and "Welch" in out.test
    half = stats.t.ppf(0.975, 2) * s / math.sqrt(3)
    assert out.ci_low == pytest.approx(m - half) and out.ci_high == pytest.approx(
        m + half)


def test_one_sample_without_a_spread_and_a_clear_miss():
    sim = np.array([60.0, 61.0, 59.5, 60.5])
    out = compare_to_target(sim, 44.12)
    t = (sim.mean() - 44.12) / (sim.std(ddof=1) / 2)
    assert out.p_value == pytest.approx(2 * stats.t.sf(abs(t), 3), rel=1e-10)
    assert out.consistent is False and "one-sample" in out.test


def test_too_few_replicates_give_no_verdict():
    out = compare_to_target(np.array([44.0]), 44.12, 1.74, 5)
    assert out.p_value is None and out.consistent is None and out.ci_low is None


def _surface():
    from demcal import doe

    d = doe.box_behnken({"a": (0.0, 1.0), "b": (0.0, 2.0), "c": (-1.0, 1.0)}, center_points=3,
                        randomize=False)
    x = np.asarray(d.coded, dtype=float)
    rng = np.random.default_rng(11)
    y = 40 + 3 * x[:, 0] + 2 * x[:, 1] - x[:, 2] + x[:, 0] * x[:, 1] + rng.normal(0, 0.8, len(x))
    return doe.fit(d, y, model="quadratic"), x, y


def test_confirmation_is_design_experts_interval_for_the_mean_of_n_runs():
    import statsmodels.api as sm

    from demcal import doe
    from demcal.calibrate.verify import confirmation

    rs, _, y = _surface()
    chosen = {"a": 0.65, "b": 0.8, "c": 0.5}  # coded 0.3, -0.2, 0.5
    ols = sm.OLS(y, rs.model_matrix).fit()
    x0 = doe.model_matrix(np.array([[0.3, -0.2, 0.5]]), rs.terms)
    ref = ols.get_prediction(x0, weights=6).summary_frame(alpha=0.05)
    yhat = float(ref["mean"].iloc[0])
    close = np.array([-0.5, 0.5, -0.2, 0.2, 0.1, -0.1]) + yhat
    out = confirmation(rs, chosen, close)
    assert out.confirm_pi_low == pytest.approx(float(ref["obs_ci_lower"].iloc[0]))
    assert out.confirm_pi_high == pytest.approx(float(ref["obs_ci_upper"].iloc[0]))
    assert out.confirmed is True
    # the target far outside the piles' interval: the surface kept its promise, the target not
    assert compare_to_target(close, yhat + 5.0).target_in_interval is False
    far = close + (out.confirm_pi_high - yhat) + 0.5  # the mean just above the interval
    out = confirmation(rs, chosen, far)
    assert out.confirmed is False
    assert compare_to_target(far, float(far.mean()) + 0.1).target_in_interval is True


def test_confirmation_without_a_surface_or_an_interval():
    from demcal.calibrate.verify import Confirmation, confirmation

    out = confirmation(None, {}, np.array([44.0]))
    assert out == Confirmation(confirm_pi_low=None, confirm_pi_high=None, confirmed=None)
    assert compare_to_target(np.array([44.0]), 44.12).target_in_interval is None
    out = confirmation(None, {}, np.array([44.0, 45.0]))
    assert out.confirmed is None
    assert compare_to_target(np.array([44.0, 45.0]), 44.12).target_in_interval is True


@pytest.mark.parametrize("c", [1.0, 0.4])
def test_a_refinement_rounds_confirmation_carries_the_offsets_error(c):
    # The corrected prediction yhat(x) + c b, b = sum_j w_j (ybar_j - yhat(x_j)), w_j = n_j / N,
    # c the share applied, has the variance s^2 (1/n + c^2/N) + Var(yhat(x) - c sum_j w_j
    # yhat(x_j)); the last term is statsmodels' t_test of that contrast of the model rows.
    import statsmodels.api as sm

    from demcal import doe
    from demcal.calibrate.rounds import Offset
    from demcal.calibrate.verify import confirmation

    rs, _, y = _surface()
    chosen = {"a": 0.65, "b": 0.8, "c": 0.5}
    earlier = [({"a": 0.6, "b": 1.1, "c": 0.3}, 12), ({"a": 0.7, "b": 0.9, "c": 0.6}, 4)]
    ols = sm.OLS(y, rs.model_matrix).fit()
    rows = doe.model_matrix(np.array([[0.3, -0.2, 0.5], [0.2, 0.1, 0.3], [0.4, -0.1, 0.6]]),
                            rs.terms)
    contrast = ols.t_test(rows[0] - c * (0.75 * rows[1] + 0.25 * rows[2]))
    offset, n = -1.3, 6
    se = math.sqrt(ols.mse_resid * (1 / n + c * c / 16) + float(contrast.sd[0, 0]) ** 2)
    pred = float(ols.predict(rows[:1])[0]) + c * offset
    half = stats.t.ppf(0.975, ols.df_resid) * se
    piles = np.full(n, pred) + np.array([-0.3, 0.3, -0.1, 0.1, 0.2, -0.2])
    measured = Offset(offset, earlier, [1, 2], weight=c)
    out = confirmation(rs, chosen, piles, offset=measured)
    assert out.confirm_pi_low == pytest.approx(pred - half, rel=1e-10)
    assert out.confirm_pi_high == pytest.approx(pred + half, rel=1e-10)
    assert out.confirmed is True
    out = confirmation(rs, chosen, piles + half + 0.1, offset=measured)
    assert out.confirmed is False


ROUND_OPTIMA = [{"a": 0.6, "b": 1.1, "c": 0.3}, {"a": 0.7, "b": 0.9, "c": 0.6}]


def _two_rounds(rs, pts, *, first_confirmed):
    """Rounds 1 and 2 at ``pts[0]``, ``pts[1]`` (12 and 4 piles) whose means read 2 and 1
    deg below the surface; round 2 confirmed."""
    from demcal.calibrate.rounds import Rounds
    from demcal.summaries import Optimum, Verification

    pred = rs.predict({k: [p[k] for p in pts[:2]] for k in "abc"}, units="actual")
    return Rounds(optimize=[Optimum(chosen=p) for p in pts],
                  verification=[Verification(mean=float(pred[0]) - 2.0, n_piles=12,
                                             confirmed=first_confirmed, round=1),
                                Verification(mean=float(pred[1]) - 1.0, n_piles=4,
                                             confirmed=True, round=2)])


def test_the_offset_pools_the_rounds_that_agreed_and_restarts_after_one_that_did_not():
    from demcal.calibrate.rounds import Rounds
    from demcal.summaries import Verification

    rs, _, _ = _surface()
    pts = [*ROUND_OPTIMA, {"a": 0.65, "b": 0.8, "c": 0.5}]
    rounds = _two_rounds(rs, pts, first_confirmed=False)
    pred = rs.predict({k: [p[k] for p in pts] for k in "abc"}, units="actual")
    both = rounds.offset(rs)
    assert both.rounds == [1, 2] and both.deg == pytest.approx((12 * -2.0 + 4 * -1.0) / 16)
    rounds.verification[1] = replace(rounds.verification[1], confirmed=False)  # disagreed
    assert rounds.offset(rs).rounds == [2] and rounds.offset(rs).deg == pytest.approx(-1.0)
    rounds.verification.append(Verification(mean=float(pred[2]) + 0.5, n_piles=6,
                                            confirmed=True, round=3))
    three = rounds.offset(rs)
    assert three.rounds == [2, 3] and three.deg == pytest.approx((4 * -1.0 + 6 * 0.5) / 10)
    assert Rounds().offset(rs).at == []


def test_the_weight_of_a_confirmed_offset_is_the_piles_share_of_the_information():
    # w = N h / (N h + 1), h = Var(yhat at the pile-weighted optimum row) / s^2: the
    # prediction's variance from statsmodels' t_test of that row
    import statsmodels.api as sm

    from demcal import doe
    from demcal.calibrate.rounds import offset_weight

    rs, _, y = _surface()
    earlier = [({"a": 0.6, "b": 1.1, "c": 0.3}, 12), ({"a": 0.7, "b": 0.9, "c": 0.6}, 4)]
    ols = sm.OLS(y, rs.model_matrix).fit()
    rows = doe.model_matrix(np.array([[0.2, 0.1, 0.3], [0.4, -0.1, 0.6]]), rs.terms)
    h = float(ols.t_test(0.75 * rows[0] + 0.25 * rows[1]).sd[0, 0]) ** 2 / ols.mse_resid
    assert offset_weight(rs, earlier) == pytest.approx(16 * h / (16 * h + 1), rel=1e-10)
    assert 0.0 < offset_weight(rs, earlier[1:]) < offset_weight(rs, earlier) < 1.0
    # a reduced (here linear) surface on the same design is weighed as the full quadratic:
    # its own variance would ignore the terms' selection (h = 1/15 + ... is far smaller)
    d = doe.box_behnken({"a": (0.0, 1.0), "b": (0.0, 2.0), "c": (-1.0, 1.0)}, center_points=3,
                        randomize=False)
    linear = doe.fit(d, y, model="linear")
    assert offset_weight(linear, earlier) == pytest.approx(offset_weight(rs, earlier), rel=1e-10)
    mean_row = doe.model_matrix(np.array([[0.25, 0.05, 0.375]]), linear.terms)[0]
    h_linear = float(mean_row @ linear.xtx_inv @ mean_row)
    assert 16 * h_linear / (16 * h_linear + 1) < 0.9 * offset_weight(rs, earlier)


def test_a_round_applies_a_confirmed_offset_by_its_weight_and_an_unconfirmed_one_whole():
    from demcal.calibrate.rounds import offset_weight

    rs, _, _ = _surface()
    pts = ROUND_OPTIMA
    rounds = _two_rounds(rs, pts, first_confirmed=True)
    both = rounds.offset(rs)
    w = offset_weight(rs, [(pts[0], 12), (pts[1], 4)])
    assert both.weight == pytest.approx(w) and both.applied == pytest.approx(w * both.deg)
    rounds.verification[0] = replace(rounds.verification[0], confirmed=False)  # off
    assert rounds.offset(rs).weight == 1.0 and rounds.offset(rs).applied == rounds.offset(rs).deg


def test_the_weight_is_what_the_surfaces_true_error_regresses_on_the_measured_offset():
    # A world whose quadratic surface is right but for its estimation error: over many
    # studies (a Box-Behnken with noise 0.8, then 6 piles at one optimum), the least-squares
    # factor from the measured offset to the surface's true error there is the weight, and
    # applying the weighted offset misses the truth by less than applying all of it.
    from demcal import doe
    from demcal.calibrate.rounds import offset_weight

    d = doe.box_behnken({"a": (0.0, 1.0), "b": (0.0, 2.0), "c": (-1.0, 1.0)}, center_points=3,
                        randomize=False)
    x = np.asarray(d.coded, dtype=float)

    def truth(c):
        return 40 + 3 * c[..., 0] + 2 * c[..., 1] - c[..., 2] + c[..., 0] * c[..., 1]

    chosen, coded, n = {"a": 0.65, "b": 0.8, "c": 0.5}, np.array([0.3, -0.2, 0.5]), 6
    rng = np.random.default_rng(5)
    measured, error, weights = [], [], []
    for _ in range(600):
        rs = doe.fit(d, truth(x) + rng.normal(0, 0.8, len(x)), model="quadratic")
        yhat = float(rs.predict({k: [v] for k, v in chosen.items()}, units="actual")[0])
        error.append(float(truth(coded)) - yhat)
        measured.append(float(truth(coded)) + rng.normal(0, 0.8, n).mean() - yhat)
        weights.append(offset_weight(rs, [(chosen, n)]))
    m, e, w = np.array(measured), np.array(error), float(np.mean(weights))
    assert 0.2 < w < 0.9
    assert float(m @ e / (m @ m)) == pytest.approx(w, abs=0.1)
    assert np.mean((e - w * m) ** 2) < 0.85 * np.mean((e - m) ** 2)
