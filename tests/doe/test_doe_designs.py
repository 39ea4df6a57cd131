"""Design invariants (run count, balance, orthogonality, moments, resolution) and factors."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from demcal import doe
from demcal.errors import InputError


# --------------------------------------------------------------------------------- factors
def test_factor_coding_round_trip():
    f = doe.Factor("x3", 0.35, 0.7)
    assert (f.to_coded(0.35), f.to_coded(0.7), f.to_coded(0.525)) == pytest.approx((-1, 1, 0))
    vals = np.linspace(0.2, 0.9, 11)
    np.testing.assert_allclose(f.to_actual(f.to_coded(vals)), vals)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"name": "x3", "low": 0.7, "high": 0.35}, "low must be < high for factor x3; got low=0.7"),
        ({"name": "x3", "low": 0.5, "high": 0.5}, "low must be < high"),
        ({"name": "", "low": 0, "high": 1}, "factor name"),
        ({"name": "x", "low": float("nan"), "high": 1}, "low of factor x must be finite"),
        ({"name": "x", "low": "a", "high": 1}, "low of factor x must be a number"),
    ],
)
def test_factor_validation(kwargs, message):
    with pytest.raises(InputError, match=message):
        doe.Factor(**kwargs)


def test_factor_space_rejects_duplicates_and_converts_matrices():
    with pytest.raises(InputError, match="unique"):
        doe.FactorSpace([doe.Factor("a", 0, 1), doe.Factor("a", 1, 2)])
    space = doe.FactorSpace([doe.Factor("a", 0, 1), doe.Factor("b", 10, 20, fixed=12)])
    assert space.free.names == ("a",)
    np.testing.assert_allclose(space.to_actual([[-1, 1], [0, 0]]), [[0, 20], [0.5, 15]])
    with pytest.raises(InputError, match="2 columns"):
        space.to_coded([[1, 2, 3]])


def test_load_factors_both_layouts(tmp_path):
    a = tmp_path / "a.toml"
    a.write_text(
        '[factors.x3]\nlow = 0.35\nhigh = 0.7\n[factors."pp.mu"]\nlow = 0.1\nhigh = 0.2\n'
        'fixed = 0.15\nunit = "-"\n'
    )
    b = tmp_path / "b.toml"
    b.write_text(
        '[[factors]]\nname = "x3"\nlow = 0.35\nhigh = 0.7\n'
        '[[factors]]\nname = "pp.mu"\nlow = 0.1\nhigh = 0.2\nfixed = 0.15\nunit = "-"\n'
    )
    sa, sb = doe.load_factors(a), doe.load_factors(b)
    assert sa == sb
    assert sa.names == ("x3", "pp.mu") and sa["pp.mu"].fixed == 0.15


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[factors.x3]\nlow = 0.7\nhigh = 0.35\n", "low must be < high for factor x3"),
        ("[factors.x3]\nlow = 0.7\n", r"factors.x3.high is missing"),
        ("[factors.x3]\nlow = 0\nhigh = 1\nlevel = 3\n", "unknown key"),
        ("[other]\na = 1\n", "no \\[factors\\] section"),
        ("[factors.x3\n", "not valid TOML"),
        ('[factors.x3]\nlow = "a"\nhigh = 1\n', "factors.x3.low must be a number"),
    ],
)
def test_load_factors_errors_name_the_field(tmp_path, text, message):
    p = tmp_path / "f.toml"
    p.write_text(text)
    with pytest.raises(InputError, match=message):
        doe.load_factors(p)
    with pytest.raises(InputError, match="does not exist"):
        doe.load_factors(tmp_path / "missing.toml")


# --------------------------------------------------------------------------- Plackett-Burman
@pytest.mark.parametrize("n", list(range(8, 49, 4)))
def test_plackett_burman_is_orthogonal_and_balanced(n):
    d = doe.plackett_burman(n - 1, n_runs=n, randomize=False)
    m = d.coded
    assert m.shape == (n, n - 1)
    assert set(np.unique(m)) == {-1.0, 1.0}
    np.testing.assert_array_equal(m.T @ m, n * np.eye(n - 1))  # orthogonal columns
    np.testing.assert_array_equal(m.sum(axis=0), 0)  # balanced
    assert len({tuple(r) for r in m}) == n  # distinct runs


def test_plackett_burman_generators_and_dummies():
    d = doe.plackett_burman(8, randomize=False)
    assert d.n_runs == 12 and d.dummies.shape == (12, 3)
    assert d.info["generator"] == "++-+++---+-"  # Plackett & Burman (1946), N = 12
    full = np.hstack([d.coded, d.dummies])
    np.testing.assert_array_equal(full.T @ full, 12 * np.eye(11))
    # the published cyclic generators: N = 20 and 24
    assert doe.PB_GENERATORS[20] == "++--++++-+-+----++-"
    assert doe.PB_GENERATORS[24] == "+++++-+-++--++--+-+----"
    assert doe.plackett_burman(12).n_runs == 16  # smallest multiple of 4 above k
    assert doe.plackett_burman(16).n_runs == 20
    with pytest.raises(InputError, match="multiple of 4"):
        doe.plackett_burman(5, n_runs=14)
    with pytest.raises(InputError, match="at most 11 factors"):
        doe.plackett_burman(12, n_runs=12)


def test_run_order_is_a_seeded_permutation():
    a = doe.plackett_burman(8, seed=3).run_order
    b = doe.plackett_burman(8, seed=3).run_order
    c = doe.plackett_burman(8, seed=4).run_order
    np.testing.assert_array_equal(a, b)
    assert sorted(a) == list(range(1, 13))
    assert not np.array_equal(a, c)


# ------------------------------------------------------------------------------ Box-Behnken
def _bbd_xtx_by_moments(n_centre: int) -> np.ndarray:
    """X'X of the 3-factor BBD quadratic model from its moments, written out by hand.

    Columns: 1, x1, x2, x3, x1x2, x1x3, x2x3, x1^2, x2^2, x3^2. Each factor is +/-1 in 8 of
    the 12 edge runs (sum x^2 = sum x^4 = 8); a pair of squares is 1 together in 4 runs.
    """
    n = 12 + n_centre
    xtx = np.zeros((10, 10))
    xtx[0, 0] = n
    xtx[0, 7:] = xtx[7:, 0] = 8
    for i in range(1, 4):
        xtx[i, i] = 8
    for i in range(4, 7):
        xtx[i, i] = 4
    for i in range(7, 10):
        for j in range(7, 10):
            xtx[i, j] = 8 if i == j else 4
    return xtx


@pytest.mark.parametrize("n_centre", [1, 3, 5])
def test_bbd3_det_inverse_information_matches_moments(n_centre):
    d = doe.box_behnken(3, center_points=n_centre, randomize=False)
    x = doe.model_matrix(d.coded, doe.model_terms(3, "quadratic"))
    ref = _bbd_xtx_by_moments(n_centre)
    np.testing.assert_array_equal(x.T @ x, ref)
    assert 1 / np.linalg.det(x.T @ x) == pytest.approx(1 / np.linalg.det(ref), rel=1e-12)


@pytest.mark.parametrize(("k", "edge"), [(3, 12), (4, 24), (5, 40), (6, 48), (7, 56)])
def test_bbd_run_counts_balance_and_orthogonal_main_effects(k, edge):
    d = doe.box_behnken(k, center_points=3, randomize=False)
    assert d.n_runs == edge + 3
    m = d.coded
    assert set(np.unique(m)) == {-1.0, 0.0, 1.0}
    np.testing.assert_array_equal(m.sum(axis=0), 0)
    gram = m.T @ m
    np.testing.assert_array_equal(gram, np.diag(np.diag(gram)))
    nz = (m[:edge] != 0).sum(axis=1)
    assert set(nz) == ({2} if k <= 5 else {3})
    assert np.all(np.abs(m).max(axis=1)[:edge] == 1)  # no run at a corner of the cube
    # every pair of factors varies together somewhere (all two-factor interactions estimable)
    for i, j in itertools.combinations(range(k), 2):
        assert np.any((m[:, i] != 0) & (m[:, j] != 0))
    x = doe.model_matrix(m, doe.model_terms(k, "quadratic"))
    assert np.linalg.matrix_rank(x) == x.shape[1]


def test_bbd7_is_the_fano_plane_each_pair_once():
    d = doe.box_behnken(7, center_points=0, randomize=False)
    together = np.zeros((7, 7), int)
    for block in d.info["blocks"]:
        for a, b in itertools.combinations(block, 2):
            i, j = int(a[1:]) - 1, int(b[1:]) - 1
            together[i, j] += 1
            together[j, i] += 1
    np.testing.assert_array_equal(together + np.eye(7, dtype=int), np.ones((7, 7), int))


def test_bbd_factor_count_out_of_range():
    with pytest.raises(InputError, match=r"box_behnken needs 3\.\.7 varied factors; got 2"):
        doe.box_behnken(2)


# ------------------------------------------------------------------------- central composite
@pytest.mark.parametrize("k", [2, 3, 4, 5])
def test_ccd_rotatable_moment_condition(k):
    d = doe.central_composite(k, alpha="rotatable", randomize=False)
    f = 2**k
    assert d.info["alpha"] == pytest.approx(f**0.25)
    m = d.coded
    # rotatable: sum x_i^4 = 3 sum x_i^2 x_j^2, odd moments zero
    assert np.sum(m[:, 0] ** 4) == pytest.approx(3 * np.sum(m[:, 0] ** 2 * m[:, 1] ** 2))
    np.testing.assert_allclose(m.sum(axis=0), 0, atol=1e-12)
    assert d.n_runs == f + 2 * k + (5 if k == 2 else 6)


def test_ccd2_det_inverse_information_by_hand():
    # k = 2, alpha = sqrt(2), 5 centre points: sum x^2 = 8, sum x^4 = 12, sum x1^2 x2^2 = 4
    d = doe.central_composite(2, center_points=5, randomize=False)
    x = doe.model_matrix(d.coded, doe.model_terms(2, "quadratic"))
    ref = np.array(
        [
            [13, 0, 0, 0, 8, 8],
            [0, 8, 0, 0, 0, 0],
            [0, 0, 8, 0, 0, 0],
            [0, 0, 0, 4, 0, 0],
            [8, 0, 0, 0, 12, 4],
            [8, 0, 0, 0, 4, 12],
        ],
        dtype=float,
    )
    np.testing.assert_allclose(x.T @ x, ref, atol=1e-12)
    assert 1 / np.linalg.det(x.T @ x) == pytest.approx(1 / np.linalg.det(ref), rel=1e-10)


@pytest.mark.parametrize(("k", "n0"), [(2, 4), (3, 6), (4, 3)])
def test_ccd_orthogonal_alpha_makes_square_columns_orthogonal(k, n0):
    d = doe.central_composite(k, alpha="orthogonal", center_points=n0, randomize=False)
    sq = d.coded**2
    sq = sq - sq.mean(axis=0)
    gram = sq.T @ sq
    np.testing.assert_allclose(gram - np.diag(np.diag(gram)), 0, atol=1e-10)


def test_ccd_inscribed_and_face():
    ins = doe.central_composite(3, kind="inscribed", randomize=False)
    assert np.abs(ins.coded).max() == pytest.approx(1.0)
    assert np.abs(ins.coded[:8]).max() == pytest.approx(1 / 8**0.25)
    face = doe.central_composite(3, kind="face", randomize=False)
    assert set(np.unique(face.coded)) == {-1.0, 0.0, 1.0}
    half = doe.central_composite(5, generators="E=ABCD", randomize=False)
    assert half.info["n_factorial"] == 16 and half.info["alpha"] == pytest.approx(2.0)
    with pytest.raises(InputError, match="alpha must be"):
        doe.central_composite(3, alpha="big")


# ------------------------------------------------------------------------------- factorials
PUBLISHED_RESOLUTION = {  # Montgomery, Design and Analysis of Experiments, Table 8.14
    (3, 1): 3, (4, 1): 4, (5, 1): 5, (5, 2): 3, (6, 1): 6, (6, 2): 4, (6, 3): 3, (7, 1): 7,
    (7, 2): 4, (7, 3): 4, (7, 4): 3, (8, 2): 5, (8, 3): 4, (8, 4): 4, (9, 4): 4, (9, 5): 3,
    (10, 6): 3, (11, 7): 3,
}  # fmt: skip


def _resolution_by_brute_force(m: np.ndarray) -> int | None:
    """Shortest product of columns that is constant (+/-1) over the runs."""
    k = m.shape[1]
    for r in range(1, k + 1):
        for combo in itertools.combinations(range(k), r):
            prod = np.prod(m[:, combo], axis=1)
            if np.all(prod == prod[0]):
                return r
    return None


@pytest.mark.parametrize(("k", "p"), sorted(doe.FRACTION_GENERATORS))
def test_fraction_resolution(k, p):
    d = doe.factorial(k, fraction=p, randomize=False)
    assert d.n_runs == 2 ** (k - p)
    assert d.info["resolution"] == PUBLISHED_RESOLUTION[(k, p)]
    assert _resolution_by_brute_force(d.coded) == PUBLISHED_RESOLUTION[(k, p)]
    assert len(d.info["defining_relation"]) == 2**p - 1
    m = d.coded
    np.testing.assert_array_equal(m.T @ m, d.n_runs * np.eye(k))


def test_full_factorial_yates_order_and_aliases():
    d = doe.factorial(3, center_points=2, randomize=False)
    np.testing.assert_array_equal(d.coded[:4], [[-1, -1, -1], [1, -1, -1], [-1, 1, -1], [1, 1, -1]])
    assert d.n_runs == 10 and d.info["resolution"] is None
    half = doe.factorial(4, generators=["D=ABC"], randomize=False)
    assert half.info["defining_relation"] == ["ABCD"]
    assert half.info["aliases"]["AB"] == ["CD"]
    assert half.info["aliases"]["A"] == ["BCD"]
    neg = doe.factorial(4, generators="D=-ABC", randomize=False)
    np.testing.assert_array_equal(neg.coded[:, 3], -np.prod(neg.coded[:, :3], axis=1))
    with pytest.raises(InputError, match="generators"):
        doe.factorial(4, generators=["D=ABD"])
    with pytest.raises(InputError, match="no tabulated generators"):
        doe.factorial(12, fraction=8)


# --------------------------------------------------------------------------- space filling
def test_latin_hypercube_one_point_per_stratum():
    d = doe.latin_hypercube(4, 10, seed=1)
    strata = np.floor((d.coded + 1) / 2 * 10).astype(int)
    for j in range(4):
        assert sorted(strata[:, j]) == list(range(10))
    np.testing.assert_array_equal(d.coded, doe.latin_hypercube(4, 10, seed=1).coded)


def test_sobol_in_box_and_balanced_for_powers_of_two():
    d = doe.sobol(3, 16, seed=2)
    assert d.coded.shape == (16, 3)
    assert np.all(np.abs(d.coded) <= 1)
    # a (t, m, s)-net in base 2: each half of each axis holds exactly half the points
    assert np.all((d.coded > 0).sum(axis=0) == 8)
    assert doe.sobol(3, 10, seed=2).n_runs == 10  # not a power of 2: allowed, no warning


def test_design_frame_has_run_std_actual_and_coded_columns():
    space = doe.FactorSpace(
        [doe.Factor("a", 0, 2), doe.Factor("b", 10, 20), doe.Factor("c", 1, 3, fixed=2.5)]
    )
    d = doe.factorial(space, seed=5)
    frame = d.to_frame()
    assert list(frame.columns) == ["run", "std", "point_type", "a", "b", "c", "a_coded", "b_coded"]
    assert list(frame["run"]) == [1, 2, 3, 4]
    assert (frame["c"] == 2.5).all()
    np.testing.assert_allclose(frame["a"], 1 + frame["a_coded"])
    std = d.to_frame(order="standard")
    assert list(std["std"]) == [1, 2, 3, 4]


# ---------------------------------------------------------------------------- steepest path
def test_steepest_ascent_proportional_textbook_example():
    # Montgomery, Example 11.1: yhat = 40.44 + 0.775 x1 + 0.325 x2; time 30-40 min,
    # temperature 150-160 F; a step of 5 min (1 coded) in time moves temperature by 0.42
    # coded units, i.e. about 2 F.
    space = doe.FactorSpace([doe.Factor("time", 30, 40), doe.Factor("temp", 150, 160)])
    path = doe.steepest_path({"time": 0.775, "temp": 0.325}, factors=space, n_points=4)
    assert path.info["step_coded"]["temp"] == pytest.approx(0.325 / 0.775)
    assert round(path.info["step_actual"]["temp"], 1) == 2.1
    np.testing.assert_allclose(path.actual[:, 0], [35, 40, 45, 50])
    down = doe.steepest_path({"time": 0.775, "temp": 0.325}, factors=space, direction="descent")
    assert down.info["step_coded"]["time"] == -1.0


def test_steepest_path_from_a_fit_and_errors():
    d = doe.factorial(3, randomize=False)
    y = 3 * d.coded[:, 0] - 1 * d.coded[:, 1] + 0.5 * d.coded[:, 2]
    rs = doe.fit(d, y, model="linear")
    path = doe.steepest_path(rs, n_points=3, step=0.5)
    np.testing.assert_allclose(path.coded[1], [0.5, -0.5 / 3, 0.25 / 3])
    with pytest.raises(InputError, match="steps: no step given"):
        doe.steepest_path(rs, steps={"x1": 0.1}, move=["x1", "x2"])
    with pytest.raises(InputError, match="needs factors"):
        doe.steepest_path(rs, units="actual")
