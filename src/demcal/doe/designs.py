"""Experimental designs in coded units: screening, response-surface and space-filling.

Every function returns a :class:`Design`: the coded matrix in *standard order* (the order the
design is tabulated in the literature and in Design-Expert), the factor names, a randomised run
order and, when factors with levels are given, the actual values. Coded units: -1 = low level,
+1 = high level, 0 = centre (see :mod:`demcal.doe.factors`).

Factors can be given as an int ``k`` (names ``x1 .. xk``, coded only), a sequence of names, a
:class:`~demcal.doe.factors.FactorSpace` (or a sequence of :class:`~demcal.doe.factors.Factor`),
or a mapping ``name -> (low, high)``. Fixed factors of a space are not varied; they appear in
:meth:`Design.to_frame` at their fixed value.
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Literal

import numpy as np
import pandas as pd
from scipy.stats import qmc

from demcal.doe.factors import Factor, FactorSpace, as_factor_space
from demcal.errors import InputError
from demcal.limits import MAX_DESIGN_RUNS

__all__ = [
    "FRACTION_GENERATORS",
    "PB_GENERATORS",
    "Design",
    "box_behnken",
    "central_composite",
    "factorial",
    "latin_hypercube",
    "plackett_burman",
    "sobol",
    "steepest_path",
]

Seed = int | np.random.Generator | None

#: Cyclic generators (first row) of the Plackett & Burman (1946) designs, ``+`` = high level.
#: Row ``i`` of the design is the generator rotated right by ``i``; a last row of all ``-``
#: completes it. The generators for N = 8, 12, 20, 24 and 44 are the quadratic-residue
#: (Paley) sequences; 48 is the Paley sequence mod 47. N = 28 and 40 are not cyclic and are
#: built in :func:`_pb_matrix`.
PB_GENERATORS: Mapping[int, str] = MappingProxyType(
    {
        8: "+++-+--",
        12: "++-+++---+-",
        16: "++++-+-++--+---",
        20: "++--++++-+-+----++-",
        24: "+++++-+-++--++--+-+----",
        32: "----+-+-+++-++---+++++--++-+--+",
        36: "-+-+++---+++++-+++--+----+-+-++--+-",
        44: "++--+-+--+++-+++++---+-+++-----+---++-+-++-",
        48: "+++++-++++--+-+-+++--+--++-++---+-+-++----+----",
    }
)

# Box & Behnken (1960): factor triples for 6 factors (partially balanced) and 7 factors (the
# Fano plane, a balanced incomplete block design); 0-based factor indices.
_BBD_BLOCKS: Mapping[int, tuple[tuple[int, ...], ...]] = MappingProxyType(
    {
        6: ((0, 1, 3), (1, 2, 4), (2, 3, 5), (0, 3, 4), (1, 4, 5), (0, 2, 5)),
        7: ((3, 4, 5), (0, 5, 6), (1, 4, 6), (0, 1, 3), (2, 3, 6), (0, 2, 4), (1, 2, 5)),
    }
)

# Minimum-aberration two-level fractions (Montgomery, Design and Analysis of Experiments,
# Table 8.14; Box, Hunter & Hunter). Key: (k, p). Letters A, B, C, ... skip I.
FRACTION_GENERATORS: Mapping[tuple[int, int], tuple[str, ...]] = MappingProxyType(
    {
        (3, 1): ("C=AB",),
        (4, 1): ("D=ABC",),
        (5, 1): ("E=ABCD",),
        (5, 2): ("D=AB", "E=AC"),
        (6, 1): ("F=ABCDE",),
        (6, 2): ("E=ABC", "F=BCD"),
        (6, 3): ("D=AB", "E=AC", "F=BC"),
        (7, 1): ("G=ABCDEF",),
        (7, 2): ("F=ABCD", "G=ABDE"),
        (7, 3): ("E=ABC", "F=BCD", "G=ACD"),
        (7, 4): ("D=AB", "E=AC", "F=BC", "G=ABC"),
        (8, 2): ("G=ABCD", "H=ABEF"),
        (8, 3): ("F=ABC", "G=ABD", "H=BCDE"),
        (8, 4): ("E=BCD", "F=ACD", "G=ABC", "H=ABD"),
        (9, 4): ("F=BCDE", "G=ACDE", "H=ABDE", "J=ABCE"),
        (9, 5): ("E=ABC", "F=BCD", "G=ACD", "H=ABD", "J=ABCD"),
        (10, 6): ("E=ABC", "F=BCD", "G=ACD", "H=ABD", "J=ABCD", "K=AB"),
        (11, 7): ("E=ABC", "F=BCD", "G=ACD", "H=ABD", "J=ABCD", "K=AB", "L=AC"),
    }
)

_LETTERS = "ABCDEFGHJKLMNOPQRSTUVWXYZ"  # Design-Expert's factor letters (no I)


# --------------------------------------------------------------------------------------------
# The result object
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Design:
    """A design: coded runs in standard order, factor names and run order.

    Attributes
    ----------
    coded : (n_runs, n_factors) float64 ndarray
        Coded settings of the varied factors, rows in standard order.
    names : tuple of str
        Names of the varied factors (columns of ``coded``).
    kind : str
        Design family (``"plackett_burman"``, ``"box_behnken"``, ...).
    run_order : (n_runs,) int64 ndarray
        Run number (1-based) of each standard-order row: the order to carry runs out in.
    factors : FactorSpace or None
        Levels of the varied factors and of any fixed ones; None for a purely coded design.
    point_type : (n_runs,) str ndarray
        ``"factorial"``, ``"axial"``, ``"edge"``, ``"center"``, ``"path"`` or ``"space"``.
    dummies : (n_runs, n_dummies) float64 ndarray
        Unused columns of a Plackett-Burman design (empty otherwise).
    info : mapping
        Family-specific facts: PB generator, CCD alpha, fraction generators, resolution,
        defining relation and alias structure, steepest-path step, ...
    """

    coded: np.ndarray
    names: tuple[str, ...]
    kind: str
    run_order: np.ndarray
    factors: FactorSpace | None = None
    point_type: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=object))
    dummies: np.ndarray = field(default_factory=lambda: np.empty((0, 0)))
    info: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        coded = np.array(self.coded, dtype=float)
        coded = np.round(coded, 12) + 0.0  # drop float noise such as -2e-16 (and -0.0)
        coded.setflags(write=False)
        object.__setattr__(self, "coded", coded)
        n = coded.shape[0]
        ro = np.array(self.run_order, dtype=np.int64)
        ro.setflags(write=False)
        object.__setattr__(self, "run_order", ro)
        pt = np.array(self.point_type, dtype=object)
        if pt.size == 0:
            pt = np.full(n, "factorial", dtype=object)
        object.__setattr__(self, "point_type", pt)
        d = np.array(self.dummies, dtype=float)
        if d.size == 0:
            d = np.empty((n, 0))
        object.__setattr__(self, "dummies", d)
        object.__setattr__(self, "info", MappingProxyType(dict(self.info)))

    @property
    def n_runs(self) -> int:
        """Number of runs."""
        return int(self.coded.shape[0])

    @property
    def n_factors(self) -> int:
        """Number of varied factors."""
        return int(self.coded.shape[1])

    @property
    def actual(self) -> np.ndarray:
        """(n_runs, n_factors) float64 ndarray: actual settings of the varied factors.

        Raises
        ------
        InputError
            If the design has no factor levels (it was built from names or a count).
        """
        if self.factors is None:
            raise InputError("this design has coded units only; give factors with low and high")
        return self.factors.subset(self.names).to_actual(self.coded)

    def with_factors(self, factors: Any) -> Design:
        """The same design with factor levels attached (names must match, in any order)."""
        space = as_factor_space(factors)
        missing = [n for n in self.names if n not in space]
        if missing:
            raise InputError(f"factors lack the design's factor(s) {', '.join(missing)}")
        return Design(
            self.coded,
            self.names,
            self.kind,
            self.run_order,
            space,
            self.point_type,
            self.dummies,
            self.info,
        )

    def to_frame(
        self, *, order: Literal["run", "standard"] = "run", include_dummies: bool = False
    ) -> pd.DataFrame:
        """The run sheet as a DataFrame.

        Columns: ``run`` (run order, 1-based), ``std`` (standard order, 1-based),
        ``point_type``, then for a design with factor levels the actual value of every factor
        (named by the factor, fixed factors included at their value) followed by the coded
        value of every varied factor (``<name>_coded``); for a coded-only design just the coded
        columns named by the factors.

        Parameters
        ----------
        order : {"run", "standard"}, optional
            Row order.
        include_dummies : bool, optional
            Also give a Plackett-Burman design's unused columns (``dummy1``, ...).

        Returns
        -------
        pandas.DataFrame
            One row per run.
        """
        if order not in ("run", "standard"):
            raise InputError(f"order must be 'run' or 'standard'; got {order!r}")
        cols: dict[str, Any] = {
            "run": self.run_order,
            "std": np.arange(1, self.n_runs + 1),
            "point_type": self.point_type,
        }
        if self.factors is None:
            for j, name in enumerate(self.names):
                cols[name] = self.coded[:, j]
        else:
            actual = self.actual
            for f in self.factors:
                if f.name in self.names:
                    cols[f.name] = actual[:, self.names.index(f.name)]
                else:
                    value = f.fixed if f.fixed is not None else f.center
                    cols[f.name] = np.full(self.n_runs, value)
            for j, name in enumerate(self.names):
                cols[f"{name}_coded"] = self.coded[:, j]
        if include_dummies:
            for j in range(self.dummies.shape[1]):
                cols[f"dummy{j + 1}"] = self.dummies[:, j]
        frame = pd.DataFrame(cols)
        if order == "run":
            frame = frame.sort_values("run", kind="stable")
        return frame.reset_index(drop=True)


# --------------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------------
def _resolve(factors: Any, *, min_k: int = 1, max_k: int | None = None, what: str = "design"):
    """Return (names of varied factors, FactorSpace or None)."""
    space: FactorSpace | None
    if isinstance(factors, bool):
        raise InputError(f"factors must be a count, names or factors; got {factors!r}")
    if isinstance(factors, int | np.integer):
        k = int(factors)
        if k < 1:
            raise InputError(f"number of factors must be >= 1; got {k}")
        names = tuple(f"x{i + 1}" for i in range(k))
        space = None
    elif isinstance(factors, FactorSpace | Mapping) or (
        isinstance(factors, Sequence)
        and not isinstance(factors, str)
        and len(factors) > 0
        and all(isinstance(f, Factor) for f in factors)
    ):
        space = as_factor_space(factors)
        names = space.free.names
    elif isinstance(factors, Sequence) and not isinstance(factors, str):
        names = tuple(str(n) for n in factors)
        if len(set(names)) != len(names):
            raise InputError(f"factor names must be unique; got {', '.join(names)}")
        space = None
    else:
        raise InputError(
            f"factors must be a count, a sequence of names, or factors; got {factors!r}"
        )
    k = len(names)
    if k < min_k or (max_k is not None and k > max_k):
        rng = f"{min_k}..{max_k}" if max_k is not None else f">= {min_k}"
        raise InputError(f"{what} needs {rng} varied factors; got {k}")
    return names, space


def _run_order(n: int, randomize: bool, seed: Seed) -> np.ndarray:
    if not randomize:
        return np.arange(1, n + 1)
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    order = np.empty(n, dtype=np.int64)
    order[rng.permutation(n)] = np.arange(1, n + 1)
    return order


def _check_int(value: Any, name: str, lo: int, hi: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise InputError(f"{name} must be an integer; got {value!r}")
    v = int(value)
    if v < lo or (hi is not None and v > hi):
        rng = f"in [{lo}, {hi}]" if hi is not None else f">= {lo}"
        raise InputError(f"{name} must be {rng}; got {v}")
    return v


def _full_two_level(k: int) -> np.ndarray:
    """2^k runs in Yates standard order (first column alternates fastest)."""
    n = 2**k
    idx = np.arange(n)[:, None]
    return np.where((idx >> np.arange(k)) & 1, 1.0, -1.0)


def _sign_vector(gen: str) -> np.ndarray:
    return np.array([1.0 if c == "+" else -1.0 for c in gen])


def _cyclic(gen: str) -> np.ndarray:
    v = _sign_vector(gen)
    m = len(v)
    rows = [np.roll(v, i) for i in range(m)]
    rows.append(-np.ones(m))
    return np.array(rows)


def _paley2(q: int) -> np.ndarray:
    """Hadamard matrix of order 2(q+1) for a prime q = 1 mod 4 (Paley's second construction)."""
    residues = {(i * i) % q for i in range(1, q)}
    chi = np.array([0] + [1 if i in residues else -1 for i in range(1, q)])
    jac = np.array([[chi[(j - i) % q] for j in range(q)] for i in range(q)])
    c = np.zeros((q + 1, q + 1), dtype=int)
    c[0, 1:] = 1
    c[1:, 0] = 1
    c[1:, 1:] = jac
    a = np.array([[1, 1], [1, -1]])
    b = np.array([[1, -1], [-1, -1]])
    return np.kron(c, a) + np.kron(np.eye(q + 1, dtype=int), b)


def _pb_matrix(n: int) -> np.ndarray:
    """(n, n-1) two-level orthogonal array, the Plackett-Burman design of ``n`` runs."""
    if n in PB_GENERATORS:
        return _cyclic(PB_GENERATORS[n])
    if n == 28:
        h = _paley2(13).astype(float)
    elif n == 40:
        h20 = np.c_[np.ones(20), _cyclic(PB_GENERATORS[20])]
        h = np.block([[h20, h20], [h20, -h20]])
    else:  # pragma: no cover - guarded by the caller
        raise InputError(f"n_runs must be a multiple of 4 in [8, 48]; got {n}")
    h = h * h[:, :1]  # normalise: first column all +1
    m = h[:, 1:]
    # order as the cyclic designs: the all-minus run last
    allminus = np.flatnonzero((m == -1).all(axis=1))
    if allminus.size:
        rest = np.setdiff1d(np.arange(n), allminus)
        m = np.vstack([m[rest], m[allminus]])
    return m


# --------------------------------------------------------------------------------------------
# Screening
# --------------------------------------------------------------------------------------------
def plackett_burman(
    factors: Any,
    *,
    n_runs: int | None = None,
    randomize: bool = True,
    seed: Seed = None,
) -> Design:
    """Plackett-Burman screening design.

    The first ``k`` columns of the ``n_runs``-run Plackett & Burman (1946) orthogonal array hold
    the factors; the remaining ``n_runs - 1 - k`` columns are dummies (their effects estimate
    the error). Standard order is the cyclic order: row ``i`` is the generator rotated right by
    ``i`` and the last row has every factor low. This is the order Design-Expert lists and the
    order of the paper's Table 4 (N = 12, generator ``++-+++---+-``).

    Parameters
    ----------
    factors : int, sequence of str, FactorSpace or mapping
        The factors (see the module docstring); 1 to ``n_runs - 1`` varied factors.
    n_runs : int, optional
        Multiple of 4 in [8, 48]; default the smallest one with ``n_runs > k``, at least 12
        (8 runs when ``k <= 4`` only if asked).
    randomize : bool, optional
        Randomise the run order (default True).
    seed : int or numpy.random.Generator, optional
        Seed of the run-order permutation.

    Returns
    -------
    Design
        ``coded``: (n_runs, k) of +/-1; ``dummies``: (n_runs, n_runs - 1 - k);
        ``info["generator"]``.

    Examples
    --------
    >>> from demcal import doe
    >>> d = doe.plackett_burman(8, n_runs=12, randomize=False)
    >>> d.coded[0].astype(int).tolist()
    [1, 1, -1, 1, 1, 1, -1, -1]
    """
    names, space = _resolve(factors, what="plackett_burman")
    k = len(names)
    if n_runs is None:
        n_runs = max(12, 4 * (k // 4 + 1))
    n_runs = _check_int(n_runs, "n_runs", 8, 48)
    if n_runs % 4:
        raise InputError(f"n_runs must be a multiple of 4 in [8, 48]; got {n_runs}")
    if k > n_runs - 1:
        raise InputError(
            f"plackett_burman with n_runs={n_runs} holds at most {n_runs - 1} factors; got {k}"
        )
    m = _pb_matrix(n_runs)
    info: dict[str, Any] = {"n_dummies": n_runs - 1 - k}
    if n_runs in PB_GENERATORS:
        info["generator"] = PB_GENERATORS[n_runs]
        info["construction"] = "cyclic generator, Plackett & Burman (1946)"
    elif n_runs == 28:
        info["construction"] = "Paley's second construction, q = 13"
    else:
        info["construction"] = "doubled 20-run Plackett-Burman design"
    return Design(
        coded=m[:, :k],
        names=names,
        kind="plackett_burman",
        run_order=_run_order(n_runs, randomize, seed),
        factors=space,
        dummies=m[:, k:],
        info=info,
    )


def _parse_generator(g: Any, letters: str) -> tuple[int, frozenset[int], int]:
    """Parse one ``'D=ABC'`` (or ``'D=-ABC'``) over ``letters`` into (factor, word, sign)."""
    text = str(g).replace(" ", "").upper()
    if "=" not in text:
        raise InputError(f"generators: {g!r} must look like 'D=ABC'")
    lhs, rhs = text.split("=", 1)
    sign = -1 if rhs.startswith("-") else 1
    rhs = rhs[1:] if rhs[:1] in ("-", "+") else rhs
    if len(lhs) != 1 or lhs not in letters:
        raise InputError(f"generators: {g!r}: left side must be one of the letters {letters}")
    if not rhs or any(c not in letters for c in rhs) or len(set(rhs)) != len(rhs):
        raise InputError(f"generators: {g!r}: right side must be distinct letters of {letters}")
    if lhs in rhs:
        raise InputError(f"generators: {g!r} defines a factor from itself")
    return letters.index(lhs), frozenset(letters.index(c) for c in rhs), sign


def _parse_generators(generators: Any, k: int) -> list[tuple[int, frozenset[int], int]]:
    """Parse ``'D=ABC'`` strings into (generated factor, word of basic factors, sign)."""
    if isinstance(generators, str):
        generators = generators.replace(",", " ").split()
    letters = _LETTERS[:k]
    out = [_parse_generator(g, letters) for g in generators]
    targets = [t for t, _, _ in out]
    if len(set(targets)) != len(targets):
        raise InputError("generators: a factor is generated twice")
    for _, word, _ in out:
        if word & set(targets):
            raise InputError("generators: a right side must use only basic (not generated) factors")
    return out


def _word(word: frozenset[int]) -> str:
    return "".join(_LETTERS[i] for i in sorted(word))


def _check_factorial_size(k: int, p: int, center_points: int) -> None:
    """Refuse a 2^(k-p) design beyond :data:`demcal.limits.MAX_DESIGN_RUNS` runs (or with a
    defining relation of more words) before it is built: a 2^20 full factorial took 3.4 GB."""
    runs = 2 ** (k - p) + center_points
    if runs > MAX_DESIGN_RUNS:
        raise InputError(f"a 2^({k}-{p}) factorial has {runs:,} runs; at most "
                         f"{MAX_DESIGN_RUNS:,}: use a fraction (fraction/generators) or fewer "
                         "factors")
    if 2 ** p - 1 > MAX_DESIGN_RUNS:
        raise InputError(f"{p} generators give a defining relation of {2 ** p - 1:,} words; at "
                         f"most {MAX_DESIGN_RUNS:,}")


def _defining_relation(gens: Sequence[tuple[int, frozenset[int], int]]
                       ) -> list[tuple[frozenset[int], int]]:
    """Every product of the generator words I = target * word, with its sign."""
    gen_words = [(word | {t}, sign) for t, word, sign in gens]
    relation: list[tuple[frozenset[int], int]] = []
    for r in range(1, len(gen_words) + 1):
        for combo in itertools.combinations(gen_words, r):
            w: frozenset[int] = frozenset()
            s = 1
            for gw, gs in combo:
                w = w ^ gw
                s *= gs
            relation.append((w, s))
    return relation


def _aliases(relation: Sequence[tuple[frozenset[int], int]], k: int) -> dict[str, list[str]]:
    """Aliases (of up to three letters) of each main effect and two-factor interaction."""
    if not relation:
        return {}
    effects = [frozenset([i]) for i in range(k)] + [
        frozenset(c) for c in itertools.combinations(range(k), 2)
    ]
    return {
        _word(e): sorted(
            {("-" if s < 0 else "") + _word(e ^ w) for w, s in relation if len(e ^ w) <= 3},
            key=lambda t: (len(t.lstrip("-")), t.lstrip("-")),
        )
        for e in effects
    }


def factorial(
    factors: Any,
    *,
    fraction: int = 0,
    generators: Sequence[str] | str | None = None,
    center_points: int = 0,
    randomize: bool = True,
    seed: Seed = None,
) -> Design:
    """Two-level full or regular fractional factorial design (2^(k-p)).

    Factors are lettered A, B, C, ... (I skipped) in order. A fraction is given either by
    ``generators`` such as ``["D=ABC"]`` or ``"E=ABC F=-BCD"`` (each generated factor is the
    product of basic ones), or by ``fraction = p`` alone, which takes the minimum-aberration
    generators of :data:`FRACTION_GENERATORS`. Standard order is Yates order of the basic
    factors (A alternates fastest).

    Parameters
    ----------
    factors : int, sequence of str, FactorSpace or mapping
        The factors; 2 to 25 varied factors.
    fraction : int, optional
        p, the number of generated factors (0: full factorial).
    generators : sequence of str or str, optional
        Explicit generators; overrides ``fraction``.
    center_points : int, optional
        Centre runs appended after the factorial runs.
    randomize : bool, optional
        Randomise the run order.
    seed : int or numpy.random.Generator, optional
        Seed of the run-order permutation.

    Returns
    -------
    Design
        ``info`` holds ``generators``, ``defining_relation`` (words, e.g. ``["ABCD"]``),
        ``resolution`` (int; None for a full factorial) and ``aliases`` (main effects and
        two-factor interactions -> aliased effects of order <= 3).
    """
    names, space = _resolve(factors, min_k=2, max_k=len(_LETTERS), what="factorial")
    k = len(names)
    center_points = _check_int(center_points, "center_points", 0)
    if generators is None:
        p = _check_int(fraction, "fraction", 0, k - 1)
        if p and (k, p) not in FRACTION_GENERATORS:
            known = ", ".join(f"2^({a}-{b})" for a, b in FRACTION_GENERATORS)
            raise InputError(
                f"no tabulated generators for a 2^({k}-{p}) fraction; pass generators "
                f"explicitly (tabulated: {known})"
            )
        generators = FRACTION_GENERATORS.get((k, p), ())
    gens = _parse_generators(generators, k)
    p = len(gens)
    if k - p < 1:
        raise InputError("generators leave no basic factor")
    _check_factorial_size(k, p, center_points)
    generated = {t for t, _, _ in gens}
    basic = [i for i in range(k) if i not in generated]
    base = _full_two_level(len(basic))
    coded = np.zeros((base.shape[0], k))
    coded[:, basic] = base
    for target, word, sign in gens:
        coded[:, target] = sign * np.prod(coded[:, sorted(word)], axis=1)
    relation = _defining_relation(gens)
    resolution = min((len(w) for w, _ in relation), default=None)
    aliases = _aliases(relation, k)
    n_fact = coded.shape[0]
    if center_points:
        coded = np.vstack([coded, np.zeros((center_points, k))])
    pt = np.array(["factorial"] * n_fact + ["center"] * center_points, dtype=object)
    info = {
        "letters": {_LETTERS[i]: names[i] for i in range(k)},
        "generators": [f"{_LETTERS[t]}={'-' if s < 0 else ''}{_word(w)}" for t, w, s in gens],
        "defining_relation": [("-" if s < 0 else "") + _word(w) for w, s in relation],
        "resolution": resolution,
        "aliases": aliases,
    }
    return Design(
        coded=coded,
        names=names,
        kind="factorial" if p == 0 else "fractional_factorial",
        run_order=_run_order(coded.shape[0], randomize, seed),
        factors=space,
        point_type=pt,
        info=info,
    )


# --------------------------------------------------------------------------------------------
# Response-surface designs
# --------------------------------------------------------------------------------------------
def box_behnken(
    factors: Any,
    *,
    center_points: int | None = None,
    randomize: bool = True,
    seed: Seed = None,
) -> Design:
    """Box-Behnken design for 3 to 7 factors.

    For 3-5 factors every pair of factors forms a 2^2 factorial at +/-1 with the others at 0;
    for 6 and 7 factors the standard Box & Behnken (1960) triples (a partially balanced design
    for 6 factors, the balanced Fano-plane design for 7) each form a 2^3 factorial. Centre
    points follow. Runs: 12/24/40/48/56 + centre points for k = 3/4/5/6/7.

    Parameters
    ----------
    factors : int, sequence of str, FactorSpace or mapping
        The factors; 3 to 7 varied factors.
    center_points : int, optional
        Number of centre runs; default as Design-Expert: 5 for k <= 5, 6 otherwise.
    randomize : bool, optional
        Randomise the run order.
    seed : int or numpy.random.Generator, optional
        Seed of the run-order permutation.

    Returns
    -------
    Design
        ``point_type`` is ``"edge"`` or ``"center"``.

    Examples
    --------
    >>> from demcal import doe
    >>> doe.box_behnken(3, center_points=3).n_runs
    15
    """
    names, space = _resolve(factors, min_k=3, max_k=7, what="box_behnken")
    k = len(names)
    if center_points is None:
        center_points = 5 if k <= 5 else 6
    center_points = _check_int(center_points, "center_points", 0)
    blocks = _BBD_BLOCKS.get(k) or tuple(itertools.combinations(range(k), 2))
    rows = []
    for block in blocks:
        sub = _full_two_level(len(block))
        part = np.zeros((sub.shape[0], k))
        part[:, list(block)] = sub
        rows.append(part)
    edge = np.vstack(rows)
    coded = np.vstack([edge, np.zeros((center_points, k))])
    pt = np.array(["edge"] * edge.shape[0] + ["center"] * center_points, dtype=object)
    return Design(
        coded=coded,
        names=names,
        kind="box_behnken",
        run_order=_run_order(coded.shape[0], randomize, seed),
        factors=space,
        point_type=pt,
        info={"blocks": [tuple(names[i] for i in b) for b in blocks]},
    )


def central_composite(
    factors: Any,
    *,
    kind: Literal["circumscribed", "inscribed", "face"] = "circumscribed",
    alpha: Literal["rotatable", "orthogonal"] | float = "rotatable",
    center_points: int | None = None,
    generators: Sequence[str] | str | None = None,
    randomize: bool = True,
    seed: Seed = None,
) -> Design:
    """Central composite design: 2^(k-p) factorial + 2k axial points + centre points.

    Axial distance ``alpha`` (in units of the factorial half range):

    - ``"rotatable"``: ``alpha = F ** (1/4)``, F = number of factorial runs;
    - ``"orthogonal"``: ``alpha = (F (sqrt(N) - sqrt(F))**2 / 4) ** (1/4)``, N = total runs,
      which makes the quadratic columns orthogonal to each other;
    - a number.

    ``kind="circumscribed"`` puts the factorial points at +/-1 and the axial points at
    +/-alpha; ``"inscribed"`` scales the whole design by 1/alpha so the axial points sit at
    +/-1; ``"face"`` uses alpha = 1 (face-centred).

    Parameters
    ----------
    factors : int, sequence of str, FactorSpace or mapping
        The factors; 2 to 10 varied factors.
    kind : {"circumscribed", "inscribed", "face"}, optional
        Placement of the points.
    alpha : {"rotatable", "orthogonal"} or float, optional
        Axial distance (ignored for ``kind="face"``).
    center_points : int, optional
        Centre runs; default 5 for k = 2, otherwise 6.
    generators : sequence of str or str, optional
        Fractional factorial core (e.g. ``["E=ABCD"]``); default the full factorial.
    randomize : bool, optional
        Randomise the run order.
    seed : int or numpy.random.Generator, optional
        Seed of the run-order permutation.

    Returns
    -------
    Design
        ``info["alpha"]`` (float, before inscribed scaling) and ``info["kind"]``.
    """
    names, space = _resolve(factors, min_k=2, max_k=10, what="central_composite")
    k = len(names)
    if kind not in ("circumscribed", "inscribed", "face"):
        raise InputError(f"kind must be 'circumscribed', 'inscribed' or 'face'; got {kind!r}")
    if center_points is None:
        center_points = 5 if k == 2 else 6
    center_points = _check_int(center_points, "center_points", 0)
    core = factorial(names, generators=generators or (), randomize=False).coded
    n_f = core.shape[0]
    n_total = n_f + 2 * k + center_points
    if kind == "face":
        a = 1.0
    elif alpha == "rotatable":
        a = n_f**0.25
    elif alpha == "orthogonal":
        a = (n_f * (math.sqrt(n_total) - math.sqrt(n_f)) ** 2 / 4.0) ** 0.25
    else:
        try:
            a = float(alpha)
        except (TypeError, ValueError):
            raise InputError(
                f"alpha must be 'rotatable', 'orthogonal' or a number > 0; got {alpha!r}"
            ) from None
        if not (math.isfinite(a) and a > 0):
            raise InputError(f"alpha must be 'rotatable', 'orthogonal' or > 0; got {alpha!r}")
    axial = np.zeros((2 * k, k))
    for j in range(k):
        axial[2 * j, j] = -a
        axial[2 * j + 1, j] = a
    coded = np.vstack([core, axial, np.zeros((center_points, k))])
    if kind == "inscribed":
        coded = coded / a
    pt = np.array(
        ["factorial"] * n_f + ["axial"] * (2 * k) + ["center"] * center_points, dtype=object
    )
    return Design(
        coded=coded,
        names=names,
        kind="central_composite",
        run_order=_run_order(coded.shape[0], randomize, seed),
        factors=space,
        point_type=pt,
        info={"alpha": a, "kind": kind, "n_factorial": n_f, "n_axial": 2 * k},
    )


# --------------------------------------------------------------------------------------------
# Space filling
# --------------------------------------------------------------------------------------------
def _rng_for_qmc(seed: Seed) -> np.random.Generator:
    return seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)


def latin_hypercube(
    factors: Any,
    n_runs: int,
    *,
    seed: Seed = None,
    optimization: Literal["random-cd", "lloyd"] | None = None,
) -> Design:
    """Latin hypercube sample over the coded box [-1, 1]^k (scipy.stats.qmc.LatinHypercube).

    Parameters
    ----------
    factors : int, sequence of str, FactorSpace or mapping
        The factors.
    n_runs : int
        Number of points, >= 2.
    seed : int or numpy.random.Generator, optional
        Seed of the sample.
    optimization : {"random-cd", "lloyd"}, optional
        scipy's space-filling improvement of the sample.

    Returns
    -------
    Design
        Each column holds exactly one point in each of ``n_runs`` equal strata of [-1, 1].
    """
    names, space = _resolve(factors, what="latin_hypercube")
    n_runs = _check_int(n_runs, "n_runs", 2)
    if optimization not in (None, "random-cd", "lloyd"):
        raise InputError(f"optimization must be None, 'random-cd' or 'lloyd'; got {optimization!r}")
    engine = qmc.LatinHypercube(len(names), optimization=optimization, rng=_rng_for_qmc(seed))
    u = engine.random(n_runs)
    return Design(
        coded=2.0 * u - 1.0,
        names=names,
        kind="latin_hypercube",
        run_order=np.arange(1, n_runs + 1),
        factors=space,
        point_type=np.full(n_runs, "space", dtype=object),
    )


def sobol(factors: Any, n_runs: int, *, seed: Seed = None, scramble: bool = True) -> Design:
    """Sobol low-discrepancy sequence over the coded box [-1, 1]^k (scipy.stats.qmc.Sobol).

    Parameters
    ----------
    factors : int, sequence of str, FactorSpace or mapping
        The factors (at most 21201).
    n_runs : int
        Number of points, >= 2; a power of 2 keeps the sequence's balance properties.
    seed : int or numpy.random.Generator, optional
        Seed of the scrambling.
    scramble : bool, optional
        Owen scrambling (default True).

    Returns
    -------
    Design
    """
    names, space = _resolve(factors, what="sobol")
    n_runs = _check_int(n_runs, "n_runs", 2)
    engine = qmc.Sobol(len(names), scramble=scramble, rng=_rng_for_qmc(seed))
    with warnings.catch_warnings():
        # scipy warns when n is not a power of two; documented above instead.
        warnings.filterwarnings("ignore", message=".*balance properties.*", category=UserWarning)
        u = engine.random(n_runs)
    return Design(
        coded=2.0 * u - 1.0,
        names=names,
        kind="sobol",
        run_order=np.arange(1, n_runs + 1),
        factors=space,
        point_type=np.full(n_runs, "space", dtype=object),
    )


# --------------------------------------------------------------------------------------------
# Steepest ascent / descent
# --------------------------------------------------------------------------------------------
def _main_effect_coefficients(source: Any) -> dict[str, float]:
    """Coded first-order coefficients from a mapping or a fitted ResponseSurface."""
    coefs = getattr(source, "coefficients_coded", None)
    if coefs is not None:  # a ResponseSurface (duck-typed to keep designs free of model)
        names = set(source.names)
        return {str(k): float(v) for k, v in dict(coefs).items() if k in names}
    if isinstance(source, pd.Series):
        source = source.to_dict()
    if not isinstance(source, Mapping):
        raise InputError(
            "coefficients must be a mapping factor -> coded coefficient or a ResponseSurface"
        )
    out = {}
    for k, v in source.items():
        if str(k) == "intercept":
            continue
        try:
            out[str(k)] = float(v)
        except (TypeError, ValueError):
            raise InputError(f"coefficients[{k!r}] must be a number; got {v!r}") from None
    return out


def _moving_factors(move: Sequence[str] | None, steps: Mapping[str, float] | None,
                    names: Sequence[str], coefs: Mapping[str, float]) -> list[str]:
    """The factors a steepest path moves: ``move``, else the keys of ``steps``, else all
    factors with a coefficient; each must be varied and have a coefficient."""
    if move is None:
        move = list(steps) if steps is not None else [n for n in names if n in coefs]
    move = [str(m) for m in move]
    for m in move:
        if m not in names:
            raise InputError(f"move: {m!r} is not a varied factor ({', '.join(names)})")
        if m not in coefs:
            raise InputError(f"move: no coefficient given for factor {m!r}")
    if not move:
        raise InputError("steepest_path needs at least one moving factor")
    return move


def _given_steps_coded(steps: Mapping[str, float], move: Sequence[str],
                       coefs: Mapping[str, float], unit: Mapping[str, float],
                       sgn: float) -> dict[str, float]:
    """Coded signed step per run of each moving factor from the user's step magnitudes.

    ``unit`` is one coded unit of each factor in the user's units; ``sgn`` is +1 to ascend.
    """
    missing = [m for m in move if m not in steps]
    if missing:
        raise InputError(f"steps: no step given for moving factor(s) {', '.join(missing)}")
    step_coded = {}
    for m in move:
        s = float(steps[m])
        if not (math.isfinite(s) and s > 0):
            raise InputError(f"steps[{m!r}] must be > 0; got {steps[m]!r}")
        if coefs[m] == 0:
            raise InputError(f"coefficient of {m!r} is 0; its direction is undefined")
        step_coded[m] = sgn * math.copysign(s / unit[m], coefs[m])
    return step_coded


def _proportional_steps_coded(step: float, move: Sequence[str], coefs: Mapping[str, float],
                              unit: Mapping[str, float], sgn: float) -> dict[str, float]:
    """Coded signed steps along the gradient: the largest ``|b|`` moves by ``step``."""
    key = max(move, key=lambda m: abs(coefs[m]))
    bmax = abs(coefs[key])
    if bmax == 0:
        raise InputError("all coefficients are 0; the path has no direction")
    if not (math.isfinite(float(step)) and step > 0):
        raise InputError(f"step must be > 0; got {step!r}")
    key_step = float(step) / unit[key]
    return {m: sgn * key_step * coefs[m] / bmax for m in move}


def steepest_path(
    coefficients: Any,
    *,
    factors: Any = None,
    n_points: int = 5,
    step: float = 1.0,
    steps: Mapping[str, float] | None = None,
    move: Sequence[str] | None = None,
    start: Mapping[str, float] | None = None,
    direction: Literal["ascent", "descent"] = "ascent",
    units: Literal["coded", "actual"] = "coded",
) -> Design:
    """Path of steepest ascent (or descent) from a first-order model or screening effects.

    Two ways to set the step, per run, of each moving factor j:

    - proportional (textbook, Montgomery Sec. 11.2): the factor with the largest ``|b|``
      moves by ``step``; every other factor moves ``step_coded * b_j / |b_max|`` in coded
      units (the gradient direction);
    - user-given ``steps``: each moving factor moves by its own magnitude, with the sign of its
      coefficient (reversed for descent). The paper's Table 6 is such a path: x3 0.35 -> 0.75
      by 0.1, x4 0.03 -> 0.15 by 0.03, x8 0.04 -> 0.12 by 0.02.

    Parameters
    ----------
    coefficients : mapping str -> float or ResponseSurface
        Coded first-order coefficients (or effects; only their signs and ratios matter) of the
        factors; ``"intercept"`` is ignored. A fitted ResponseSurface gives its main-effect
        coefficients.
    factors : FactorSpace, sequence of Factor or mapping, optional
        Levels (needed for ``units="actual"`` and for actual columns). Factors not moving are
        held at their fixed value or their centre.
    n_points : int, optional
        Runs on the path, the start included (>= 2).
    step : float, optional
        Proportional mode: step of the factor with the largest ``|b|``, in ``units``.
    steps : mapping str -> float, optional
        User mode: step magnitude of each moving factor, in ``units``.
    move : sequence of str, optional
        Factors that move; default the keys of ``steps``, else every factor with a coefficient.
    start : mapping str -> float, optional
        First point of the moving factors, in ``units``; default the centre.
    direction : {"ascent", "descent"}, optional
        Climb the response or descend it.
    units : {"coded", "actual"}, optional
        Units of ``step``, ``steps`` and ``start``.

    Returns
    -------
    Design
        kind ``"steepest_path"``; rows in path order (run order = path order); coded values
        may lie outside [-1, 1]. ``info["step_coded"]`` and ``info["step_actual"]`` map each
        moving factor to its step per run.
    """
    coefs = _main_effect_coefficients(coefficients)
    if direction not in ("ascent", "descent"):
        raise InputError(f"direction must be 'ascent' or 'descent'; got {direction!r}")
    if units not in ("coded", "actual"):
        raise InputError(f"units must be 'coded' or 'actual'; got {units!r}")
    n_points = _check_int(n_points, "n_points", 2)
    space = None if factors is None else as_factor_space(factors)
    if space is not None:
        names = space.free.names
    elif units == "actual":
        raise InputError("units='actual' needs factors with low and high")
    else:
        names = tuple(coefs)
    move = _moving_factors(move, steps, names, coefs)
    sgn = 1.0 if direction == "ascent" else -1.0
    half = {n: (space[n].half_range if space is not None else 1.0) for n in names}
    unit = {m: (half[m] if units == "actual" else 1.0) for m in move}
    if steps is not None:
        step_coded = _given_steps_coded(steps, move, coefs, unit, sgn)
    else:
        step_coded = _proportional_steps_coded(step, move, coefs, unit, sgn)
    origin = np.zeros(len(names))
    for m, v in (start or {}).items():
        if m not in move:
            raise InputError(f"start: {m!r} is not a moving factor ({', '.join(move)})")
        v = float(v)
        origin[names.index(m)] = space[m].to_coded(v) if units == "actual" else v
    delta = np.zeros(len(names))
    for m, s in step_coded.items():
        delta[names.index(m)] = s
    coded = origin + np.arange(n_points)[:, None] * delta
    return Design(
        coded=coded,
        names=names,
        kind="steepest_path",
        run_order=np.arange(1, n_points + 1),
        factors=space,
        point_type=np.full(n_points, "path", dtype=object),
        info={
            "direction": direction,
            "step_coded": step_coded,
            "step_actual": {m: s * half[m] for m, s in step_coded.items()}
            if space is not None
            else None,
        },
    )
