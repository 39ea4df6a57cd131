"""Design-Expert's model diagnostics, recomputed from a stage's stored design runs.

The screening and response-surface summaries store each design run (coded settings and AoR)
and, for the response surface, the model's terms (``coefficients_coded``). :func:`refit`
rebuilds the same least-squares fit with :func:`demcal.doe.fit`; :func:`model_diagnostics`
returns what Design-Expert plots for every model:

- externally studentized residuals (``t_i = r_i sqrt((n-p-1)/(n-p-r_i^2))`` with the internally
  studentized ``r_i = e_i / sqrt(MSE (1-h_i))``), their normal probability plot positions
  (Blom: ``(i - 3/8)/(n + 1/4)``), and their outlier limit: the two-sided Bonferroni t at
  alpha = 0.05 (``t(1 - 0.025/n; n-p-1)``);
- leverage ``h_i`` with the limit ``2 p / n`` (twice the average);
- Cook's distance ``D_i = r_i^2 h_i / (p (1-h_i))`` with the limit ``F(0.5; p, n-p)``
  (Cook's median rule);
- the Box-Cox curve ``ln SS_E(lambda)`` of the geometric-mean-scaled transform for lambda in
  [-3, 3], its minimum, the 95 % interval ``SS_min (1 + t(0.975; df)^2 / df)`` and the
  recommended transform (none when lambda = 1 is inside the interval).

:func:`adequacy_checks` turns them and the stored fit statistics into the verdict the report
prints, so that the verdict agrees with the plots: predicted R² >= 0.5 (and within 0.2 of the
adjusted R²), Adeq Precision > 4, model p < 0.05, no significant lack of fit, no outlier,
no transform recommended; runs above Cook's or the leverage limit are flagged, not failed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

from demcal import doe
from demcal.doe.model import ResponseSurface
from demcal.errors import InputError
from demcal.summaries import Screening, Surface

__all__ = ["BOXCOX_LAMBDAS", "Check", "Diagnostics", "adequacy_checks", "model_diagnostics",
           "refit", "verdict"]

#: The lambda grid of the Box-Cox plot.
BOXCOX_LAMBDAS = np.round(np.linspace(-3.0, 3.0, 121), 6)
_STANDARD = (-3.0, -2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0, 3.0)
_TRANSFORM = {-3.0: "inverse cube", -2.0: "inverse square", -1.0: "inverse",
              -0.5: "inverse square root", 0.0: "natural log", 0.5: "square root",
              1.0: "none", 2.0: "square", 3.0: "cube"}


def refit(found: Screening | Surface, stage: str) -> ResponseSurface:
    """The stage's model refitted on its stored runs (NaN = no pile, excluded).

    Parameters
    ----------
    found : Screening or Surface
        The screening or response-surface stage (its factors and runs; the surface's
        ``coefficients_coded`` name the terms).
    stage : {"screening", "rsm"}
        Screening fits the linear main-effects model; the response surface the stored terms.

    Raises
    ------
    InputError
        No factors or runs, or a model that cannot be fitted.
    """
    names = [f.name for f in found.factors or []]
    runs = found.runs or []
    if not names or not runs:
        raise InputError(f"{stage}: the summary has no factors or runs to fit")
    coded = np.array([[float(r.coded.get(n, math.nan)) for n in names] for r in runs])
    y = np.array([math.nan if r.value is None else float(r.value) for r in runs])
    frame = pd.DataFrame(coded, columns=names, index=[r.point for r in runs])
    if stage == "rsm" and isinstance(found, Surface) and found.coefficients_coded:
        terms = list(found.coefficients_coded)
        return doe.fit(frame, y, terms=terms, units="coded", response_name="AoR")
    return doe.fit(frame, y, model="linear" if stage == "screening" else "quadratic",
                   units="coded", response_name="AoR")


@dataclass(frozen=True)
class Diagnostics:
    """Residual diagnostics of a fitted model (angles in degrees).

    Attributes
    ----------
    labels : (n,) ndarray
        Design point of each run used in the fit (the run order of the design).
    actual, predicted, residual : (n,) float64 ndarray
        Response, fitted value and ``actual - predicted``, deg.
    studentized : (n,) float64 ndarray
        Externally studentized residuals (NaN where undefined).
    normal_quantile : (n,) float64 ndarray
        Normal quantile of each run's studentized residual rank (Blom positions).
    leverage, cooks : (n,) float64 ndarray
        Leverage ``h_i`` and Cook's distance ``D_i``.
    outlier_limit, leverage_limit, cooks_limit : float
        Limits above which a run is flagged.
    boxcox_lambda, boxcox_ln_ss : (m,) float64 ndarray
        The Box-Cox curve; empty when the response is not positive.
    boxcox_best, boxcox_low, boxcox_high : float
        Best lambda and its 95 % interval (NaN when not computed).
    boxcox_ci_ln_ss : float
        ln SS at the interval's limit.
    recommended : str
        The recommended transform (``none`` when lambda = 1 is in the interval).
    p, n : int
        Terms and runs of the model.
    """

    labels: np.ndarray
    actual: np.ndarray
    predicted: np.ndarray
    residual: np.ndarray
    studentized: np.ndarray
    normal_quantile: np.ndarray
    leverage: np.ndarray
    cooks: np.ndarray
    outlier_limit: float
    leverage_limit: float
    cooks_limit: float
    boxcox_lambda: np.ndarray
    boxcox_ln_ss: np.ndarray
    boxcox_best: float
    boxcox_low: float
    boxcox_high: float
    boxcox_ci_ln_ss: float
    recommended: str
    p: int
    n: int

    @property
    def outliers(self) -> list:
        """Design points whose |studentized residual| exceeds the outlier limit."""
        bad = np.abs(np.nan_to_num(self.studentized)) > self.outlier_limit
        return [self.labels[i].item() if hasattr(self.labels[i], "item") else self.labels[i]
                for i in np.flatnonzero(bad)]

    @property
    def influential(self) -> list:
        """Design points whose Cook's distance exceeds its limit."""
        return [self.labels[i].item() if hasattr(self.labels[i], "item") else self.labels[i]
                for i in np.flatnonzero(np.nan_to_num(self.cooks) > self.cooks_limit)]

    @property
    def high_leverage(self) -> list:
        """Design points whose leverage exceeds 2 p / n."""
        return [self.labels[i].item() if hasattr(self.labels[i], "item") else self.labels[i]
                for i in np.flatnonzero(self.leverage > self.leverage_limit + 1e-12)]

    def to_dict(self) -> dict[str, Any]:
        """JSON form (NaN as None) for ``report.json``."""
        def arr(a: np.ndarray) -> list:
            return [None if not np.isfinite(v) else float(v) for v in np.asarray(a, float)]

        def num(v: float) -> float | None:
            return float(v) if math.isfinite(v) else None

        return {"points": [x.item() if hasattr(x, "item") else x for x in self.labels],
                "actual": arr(self.actual), "predicted": arr(self.predicted),
                "residual": arr(self.residual), "studentized": arr(self.studentized),
                "leverage": arr(self.leverage), "cooks": arr(self.cooks),
                "outlier_limit": num(self.outlier_limit),
                "leverage_limit": num(self.leverage_limit),
                "cooks_limit": num(self.cooks_limit), "outliers": self.outliers,
                "influential": self.influential, "high_leverage": self.high_leverage,
                "boxcox": {"best_lambda": num(self.boxcox_best),
                           "ci_low": num(self.boxcox_low), "ci_high": num(self.boxcox_high),
                           "recommended": self.recommended}}


def _boxcox(rs: ResponseSurface) -> tuple[np.ndarray, np.ndarray, float, float, float, float]:
    y = np.asarray(rs.response, float)
    x = rs.model_matrix
    df = rs.df_resid
    empty = (np.array([]), np.array([]), math.nan, math.nan, math.nan, math.nan)
    if df < 1 or np.any(y <= 0) or np.ptp(y) == 0:
        return empty
    gm = math.exp(float(np.mean(np.log(y))))
    ln_ss = []
    for lam in BOXCOX_LAMBDAS:
        if abs(lam) < 1e-12:
            z = gm * np.log(y)
        else:
            z = (y ** lam - 1.0) / (lam * gm ** (lam - 1.0))
        coef, *_ = np.linalg.lstsq(x, z, rcond=None)
        ss = float(np.sum((z - x @ coef) ** 2))
        ln_ss.append(math.log(ss) if ss > 0 else -math.inf)
    ln = np.array(ln_ss)
    if not np.isfinite(ln).all():
        return empty
    k = int(np.argmin(ln))
    limit = ln[k] + math.log(1.0 + stats.t.ppf(0.975, df) ** 2 / df)
    inside = BOXCOX_LAMBDAS[ln <= limit]
    return ln.copy(), BOXCOX_LAMBDAS.copy(), float(BOXCOX_LAMBDAS[k]), float(inside.min()), \
        float(inside.max()), float(limit)


def model_diagnostics(rs: ResponseSurface) -> Diagnostics:
    """Residuals, leverage, Cook's distance and Box-Cox of a fitted model (see module doc)."""
    n, p = rs.n_runs, rs.n_params
    e = np.asarray(rs.residuals, float)
    h = np.asarray(rs.leverage, float)
    mse = rs.mse
    with np.errstate(divide="ignore", invalid="ignore"):
        r = e / np.sqrt(mse * (1.0 - h)) if mse > 0 else np.full(n, math.nan)
        dfe = n - p
        t = r * np.sqrt((dfe - 1) / (dfe - r * r)) if dfe > 1 else np.full(n, math.nan)
        cooks = r * r * h / (p * (1.0 - h))
    t = np.where(np.isfinite(t), t, math.nan)
    order = np.argsort(np.nan_to_num(t, nan=0.0), kind="stable")
    q = np.empty(n)
    q[order] = stats.norm.ppf((np.arange(1, n + 1) - 0.375) / (n + 0.25))
    out_lim = float(stats.t.ppf(1 - 0.025 / n, dfe - 1)) if dfe > 1 else math.nan
    cook_lim = float(stats.f.ppf(0.5, p, dfe)) if dfe > 0 else math.nan
    ln, lam, best, lo, hi, lim = _boxcox(rs)
    if not math.isfinite(best):
        rec = "not computed"
    elif lo <= 1.0 <= hi:
        rec = "none"
    else:
        std = [s for s in _STANDARD if lo <= s <= hi]
        pick = min(std or _STANDARD, key=lambda s: abs(s - best))
        rec = f"{_TRANSFORM[pick]} (lambda = {pick:g})"
    return Diagnostics(
        labels=np.array(rs.run_labels, dtype=object), actual=np.asarray(rs.response, float),
        predicted=np.asarray(rs.fitted, float), residual=e, studentized=t, normal_quantile=q,
        leverage=h, cooks=np.where(np.isfinite(cooks), cooks, math.nan),
        outlier_limit=out_lim, leverage_limit=2.0 * p / n, cooks_limit=cook_lim,
        boxcox_lambda=lam, boxcox_ln_ss=ln, boxcox_best=best, boxcox_low=lo, boxcox_high=hi,
        boxcox_ci_ln_ss=lim, recommended=rec, p=p, n=n)


@dataclass(frozen=True)
class Check:
    """One adequacy rule: what is checked, the value, the rule, and whether it passes
    (None: cannot be evaluated, e.g. no lack-of-fit test).

    A check that is not ``binding`` (Cook's distance, leverage) flags runs to look at without
    making the model inadequate: a design's high-leverage points are influential by design.
    """

    name: str
    value: str
    rule: str
    ok: bool | None
    binding: bool = True

    @property
    def result(self) -> str:
        """``pass``, ``FAIL``, ``flag`` (a non-binding check that does not pass) or ``—``."""
        if self.ok is None:
            return "—"
        if self.ok:
            return "pass"
        return "FAIL" if self.binding else "flag"


def _fmt(v: Any, spec: str = ".3f") -> str:
    try:
        f = float(v)
    except (TypeError, ValueError):
        return "—"
    return f"{f:{spec}}" if math.isfinite(f) else "—"


def adequacy_checks(found: Screening | Surface, rs: ResponseSurface,
                    diag: Diagnostics) -> list[Check]:
    """The rules a reviewer applies to a model, evaluated on the stored fit and the plots.

    The binding rules are the stage's own (:func:`demcal.calibrate.stages.adequacy`,
    Design-Expert's): model p < 0.05, no significant lack of fit, adjusted R^2 >= 0.7,
    predicted R^2 not negative and within 0.2 of the adjusted R^2, Adeq Precision >= 4, with
    the statistics of the design-point means the stage stored (``Surface.adequacy``), so
    the report's verdict and the stage's agree. Outliers, influential runs, leverage and a
    Box-Cox transform are flagged for a look, not binding. A check that cannot be evaluated
    (e.g. no lack-of-fit test) does not fail.
    """
    surface = found if isinstance(found, Surface) else None
    # the surface's statistics of the means where stored, else the ANOVA's, else the model's
    stored = [s for s in (surface.adequacy if surface else None, found.fit) if s is not None]

    def stat(name: str, fallback: float) -> Any:
        return next((getattr(s, name) for s in stored if hasattr(s, name)), fallback)

    pred, adj = stat("pred_r2", rs.pred_r2), stat("adj_r2", rs.adj_r2)
    adeq, p_model = stat("adeq_precision", rs.adeq_precision), stat("p_model", rs.f_pvalue)
    lof = surface.lack_of_fit_p if surface else None

    def finite(v: Any) -> float | None:
        try:
            f = float(v)
        except (TypeError, ValueError):
            return None
        return f if math.isfinite(f) else None

    pr, ar, ap, pm = finite(pred), finite(adj), finite(adeq), finite(p_model)
    checks = [
        Check("model significant", f"p = {_fmt(pm, '.4g')}", "p < 0.05",
              None if pm is None else bool(pm < 0.05)),
        Check("adjusted R²", _fmt(ar), ">= 0.7", None if ar is None else ar >= 0.7),
        Check("predicted R²", _fmt(pr), ">= 0 and within 0.2 of the adjusted R²",
              None if pr is None or ar is None else bool(pr >= 0 and ar - pr <= 0.2)),
        Check("Adeq Precision", _fmt(ap, ".2f"), ">= 4", None if ap is None else ap >= 4),
        Check("lack of fit", f"p = {_fmt(lof, '.4g')}" if lof is not None else "no test",
              "p >= 0.05", None if finite(lof) is None else bool(lof >= 0.05)),
        Check("outliers (studentized residuals)",
              ", ".join(map(str, diag.outliers)) or "none",
              f"|t| <= {_fmt(diag.outlier_limit, '.2f')}",
              None if not math.isfinite(diag.outlier_limit) else not diag.outliers,
              binding=False),
        Check("influential runs (Cook's distance)",
              ", ".join(map(str, diag.influential)) or "none",
              f"D <= {_fmt(diag.cooks_limit, '.3f')}",
              None if not math.isfinite(diag.cooks_limit) else not diag.influential,
              binding=False),
        Check("high leverage", ", ".join(map(str, diag.high_leverage)) or "none",
              f"h <= 2p/n = {_fmt(diag.leverage_limit, '.3f')}", not diag.high_leverage,
              binding=False),
        Check("Box-Cox", f"lambda = {_fmt(diag.boxcox_best, '.2f')} "
              f"({_fmt(diag.boxcox_low, '.2f')} to {_fmt(diag.boxcox_high, '.2f')})",
              "no transform (lambda = 1 in the 95 % interval)",
              None if diag.recommended == "not computed" else diag.recommended == "none",
              binding=False),
    ]
    return checks


def verdict(checks: list[Check]) -> bool:
    """True when no binding check fails."""
    return not any(c.ok is False and c.binding for c in checks)
