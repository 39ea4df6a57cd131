"""The report's tables as pandas DataFrames, built from the stored stage summaries.

Each function takes the report data (or one stage summary) and returns a :class:`Table`: its
key (the CSV file stem and the HTML id), a title, and a DataFrame of raw values (angles in
degrees, everything else SI; None/NaN where a value does not exist). The HTML shows the same
frames with :func:`format_cell`; ``report.json`` and ``tables/*.csv`` hold the raw values.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import pandas as pd

from demcal.display import readable
from demcal.doe.anova import significance
from demcal.report.data import ReportData, StageView
from demcal.summaries import (
    AnovaFit,
    AnovaRecord,
    Optimum,
    RangeFind,
    Screening,
    Steepest,
    StudyFactor,
    Surface,
    Target,
    Verification,
)
from demcal.summaries.steepest import AnchorRun, PathStep

__all__ = [
    "Table",
    "anova_frame",
    "candidates_table",
    "excluded_table",
    "factors_table",
    "fit_table",
    "fixed_params_table",
    "format_cell",
    "measurement_table",
    "physical_table",
    "rangefind_points_table",
    "rangefind_table",
    "rsm_coefficients_table",
    "rsm_design_table",
    "screening_anova_table",
    "screening_design_table",
    "screening_responses_table",
    "stage_runs_table",
    "stages_table",
    "steepest_levels_table",
    "steepest_table",
    "target_table",
    "term_label",
    "verification_summary_table",
    "verification_table",
]

P_COLUMNS = ("p", "p-value", "lack-of-fit p")


@dataclass(frozen=True)
class Table:
    """A titled table: ``key`` (file stem / HTML id), ``title`` and the raw ``frame``."""

    key: str
    title: str
    frame: pd.DataFrame
    note: str = ""

    def records(self) -> dict[str, Any]:
        """JSON form: ``{"title", "columns", "rows"}`` with None for missing numbers."""
        rows = [[_json_value(v) for v in row] for row in self.frame.itertuples(index=False)]
        return {"title": self.title, "columns": [str(c) for c in self.frame.columns],
                "rows": rows, "note": self.note}


def _json_value(v: Any) -> Any:
    if v is None:
        return None
    if hasattr(v, "item"):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def format_cell(value: Any, column: str = "") -> str:
    """Text of a table cell: floats to 5 significant digits, p-values as Design-Expert prints
    them (``<0.0001`` or 4 decimals), integers as integers, None/NaN as an empty cell."""
    value = _json_value(value)
    if value is None:
        return ""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if column in P_COLUMNS:
            return "<0.0001" if value < 1e-4 else f"{value:.4f}"
        return readable(value, 5)
    return str(value)


def term_label(term: str, symbols: Mapping[str, str]) -> str:
    """Display name of a model term with paper symbols: ``x3·x4``, ``x3²``, ``Intercept``."""
    if term in ("intercept", "1"):
        return "Intercept"
    if term in ("Block", "Model", "Residual", "Lack of Fit", "Pure Error", "Cor Total"):
        return term
    parts = []
    for piece in str(term).split("*"):
        name, _, exp = piece.strip().partition("^")
        sym = symbols.get(name, name)
        parts.append(sym + ("" if not exp else "²" if exp == "2" else f"^{exp}"))
    return "·".join(parts)


def _num(v: Any) -> float | None:
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


def _frame(rows: list[dict[str, Any]], columns: list[str]) -> pd.DataFrame:
    return pd.DataFrame(rows, columns=columns).astype(object)


# ------------------------------------------------------------------------------ study / inputs
def stages_table(data: ReportData) -> Table:
    """Status of every stage, with the failure message or the stage's message."""
    rows = []
    for view in data.stages.values():
        msg = view.error or view.summary.get("message") or ""
        if view.status == "missing":
            msg = "not run (no record in the store)"
        elif view.status == "disabled":
            msg = "disabled in the study"
        elif view.status == "running":
            msg = msg or "started, not finished"
        rows.append({"stage": view.title, "status": view.status, "runs": len(view.runs),
                     "message": str(msg)})
    return Table("stages", "Status of each stage",
                 _frame(rows, ["stage", "status", "runs", "message"]))


def factors_table(data: ReportData) -> Table:
    """The study's factors: symbol, parameter, unit and range as given."""
    rows = [{"symbol": f.symbol or "", "parameter": f.name, "unit": f.unit or "",
             "low": _num(f.low), "high": _num(f.high)} for f in data.factors]
    return Table("factors", "Factors and their ranges (as given in the study)",
                 _frame(rows, ["symbol", "parameter", "unit", "low", "high"]))


def fixed_params_table(data: ReportData) -> Table:
    """Every parameter that is not a factor, with its fixed value (SI)."""
    rows = [{"parameter": k, "value": _num(v)} for k, v in data.fixed_params.items()]
    return Table("fixed_params", "Fixed parameters (SI units)",
                 _frame(rows, ["parameter", "value"]))


def _flatten(prefix: str, value: Any, out: list[dict[str, Any]]) -> None:
    if isinstance(value, Mapping):
        for k, v in value.items():
            _flatten(f"{prefix}.{k}" if prefix else str(k), v, out)
    elif isinstance(value, list | tuple) and all(_num(v) is not None for v in value) and value:
        out.append({"quantity": prefix, "value": ", ".join(format_cell(float(v))
                                                          for v in value)})
    else:
        num = _num(value)
        out.append({"quantity": prefix, "value": num if num is not None else
                    ("" if value is None else str(value))})


def physical_table(data: ReportData) -> Table:
    """The intrinsic properties measured on the material (flattened ``meta["physical"]``)."""
    rows: list[dict[str, Any]] = []
    _flatten("", data.meta.get("physical") or {}, rows)
    return Table("physical", "Physical measurements (SI units)",
                 _frame(rows, ["quantity", "value"]))


def target_table(data: ReportData) -> Table:
    """The target angle of repose: mean, standard deviation, number and source."""
    t = data.target or Target()
    rows = [{"target AoR (deg)": _num(t.aor_deg), "std (deg)": _num(t.std_deg),
             "n": t.n, "source": t.source or ""}]
    return Table("target", "Target angle of repose",
                 _frame(rows, ["target AoR (deg)", "std (deg)", "n", "source"]))


def measurement_table(data: ReportData) -> Table:
    """Each photo's measured angles (left and right flank, mean), degrees."""
    photos = (data.target or Target()).photos
    rows = [{"photo": i + 1, "file": str(p.file or ""), "left (deg)": _num(p.left_deg),
             "right (deg)": _num(p.right_deg), "mean (deg)": _num(p.mean_deg)}
            for i, p in enumerate(photos)]
    return Table("measurements", "Angle of repose of each photo",
                 _frame(rows, ["photo", "file", "left (deg)", "right (deg)", "mean (deg)"]))


# --------------------------------------------------------------------------------- range finding
def rangefind_table(found: RangeFind, symbols: Mapping[str, str]) -> Table:
    """Per factor: range given, range kept, points tried, no-pile points and the reason."""
    rows = []
    for f in found.factors:
        rows.append({"symbol": f.symbol or symbols.get(f.name, ""), "parameter": f.name,
                     "low": _num(f.low), "high": _num(f.high), "new low": _num(f.new_low),
                     "new high": _num(f.new_high), "points": len(f.points),
                     "no pile": sum(1 for p in f.points if p.outcome != "pile"),
                     "reason": f.reason or ""})
    cols = ["symbol", "parameter", "low", "high", "new low", "new high", "points", "no pile",
            "reason"]
    return Table("rangefind", "Range-finding scan: ranges given and kept", _frame(rows, cols))


def rangefind_points_table(found: RangeFind, symbols: Mapping[str, str]) -> Table:
    """Every point of the range-finding scan: factor, value, outcome, AoR (deg)."""
    rows = []
    for f in found.factors:
        sym = f.symbol or symbols.get(f.name, f.name)
        for p in f.points:
            rows.append({"symbol": sym, "value": _num(p.value), "outcome": p.outcome,
                         "AoR (deg)": _num(p.response)})
    return Table("rangefind_points", "Range-finding scan: every point",
                 _frame(rows, ["symbol", "value", "outcome", "AoR (deg)"]))


def rangefind_responses_table(found: RangeFind) -> Table | None:
    """Every other response over the scans (several responses): the span measured, its lab
    value and whether the scans reached it; None with one response."""
    if not found.responses:
        return None
    rows = [{"response": r.name, "lowest seen": _num(r.low), "highest seen": _num(r.high),
             "lab value": _num(r.lab),
             "lab inside": "" if r.in_range is None else ("yes" if r.in_range else "no")}
            for r in found.responses]
    return Table("rangefind_responses", "Range-finding scan: the other responses",
                 _frame(rows, ["response", "lowest seen", "highest seen", "lab value",
                               "lab inside"]))


# ------------------------------------------------------------------------------------ screening
def _factor_symbols(factors: Sequence[StudyFactor], symbols: Mapping[str, str]
                   ) -> list[tuple]:
    return [(f.name, f.symbol or symbols.get(f.name, f.name)) for f in factors]


def screening_design_table(found: Screening, symbols: Mapping[str, str]) -> Table:
    """The screening design in coded units and its responses (the paper's Table 4)."""
    facs = _factor_symbols(found.factors or [], symbols)
    runs = found.runs or []
    dummies = [d for d in found.dummies or []  # shown only when their levels are stored
               if any(d in r.coded for r in runs)]
    rows = []
    for r in runs:
        row: dict[str, Any] = {"point": r.point}
        for name, sym in facs:
            row[sym] = _num(r.coded.get(name))
        for d in dummies:
            row[d] = _num(r.coded.get(d))
        row["AoR (deg)"] = _num(r.value)
        row["outcome"] = r.outcome
        rows.append(row)
    cols = ["point", *(s for _, s in facs), *dummies, "AoR (deg)", "outcome"]
    frame = _frame(rows, cols)
    for _, s in facs:  # coded levels are integers (-1, +1)
        frame[s] = [None if v is None else int(v) if float(v).is_integer() else v
                    for v in frame[s]]
    return Table("screening_design", "Screening design and results (coded levels; cf. Table 4)",
                 frame)


def anova_frame(records: Sequence[AnovaRecord], symbols: Mapping[str, str]) -> pd.DataFrame:
    """A stored ANOVA table's rows as a frame with a significance column."""
    rows = [{"source": term_label(r.term, symbols), "SS": _num(r.ss), "df": r.df,
             "MS": _num(r.ms), "F": _num(r.f), "p": _num(r.p),
             "significance": significance(math.nan if r.p is None else r.p)} for r in records]
    return _frame(rows, ["source", "SS", "df", "MS", "F", "p", "significance"])


def screening_anova_table(found: Screening, symbols: Mapping[str, str]) -> Table:
    """ANOVA of the screening fit with each effect, % contribution and rank (cf. Table 5)."""
    frame = anova_frame(found.anova or [], symbols)
    eff = {term_label(e.term, symbols): e for e in found.effects or []}
    frame["effect"] = [_num(eff[s].effect) if s in eff else None for s in frame["source"]]
    frame["contribution %"] = [_num(eff[s].contribution_percent) if s in eff else None
                               for s in frame["source"]]
    frame["rank"] = [eff[s].rank if s in eff else None for s in frame["source"]]
    return Table("screening_anova", "Screening ANOVA, effects and % contribution (cf. Table 5)",
                 frame, note="** p < 0.01, * p < 0.05. Effect = mean AoR at +1 minus at -1, "
                             "deg; contribution = 100 SS / SS total.")


def screening_responses_table(found: Screening, symbols: Mapping[str, str]) -> Table:
    """Each factor's effect on every response of a several-response study over the screening
    runs, with its p: which test moves which parameter (empty with one response)."""
    models = {"AoR": found.effects or [],
              **{name: m.effects for name, m in (found.responses or {}).items()}}
    terms = [e.term for e in found.effects or []]
    rows = []
    for term in terms:
        row: dict[str, Any] = {"term": term_label(term, symbols)}
        for name, effects in models.items():
            e = next((x for x in effects if x.term == term), None)
            row[f"{name} effect"] = None if e is None else _num(e.effect)
            row[f"{name} p"] = None if e is None else _num(e.p)
        rows.append(row)
    cols = ["term", *(f"{n} {k}" for n in models for k in ("effect", "p"))]
    notes = [m.note for m in (found.responses or {}).values() if m.note]
    return Table("screening_responses", "Screening: each factor's effect on every response",
                 _frame(rows, cols),
                 note="Effect = mean response at +1 minus at -1, in the response's unit; a "
                      "factor significant (p < alpha) for any response is a candidate for "
                      "the next stage." + "".join(f" {n}." for n in notes))


def fit_table(key: str, title: str, fit: AnovaFit,
              lack_of_fit_p: float | None = None) -> Table:
    """The fit statistics under an ANOVA table as statistic/value rows."""
    names = {"std_dev": "Std. Dev. (deg)", "mean": "Mean (deg)", "cv_percent": "C.V. %",
             "press": "PRESS", "r2": "R²", "adj_r2": "Adjusted R²", "pred_r2": "Predicted R²",
             "adeq_precision": "Adeq Precision"}
    rows = [{"statistic": names[f.name], "value": _num(getattr(fit, f.name))}
            for f in dataclasses.fields(fit)]
    if lack_of_fit_p is not None:
        rows.append({"statistic": "Lack of fit p", "value": _num(lack_of_fit_p)})
    return Table(key, title, _frame(rows, ["statistic", "value"]))


# ------------------------------------------------------------------------------------- steepest
def _path_rows(points: Sequence[PathStep | AnchorRun], names: Sequence[str],
               symbols: Mapping[str, str], values: Mapping[str, str]) -> list[dict[str, Any]]:
    """One row per path point: its step, factor settings, then ``values`` (column -> the
    point's attribute) and its outcome."""
    rows = []
    for s in points:
        row: dict[str, Any] = {"step": s.step}
        row.update({symbols.get(n, n): _num(s.actual.get(n)) for n in names})
        row.update({col: _num(getattr(s, key)) for col, key in values.items()})
        row["outcome"] = s.outcome
        rows.append(row)
    return rows


def steepest_table(path: Steepest, symbols: Mapping[str, str]) -> Table:
    """The path of steepest ascent: settings, AoR and relative error per step (cf. Table 6)."""
    names = list(path.factors or [])
    steps = path.steps or []
    rows = _path_rows(steps, names, symbols, {"AoR (deg)": "value",
                                               "relative error %": "relative_error_percent"})
    # several responses: the others' means and the overall desirability the path climbed
    others = [n for n in path.followed or [] if n != "aor_deg"]
    for row, s in zip(rows, steps, strict=True):
        row["best"] = "best" if s.step == path.best_step else ""
        row.update({n: _num((s.responses or {}).get(n)) for n in others})
        if others:
            row["D"] = _num(s.desirability)
    cols = ["step", *(symbols.get(n, n) for n in names), "AoR (deg)", "relative error %",
            *others, *(["D"] if others else []), "outcome", "best"]
    return Table("steepest", "Path of steepest ascent (cf. Table 6)", _frame(rows, cols))


def steepest_anchor_table(path: Steepest, symbols: Mapping[str, str]) -> Table:
    """The anchor's runs: the study's own test at path points, next to the path's cheaper
    test at the same points (empty when the path ran at the study's fidelity)."""
    runs = [] if path.anchor is None else path.anchor.runs
    names = list(path.factors or [])
    own = f"AoR, {(path.anchor and path.anchor.fidelity) or 'study'} (deg)"
    rows = _path_rows(runs, names, symbols,
                      {own: "value", "AoR, path's test (deg)": "path_value"})
    cols = ["step", *(symbols.get(n, n) for n in names), own, "AoR, path's test (deg)",
            "outcome"]
    return Table("steepest_anchor", "The path anchored at the study's test", _frame(rows, cols))


def steepest_levels_table(path: Steepest, symbols: Mapping[str, str]) -> Table:
    """Levels chosen for the response-surface design from the best step."""
    rows = []
    for n, lv in path.levels.items():
        lv = list(lv) + [None] * (3 - len(lv))
        rows.append({"symbol": symbols.get(n, n), "parameter": n, "low": _num(lv[0]),
                     "centre": _num(lv[1]), "high": _num(lv[2])})
    return Table("steepest_levels", "Levels for the response surface",
                 _frame(rows, ["symbol", "parameter", "low", "centre", "high"]))


# ------------------------------------------------------------------------------------------ rsm
def rsm_design_table(surface: Surface, symbols: Mapping[str, str]) -> Table:
    """The response-surface design, coded and actual, with its responses (cf. Table 7); with
    replicates, the AoR is their mean and each replicate and their spread are shown; the
    title names the surface's own fidelity where it has one."""
    facs = _factor_symbols(surface.factors, symbols)
    runs = surface.runs
    replicated = any(len(r.replicates or []) > 1 for r in runs)
    rows = []
    for r in runs:
        row: dict[str, Any] = {"point": r.point}
        for name, sym in facs:
            row[sym] = _num(r.coded.get(name))
        for name, sym in facs:
            row[f"{sym} actual"] = _num(r.actual.get(name))
        row["AoR (deg)"] = _num(r.value)
        if replicated:
            row["replicates (deg)"] = ", ".join(f"{v:.2f}" for v in r.replicates or [])
            row["std (deg)"] = _num(r.replicate_std)
        row["outcome"] = r.outcome
        rows.append(row)
    cols = ["point", *(s for _, s in facs), *(f"{s} actual" for _, s in facs), "AoR (deg)",
            *(["replicates (deg)", "std (deg)"] if replicated else []), "outcome"]
    frame = _frame(rows, cols)
    for _, s in facs:
        frame[s] = [None if v is None else int(v) if float(v).is_integer() else v
                    for v in frame[s]]
    own = ("" if surface.fidelity is None else f", on the {surface.fidelity} test (the "
           "verification runs the study's)")
    return Table("rsm_design", f"{_design_name(surface.design)} design and results "
                 f"(cf. Table 7){own}", frame)


def _design_name(design: str | None) -> str:
    """The design's name as the paper writes it (a stored summary without one:
    "Response-surface")."""
    if design is None:
        return "Response-surface"
    return {"box_behnken": "Box-Behnken", "ccd": "Central composite"}.get(str(design),
                                                                          str(design))


def rsm_coefficients_table(surface: Surface, symbols: Mapping[str, str]) -> Table:
    """Coefficients of the fitted polynomial in coded and in actual units."""
    coded = surface.coefficients_coded
    actual = surface.coefficients_actual
    terms = list(coded) + [t for t in actual if t not in coded]
    rows = [{"term": term_label(t, symbols), "coded": _num(coded.get(t)),
             "actual": _num(actual.get(t))} for t in terms]
    return Table("rsm_coefficients", "Coefficients (coded and actual units)",
                 _frame(rows, ["term", "coded", "actual"]))


# ------------------------------------------------------------------------- optimum and checks
def candidates_table(optimum: Optimum, symbols: Mapping[str, str]) -> Table:
    """Ranked candidate settings with their predicted AoR and 95 % prediction interval."""
    names: list[str] = []
    for c in optimum.candidates:
        names += [n for n in c.params if n not in names]
    rows = []
    for i, c in enumerate(optimum.candidates):
        row: dict[str, Any] = {"rank": i + 1}
        for n in names:
            row[symbols.get(n, n)] = _num(c.params.get(n))
        row["predicted AoR (deg)"] = _num(c.predicted_lead)
        row["PI low (deg)"] = _num(c.pi_low)
        row["PI high (deg)"] = _num(c.pi_high)
        row["P(pile)"] = _num(c.p_pile)
        rows.append(row)
    cols = ["rank", *(symbols.get(n, n) for n in names), "predicted AoR (deg)", "PI low (deg)",
            "PI high (deg)", "P(pile)"]
    return Table("candidates", "Optimum and ranked alternatives", _frame(rows, cols))


def verification_table(ver: Verification) -> Table:
    """Each verification replicate: AoR (deg) and outcome."""
    aors: list[float | None] = list(ver.values)
    outs = list(ver.outcomes)
    n = max(len(aors), len(outs))
    aors += [None] * (n - len(aors))
    outs += [""] * (n - len(outs))
    rows = [{"replicate": i + 1, "AoR (deg)": _num(a), "outcome": o}
            for i, (a, o) in enumerate(zip(aors, outs, strict=True))]
    return Table("verification", "Verification replicates",
                 _frame(rows, ["replicate", "AoR (deg)", "outcome"]))


def verification_summary_table(ver: Verification, target: float | None) -> Table:
    """Mean ± std of the replicates, their 95 % interval, the relative error against the
    measurement and the t-test's p and verdict (see demcal.calibrate.verify.compare_to_target),
    and Design-Expert's confirmation: the surface's prediction interval for the mean of the n
    runs and whether the mean lies inside it (demcal.calibrate.verify.confirmation)."""
    lo, hi = ver.ci_low, ver.ci_high
    plo, phi = ver.confirm_pi_low, ver.confirm_pi_high
    ok, confirmed = ver.consistent, ver.confirmed
    rows = [{"n": ver.n, "mean AoR (deg)": _num(ver.mean),
             "std (deg)": _num(ver.std),
             "95 % interval (deg)": "" if lo is None else f"{lo:.2f}-{hi:.2f}",
             "measured AoR (deg)": target,
             "relative error %": _num(ver.relative_error_percent),
             "p": _num(ver.p_value),
             "verdict": "" if ok is None else ("consistent" if ok else "differs"),
             "surface's 95 % PI for the mean (deg)": "" if plo is None else
             f"{plo:.2f}-{phi:.2f}",
             "confirmation": "" if confirmed is None else
             ("confirmed" if confirmed else "not confirmed")}]
    return Table("verification_summary", "Verification against the measurement",
                 _frame(rows, ["n", "mean AoR (deg)", "std (deg)", "95 % interval (deg)",
                               "measured AoR (deg)", "relative error %", "p", "verdict",
                               "surface's 95 % PI for the mean (deg)", "confirmation"]))


def verification_rounds_table(optimum: Optimum, verification: Verification,
                              symbols: Mapping[str, str]) -> Table | None:
    """One row per verification round (demcal.calibrate.refine), None for a single round:
    the round's optimum, the offset the earlier rounds measured, the share of it applied
    and the surface offset it aimed by (deg), the piles' mean and std (deg),
    the relative error to the target and Design-Expert's confirmation."""
    opts = [*optimum.rounds, optimum]
    vers = [*verification.rounds, verification]
    if len(vers) < 2 or len(opts) != len(vers):
        return None
    names = list(optimum.chosen)
    rows = []
    for o, v in zip(opts, vers, strict=True):
        conf = v.confirmed
        # round 1 was aimed by no offset: 0, all of it applied
        surface = 0.0 if o.surface_offset is None else o.surface_offset
        rows.append({"round": v.round_number,
                     **{symbols.get(n, n): _num(o.chosen.get(n)) for n in names},
                     "measured offset (deg)": _num(surface if o.measured_offset is None
                                                   else o.measured_offset),
                     "share applied": _num(1.0 if o.offset_weight is None else o.offset_weight),
                     "surface offset (deg)": _num(surface),
                     "piles": v.n_piles, "mean AoR (deg)": _num(v.mean),
                     "std (deg)": _num(v.std),
                     "relative error %": _num(v.relative_error_percent),
                     "confirmation": "" if conf is None else
                     ("confirmed" if conf else "not confirmed")})
    factors = [symbols.get(n, n) for n in names]
    piles = ["piles", "mean AoR (deg)", "std (deg)", "relative error %"]
    if optimum.opts == "bayes":  # no surface to aim: each round's posterior has more runs
        for row, o in zip(rows, opts, strict=True):
            row["predicted AoR (deg)"] = _num(o.predicted_lead)
        return Table("verification_rounds", "Verification rounds: each later round verifies "
                     "the best point of the posterior conditioned on the earlier rounds' "
                     "piles as well (the surrogates learn where they were wrong); the study's "
                     "answer is the last round's",
                     _frame(rows, ["round", *factors, "predicted AoR (deg)", *piles]))
    cols = ["round", *factors, "measured offset (deg)", "share applied",
            "surface offset (deg)", *piles, "confirmation"]
    return Table("verification_rounds", "Verification rounds: each later round aims the "
                 "surface by the offset the earlier rounds' piles measured (all of it after "
                 "an unconfirmed round; after confirmed ones the share the piles' information "
                 "bears against the surface's); the study's answer is the last round's",
                 _frame(rows, cols))


def excluded_table(data: ReportData) -> Table:
    """Runs without a usable angle (no pile, failed): excluded from every fit."""
    rows = [{"stage": r.stage, "point": r.point, "replicate": r.replicate, "status": r.status,
             "outcome": r.outcome or "", "reason": r.reason or ""}
            for r in data.excluded_runs()]
    return Table("excluded_runs", "Excluded runs (no pile or failed)",
                 _frame(rows, ["stage", "point", "replicate", "status", "outcome", "reason"]))


def stage_runs_table(view: StageView, symbols: Mapping[str, str], lead: str = "aor_deg"
                     ) -> Table:
    """The runs a stage stored (for a failed or unfinished stage): the parameters that vary
    between them, the outcome and the lead response (the AoR, deg)."""
    runs = view.runs
    names = sorted({k for r in runs for k in r.params})
    varying = [n for n in names if len({repr(r.params.get(n)) for r in runs}) > 1]
    varying = [n for n in symbols if n in varying] + [n for n in varying if n not in symbols]
    rows = []
    for r in runs:
        row: dict[str, Any] = {"point": r.point, "replicate": r.replicate}
        for n in varying:
            row[symbols.get(n, n)] = _num(r.params.get(n))
        row.update({"status": r.status, "outcome": r.outcome or "", "AoR (deg)": r.response(lead),
                    "reason": r.reason or ""})
        rows.append(row)
    cols = ["point", "replicate", *(symbols.get(n, n) for n in varying), "status", "outcome",
            "AoR (deg)", "reason"]
    return Table(f"{view.name}_runs", f"Runs stored by this stage ({len(runs)})",
                 _frame(rows, cols))
