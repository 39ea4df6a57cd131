"""The response-surface model's rules, shared by the angle's surface and every other
response's: the rows it is fitted to (every replicate a row, in blocks with common seeds), a
response that cannot be modelled, and Design-Expert's adequacy and model reduction."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from demcal import doe
from demcal.errors import InputError
from demcal.summaries.surface import FitStatistics

__all__ = ["Adequacy", "JudgedModel", "ModelChoice", "adequacy", "choose_model",
           "fit_rows", "no_variation", "replicated", "resolution_note"]


def replicated(design: doe.Design, runs: list[list[float]], n_reps: int
                ) -> tuple[doe.Design, np.ndarray]:
    """The design with one row per replicate run, and their angles (NaN rows: no pile).

    Fitting every replicate as its own row (as Design-Expert does) gives the pure error of the
    replicates and a lack-of-fit test with their degrees of freedom; with one replicate it is
    the design itself.
    """
    if n_reps == 1:
        return design, np.array([r[0] if r else math.nan for r in runs])
    idx = np.repeat(np.arange(design.n_runs), n_reps)
    y = np.array([runs[i][k] if runs[i] else math.nan
                  for i in range(design.n_runs) for k in range(n_reps)])
    rep = doe.Design(design.coded[idx], design.names, design.kind,
                     np.arange(1, idx.size + 1), design.factors, design.point_type[idx],
                     design.dummies[idx] if design.dummies.size else np.empty((idx.size, 0)),
                     design.info)
    return rep, y


def no_variation(y: np.ndarray, unit: str = "deg") -> str | None:
    """Why the responses ``y`` (NaN: no response) cannot be modelled, else None.

    A response that does not vary (every run gave the same angle: the factors' ranges move
    nothing the test measures, or the engine writes a constant), or whose spread is not a
    finite number (a crafted or broken result of 1e308), has no effect to estimate: the
    ANOVA would divide 0 by 0.
    """
    y = np.asarray(y, dtype=float)
    y = y[~np.isnan(y)]
    if y.size < 2:
        return None  # too few responses: the fit says so
    lo, hi = float(np.min(y)), float(np.max(y))
    u = f" {unit}" if unit else ""
    if not (math.isfinite(lo) and math.isfinite(hi) and math.isfinite(hi - lo)):
        return (f"the responses are not finite numbers of a usable size (from {lo:.6g} to "
                f"{hi:.6g}{u}); check the test's results")
    if hi - lo <= 1e-9 * max(1.0, abs(hi)):
        return (f"the response does not vary: all {y.size} runs gave {hi:.6g}{u}; the "
                "factors' ranges move nothing the test measures (widen them) or the test "
                "gives a constant (check its result)")
    return None


def fit_rows(rep_design: doe.Design, y_rows: np.ndarray, n_reps: int, common_seeds: bool,
             *, unit: str = "deg") -> tuple[doe.ResponseSurface, list[str]]:
    """The quadratic fitted to every replicate row; with common seeds, in blocks.

    With ``common_seeds`` replicate k of every design point shares seed set k, so each
    replicate round is a block (Design-Expert's): its shared offset leaves the residual and the
    pure error. A run without a pile unbalances the blocks; then the rows are fitted without
    blocks and a note (the list returned) says so.
    """
    if (flat := no_variation(y_rows, unit)) is not None:  # a clear statement, not a 0/0
        raise InputError(flat)
    if not common_seeds or n_reps < 2:
        return doe.fit(rep_design, y_rows, model="quadratic"), []
    blocks = np.tile(np.arange(1, n_reps + 1), rep_design.n_runs // n_reps)
    try:
        return doe.fit(rep_design, y_rows, model="quadratic", blocks=blocks), []
    except doe.UnbalancedBlocksError as exc:
        return doe.fit(rep_design, y_rows, model="quadratic"), [
            f"common seeds: the replicate rounds are not used as blocks ({exc}); the pure "
            "error includes the seed sets' offsets"]


@dataclass(frozen=True)
class Adequacy:
    """Design-Expert's verdict on a model: adequate, the rules it failed and its statistics
    (:class:`demcal.summaries.surface.FitStatistics`, stored as the summary's ``adequacy``)."""

    adequate: bool
    failed: tuple[str, ...]
    statistics: FitStatistics


@dataclass(frozen=True)
class JudgedModel:
    """A model fitted to every replicate (``rows``), its ANOVA, lack of fit and adequacy (of
    the design-point means)."""

    rows: Any
    table: Any
    lack_of_fit_p: float | None
    adequacy: Adequacy


@dataclass(frozen=True)
class ModelChoice:
    """The model the optimum is read from (:func:`choose_model`).

    Attributes
    ----------
    chosen : JudgedModel
    kind : str
        ``"quadratic"`` or ``"reduced"``.
    removed_terms : tuple of str
        The terms the reduction removed (none for the full quadratic).
    full : JudgedModel
        The full quadratic's judgement (the same as ``chosen`` when it was kept).
    notes : tuple of str
        What to tell the user.
    """

    chosen: JudgedModel
    kind: str
    removed_terms: tuple[str, ...]
    full: JudgedModel
    notes: tuple[str, ...] = ()

    @property
    def adequacy(self) -> Adequacy:
        """The chosen model's verdict."""
        return self.chosen.adequacy


def adequacy(model: Any, lof_p: float | None) -> Adequacy:
    """Is a response-surface model adequate, as Design-Expert judges it?

    Inadequate when: the model is not significant (p >= 0.05); the lack of fit is
    significant (p < 0.05); adjusted R^2 < 0.7; predicted R^2 is negative or more than 0.2
    below the adjusted R^2 (the model does not predict new runs); or Adeq Precision (signal
    to noise) < 4. Returns the verdict, the failed rules as warnings and the statistics.
    """
    p_model = float(model.f_pvalue)
    adj, pred, adeq = float(model.adj_r2), float(model.pred_r2), float(model.adeq_precision)
    fails = []
    if not p_model < 0.05:
        fails.append(f"model not significant (p = {p_model:.3g} >= 0.05)")
    if lof_p is not None and lof_p < 0.05:
        fails.append(f"significant lack of fit (p = {lof_p:.3g} < 0.05)")
    if not adj >= 0.7:
        fails.append(f"adjusted R^2 = {adj:.3f} < 0.7")
    if not math.isfinite(pred) or pred < 0:
        fails.append(f"predicted R^2 = {pred:.3f} is negative: the model predicts new runs "
                     "worse than their mean")
    elif adj - pred > 0.2:
        fails.append(f"predicted R^2 = {pred:.3f} is more than 0.2 below the adjusted R^2 "
                     f"({adj:.3f})")
    if not adeq >= 4:
        fails.append(f"Adeq Precision = {adeq:.2f} < 4 (signal too weak against the noise)")
    stats_ = FitStatistics(p_model=p_model, lack_of_fit_p=lof_p, r2=float(model.r2),
                           adj_r2=adj, pred_r2=pred if math.isfinite(pred) else None,
                           adeq_precision=adeq if math.isfinite(adeq) else None)
    return Adequacy(adequate=not fails, failed=tuple(fails), statistics=stats_)


def _lof_p(table: Any) -> float | None:
    for row in table.rows:
        if row.source == "Lack of Fit" and math.isfinite(row.p):
            return float(row.p)
    return None


def _judged(rows: Any, means: Any) -> JudgedModel:
    """A model's ANOVA (rows: every replicate), lack of fit and adequacy (of the means)."""
    table = rows.anova()
    lof_p = _lof_p(table)
    return JudgedModel(rows=rows, table=table, lack_of_fit_p=lof_p,
                       adequacy=adequacy(means, lof_p))


def choose_model(kind: str, alpha_out: float, rows: Any, means: Any) -> ModelChoice:
    """The response-surface model the optimum is read from, judged as Design-Expert would.

    ``rows`` is the full quadratic fitted to every replicate, ``means`` the same model fitted
    to the design-point means (the same coefficients: the replication is balanced). R^2,
    predicted R^2 and Adeq Precision are the means' (the rows' R^2 is capped by the run-to-run
    noise however many replicates are run); the ANOVA and its lack of fit are the rows'.

    ``kind``: ``"quadratic"`` keeps the full model; ``"reduced"`` removes terms by
    hierarchical backward elimination (p > ``alpha_out`` in the rows' ANOVA, as
    Design-Expert's "backward" model reduction) and judges the reduced model; ``"auto"`` keeps
    the full model when it is adequate and reduces it otherwise. A reduction that would leave
    no factor term keeps the full model.
    """
    full = _judged(rows, means)
    kept_full = ModelChoice(chosen=full, kind="quadratic", removed_terms=(), full=full)
    if kind == "quadratic" or (kind == "auto" and full.adequacy.adequate):
        return kept_full
    reduced = rows.reduce(alpha_out=alpha_out, hierarchical=True)
    if reduced is rows or len(reduced.terms) < 2:
        return kept_full
    kept = set(reduced.term_names)
    removed = tuple(t for t in rows.term_names if t not in kept)
    means_r = reduced if rows is means else means.with_terms(list(reduced.terms))
    why = ("the full quadratic model is not adequate: " + "; ".join(full.adequacy.failed)
           if not full.adequacy.adequate else "the full quadratic model is in 'anova_full'")
    note = (f"the optimum is read from the reduced model (backward elimination, alpha out "
            f"{alpha_out:g}; removed: {', '.join(removed)}); {why}")
    return ModelChoice(chosen=_judged(reduced, means_r), kind="reduced", removed_terms=removed,
                       full=full, notes=(note,))


#: above this many replicates per design point the note says the test barely responds
MANY_REPLICATES = 50


def resolution_note(full: Any, replicates: int, n_points: int, unit: str = "deg") -> str | None:
    """What an inadequate surface lacked, in one sentence: its largest main effect, how many
    standard errors it stands from zero and about how many replicates of every design point
    would tell an effect of that size from the test's noise (p < 0.05, 80 % power;
    :func:`demcal.doe.power.replicates_to_resolve`). None where the fit has no noise to
    judge against, or already has the replicates."""
    from demcal.doe.power import replicates_to_resolve

    res = replicates_to_resolve(full, replicates)
    if res is None or res.replicates_needed is None or res.replicates_needed <= replicates:
        return None
    u = f" {unit}" if unit else ""
    need = res.replicates_needed
    head = (f"its largest main effect, {res.term} ({res.coefficient:+.3g}{u} from the centre "
            f"to the high level), is {abs(res.t):.2g} standard errors from zero at the "
            f"test's noise ({res.noise_std:.3g}{u})")
    if need > MANY_REPLICATES:
        return (f"{head}: telling it from the noise would take more than {MANY_REPLICATES} "
                "replicates of each design point; over these ranges the test barely responds "
                "to the factors")
    return (f"{head}: about {need} replicates of each design point ({need * n_points} runs) "
            "would tell an effect of that size from the noise (p < 0.05, 80 % power)")
