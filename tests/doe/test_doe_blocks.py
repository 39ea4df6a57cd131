"""Blocks in a response-surface fit (Design-Expert's), against statsmodels with block terms."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import statsmodels.formula.api as smf
from statsmodels.stats.anova import anova_lm

from demcal import doe
from demcal.errors import InputError

QUAD = ("y ~ C(blk, Sum) + x1 + x2 + x3 + x1:x2 + x1:x3 + x2:x3 + I(x1**2) + I(x2**2)"
        " + I(x3**2)")


def _blocked_data(n_blocks: int = 3, seed: int = 3):
    rng = np.random.default_rng(seed)
    d = doe.box_behnken(3, center_points=3, randomize=False)
    x = np.tile(d.coded, (n_blocks, 1))
    blk = np.repeat(np.arange(n_blocks), d.n_runs)
    offsets = np.linspace(-2.5, 3.0, n_blocks)
    y = (40 + 2 * x[:, 0] - x[:, 1] ** 2 + 0.5 * x[:, 0] * x[:, 2] + offsets[blk]
         + rng.normal(0, 1, len(blk)))
    frame = pd.DataFrame(x, columns=["x1", "x2", "x3"])
    frame["y"], frame["blk"] = y, blk
    return x, y, blk, frame


def test_blocked_fit_equals_least_squares_with_block_terms():
    x, y, blk, frame = _blocked_data()
    rs = doe.fit(x, y, model="quadratic", blocks=blk)
    ref = smf.ols(QUAD, frame).fit()
    names = {"intercept": "Intercept", "x1": "x1", "x2": "x2", "x3": "x3",
             "x1*x2": "x1:x2", "x1*x3": "x1:x3", "x2*x3": "x2:x3",
             "x1^2": "I(x1 ** 2)", "x2^2": "I(x2 ** 2)", "x3^2": "I(x3 ** 2)"}
    for ours, theirs in names.items():
        assert rs.coefficients_coded[ours] == pytest.approx(ref.params[theirs], abs=1e-10)
    assert rs.df_resid == ref.df_resid
    assert rs.mse == pytest.approx(ref.mse_resid, rel=1e-12)
    assert rs.block_ss == pytest.approx(anova_lm(ref, typ=1).loc["C(blk, Sum)", "sum_sq"],
                                        rel=1e-10)
    # partial (Type III) tests of the terms, PRESS from the full hat matrix
    table = rs.anova().to_frame()
    type3 = anova_lm(ref, typ=3)
    for ours, theirs in names.items():
        if ours != "intercept":
            assert table.loc[ours, "p"] == pytest.approx(type3.loc[theirs, "PR(>F)"], rel=1e-8)
    hat = ref.get_influence().hat_matrix_diag
    assert rs.press == pytest.approx(float(np.sum((ref.resid / (1 - hat)) ** 2)), rel=1e-10)
    # pure error: the residual of one mean per design point plus the blocks
    frame["point"] = pd.factorize(pd.Series([tuple(r) for r in np.round(x, 9)]))[0]
    pe = smf.ols("y ~ C(point) + C(blk)", frame).fit()
    ss_pe, df_pe = rs.pure_error
    assert ss_pe == pytest.approx(pe.ssr, rel=1e-10)
    assert df_pe == pe.df_resid


def test_the_anova_lists_the_block_first_and_its_total_includes_it():
    x, y, blk, _ = _blocked_data()
    table = doe.fit(x, y, model="quadratic", blocks=blk).anova().to_frame()
    assert table.index[0] == "Block"
    assert table.loc["Block", "df"] == 2
    assert np.isnan(table.loc["Block", "p"])
    assert table.loc["Cor Total", "ss"] == pytest.approx(float(np.sum((y - y.mean()) ** 2)))
    assert table.loc["Cor Total", "df"] == len(y) - 1


def test_blocks_remove_a_seed_set_offset_from_the_noise():
    """Large block offsets inflate the unblocked residual; the blocked fit does not see them."""
    x, y, blk, _ = _blocked_data()
    plain = doe.fit(x, y, model="quadratic")
    blocked = doe.fit(x, y, model="quadratic", blocks=blk)
    assert blocked.mse < 0.5 * plain.mse
    np.testing.assert_allclose(blocked.params, plain.params, atol=1e-12)  # balanced: same b


def test_one_block_or_none_is_the_plain_fit():
    x, y, _, _ = _blocked_data()
    plain = doe.fit(x, y, model="quadratic")
    one = doe.fit(x, y, model="quadratic", blocks=[7] * len(y))
    assert one.block_df == 0
    assert one.mse == plain.mse
    assert one.anova().to_frame().index[0] == "Model"


def test_reduced_models_keep_the_blocks():
    x, y, blk, _ = _blocked_data()
    rs = doe.fit(x, y, model="quadratic", blocks=blk)
    reduced = rs.with_terms(["intercept", "x1", "x2^2"])
    assert reduced.block_df == 2
    assert reduced.df_resid == len(y) - 3 - 2


def test_unbalanced_blocks_are_refused_with_the_block_named():
    x, y, blk, _ = _blocked_data()
    y = y.copy()
    y[20] = np.nan  # a run without a result: its point is missing from block 1
    with pytest.raises(InputError, match="blocks are unbalanced: block 1"):
        doe.fit(x, y, model="quadratic", blocks=blk)
    with pytest.raises(InputError, match="blocks has 3 labels"):
        doe.fit(x, y, model="quadratic", blocks=[0, 1, 2])
