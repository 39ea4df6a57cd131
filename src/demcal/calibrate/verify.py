"""The verification's statistics: the simulated mean against the lab's, the response
surface's promise at the optimum (Design-Expert's confirmation), and how many runs the
verification needs for its interval."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from demcal.calibrate.rounds import Offset, model_rows, pile_mean_row

__all__ = ["Confirmation", "TargetComparison", "compare_to_target", "confirmation",
           "interval_half_width", "pure_error_std", "verification_seed", "verification_size"]


@dataclass(frozen=True)
class TargetComparison:
    """The simulated mean against the lab's (:func:`compare_to_target`); every field None with
    fewer than two runs.

    Attributes
    ----------
    ci_low, ci_high : float or None
        The (1 - alpha) t-interval of the simulated mean, the response's unit.
    target_in_interval : bool or None
        The lab value inside that interval.
    p_value : float or None
        The t-test's p (None also when both spreads are zero).
    test : str or None
        Which t-test.
    consistent : bool or None
        p >= alpha.
    """

    ci_low: float | None = None
    ci_high: float | None = None
    target_in_interval: bool | None = None
    p_value: float | None = None
    test: str | None = None
    consistent: bool | None = None


@dataclass(frozen=True)
class Confirmation:
    """Design-Expert's confirmation (:func:`confirmation`); every field None without a surface
    or a run that gave a value.

    Attributes
    ----------
    confirm_pi_low, confirm_pi_high : float or None
        The surface's (1 - alpha) prediction interval for the mean of the n runs.
    confirmed : bool or None
        The runs' mean inside it.
    """

    confirm_pi_low: float | None = None
    confirm_pi_high: float | None = None
    confirmed: bool | None = None


def compare_to_target(values: np.ndarray, target: float, target_std: float | None = None,
                      target_n: int | None = None, alpha: float = 0.05) -> TargetComparison:
    """Is the simulated mean consistent with the measured one? (the response's unit)

    With the measurement's spread and count known, Welch's two-sample t-test of the
    replicates against the measurement (scipy ``ttest_ind_from_stats``); otherwise a one-sample
    t-test against the target value. Also the (1 - alpha) t-interval of the simulated mean.
    """
    from scipy import stats

    if values.size < 2:
        return TargetComparison()
    mean, sd, n = float(values.mean()), float(values.std(ddof=1)), int(values.size)
    half = interval_half_width(values, alpha)
    interval = {"ci_low": mean - half, "ci_high": mean + half,
                "target_in_interval": bool(abs(mean - target) <= half)}
    if sd == 0.0 and not target_std:
        return TargetComparison(**interval)
    if target_std is not None and target_n is not None and target_n >= 2:
        res = stats.ttest_ind_from_stats(mean, sd, n, target, target_std, target_n,
                                         equal_var=False)
        test = f"Welch t-test against the measurement (n = {target_n})"
    else:
        res = stats.ttest_1samp(values, target)
        test = "one-sample t-test against the target value"
    return TargetComparison(**interval, p_value=float(res.pvalue), test=test,
                            consistent=bool(res.pvalue >= alpha))


def confirmation(model: Any, chosen: Mapping[str, float], values: np.ndarray, *,
                 alpha: float = 0.05, offset: Offset | None = None) -> Confirmation:
    """Did the optimum give what the response surface promised? (the response's unit)

    Design-Expert's confirmation: the mean of the n verification piles against the surface's
    (1 - alpha) prediction interval for the mean of n new runs at the chosen settings
    (``predict_interval(..., n_new=n)``), and whether the mean lies inside it; None without a
    surface or a pile.

    In a refinement round the promise is the surface corrected by ``offset``: b = sum_j w_j
    (ybar_j - yhat(x_j)) over earlier optima x_j with n_j piles (w_j = n_j / N), of which the
    round applied the share c (``offset.weight``). Then the prediction is yhat(x) + c b and
    its variance s^2 (1/n + c^2/N + d' (X'X)^-1 d), with d the model row at x less c times
    the w-weighted rows at the x_j (the predictions share their coefficients' error; s^2 the
    residual mean square, t on its df).
    """
    if model is None or values.size == 0 or model.df_resid <= 0:
        return Confirmation()
    at = {n: [chosen[n]] for n in model.names}
    if offset is None or not offset.at:
        iv = model.predict_interval(at, units="actual", alpha=alpha, n_new=int(values.size))
        lo, hi = float(iv["pi_low"].iloc[0]), float(iv["pi_high"].iloc[0])
    else:
        from scipy import stats

        c = offset.weight
        d = model_rows(model, [chosen], model.terms)[0] - c * pile_mean_row(
            model, offset.at, model.terms)
        n_at = float(sum(n for _, n in offset.at))
        var = model.mse * (1 / values.size + c * c / n_at + float(d @ model.xtx_inv @ d))
        pred = float(model.predict(at, units="actual")[0]) + offset.applied
        half = float(stats.t.ppf(1 - alpha / 2, model.df_resid)) * math.sqrt(var)
        lo, hi = pred - half, pred + half
    return Confirmation(confirm_pi_low=lo, confirm_pi_high=hi,
                        confirmed=bool(lo <= float(values.mean()) <= hi))


def interval_half_width(values: np.ndarray, alpha: float = 0.05) -> float:
    """Half-width of the (1 - alpha) t-interval of the mean of ``values`` (inf below two)."""
    from scipy import stats

    if values.size < 2:
        return math.inf
    return float(stats.t.ppf(1 - alpha / 2, values.size - 1) * values.std(ddof=1)
                 / math.sqrt(values.size))


def verification_size(values: np.ndarray, half_width: float, max_n: int,
                      sigma: float | None = None, sigma_df: int | None = None) -> int:
    """Replicates whose 95 % interval half-width should reach ``half_width`` deg (<= max_n).

    The smallest n with t(n-1) s / sqrt(n) <= half_width, at least one more than now while the
    interval is still too wide. ``s`` is the test's scatter as well as it is known: the runs'
    own spread with ``sigma``, the scatter measured elsewhere (the response surface's pure
    error), so that a verification whose first runs happen to agree closely does not stop
    before the test's known scatter allows the goal. With ``sigma_df`` (sigma's degrees of
    freedom) the two are pooled, each weighted by its degrees of freedom: a pure error from
    30-odd df dominates a few runs, one from three centre points (2 df) does not outweigh ten
    runs. Without it ``sigma`` counts as known exactly and the larger of the two is taken.
    """
    from scipy import stats

    n = values.size
    s = float(values.std(ddof=1)) if n > 1 else math.inf
    if sigma is not None and math.isfinite(sigma):
        if sigma_df is not None and sigma_df > 0 and n > 1:
            own = n - 1
            s = math.sqrt((sigma_df * sigma ** 2 + own * s ** 2) / (sigma_df + own))
        else:
            s = max(s, float(sigma))

    def wide(k: int) -> bool:
        return bool(stats.t.ppf(0.975, k - 1) * s / math.sqrt(k) > half_width)

    if n >= max_n or (interval_half_width(values) <= half_width and not wide(n)):
        return n
    want = n + 1
    while want < max_n and wide(want):
        want += 1
    return min(max_n, want)


def pure_error_std(model: Any) -> tuple[float | None, int]:
    """Standard deviation (deg) and df of a fitted model's pure error (None without one)."""
    ss, df = model.pure_error if model is not None else (0.0, 0)
    return (math.sqrt(ss / df), df) if df > 0 else (None, 0)


def verification_seed(seed: int, round_: int, i: int) -> int:
    """Seed of verification run ``i`` of round ``round_`` (1-based): ``seed + 10000 round + i``,
    never one a design point of the study used (they are ``seed + 1000 replicate + point``
    with fewer than 10 replicates) nor one of another round (at most 200 runs a round)."""
    return int(seed + 10_000 * round_ + i)
