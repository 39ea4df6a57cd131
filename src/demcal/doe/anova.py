"""The ANOVA table Design-Expert prints, screening effects, and backward elimination.

Rows of :class:`AnovaTable` (Design-Expert's "ANOVA for Response Surface ... Model",
partial sum of squares, Type III):

========== ============================ ====================== ============ =============
source     SS                           df                     F            p
========== ============================ ====================== ============ =============
Model      SS_total - SSE               p - 1                  MS / MSE     F_{df, n-p}
term j     b_j^2 / [(X'X)^-1]_jj        1                      MS / MSE     F_{1, n-p}
Residual   SSE                          n - p
Lack of Fit SSE - SS_PE                 n - p - df_PE          MS / MS_PE   F_{df, df_PE}
Pure Error SS within replicated points  n - (distinct points)
Cor Total  sum (y - ybar)^2             n - 1
========== ============================ ====================== ============ =============

Lack of fit and pure error appear only when the design has replicated points and the
residual has degrees of freedom beyond them. A fit with b blocks (:func:`demcal.doe.fit`'s
``blocks``) adds a first row ``Block`` (the blocks' SS, b - 1 df, no test), takes b - 1 df
from Residual and Pure Error, and its Cor Total includes the blocks. Significance
markers: ``**`` p < 0.01, ``*`` p < 0.05 (the paper's convention).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
from scipy import stats

from demcal.doe.terms import divides, is_hierarchical, term_name
from demcal.errors import InputError

if TYPE_CHECKING:
    from demcal.doe.model import ResponseSurface

__all__ = [
    "AnovaRow",
    "AnovaTable",
    "FitStatistics",
    "anova_table",
    "backward_elimination",
    "screening_effects",
    "significance",
]


def significance(p: float) -> str:
    """``"**"`` if p < 0.01, ``"*"`` if p < 0.05, else ``""`` (NaN gives ``""``)."""
    if p is None or not math.isfinite(p):
        return ""
    return "**" if p < 0.01 else "*" if p < 0.05 else ""


@dataclass(frozen=True)
class AnovaRow:
    """One source of variation: SS, df, MS = SS/df, F and p (NaN where not defined)."""

    source: str
    ss: float
    df: int
    ms: float
    f: float
    p: float

    @property
    def significance(self) -> str:
        """``**`` (p < 0.01), ``*`` (p < 0.05) or empty."""
        return significance(self.p)

    def to_dict(self) -> dict[str, Any]:
        """``{"term", "ss", "df", "ms", "f", "p"}`` with None for NaN (JSON friendly)."""

        def clean(v: float) -> float | None:
            return None if v is None or not math.isfinite(v) else float(v)

        return {
            "term": self.source,
            "ss": clean(self.ss),
            "df": int(self.df),
            "ms": clean(self.ms),
            "f": clean(self.f),
            "p": clean(self.p),
        }


@dataclass(frozen=True)
class FitStatistics:
    """Design-Expert's fit statistics (see the ResponseSurface properties for formulas)."""

    std_dev: float
    mean: float
    cv_percent: float
    press: float
    r2: float
    adj_r2: float
    pred_r2: float
    adeq_precision: float

    def to_dict(self) -> dict[str, float | None]:
        """Plain dict with None for NaN."""
        return {k: (None if not math.isfinite(v) else float(v)) for k, v in self.__dict__.items()}


@dataclass(frozen=True)
class AnovaTable:
    """ANOVA table and fit statistics of a response surface.

    Attributes
    ----------
    rows : tuple of AnovaRow
        Model, the terms, Residual, [Lack of Fit, Pure Error,] Cor Total.
    fit : FitStatistics
        Std. Dev., Mean, C.V. %, PRESS, R2, Adj R2, Pred R2, Adeq Precision.
    response_name : str
    model : str
    n_runs : int
        Runs used.
    excluded_runs : tuple
        Labels of runs without a response.
    """

    rows: tuple[AnovaRow, ...]
    fit: FitStatistics
    response_name: str
    model: str
    n_runs: int
    excluded_runs: tuple[Any, ...] = ()

    def __getitem__(self, source: str) -> AnovaRow:
        for r in self.rows:
            if r.source == source:
                return r
        raise KeyError(source)

    @property
    def sources(self) -> tuple[str, ...]:
        """Row names in order."""
        return tuple(r.source for r in self.rows)

    def to_frame(self) -> pd.DataFrame:
        """Columns ``ss``, ``df``, ``ms``, ``f``, ``p``, ``significance``; index = source."""
        frame = pd.DataFrame(
            {
                "ss": [r.ss for r in self.rows],
                "df": [r.df for r in self.rows],
                "ms": [r.ms for r in self.rows],
                "f": [r.f for r in self.rows],
                "p": [r.p for r in self.rows],
                "significance": [r.significance for r in self.rows],
            },
            index=pd.Index([r.source for r in self.rows], name="source"),
        )
        return frame

    def to_records(self) -> list[dict[str, Any]]:
        """Rows as dicts ``{"term", "ss", "df", "ms", "f", "p"}`` (None for NaN)."""
        return [r.to_dict() for r in self.rows]

    def __str__(self) -> str:
        lines = [
            f"ANOVA for {self.model} model of {self.response_name} "
            "(partial sum of squares, Type III)",
            f"{'Source':<14}{'SS':>12}{'df':>5}{'MS':>12}{'F':>10}{'p':>10}",
        ]
        for r in self.rows:

            def fmt(v: float, w: int, spec: str) -> str:
                return f"{v:>{w}{spec}}" if math.isfinite(v) else " " * w

            p = "" if not math.isfinite(r.p) else ("<0.0001" if r.p < 1e-4 else f"{r.p:.4f}")
            lines.append(
                f"{r.source:<14}{fmt(r.ss, 12, '.4f')}{r.df:>5d}{fmt(r.ms, 12, '.4f')}"
                f"{fmt(r.f, 10, '.2f')}{p:>10} {r.significance}"
            )
        f = self.fit
        lines.append(
            f"Std. Dev. {f.std_dev:.4g}  Mean {f.mean:.4g}  C.V. % {f.cv_percent:.4g}  "
            f"R2 {f.r2:.4f}  Adj R2 {f.adj_r2:.4f}  Pred R2 {f.pred_r2:.4f}  "
            f"Adeq Precision {f.adeq_precision:.3f}"
        )
        return "\n".join(lines)


def _row(source: str, ss: float, df: int, denom_ms: float, denom_df: int) -> AnovaRow:
    ms = ss / df if df > 0 else math.nan
    if df > 0 and denom_df > 0 and math.isfinite(denom_ms) and denom_ms > 0:
        f = ms / denom_ms
        p = float(stats.f.sf(f, df, denom_df))
    else:
        f = p = math.nan
    return AnovaRow(source, float(ss), int(df), float(ms), float(f), float(p))


def anova_table(rs: ResponseSurface) -> AnovaTable:
    """Build the ANOVA table of a fitted response surface (see the module docstring).

    Parameters
    ----------
    rs : ResponseSurface
        A fit with an intercept.

    Returns
    -------
    AnovaTable
    """
    if not rs.has_intercept:
        raise InputError("the ANOVA table needs a model with an intercept")
    mse, dfe = rs.mse, rs.df_resid
    rows = []
    if rs.block_df > 0:  # Design-Expert lists the blocks first, without a test
        rows.append(AnovaRow("Block", rs.block_ss, rs.block_df, rs.block_ss / rs.block_df,
                             math.nan, math.nan))
    rows.append(_row("Model", rs.ss_model, rs.df_model, mse, dfe))
    for name, ss in rs.ss_partial.items():
        rows.append(_row(str(name), float(ss), 1, mse, dfe))
    rows.append(AnovaRow("Residual", rs.ss_resid, dfe, mse, math.nan, math.nan))
    ss_pe, df_pe = rs.pure_error
    ss_lof, df_lof = rs.lack_of_fit
    if df_pe > 0 and df_lof > 0:
        ms_pe = ss_pe / df_pe
        rows.append(_row("Lack of Fit", ss_lof, df_lof, ms_pe, df_pe))
        rows.append(AnovaRow("Pure Error", ss_pe, df_pe, ms_pe, math.nan, math.nan))
    rows.append(AnovaRow("Cor Total", rs.ss_total + rs.block_ss, rs.n_runs - 1, math.nan,
                         math.nan, math.nan))
    fit = FitStatistics(
        std_dev=rs.std_dev,
        mean=rs.mean,
        cv_percent=rs.cv_percent,
        press=rs.press,
        r2=rs.r2,
        adj_r2=rs.adj_r2,
        pred_r2=rs.pred_r2,
        adeq_precision=rs.adeq_precision,
    )
    return AnovaTable(
        rows=tuple(rows),
        fit=fit,
        response_name=rs.response_name,
        model=rs.model,
        n_runs=rs.n_runs,
        excluded_runs=rs.excluded_runs,
    )


def screening_effects(rs: ResponseSurface) -> pd.DataFrame:
    """Effects of a two-level screening fit, their % contribution and Pareto ranking.

    For factors coded +/-1, ``effect = 2 b`` (mean response at the high level minus mean at
    the low level, for a balanced orthogonal design). ``contribution_percent = 100 SS_j /
    SS_total`` with SS_j the term's partial sum of squares. ``rank`` orders the terms by p-value
    (1 = most significant; by |effect| when the fit is saturated).

    Parameters
    ----------
    rs : ResponseSurface
        A fit with an intercept (normally ``model="linear"`` on a Plackett-Burman design).

    Returns
    -------
    pandas.DataFrame
        Index = term; columns ``coefficient``, ``effect``, ``ss``, ``contribution_percent``,
        ``f``, ``p``, ``significance``, ``rank``; rows sorted by rank (Pareto order).
    """
    coefs = rs.coefficients_coded.drop("intercept", errors="ignore")
    ss = rs.ss_partial
    terms = list(ss.index)
    with np.errstate(divide="ignore", invalid="ignore"):  # a flat response: 0/0 is NaN
        f = (ss / rs.mse).to_numpy() if rs.df_resid > 0 and rs.ss_total > 0 else \
            np.full(len(terms), np.nan)
        share = 100.0 * ss.to_numpy() / rs.ss_total
    p = stats.f.sf(f, 1, rs.df_resid) if rs.df_resid > 0 else np.full(len(terms), np.nan)
    frame = pd.DataFrame(
        {
            "coefficient": coefs[terms].to_numpy(),
            "effect": 2.0 * coefs[terms].to_numpy(),
            "ss": ss.to_numpy(),
            "contribution_percent": share,
            "f": f,
            "p": p,
        },
        index=pd.Index(terms, name="term"),
    )
    frame["significance"] = [significance(v) for v in frame["p"]]
    key = frame["p"] if np.isfinite(frame["p"]).all() else -frame["effect"].abs()
    frame["rank"] = key.rank(method="min").astype(int)
    return frame.sort_values("rank", kind="stable")


def backward_elimination(
    rs: ResponseSurface,
    *,
    alpha_out: float = 0.1,
    hierarchical: bool = True,
    keep: Sequence[str] = (),
) -> ResponseSurface:
    """Remove insignificant terms one at a time (Design-Expert's backward selection).

    Repeatedly refit without the term of largest p-value while that p-value exceeds
    ``alpha_out``. With ``hierarchical=True`` a term is a candidate only if no remaining term
    contains it (``x3`` stays while ``x3*x4`` or ``x3^2`` does), so the reduced model stays
    hierarchical. The intercept is never removed.

    Parameters
    ----------
    rs : ResponseSurface
        The full fit.
    alpha_out : float, optional
        Removal threshold, in (0, 1).
    hierarchical : bool, optional
        Keep the model hierarchical.
    keep : sequence of str, optional
        Terms never removed.

    Returns
    -------
    ResponseSurface
        The reduced fit (``model == "custom"``); ``rs`` itself when nothing is removed.
    """
    if not 0 < alpha_out < 1:
        raise InputError(f"alpha_out must be in (0, 1); got {alpha_out!r}")
    if hierarchical and not is_hierarchical(rs.terms):
        raise InputError("the starting model is not hierarchical; use hierarchical=False")
    keep_set = set(keep)
    unknown = keep_set - set(rs.term_names)
    if unknown:
        raise InputError(f"keep: unknown term(s) {', '.join(sorted(unknown))}")
    current = rs
    while current.df_resid > 0:
        pvals = current.pvalues
        candidates = []
        for t in current.terms:
            name = term_name(t, current.names)
            if sum(t) == 0 or name in keep_set:
                continue
            if hierarchical and any(divides(t, other) for other in current.terms):
                continue
            candidates.append((float(pvals[name]), t))
        if not candidates:
            break
        p_worst, t_worst = max(candidates, key=lambda c: c[0])
        if not p_worst > alpha_out:
            break
        current = current.with_terms([t for t in current.terms if t != t_worst])
    return current
