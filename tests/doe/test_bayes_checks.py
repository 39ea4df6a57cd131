"""The surrogates' leave-one-out check (demcal.doe.bayes.checks): the closed form against
refits without each run, and the verdict on a smooth response and on a step."""

from __future__ import annotations

import numpy as np
from scipy.stats import norm
from sklearn.gaussian_process import GaussianProcessRegressor

from demcal.doe.bayes import check_surrogate, fit_surrogate


def _runs(n: int, seed: int, step: bool = False) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1, 1, (n, 2))
    if step:  # a jump a smooth kernel cannot follow: the runs next to it are missed
        return x, 30 + 5 * np.sign(x[:, 0]) + 0.1 * rng.standard_normal(n)
    return x, 30 + 5 * x[:, 0] + 3 * np.sin(2 * x[:, 1]) + 0.5 * rng.standard_normal(n)


def test_the_closed_form_is_the_refit_without_each_run():
    x, y = _runs(15, 1)
    sur = fit_surrogate("aor", x, y, seed=1)
    mean, std = sur.leave_one_out()
    gp = sur._gp  # the fitted hyperparameters, kept for every refit
    scale, centre = sur._y_scale, sur._y_mean
    for i in range(len(y)):
        keep = np.arange(len(y)) != i
        ref = GaussianProcessRegressor(kernel=gp.kernel_, alpha=gp.alpha, optimizer=None,
                                       normalize_y=False)
        ref.fit(x[keep], (y[keep] - centre) / scale)
        m, s = ref.predict(x[i:i + 1], return_std=True)  # white noise included: one run
        assert abs(centre + scale * m[0] - mean[i]) < 1e-6 * scale
        assert abs(scale * s[0] - std[i]) < 1e-6 * scale


def test_a_smooth_response_passes_and_a_step_is_said():
    smooth = check_surrogate(fit_surrogate("aor", *_runs(30, 2), seed=2))
    assert smooth.n == 30 and 0.6 < smooth.rms_z < 1.5, smooth
    assert smooth.limit == norm.isf(0.05 / 60) and not smooth.misses_a_run, smooth
    x, y = _runs(30, 0, step=True)
    step = check_surrogate(fit_surrogate("aor", x, y, seed=0))
    assert step.misses_a_run and step.max_abs_z > step.limit, step
    assert abs(x[step.worst, 0]) < 0.3  # the missed run is one next to the jump
    few = check_surrogate(fit_surrogate("aor", x[:8], y[:8]))
    assert not few.judged and not few.misses_a_run
