"""An ANOVA table as a stage stores it: its rows and the fit statistics printed under it
(``demcal.doe.anova.AnovaTable``'s records, None where a number is not defined)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from demcal.summaries._stored import _Flat

__all__ = ["AnovaFit", "AnovaRecord", "anova_records"]


@dataclass(frozen=True)
class AnovaRecord(_Flat):
    """One source of variation of a stored ANOVA table (``AnovaRow.to_dict()``).

    Attributes
    ----------
    term : str
        ``"Model"``, a term (``"pp.static_friction"``, ``"pp.static_friction^2"``, ``"a*b"``),
        ``"Residual"``, ``"Lack of Fit"``, ``"Pure Error"`` or ``"Cor Total"``.
    ss : float or None
        Sum of squares, in the response's unit squared.
    df : int or None
        Degrees of freedom.
    ms : float or None
        Mean square, SS / df.
    f : float or None
        F value (None: the source has no test).
    p : float or None
        Prob > F.
    """

    term: str = ""
    ss: float | None = None
    df: int | None = None
    ms: float | None = None
    f: float | None = None
    p: float | None = None


@dataclass(frozen=True)
class AnovaFit(_Flat):
    """The fit statistics under a stored ANOVA table (``FitStatistics.to_dict()`` of
    :mod:`demcal.doe.anova`; None where not finite).

    Attributes
    ----------
    std_dev : float or None
        The residual standard deviation, in the response's unit.
    mean : float or None
        The response's mean, in its unit.
    cv_percent : float or None
        C.V. %, 100 std_dev / mean.
    press : float or None
        The predicted residual sum of squares.
    r2, adj_r2, pred_r2 : float or None
        R^2, adjusted and predicted R^2.
    adeq_precision : float or None
        Adeq Precision (signal to noise).
    """

    std_dev: float | None = None
    mean: float | None = None
    cv_percent: float | None = None
    press: float | None = None
    r2: float | None = None
    adj_r2: float | None = None
    pred_r2: float | None = None
    adeq_precision: float | None = None


def anova_records(stored: Iterable[Mapping[str, Any]] | None) -> list[AnovaRecord]:
    """The stored rows of an ANOVA table (``AnovaTable.to_records()``), typed."""
    return [AnovaRecord.from_summary(r) for r in stored or []]
