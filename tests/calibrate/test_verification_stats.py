"""The verification's comparison with the measurement, against hand-computed t statistics."""

import math

import numpy as np
import pytest
from scipy import stats

from demcal.calibrate.stages import compare_to_target


def test_welch_against_the_measurement_by_hand():
    sim = np.array([54.1, 37.3, 51.6])
    out = compare_to_target(sim, 44.12, 1.74, 5)
    m, s, n = sim.mean(), sim.std(ddof=1), 3
    se2 = s**2 / n + 1.74**2 / 5
    t = (m - 44.12) / math.sqrt(se2)
    dof = se2**2 / ((s**2 / n) ** 2 / (n - 1) + (1.74**2 / 5) ** 2 / 4)  # Welch-Satterthwaite
    p = 2 * stats.t.sf(abs(t), dof)
    assert out["p_value"] == pytest.approx(p, rel=1e-10)
    assert out["consistent"] is True and "Welch" in out["test"]
    half = stats.t.ppf(0.975, 2) * s / math.sqrt(3)
    assert out["ci_low_deg"] == pytest.approx(m - half) and out["ci_high_deg"] == pytest.approx(
        m + half)


def test_one_sample_without_a_spread_and_a_clear_miss():
    sim = np.array([60.0, 61.0, 59.5, 60.5])
    out = compare_to_target(sim, 44.12)
    t = (sim.mean() - 44.12) / (sim.std(ddof=1) / 2)
    assert out["p_value"] == pytest.approx(2 * stats.t.sf(abs(t), 3), rel=1e-10)
    assert out["consistent"] is False and "one-sample" in out["test"]


def test_too_few_replicates_give_no_verdict():
    out = compare_to_target(np.array([44.0]), 44.12, 1.74, 5)
    assert out["p_value"] is None and out["consistent"] is None and out["ci_low_deg"] is None
