"""Least-squares response-surface models in coded units (Model -> fit -> Results).

:func:`fit` fits a linear (main effects), two-factor-interaction or quadratic polynomial by
ordinary least squares in coded units and returns an immutable :class:`ResponseSurface`. Its
statistics are cached properties, each documenting its formula, with the names Design-Expert
prints (Std. Dev., C.V. %, R-Squared, Adj R-Squared, Pred R-Squared, Adeq Precision). Runs
whose response is NaN (a run without a result, e.g. no pile formed) are dropped and listed in
:attr:`ResponseSurface.excluded_runs`.

Notation: n runs with a response, p model terms (intercept included), X the (n, p) model
matrix in coded units, b the coefficients, yhat = X b, e = y - yhat, h the leverages
(diagonal of X (X'X)^-1 X').
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from itertools import product
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import pandas as pd
from scipy import stats

from demcal.doe.designs import Design
from demcal.doe.factors import FactorSpace, as_factor_space
from demcal.doe.terms import (
    MODELS,
    Powers,
    model_matrix,
    model_terms,
    parse_term,
    term_name,
)
from demcal.errors import InputError

if TYPE_CHECKING:
    from demcal.doe.anova import AnovaTable

__all__ = ["ResponseSurface", "UnbalancedBlocksError", "fit"]


class UnbalancedBlocksError(InputError):
    """The blocks of a fit do not each hold the same design points (see :func:`fit`)."""

_RANK_TOL = 1e-9


def _point_rows(points: Any, names: Sequence[str]) -> np.ndarray:
    """Points (a DataFrame or mapping with a column per factor, or an array) as float rows."""
    if isinstance(points, pd.DataFrame):
        missing = [n for n in names if n not in points.columns]
        if missing:
            raise InputError(f"points lack factor column(s) {', '.join(missing)}")
        return points[list(names)].to_numpy(dtype=float)
    if isinstance(points, Mapping):
        missing = [n for n in names if n not in points]
        if missing:
            raise InputError(f"points lack factor(s) {', '.join(missing)}")
        return np.column_stack([np.atleast_1d(np.asarray(points[n], float)) for n in names])
    arr = np.asarray(points, dtype=float)
    return arr.reshape(1, -1) if arr.ndim == 1 else arr


@dataclass(frozen=True, eq=False)
class ResponseSurface:
    """A fitted polynomial response surface (immutable; statistics computed on first use).

    Build it with :func:`fit`. Attributes are read-only arrays.

    Attributes
    ----------
    names : tuple of str
        Factor names (columns of ``coded``).
    terms : tuple of Powers
        Model terms (exponent tuples), intercept first.
    coded : (n, k) float64 ndarray
        Coded settings of the runs used in the fit.
    response : (n,) float64 ndarray
        Responses of those runs.
    factors : FactorSpace or None
        Levels of the factors (for actual units), or None.
    run_labels : tuple
        Label of each run used (CSV row / run number / standard order).
    excluded_runs : tuple
        Labels of runs dropped because their response was NaN.
    model : str
        ``"linear"``, ``"2fi"``, ``"quadratic"`` or ``"custom"`` (explicit or reduced terms).
    response_name : str
        Name of the response, for display.
    block_df, block_ss, block_leverage : int, float, float
        Blocks (Design-Expert's): ``b - 1`` degrees of freedom, the blocks' sum of squares
        and the leverage each run gains from its block's mean (``1/n_b - 1/n``). With blocks,
        ``response`` holds the block-adjusted responses (each block shifted to the grand
        mean); see :func:`fit`. All 0 without blocks.
    """

    names: tuple[str, ...]
    terms: tuple[Powers, ...]
    coded: np.ndarray
    response: np.ndarray
    factors: FactorSpace | None = None
    run_labels: tuple[Any, ...] = ()
    excluded_runs: tuple[Any, ...] = ()
    model: str = "custom"
    response_name: str = "response"
    block_df: int = 0
    block_ss: float = 0.0
    block_leverage: float = 0.0

    def __post_init__(self) -> None:
        for name in ("coded", "response"):
            arr = np.array(getattr(self, name), dtype=float)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "terms", tuple(tuple(int(e) for e in t) for t in self.terms))
        if not self.run_labels:
            object.__setattr__(self, "run_labels", tuple(range(1, len(self.response) + 1)))

    # ---------------------------------------------------------------- sizes and the fit itself
    @cached_property
    def _X(self) -> np.ndarray:
        x = model_matrix(self.coded, self.terms)
        x.setflags(write=False)
        return x

    @property
    def model_matrix(self) -> np.ndarray:
        """(n, p) float64 ndarray: the model matrix X in coded units."""
        return self._X

    @property
    def term_names(self) -> tuple[str, ...]:
        """Names of the terms: ``intercept``, ``x3``, ``x3*x4``, ``x3^2`` ..."""
        return tuple(term_name(t, self.names) for t in self.terms)

    @property
    def n_runs(self) -> int:
        """n, the number of runs used in the fit."""
        return int(self.response.shape[0])

    @property
    def n_params(self) -> int:
        """p, the number of model terms (intercept included)."""
        return len(self.terms)

    @property
    def has_intercept(self) -> bool:
        """True if the model has an intercept."""
        return any(sum(t) == 0 for t in self.terms)

    @cached_property
    def _xtx_inv(self) -> np.ndarray:
        x = self._X
        r = np.linalg.qr(x, mode="r")
        rinv = np.linalg.inv(r)
        return rinv @ rinv.T

    @cached_property
    def xtx_inv(self) -> np.ndarray:
        """(p, p) float64 ndarray: (X'X)^-1 in coded units."""
        out = self._xtx_inv.copy()
        out.setflags(write=False)
        return out

    @cached_property
    def params(self) -> np.ndarray:
        """(p,) float64 ndarray: least-squares coefficients b = (X'X)^-1 X'y, coded units."""
        b, *_ = np.linalg.lstsq(self._X, self.response, rcond=None)
        b.setflags(write=False)
        return b

    @cached_property
    def coefficients_coded(self) -> pd.Series:
        """Coefficients in coded units, indexed by term name (Design-Expert's coded equation)."""
        return pd.Series(np.array(self.params), index=list(self.term_names), name="coded")

    @property
    def coefficients(self) -> pd.Series:
        """Alias of :attr:`coefficients_coded`."""
        return self.coefficients_coded

    @cached_property
    def coefficients_actual(self) -> pd.Series:
        """Coefficients of the same polynomial in actual units (Design-Expert's actual equation).

        Each coded factor is ``(x - c) / h`` (centre c, half range h); the coded polynomial is
        expanded in powers of the actual x. A hierarchical model gives the same terms; a
        non-hierarchical one may gain lower-order terms, which are appended.

        Raises
        ------
        InputError
            If the surface has no factor levels.
        """
        if self.factors is None:
            raise InputError("actual-unit coefficients need factors with low and high")
        space = self.factors.subset(self.names)
        c, h = space.center, space.half_range
        acc: dict[Powers, float] = {}
        for t, b in zip(self.terms, self.params, strict=True):
            # prod_f ((x_f - c_f)/h_f)^e_f = prod_f sum_j C(e,j) x^j (-c)^(e-j) / h^e
            choices = [range(e + 1) for e in t]
            for js in product(*choices):
                coef = b
                for f, (e, j) in enumerate(zip(t, js, strict=True)):
                    coef *= math.comb(e, j) * (-c[f]) ** (e - j) / h[f] ** e
                acc[tuple(js)] = acc.get(tuple(js), 0.0) + coef
        order = list(self.terms) + sorted(
            (t for t in acc if t not in set(self.terms)), key=lambda t: (sum(t), t)
        )
        return pd.Series(
            [acc.get(t, 0.0) for t in order],
            index=[term_name(t, self.names) for t in order],
            name="actual",
        )

    # ------------------------------------------------------------------ fitted values and sums
    @cached_property
    def fitted(self) -> np.ndarray:
        """(n,) float64 ndarray: predicted responses at the runs, yhat = X b."""
        return self._X @ self.params

    @cached_property
    def residuals(self) -> np.ndarray:
        """(n,) float64 ndarray: e = y - yhat."""
        return self.response - self.fitted

    @cached_property
    def mean(self) -> float:
        """Mean of the responses, ybar (Design-Expert's "Mean")."""
        return float(np.mean(self.response))

    @cached_property
    def ss_total(self) -> float:
        """Corrected total sum of squares, sum (y - ybar)^2 (Design-Expert's "Cor Total")."""
        return float(np.sum((self.response - self.mean) ** 2))

    @cached_property
    def ss_resid(self) -> float:
        """Residual sum of squares, SSE = sum e^2."""
        return float(np.sum(self.residuals**2))

    @cached_property
    def ss_model(self) -> float:
        """Model sum of squares, SS_total - SSE (model with intercept)."""
        return self.ss_total - self.ss_resid

    @property
    def df_model(self) -> int:
        """Model degrees of freedom, p - 1."""
        return self.n_params - (1 if self.has_intercept else 0)

    @property
    def df_resid(self) -> int:
        """Residual degrees of freedom, n - p (- (b - 1) with b blocks)."""
        return self.n_runs - self.n_params - self.block_df

    @cached_property
    def mse(self) -> float:
        """Residual mean square, s^2 = SSE / (n - p); NaN for a saturated fit."""
        return self.ss_resid / self.df_resid if self.df_resid > 0 else math.nan

    @cached_property
    def std_dev(self) -> float:
        """Residual standard deviation, s = sqrt(MSE) (Design-Expert's "Std. Dev.")."""
        return math.sqrt(self.mse) if self.df_resid > 0 else math.nan

    @cached_property
    def cv_percent(self) -> float:
        """Coefficient of variation, C.V. % = 100 s / ybar."""
        return 100.0 * self.std_dev / self.mean if self.mean != 0 else math.nan

    @cached_property
    def r2(self) -> float:
        """R-Squared, 1 - SSE / SS_total."""
        return 1.0 - self.ss_resid / self.ss_total if self.ss_total > 0 else math.nan

    @cached_property
    def adj_r2(self) -> float:
        """Adjusted R-Squared, 1 - (SSE / (n - p)) / (SS_total / (n - 1))."""
        if self.df_resid <= 0 or self.ss_total <= 0:
            return math.nan
        return 1.0 - self.mse / (self.ss_total / (self.n_runs - 1 - self.block_df))

    @cached_property
    def leverage(self) -> np.ndarray:
        """(n,) float64 ndarray: h_i = x_i' (X'X)^-1 x_i; they sum to p (p + b - 1 with b
        blocks, whose contrasts are orthogonal to the terms in a balanced design)."""
        h = np.einsum("ij,jk,ik->i", self._X, self._xtx_inv, self._X)
        return h + self.block_leverage

    @cached_property
    def press(self) -> float:
        """Prediction error sum of squares, PRESS = sum (e_i / (1 - h_i))^2; NaN if some h_i = 1."""
        h = self.leverage
        if np.any(h > 1.0 - 1e-10):
            return math.nan
        return float(np.sum((self.residuals / (1.0 - h)) ** 2))

    @cached_property
    def pred_r2(self) -> float:
        """Predicted R-Squared, 1 - PRESS / SS_total (NaN where PRESS is undefined)."""
        if math.isnan(self.press) or self.ss_total <= 0:
            return math.nan
        return 1.0 - self.press / self.ss_total

    @cached_property
    def adeq_precision(self) -> float:
        """Adeq Precision, Design-Expert's signal-to-noise ratio.

        ``(max yhat - min yhat) / sqrt(mean V(yhat))`` over the design points, with
        ``V(yhat_i) = h_i s^2`` so that ``mean V(yhat) = p s^2 / n``. Above 4 is adequate.
        Reproduces the paper's 26.586 for its Table 7 data.
        """
        if self.df_resid <= 0 or not self.mse > 0:  # no noise estimate (an exact fit)
            return math.nan
        mean_var = self.n_params * self.mse / self.n_runs
        return float((self.fitted.max() - self.fitted.min()) / math.sqrt(mean_var))

    # ------------------------------------------------------------------ coefficient statistics
    @cached_property
    def cov_params(self) -> pd.DataFrame:
        """(p, p) covariance of the coded coefficients, s^2 (X'X)^-1."""
        n = list(self.term_names)
        return pd.DataFrame(self.mse * self._xtx_inv, index=n, columns=n)

    @cached_property
    def bse(self) -> pd.Series:
        """Standard errors of the coded coefficients, sqrt(diag(s^2 (X'X)^-1))."""
        return pd.Series(
            np.sqrt(self.mse * np.diag(self._xtx_inv)), index=list(self.term_names), name="se"
        )

    @cached_property
    def tvalues(self) -> pd.Series:
        """t statistics of the coefficients, b / se(b)."""
        return pd.Series(self.params / self.bse.to_numpy(), index=list(self.term_names), name="t")

    @cached_property
    def pvalues(self) -> pd.Series:
        """Two-sided p-values of the coefficients, 2 P(T_{n-p} > |t|) (= the partial F test)."""
        p = 2.0 * stats.t.sf(np.abs(self.tvalues.to_numpy()), self.df_resid)
        return pd.Series(p, index=list(self.term_names), name="p")

    @cached_property
    def conf_int(self) -> pd.DataFrame:
        """95 % confidence intervals of the coded coefficients, b -/+ t_{0.975, n-p} se(b)."""
        t = stats.t.ppf(0.975, self.df_resid) if self.df_resid > 0 else math.nan
        b, se = self.params, self.bse.to_numpy()
        return pd.DataFrame({"low": b - t * se, "high": b + t * se}, index=list(self.term_names))

    @cached_property
    def vif(self) -> pd.Series:
        """Variance inflation factors of the non-intercept terms, 1 / (1 - R_j^2).

        R_j^2 is from regressing column j of X on the other columns (intercept included);
        computed as the diagonal of the inverse correlation matrix of the non-intercept
        columns. 1 means orthogonal to the other terms.
        """
        cols = [j for j, t in enumerate(self.terms) if sum(t) > 0]
        names = [self.term_names[j] for j in cols]
        if len(cols) == 1:
            return pd.Series([1.0], index=names, name="vif")
        z = self._X[:, cols]
        z = z - z.mean(axis=0)
        z = z / np.sqrt((z**2).sum(axis=0))
        return pd.Series(np.diag(np.linalg.inv(z.T @ z)), index=names, name="vif")

    @cached_property
    def ss_partial(self) -> pd.Series:
        """Partial (Type III) sum of squares of each non-intercept term, b_j^2 / [(X'X)^-1]_jj.

        It equals SSE(model without term j) - SSE(full model): the sum of squares Design-Expert
        prints per term.
        """
        out = {}
        for j, t in enumerate(self.terms):
            if sum(t) > 0:
                out[self.term_names[j]] = float(self.params[j] ** 2 / self._xtx_inv[j, j])
        return pd.Series(out, name="ss", dtype=float)

    @cached_property
    def f_value(self) -> float:
        """Model F value, (SS_model / df_model) / MSE."""
        if self.df_resid <= 0 or self.df_model <= 0:
            return math.nan
        if not self.ss_total > 0:  # a response that does not vary: no model to test
            return math.nan
        if not self.mse > 0:  # an exact fit: no noise to test the model against
            return math.inf
        return (self.ss_model / self.df_model) / self.mse

    @cached_property
    def f_pvalue(self) -> float:
        """p-value of the model F test, P(F_{df_model, n-p} > F)."""
        if math.isnan(self.f_value):
            return math.nan
        return float(stats.f.sf(self.f_value, self.df_model, self.df_resid))

    # --------------------------------------------------------------- replicates: pure error
    @cached_property
    def pure_error(self) -> tuple[float, int]:
        """(SS, df) of pure error: the spread of responses within groups of replicated runs.

        SS_PE = sum over groups of identical settings of sum (y - group mean)^2,
        df_PE = n - number of distinct settings (- (b - 1) with b blocks: the block-adjusted
        responses have the block offsets removed from the groups' spread).
        """
        key = np.round(self.coded, 9)
        _, inverse = np.unique(key, axis=0, return_inverse=True)
        inverse = inverse.ravel()
        ss = 0.0
        n_groups = int(inverse.max()) + 1 if inverse.size else 0
        for g in range(n_groups):
            y = self.response[inverse == g]
            ss += float(np.sum((y - y.mean()) ** 2))
        return ss, self.n_runs - n_groups - self.block_df

    @cached_property
    def lack_of_fit(self) -> tuple[float, int]:
        """(SS, df) of lack of fit: SSE - SS_PE, (n - p) - df_PE."""
        ss_pe, df_pe = self.pure_error
        return self.ss_resid - ss_pe, self.df_resid - df_pe

    # ----------------------------------------------------------------------------- prediction
    def _points(self, points: Any, units: str | None) -> np.ndarray:
        if units is None:
            units = "actual" if self.factors is not None else "coded"
        if units not in ("coded", "actual"):
            raise InputError(f"units must be 'coded' or 'actual'; got {units!r}")
        arr = _point_rows(points, self.names)
        if arr.ndim != 2 or arr.shape[1] != len(self.names):
            raise InputError(
                f"points must have {len(self.names)} columns ({', '.join(self.names)}); "
                f"got shape {arr.shape}"
            )
        if units == "actual":
            if self.factors is None:
                raise InputError("units='actual' needs a surface fitted with factors")
            arr = self.factors.subset(self.names).to_coded(arr)
        return arr

    def predict(
        self, points: Any, *, units: Literal["coded", "actual"] | None = None
    ) -> np.ndarray:
        """Predicted mean response.

        Parameters
        ----------
        points : (m, k) array_like, DataFrame with the factor columns, or mapping name -> values
            Factor settings.
        units : {"coded", "actual"}, optional
            Units of ``points``; default actual if the surface has factors, else coded.

        Returns
        -------
        (m,) float64 ndarray
        """
        x = self._points(points, units)
        return model_matrix(x, self.terms) @ self.params

    def predict_interval(
        self,
        points: Any,
        *,
        units: Literal["coded", "actual"] | None = None,
        alpha: float = 0.05,
        n_new: int = 1,
    ) -> pd.DataFrame:
        """Predictions with two-sided confidence and prediction intervals.

        ``se_mean = s sqrt(x0' (X'X)^-1 x0)``; CI = yhat -/+ t se_mean;
        PI = yhat -/+ t sqrt(s^2 / n_new + se_mean^2); t = t_{1 - alpha/2, n - p}. With
        ``n_new`` > 1 the PI is for the mean of that many new runs (Design-Expert's
        confirmation interval).

        Parameters
        ----------
        points : (m, k) array_like, DataFrame or mapping
            Factor settings (see :meth:`predict`).
        units : {"coded", "actual"}, optional
            Units of ``points``.
        alpha : float, optional
            1 - confidence level, in (0, 1).
        n_new : int, optional
            The prediction interval is for the mean of this many new runs (>= 1).

        Returns
        -------
        pandas.DataFrame
            m rows; columns ``predicted``, ``se_mean``, ``ci_low``, ``ci_high``, ``pi_low``,
            ``pi_high``.
        """
        if not 0 < alpha < 1:
            raise InputError(f"alpha must be in (0, 1); got {alpha!r}")
        if int(n_new) < 1:
            raise InputError(f"n_new must be >= 1; got {n_new!r}")
        x0 = model_matrix(self._points(points, units), self.terms)
        yhat = x0 @ self.params
        q = np.einsum("ij,jk,ik->i", x0, self._xtx_inv, x0)
        se = np.sqrt(self.mse * q)
        t = stats.t.ppf(1 - alpha / 2, self.df_resid) if self.df_resid > 0 else math.nan
        se_pred = np.sqrt(self.mse / int(n_new) + se**2)
        return pd.DataFrame(
            {
                "predicted": yhat,
                "se_mean": se,
                "ci_low": yhat - t * se,
                "ci_high": yhat + t * se,
                "pi_low": yhat - t * se_pred,
                "pi_high": yhat + t * se_pred,
            }
        )

    # ------------------------------------------------------------------- tables and reductions
    def anova(self) -> AnovaTable:
        """The ANOVA table Design-Expert prints (see :class:`demcal.doe.anova.AnovaTable`)."""
        from demcal.doe.anova import anova_table

        return anova_table(self)

    def effects(self) -> pd.DataFrame:
        """Screening effects (two-level designs); see :func:`demcal.doe.anova.screening_effects`."""
        from demcal.doe.anova import screening_effects

        return screening_effects(self)

    def with_terms(self, terms: Sequence[Powers | str]) -> ResponseSurface:
        """Refit the same data with other terms (names such as ``"x3*x4"`` or exponent tuples)."""
        parsed = [parse_term(t, self.names) if isinstance(t, str) else tuple(t) for t in terms]
        return _build(
            self.names,
            tuple(parsed),
            self.coded,
            self.response,
            factors=self.factors,
            run_labels=self.run_labels,
            excluded=self.excluded_runs,
            model="custom",
            response_name=self.response_name,
            blocks=(self.block_df, self.block_ss, self.block_leverage),
        )

    def reduce(self, *, alpha_out: float = 0.1, hierarchical: bool = True) -> ResponseSurface:
        """Backward elimination; see :func:`demcal.doe.anova.backward_elimination`."""
        from demcal.doe.anova import backward_elimination

        return backward_elimination(self, alpha_out=alpha_out, hierarchical=hierarchical)

    def equation(self, *, units: Literal["coded", "actual"] = "coded", digits: int = 4) -> str:
        """The fitted equation as text, ``response = +41.77 +2.43 * x3 ...``."""
        coefs = self.coefficients_coded if units == "coded" else self.coefficients_actual
        parts = []
        for name, v in coefs.items():
            parts.append(f"{v:+.{digits}g}" if name == "intercept" else f"{v:+.{digits}g} * {name}")
        return f"{self.response_name} = " + " ".join(parts)


# ------------------------------------------------------------------------------------ fitting
def _numeric_frame(frame: pd.DataFrame, columns: Sequence[str], what: str) -> np.ndarray:
    out = []
    for c in columns:
        if c not in frame.columns:
            raise InputError(
                f"{what}: column {c!r} not found; columns: {', '.join(map(str, frame.columns))}"
            )
        col = pd.to_numeric(frame[c], errors="coerce")
        bad = col.isna() & frame[c].notna()
        if bad.any():
            raise InputError(
                f"{what}: column {c!r} is not numeric (row {frame.index[bad][0]!r}: "
                f"{frame[c][bad].iloc[0]!r})"
            )
        out.append(col.to_numpy(dtype=float))
    return np.column_stack(out) if out else np.empty((len(frame), 0))


def _build(
    names: tuple[str, ...],
    terms: tuple[Powers, ...],
    coded: np.ndarray,
    y: np.ndarray,
    *,
    factors: FactorSpace | None,
    run_labels: tuple[Any, ...],
    excluded: tuple[Any, ...],
    model: str,
    response_name: str,
    blocks: tuple[int, float, float] = (0, 0.0, 0.0),
) -> ResponseSurface:
    n, p = len(y), len(terms)
    label = model if model != "custom" else f"{p}-term"
    if n < p:
        raise InputError(
            f"too few runs for the {label} model: it has {p} terms but only {n} runs have a "
            f"response ({len(excluded)} excluded)"
        )
    with np.errstate(over="ignore", invalid="ignore"):
        x = model_matrix(coded, terms)
        # singular design: find the first term that adds no rank (aliased with earlier ones)
        scale = np.sqrt((x**2).sum(axis=0))
    if not np.all(np.isfinite(scale)):  # a 1e308 cell: its square overflows
        j = int(np.flatnonzero(~np.isfinite(scale))[0])
        raise InputError(
            f"the {label} model cannot be fitted: term {term_name(terms[j], names)} overflows "
            f"(largest |coded value| {float(np.max(np.abs(coded))):.3g}); check the run sheet"
        )
    if np.any(scale == 0):
        j = int(np.flatnonzero(scale == 0)[0])
        raise InputError(
            f"design is singular for the {label} model: term {term_name(terms[j], names)} is "
            "zero in every run"
        )
    xs = x / scale
    if np.linalg.matrix_rank(xs, tol=_RANK_TOL * max(xs.shape)) < p:
        for j in range(1, p + 1):
            if np.linalg.matrix_rank(xs[:, :j], tol=_RANK_TOL * max(xs.shape)) < j:
                raise InputError(
                    f"design is singular for the {label} model: term "
                    f"{term_name(terms[j - 1], names)} is aliased with earlier terms "
                    "(add runs or choose a smaller model)"
                )
    return ResponseSurface(
        names=names,
        terms=terms,
        coded=coded,
        response=y,
        factors=factors,
        run_labels=run_labels,
        excluded_runs=excluded,
        model=model,
        response_name=response_name,
        block_df=int(blocks[0]),
        block_ss=float(blocks[1]),
        block_leverage=float(blocks[2]),
    )


def _design_settings(design: Any, names: Sequence[str] | None
                     ) -> tuple[np.ndarray, tuple[str, ...], tuple[Any, ...]]:
    """A DataFrame's or an array's settings as given: (x, factor names, run labels)."""
    if isinstance(design, pd.DataFrame):
        nm = tuple(str(c) for c in (names if names is not None else design.columns))
        return _numeric_frame(design, nm, "design"), nm, tuple(design.index.tolist())
    x = np.asarray(design, dtype=float)
    if x.ndim == 1:
        x = x.reshape(-1, 1)
    if x.ndim != 2:
        raise InputError(f"design must be a 2-D (runs, factors) array; got shape {x.shape}")
    nm = tuple(names) if names is not None else tuple(f"x{i + 1}" for i in range(x.shape[1]))
    if len(nm) != x.shape[1]:
        raise InputError(f"names must give {x.shape[1]} factor names; got {len(nm)}")
    return x, nm, tuple(range(1, x.shape[0] + 1))


def _from_design(design: Design, names: Sequence[str] | None, units: str | None
                 ) -> tuple[np.ndarray, tuple[str, ...]]:
    """A :class:`Design`'s coded settings (of ``names``, if given) and factor names."""
    x = np.asarray(design.coded, dtype=float)
    nm = tuple(design.names)
    if names is not None:
        idx = [nm.index(n) if n in nm else -1 for n in names]
        if -1 in idx:
            raise InputError(f"names must be among the design's factors {', '.join(nm)}")
        x, nm = x[:, idx], tuple(names)
    if units not in (None, "coded"):
        raise InputError("a Design is always in coded units; drop units=")
    return x, nm


def _coded_design(design: Any, names: Sequence[str] | None, space: FactorSpace | None,
                  units: str | None) -> tuple[np.ndarray, tuple[str, ...], tuple[Any, ...],
                                              FactorSpace | None]:
    """:func:`fit`'s design as coded settings: (x, factor names, run labels, factor space)."""
    if isinstance(design, Design):
        x, nm = _from_design(design, names, units)
        space = space if space is not None else design.factors
        labels: tuple[Any, ...] = tuple(range(1, x.shape[0] + 1))
        units = "coded"
    else:
        x, nm, labels = _design_settings(design, names)
    if len(set(nm)) != len(nm):
        raise InputError(f"factor names must be unique; got {', '.join(nm)}")
    if not nm:
        raise InputError("design has no factor columns")
    if units is None:
        units = "actual" if space is not None else "coded"
    if units not in ("coded", "actual"):
        raise InputError(f"units must be 'coded' or 'actual'; got {units!r}")
    if units == "actual" and space is None:
        raise InputError("units='actual' needs factors with low and high")
    if space is not None:
        missing = [n for n in nm if n not in space]
        if missing:
            raise InputError(("factors file lacks" if units == "actual" else "factors lack")
                             + f" factor(s) {', '.join(missing)}")
        if units == "actual":
            x = space.subset(nm).to_coded(x)
    return x, nm, labels, space


def _response_values(response: Any, n_runs: int) -> np.ndarray:
    """The response as ``n_runs`` floats, finite or NaN (NaN marks a run without a result)."""
    try:
        y = np.asarray(response, dtype=float).ravel()
    except (TypeError, ValueError):
        raise InputError("response must be numeric (NaN marks a run without a result)") from None
    if y.shape[0] != n_runs:
        raise InputError(f"response has {y.shape[0]} values but the design has {n_runs} runs")
    if np.any(np.isinf(y)):
        raise InputError("response must be finite or NaN (NaN marks a run without a result)")
    return y


def _fit_terms(terms: Any, model: str, names: Sequence[str]) -> tuple[tuple[Powers, ...], str]:
    """The model's terms and its kind: the user's ``terms`` ("custom"), else ``model``'s."""
    if terms is not None:
        parsed = tuple(parse_term(t, names) if isinstance(t, str) else tuple(t) for t in terms)
        if len(set(parsed)) != len(parsed):
            raise InputError("terms: a term is listed twice")
        return parsed, "custom"
    if model not in MODELS:
        raise InputError(f"model must be one of {', '.join(MODELS)}; got {model!r}")
    return model_terms(len(names), model), model


def fit(
    design: Any,
    response: Any,
    *,
    model: str = "quadratic",
    terms: Sequence[str | Powers] | None = None,
    names: Sequence[str] | None = None,
    factors: Any = None,
    units: Literal["coded", "actual"] | None = None,
    response_name: str | None = None,
    blocks: Sequence[Any] | None = None,
) -> ResponseSurface:
    """Fit a polynomial response surface by least squares in coded units.

    Parameters
    ----------
    design : Design, pandas.DataFrame or (n, k) array_like
        Factor settings of the runs. A :class:`~demcal.doe.designs.Design` gives coded values,
        names and factors (rows in standard order). A DataFrame gives names from its columns
        (``names`` selects some) and run labels from its index.
    response : (n,) array_like of float
        One response per run; NaN marks a run without a result, which is dropped and reported
        in :attr:`ResponseSurface.excluded_runs`.
    model : {"linear", "2fi", "quadratic"}, optional
        Polynomial order (ignored when ``terms`` is given).
    terms : sequence of str or Powers, optional
        Explicit terms, e.g. ``["intercept", "x3", "x4", "x3*x4"]``.
    names : sequence of str, optional
        Factor names (columns to use from a DataFrame; default ``x1..xk`` for an array).
    factors : FactorSpace, sequence of Factor or mapping, optional
        Factor levels, needed for actual units (input or coefficients).
    units : {"coded", "actual"}, optional
        Units of ``design`` values (not for a Design). Default: actual when ``factors`` is
        given, coded otherwise.
    response_name : str, optional
        For display (default the Series name or ``"response"``).
    blocks : (n,) sequence, optional
        Block label of each run (Design-Expert's blocks), e.g. the seed set of each replicate
        when every design point ran on the same seeds. Each block must hold the same design
        points (a balanced design: its runs with a response, after NaN rows are dropped); then
        the blocks are orthogonal to every term, and the fit subtracts each block's offset
        from its runs, takes ``b - 1`` degrees of freedom from the residual and the pure error,
        and the ANOVA shows a Block row. Coefficients and predictions are those of the average
        block.

    Returns
    -------
    ResponseSurface

    Raises
    ------
    InputError
        Unknown model; missing or non-numeric columns; lengths differ; non-finite settings;
        too few runs with a response for the model; a singular design (the message names the
        aliased term); blocks of another length than the design; unbalanced blocks
        (:class:`UnbalancedBlocksError`).

    Examples
    --------
    >>> import numpy as np
    >>> from demcal import doe
    >>> d = doe.box_behnken(3, center_points=3, randomize=False)
    >>> y = 40 + 2 * d.coded[:, 0] - d.coded[:, 1] ** 2
    >>> rs = doe.fit(d, y, model="quadratic")
    >>> round(float(rs.coefficients_coded["x1"]), 6), round(float(rs.coefficients_coded["x2^2"]), 6)
    (2.0, -1.0)
    """
    space = None if factors is None else as_factor_space(factors)
    x, nm, labels, space = _coded_design(design, names, space, units)

    if isinstance(response, pd.Series) and response_name is None:
        response_name = str(response.name) if response.name is not None else None
    y = _response_values(response, x.shape[0])
    bad_x = ~np.isfinite(x)
    if bad_x.any():
        i, j = np.argwhere(bad_x)[0]
        raise InputError(f"design: factor {nm[j]!r} of run {labels[i]!r} is not a finite number")
    keep = ~np.isnan(y)
    excluded = tuple(lab for lab, k in zip(labels, keep, strict=True) if not k)
    used = tuple(lab for lab, k in zip(labels, keep, strict=True) if k)

    parsed, kind = _fit_terms(terms, model, nm)
    y_fit, block_stats = y[keep], (0, 0.0, 0.0)
    if blocks is not None:
        labels_b = np.asarray(list(blocks), dtype=object)
        if labels_b.shape[0] != x.shape[0]:
            raise InputError(f"blocks has {labels_b.shape[0]} labels but the design has "
                             f"{x.shape[0]} runs")
        y_fit, block_stats = _block_adjust(x[keep], y_fit, labels_b[keep], used)
    try:
        return _build(
            nm,
            parsed,
            x[keep],
            y_fit,
            factors=space,
            run_labels=used,
            excluded=excluded,
            model=kind,
            response_name=response_name or "response",
            blocks=block_stats,
        )
    except (np.linalg.LinAlgError, OverflowError) as exc:  # e.g. a 1e308 cell: inf squares
        raise InputError(f"the {kind} model cannot be fitted ({exc}): a factor value is too "
                         f"large for its squares and products (largest |coded value| "
                         f"{float(np.max(np.abs(x))):.3g}); check the run sheet") from None


def _block_adjust(x: np.ndarray, y: np.ndarray, blocks: np.ndarray, labels: tuple[Any, ...]
                  ) -> tuple[np.ndarray, tuple[int, float, float]]:
    """Block-adjusted responses and (b - 1, SS_blocks, 1/n_b - 1/n) of a balanced design.

    In a balanced design every block holds the same settings, so every term's column has the
    same sum in each block and the block contrasts are orthogonal to the terms: fitting the
    terms to ``y - (block mean - grand mean)`` gives the coefficients, residuals and partial
    sums of squares of the fit with block terms (Design-Expert's), with ``b - 1`` fewer
    residual degrees of freedom.
    """
    names = list(dict.fromkeys(blocks.tolist()))
    if len(names) < 2:
        return y, (0, 0.0, 0.0)
    keys = [tuple(row) for row in np.round(x, 9)]
    content = {}
    for name in names:
        rows = sorted(k for k, b in zip(keys, blocks, strict=True) if b == name)
        content[name] = rows
    first = names[0]
    for name in names[1:]:
        if content[name] != content[first]:
            runs = [lab for lab, b in zip(labels, blocks, strict=True) if b == name]
            raise UnbalancedBlocksError(
                f"blocks are unbalanced: block {name} (runs {runs[:6]}) does not hold the "
                f"same design points as block {first} (a run without a response removes its "
                "point from one block); fit without blocks")
    grand = float(y.mean())
    y_adj = y.astype(float).copy()
    ss = 0.0
    for name in names:
        sel = blocks == name
        offset = float(y[sel].mean()) - grand
        y_adj[sel] -= offset
        ss += int(sel.sum()) * offset**2
    n_b = len(content[first])
    return y_adj, (len(names) - 1, ss, 1.0 / n_b - 1.0 / len(y))
