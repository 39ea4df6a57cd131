"""Assemble the report from the store: ``report.html``, ``report.json``, CSV tables, PNGs.

:func:`build_report` reads the study's store, builds every table and figure of the stages
that have data, and writes them under ``<study_dir>/report`` (or ``out_dir``). A failed,
running or missing stage is shown as such and the report still builds; a figure that cannot
be drawn from malformed data is replaced by a note naming the error.
"""

from __future__ import annotations

import datetime as _dt
import io
import itertools
import json
import logging
import math
from collections.abc import Callable
from html import escape
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure

from demcal.errors import InputError
from demcal.report import bayes_section as BS
from demcal.report import diagnostics as D
from demcal.report import figures as F
from demcal.report import material as M
from demcal.report import model_figures as MF
from demcal.report import responses as RS
from demcal.report import tables as T
from demcal.report.data import ReportData, StageView, load_report_data
from demcal.report.html import badge, banner, figure_html, page, table_html
from demcal.report.lead_labels import relabel_figure, relabel_html, relabel_table
from demcal.report.surface import StoredSurface, significant_pairs
from demcal.safety import csv_safe, safe_filename, study_image
from demcal.summaries import Screening, Surface, Target, Verification
from demcal.summaries.spread import target_spread
from demcal.virtual.card_blocks import CardShape
from demcal.virtual.material_card import CONTACT_LAWS, ROLLING_LAWS, MaterialCard

__all__ = ["build_report"]

log = logging.getLogger("demcal.report")
DPI = 110


class _Builder:
    """Collects tables (CSV + JSON) and figures (PNG) while the HTML is written."""

    def __init__(self, data: ReportData, out_dir: Path) -> None:
        self.data = data
        self.out_dir = out_dir
        self.tables: dict[str, dict[str, Any]] = {}
        self.figures: list[str] = []
        self.problems: list[str] = []
        self.diagnostics: dict[str, Any] = {}
        self.card: MaterialCard | None = None
        (out_dir / "tables").mkdir(parents=True, exist_ok=True)
        (out_dir / "figures").mkdir(parents=True, exist_ok=True)

    def table(self, table: T.Table) -> str:
        table = relabel_table(table, self.data.lead)
        csv_safe(table.frame).to_csv(self.out_dir / "tables" / f"{safe_filename(table.key)}.csv",
                                     index=False)
        self.tables[table.key] = table.records()
        return table_html(table)

    def figure(self, key: str, caption: str, make: Callable[[], Figure]) -> str:
        try:
            fig = relabel_figure(make(), self.data.lead)
            buf = io.BytesIO()
            fig.savefig(buf, format="png", dpi=DPI)
        except Exception as exc:  # a bad figure must not stop the report
            msg = f"figure {key} could not be drawn: {type(exc).__name__}: {exc}"
            log.warning(msg)
            self.problems.append(msg)
            return f'<p class="warn">{escape(msg)}</p>'
        png = buf.getvalue()
        key = safe_filename(key)
        (self.out_dir / "figures" / f"{key}.png").write_bytes(png)
        self.figures.append(f"figures/{key}.png")
        return figure_html(png, caption)

    def image(self, key: str, path: str | None, caption: str) -> str:
        """Embed a PNG stored by the study (a diagnostic figure), copied into figures/."""
        if not path:
            return ""
        p, why = study_image(path, self.data.study_dir)
        if p is None:
            if why != "image not found":
                self.problems.append(f"{caption}: {why}: {path}")
            return f'<p class="warn">{escape(caption)}: {why} ({escape(str(path))})</p>'
        png, key = p.read_bytes(), safe_filename(key)
        (self.out_dir / "figures" / f"{key}.png").write_bytes(png)
        self.figures.append(f"figures/{key}.png")
        return figure_html(png, caption)


def _fmt(v: Any, spec: str = ".2f", unit: str = "") -> str:
    try:
        f = float(v)
    except (TypeError, ValueError):
        return "—"
    return f"{f:{spec}}{unit}" if math.isfinite(f) else "—"


def _equation(coefs: dict[str, Any], symbols: dict[str, str]) -> str:
    """``AoR = +41.77 +2.429·x3 ...`` from stored coefficients (4 significant digits)."""
    parts = []
    for term, v in coefs.items():
        c = _fmt(v, "+.4g")
        label = T.term_label(term, symbols)
        parts.append(c if label == "Intercept" else f"{c}·{label}")
    return "AoR (°) = " + " ".join(parts)


def _section(sid: str, title: str, status: str | None, body: str) -> str:
    head = f"<h2>{escape(title)}{badge(status) if status else ''}</h2>"
    return f'<section id="{escape(sid)}">{head}{body}</section>'


def _guard(b: _Builder, view: StageView, render: Callable[[], str]) -> str:
    """Banner, then the stage's content (if it has any); a render error becomes a note."""
    out = banner(view)
    if view.status in ("failed", "missing", "disabled") and not any(
            k != "error" for k in view.summary):
        if view.runs:  # what the stage ran before it stopped
            out += b.table(T.stage_runs_table(view, b.data.symbols, b.data.lead.name))
        return out
    before = set(b.tables)
    try:
        return out + render()
    except Exception as exc:  # malformed summary: say so
        for key in set(b.tables) - before:  # keep report.json to the tables shown
            del b.tables[key]
        msg = f"{view.name}: the stored summary could not be shown ({type(exc).__name__}: {exc})"
        b.problems.append(msg)
        return out + f'<p class="warn">{escape(msg)}</p>'


# ------------------------------------------------------------------------------------- sections
def _overview(b: _Builder) -> str:
    d = b.data
    name = d.title_name
    opt, ver = d.optimum, d.verification
    lead = d.lead
    t = d.lead_lab or Target()
    label, u = lead.label, lead.after_number(degree_sign=True)
    cards = [(f"Measured {label}", _fmt(t.aor_deg, ".2f", u)
              + (f" ± {_fmt(t.std_deg, '.2f')}{u}" if t.std_deg is not None else "")),
             ("Predicted at optimum", _fmt(opt.predicted_lead, ".2f", u)),
             (f"Verified {label}", _fmt(ver.mean, ".2f", u)
              + (f" ± {_fmt(ver.std, '.2f')}{u}" if ver.std is not None
                 else "")),
             ("Relative error", _fmt(ver.relative_error_percent, ".2f", " %"))]
    cards += [(f"{d.symbol(k)} ({k})", _fmt(v, ".4g")) for k, v in opt.chosen.items()]
    grid = "".join(f'<div class="card"><div class="k">{escape(k)}</div>'
                   f'<div class="v">{escape(v)}</div></div>' for k, v in cards)
    when = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    meta = (f'<p class="meta">Study folder <code>{escape(str(d.study_dir))}</code>'
            + (f" · study file <code>{escape(str(d.meta['study_file']))}</code>"
               if d.meta.get("study_file") else "")
            + f" · report built {when} from the run store alone.</p>")
    led = ("" if lead.is_angle else
           f'<p class="warn">This study leads with <b>{escape(lead.name)}</b>'
           f"{escape(f' ({lead.unit})' if lead.unit else '')}, not the angle of repose: range "
           "finding, screening, the path, the surface and the verification follow it, and the "
           "sections below name it where a study of the angle says AoR.</p>")
    return (f"<header><h1>Calibration report: {escape(str(name))}</h1>{meta}"
            f'<div class="summary">{grid}</div>{led}</header>')


def _stages(b: _Builder) -> str:
    return _section("stages", "Stages", None, b.table(T.stages_table(b.data))) + BS.bayes_section(b)


def _shape_line(shape: CardShape | None) -> str:
    """``Particle: stalk of 7 spheres, 10 x 4 mm, size factor 0.75-1.25.``"""
    if shape is None:
        return ""
    mm = 1e3
    what = shape.template or ""
    if what == "stalk":
        what += f" of {shape.n_spheres} spheres"
    size = (f"{_fmt(_num_or_nan(shape.length_m) * mm, '.3g')} x "
            f"{_fmt(_num_or_nan(shape.diameter_m) * mm, '.3g')} mm (length x diameter)"
            if what != "sphere" else
            f"{_fmt(_num_or_nan(shape.diameter_m) * mm, '.3g')} mm diameter")
    return (f"<p><b>Particle:</b> {escape(what)}, {escape(size)}, size factor "
            f"{_fmt(shape.size_min, '.3g')}-{_fmt(shape.size_max, '.3g')} "
            "(uniform).</p>")


def _num_or_nan(v: Any) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def _material(b: _Builder) -> str:
    """The calibrated material at the top: the card's table, laws, engine, verification."""
    card = b.card
    if card is None:
        return _section("material", "Calibrated material", "missing",
                        '<div class="banner missing"><b>No calibrated parameter set</b> is '
                        "stored yet (the optimum and verification have not run).</div>")
    lammps = card.engine_name == "lammps"
    laws = "".join(f"<li><b>{escape(k)}</b>: {escape(v)}</li>" for k, v in (
        card.to_dict()["engine"]["contact_laws"].items() if lammps else (
            ("elastic", CONTACT_LAWS["elastic"]), ("normal", CONTACT_LAWS["normal"]),
            ("damping", CONTACT_LAWS["damping"]), ("tangential", CONTACT_LAWS["tangential"]),
            ("rolling", f"model {card.rolling_model}: "
                        + ROLLING_LAWS.get(card.rolling_model, card.rolling_model)))))
    eng = card.engine
    test = card.test
    who = (f"LAMMPS (pair granular; demcal {escape(str(eng.version or ''))} wrote the "
           "test and measured the piles): <b>these parameters are for LAMMPS</b> with "
           "demcal's mapping (docs/lammps.md), not for demcal's engine"
           if lammps else f"demcal {escape(str(eng.version or ''))} (backend "
           f"{escape(str(eng.backend or 'auto'))}, rolling friction model "
           f"{escape(card.rolling_model)})")
    line = (f"<p><b>Engine:</b> {who}; virtual test {escape(str(test.kind))}"
            f" at fidelity {escape(str(test.fidelity))}"
            + (f", time step {_fmt(eng.dt_fraction, '.3g')} of the Rayleigh step"
               if eng.dt_fraction is not None else "") + ".</p>"
            + _shape_line(card.shape)
            + f'<p class="verdict"><b>Verification:</b> '
            f"{escape(card.verification.line)}.</p>")
    if card.is_external:  # an external engine: its laws, not demcal's
        line = (f"<p><b>Engine:</b> {escape(str(eng.name))}: "
                f"<code>{escape(str(eng.command or ''))}</code> (input template "
                f"<code>{escape(str(eng.template or ''))}</code>, SHA-256 "
                f"{escape(str(eng.template_sha256 or '')[:12])}). The parameters are "
                "that engine's: they mean its contact laws, not demcal's.</p>"
                f'<p class="verdict"><b>Verification:</b> '
                f"{escape(card.verification.line)}.</p>")
        return _section("material", "Calibrated material", None,
                        line + b.table(M.card_table(card))
                        + "<p>Material card: <code>material.toml</code> and "
                          "<code>material.json</code> next to this report.</p>")
    files = ("<p>Material card: <code>material.toml</code> and <code>material.json</code> "
             "next to this report; run it again with "
             "<code>demcal simulate aor --material material.toml</code>.</p>")
    return _section("material", "Calibrated material", None,
                    line + b.table(M.card_table(card)) + files
                    + f"<details open><summary>Contact laws of the engine "
                      f"({'LAMMPS pair granular' if lammps else 'demcal.dem.contact'})"
                      f"</summary><ul>{laws}</ul></details>")


def _measurement(b: _Builder) -> str:
    d = b.data
    parts = [b.table(M.parameter_table(d, b.card))]
    if d.target is None:
        return _section("measurement", "Physical measurements and target", "missing",
                        '<div class="banner missing"><b>No target</b> is stored.</div>'
                        + "".join(parts))
    parts.append(b.table(M.measurements_table(d)))
    parts.append(b.table(T.target_table(d)))
    target = d.target
    photos = target.photos
    if photos:
        parts.append(b.table(T.measurement_table(d)))
        parts.append(b.figure("measurement", "Angle of repose of each photo with the target "
                              "mean ± 1 std.", lambda: F.measurement_figure(target)))
        shots = [b.image(f"photo_{i + 1}", p.figure,
                         f"Photo {i + 1} ({Path(str(p.file or '')).name}): "
                         f"{_fmt(p.mean_deg, '.2f', '°')} (left "
                         f"{_fmt(p.left_deg, '.2f', '°')}, right "
                         f"{_fmt(p.right_deg, '.2f', '°')}); boundary and fitted "
                         "flank lines") for i, p in enumerate(photos)]
        if any(shots):
            parts.append('<h3>Diagnostic figure of each photo</h3><div class="gallery">'
                         + "".join(shots) + "</div>")
    if d.meta.get("physical"):
        parts.append('<p class="note">The raw measurements and everything derived from them '
                     "are in <code>report.json</code> (<code>meta.physical</code>).</p>")
    return _section("measurement", "Physical measurements and target", None, "".join(parts))


def _rangefind(b: _Builder) -> str:
    d, view = b.data, b.data.stage("rangefind")

    def render() -> str:
        s = d.rangefind
        parts = []
        if s.message:
            parts.append(f"<p>{escape(s.message)}</p>")
        if s.response_min is not None:
            parts.append(f"<p>AoR over the scan: {_fmt(s.response_min)}° to "
                         f"{_fmt(s.response_max)}°; target "
                         f"{'inside' if s.target_in_range else 'outside'} this range.</p>")
        parts.append(b.table(T.rangefind_table(s, d.symbols)))
        others = T.rangefind_responses_table(s)
        if others is not None:  # several responses: which lab value the scans reached
            parts.append(b.table(others))
        parts.append(b.figure("rangefind", "AoR against each factor's value; × = no pile; "
                              "shaded = range kept; dashed = target.",
                              lambda: F.rangefind_figure(s, d.lead_target, d.symbols)))
        parts.append("<details open><summary>Every point of the scan</summary>"
                     + b.table(T.rangefind_points_table(s, d.symbols)) + "</details>")
        return "".join(parts)

    return _section("rangefind", "Range-finding scan", view.status, _guard(b, view, render))


def _fitted(found: Screening | Surface, rs: Any) -> StoredSurface:
    """The refitted model as a surface to draw (its coded coefficients over the stage's
    factors)."""
    return StoredSurface.from_model(found.factors or [], {
        str(k): float(v) for k, v in rs.coefficients_coded.items()})


def _diagnostics(b: _Builder, stage: str, found: Screening | Surface,
                 hold: dict[str, float] | None) -> tuple[str, bool | None]:
    """Design-Expert's diagnostics of a stage's model: the adequacy checks, the residual
    plots, Box-Cox and the perturbation plot. Returns the HTML and the verdict (None when
    the model cannot be refitted)."""
    d = b.data
    try:
        rs = D.refit(found, stage)
        diag = D.model_diagnostics(rs)
    except Exception as exc:
        msg = f"{stage}: diagnostics not computed ({type(exc).__name__}: {exc})"
        b.problems.append(msg)
        return f'<p class="warn">{escape(msg)}</p>', None
    checks = D.adequacy_checks(found, rs, diag)
    ok = D.verdict(checks)
    b.diagnostics[stage] = {**diag.to_dict(), "checks": [
        {"check": c.name, "value": c.value, "rule": c.rule, "ok": c.ok, "binding": c.binding}
        for c in checks], "adequate": ok}
    rows = [{"check": c.name, "value": c.value, "rule": c.rule, "result": c.result}
            for c in checks]
    parts = [f"<h3>Model diagnostics ({rs.n_runs} runs, {rs.n_params} terms)</h3>",
             b.table(T.Table(f"{stage}_checks", "Adequacy checks (Design-Expert's rules)",
                             T._frame(rows, ["check", "value", "rule", "result"]),
                             note="— = cannot be evaluated (does not fail); flag = runs to look "
                                  "at (does not fail). Outlier limit: Bonferroni t at alpha "
                                  "0.05; Cook's limit F(0.5; p, n-p).")),
             b.figure(f"{stage}_residuals", "Normal probability plot of the externally "
                      "studentized residuals, residuals vs predicted and vs run (dashed: "
                      "outlier limits), predicted vs actual, Cook's distance and leverage "
                      "(dashed: limits; flagged runs labelled by design point).",
                      lambda: MF.residual_figure(diag)),
             '<div class="row">',
             b.figure(f"{stage}_boxcox", f"Box-Cox plot for power transforms: recommended "
                      f"transform {diag.recommended}.", lambda: MF.boxcox_figure(diag)),
             b.figure(f"{stage}_perturbation", "Perturbation: predicted AoR as each factor "
                      "moves from -1 to +1 (coded) through "
                      f"{'the optimum' if hold else 'the centre'}; dashed = target.",
                      lambda: MF.perturbation_figure(_fitted(found, rs), hold,
                                                     d.lead_target)),
             "</div>",
             f'<p class="verdict"><b>Diagnostics verdict:</b> '
             f"{'adequate' if ok else 'not adequate'}"
             + (f" (fails: {escape(', '.join(c.name for c in checks if c.result == 'FAIL'))})"
                if not ok else "") + ".</p>"]
    stored = found.adequate if isinstance(found, Surface) else None
    if stored is not None and bool(stored) != ok:
        parts.append(f'<p class="warn">The stage stored "adequate = '
                     f"{'yes' if stored else 'no'}\" but the diagnostics above say "
                     f"{'adequate' if ok else 'not adequate'}; the diagnostics verdict is the "
                     "one to trust.</p>")
    return "".join(parts), ok


def _screening(b: _Builder) -> str:
    d, view = b.data, b.data.stage("screening")

    def render() -> str:
        s = d.screening
        parts = []
        info = (f"{(s.design or '').replace('_', '-').title()} design, "
                f"{s.n_runs if s.n_runs is not None else len(s.runs or [])} runs, "
                f"alpha = {s.alpha}.")
        if s.dummies:
            info += f" Dummy columns: {', '.join(map(str, s.dummies))}."
        parts.append(f"<p>{escape(info)}</p>")
        parts.append(b.table(T.screening_design_table(s, d.symbols)))
        row = []
        if s.anova:
            row.append(b.table(T.screening_anova_table(s, d.symbols)))
        if s.fit:
            row.append(b.table(T.fit_table("screening_fit", "Screening fit statistics",
                                           s.fit)))
        parts.append(f'<div class="row">{"".join(row)}</div>')
        if s.effects:
            parts.append(b.figure("pareto", "Pareto chart of the effects: |effect| with % "
                                  "contribution; ** p < 0.01, * p < 0.05.",
                                  lambda: F.pareto_figure(s.effects or [], d.symbols)))
        if s.responses:
            parts.append(b.table(T.screening_responses_table(s, d.symbols)))
        sel = ", ".join(f"{d.symbol(n)} ({n})" for n in s.selected)
        parts.append(f"<p><b>Selected for the next stage:</b> {escape(sel or 'none')}.</p>")
        if s.excluded_points:
            parts.append(f"<p>Excluded design points (no pile): "
                         f"{escape(', '.join(map(str, s.excluded_points)))}.</p>")
        if s.message:
            parts.append(f"<p>{escape(s.message)}</p>")
        if s.runs and s.anova:
            parts += _screening_model(b, s)
        return "".join(parts)

    return _section("screening", "Screening", view.status, _guard(b, view, render))


def _screening_model(b: _Builder, s: Screening) -> list[str]:
    """The screening model's diagnostics and its contours over the selected factors'
    pairs."""
    d = b.data
    parts = [_diagnostics(b, "screening", s, None)[0]]
    sel = [n for n in s.selected if n in s.names]
    if len(sel) >= 2:
        goal = d.lead_target
        parts.append(b.figure(
            "screening_contours", "Contours of the screening model (linear) over each "
            "pair of the selected factors, the others at their centres"
            + ("" if goal is None else f"; red = the target {goal:.2f}° where reached")
            + ".",
            lambda: MF.pair_contours_figure(
                _fitted(s, D.refit(s, "screening")),
                list(itertools.combinations(sel, 2)), None, goal)))
    return parts


def _steepest(b: _Builder) -> str:
    d, view = b.data, b.data.stage("steepest")

    def render() -> str:
        s = d.steepest
        direction = ", ".join(f"{d.symbol(k)} {'up' if v > 0 else 'down'}"
                              for k, v in (s.direction or {}).items())
        climbed = (f" The path climbed the overall desirability of "
                   f"{', '.join(s.followed or [])} (first-order models over the screening "
                   "runs)." if len(s.followed or []) > 1 else "")
        parts = [f"<p>Direction: {escape(direction or '—')}; best step: "
                 f"{escape(str(s.best_step if s.best_step is not None else '—'))}."
                 f"{escape(climbed)}</p>",
                 b.table(T.steepest_table(s, d.symbols)),
                 b.figure("steepest", "AoR (line) and relative error to the measurement (bars) "
                          "along the path.",
                          lambda: F.steepest_figure(s, d.lead_target, d.symbols))]
        if s.anchor is not None:
            a = s.anchor
            parts += [f"<p>Anchor: {escape(a.message)}; the response surface "
                      f"is centred at step {_fmt(a.centre_step)}.</p>",
                      b.table(T.steepest_anchor_table(s, d.symbols))]
        if s.levels:
            parts.append(b.table(T.steepest_levels_table(s, d.symbols)))
        return "".join(parts)

    return _section("steepest", "Path of steepest ascent", view.status, _guard(b, view, render))


def _rsm_anova_tables(b: _Builder, s: Surface) -> list[str]:
    """The response surface's ANOVA and fit statistics; with a reduced model, the full
    quadratic model's ANOVA (the paper's Table 8) below them."""
    d = b.data
    reduced = s.model == "reduced"
    row = []
    if s.anova:
        title = ("ANOVA of the reduced response surface (backward elimination; the "
                 "optimum is read from it)" if reduced else
                 "ANOVA of the response surface with lack of fit (cf. Table 8)")
        row.append(b.table(T.Table(
            "rsm_anova", title, T.anova_frame(s.anova, d.symbols),
            note="Partial sum of squares (Type III). ** p < 0.01, * p < 0.05.")))
    if s.fit:
        row.append(b.table(T.fit_table("rsm_fit", "Fit statistics", s.fit, s.lack_of_fit_p)))
    parts = [f'<div class="row">{"".join(row)}</div>']
    if reduced and s.anova_full:
        parts.append(b.table(T.Table(
            "rsm_anova_full", "ANOVA of the full quadratic model (cf. Table 8)",
            T.anova_frame(s.anova_full, d.symbols),
            note="Not adequate by Design-Expert's rules or not chosen (stages.rsm.model); "
                 "removed from it: " + (", ".join(s.removed_terms or []) or "none")
                 + ".")))
    return parts


def _rsm_warnings(s: Surface) -> list[str]:
    """The stage's warnings and, for a model that is not adequate, what would resolve it."""
    out = [f'<p class="warn">Warning: {escape(str(w))}</p>' for w in s.warnings]
    if s.resolution is not None:  # what the budget lacked, in replicates
        out.append(f'<p class="warn">Not resolved: {escape(s.resolution)}.</p>')
    return out


def _rsm(b: _Builder) -> str:
    d, view = b.data, b.data.stage("rsm")

    def render() -> str:
        s = d.surface
        parts = [b.table(T.rsm_design_table(s, d.symbols))]
        parts += _rsm_anova_tables(b, s)
        parts += _rsm_warnings(s)
        if s.coefficients_coded:
            parts.append(b.table(T.rsm_coefficients_table(s, d.symbols)))
        for coefs, label in ((s.coefficients_coded, "Coded equation (factors from -1 to +1)"),
                             (s.coefficients_actual,
                              "Actual equation (factors in their units)")):
            if coefs:
                parts.append(f'<h3>{label}</h3><div class="eq">'
                             f"{escape(_equation(coefs, d.symbols))}</div>")
        hold = d.optimum.chosen or None
        if s.runs and s.coefficients_coded:
            parts.append(_diagnostics(b, "rsm", s, hold)[0])
            if s.adequate is not None:
                parts.append(f"<p><b>Model adequate (stored by the stage):</b> "
                             f"{'yes' if s.adequate else 'no'}.</p>")
        if s.coefficients_coded and len(s.factors) >= 2:
            parts += _rsm_pair_figures(b, s, hold)
        if s.excluded_points:
            parts.append(f"<p>Excluded design points (no pile): "
                         f"{escape(', '.join(map(str, s.excluded_points)))}.</p>")
        return "".join(parts)

    return _section("rsm", "Response surface", view.status, _guard(b, view, render))


def _rsm_pair_figures(b: _Builder, s: Surface, hold: dict[str, float] | None) -> list[str]:
    """The response surface over each factor pair (interactions first) and predicted vs
    actual."""
    d = b.data
    p_of = {r.term: r.p for r in s.anova}
    sig = set(significant_pairs(s))
    try:  # a surface whose terms cannot be read: each figure says so, the tables stay
        surf: StoredSurface | None = StoredSurface.from_surface(s)
    except InputError:
        surf = None

    def drawn() -> StoredSurface:  # the surface, or the reason it cannot be drawn (raised)
        return surf if surf is not None else StoredSurface.from_surface(s)

    parts = ["<h3>Response surface and contour of each factor pair</h3>"]
    goal = d.lead_target
    for a, c in itertools.combinations(s.names, 2):
        key = f"surface_{d.symbol(a)}_{d.symbol(c)}".replace(".", "_")
        p = p_of.get(f"{a}*{c}", p_of.get(f"{d.symbol(a)}*{d.symbol(c)}"))
        why = (f"interaction p = {_fmt(p, '.4f')}" if p is not None else
               "interaction not in the model")
        if (a, c) in sig:
            why += ", significant" if p is not None and p < 0.05 else \
                ", strongest main effects"
        reached = surf is not None and MF.target_reached(surf, (a, c), hold, goal)
        parts.append(b.figure(
            key, f"Response surface and contour of AoR over {d.symbol(a)} and "
            f"{d.symbol(c)} ({why}; other factors at "
            f"{'the optimum (star)' if hold else 'their centres (star)'}; "
            + ("no target stored" if goal is None else
               f"red = the target {goal:.2f}° contour" if reached else
               f"the target {goal:.2f}° is not reached over this pair")
            + "; dots = design points).",
            lambda a=a, c=c: MF.pair_surface_figure(drawn(), (a, c), hold, goal)))
    parts.append(b.figure("predicted_actual", "Predicted (stored model) vs actual AoR "
                          "of the design runs.", lambda: F.predicted_actual_figure(s)))
    return parts


def _optimize(b: _Builder) -> str:
    d, view = b.data, b.data.stage("optimize")

    def render() -> str:
        opt = d.optimum
        chosen = ", ".join(f"{d.symbol(k)} = {_fmt(v, '.4g')}" for k, v in opt.chosen.items())
        spread = target_spread(opt, d.surface.ranges)
        return (f"<p>Target {_fmt(opt.target)}°. <b>Chosen:</b> "
                f"{escape(chosen or '—')}, predicted AoR "
                f"{_fmt(opt.predicted_lead)}°.</p>"
                + b.table(T.candidates_table(opt, d.symbols))
                + ("" if spread is None else
                   f'<p class="warn">Note: {escape(spread.line("°"))}.</p>'))

    return _section("optimize", "Optimum and alternatives", view.status, _guard(b, view, render))


def _several_responses(b: _Builder) -> str:
    """Each response's goal, model, prediction and verification (several-response studies)."""
    view = RS.responses_view(b.data.surface, b.data.optimum, b.data.verification)
    if view is None:
        return ""
    goals, verified = RS.responses_tables(view)
    equations = "".join(f"<p><b>{escape(r.name)}</b> = {escape(r.equation)}</p>"
                        for r in view.rows if r.equation and r.name != view.rows[0].name)
    rsm, opt = b.data.surface, b.data.optimum
    names = rsm.names
    figures = "".join(
        b.figure(f"overlay_{p}_{q}", f"Overlay on {b.data.symbol(p)} x {b.data.symbol(q)}, the "
                 "other factors at the optimum (red star)",
                 lambda p=p, q=q: RS.overlay_figure(rsm, opt, (p, q)))
        for p, q in itertools.combinations(names, 2))
    return _section("responses", "Several responses", None,
                    b.table(goals) + equations + _response_anovas(b, rsm) + b.table(verified)
                    + figures)


def _response_anovas(b: _Builder, rsm: Surface) -> str:
    """Each other response's ANOVA at the response surface, with its adequacy and warnings
    (the angle's is the Response surface section's)."""
    parts = []
    for name, fit in (rsm.responses or {}).items():
        if not fit.anova:
            continue
        a = fit.adequacy
        note = (f"{'adequate' if fit.adequate else 'not adequate'} by Design-Expert's rules: "
                f"model p {_fmt(a.p_model, '.3g')}, lack of fit p "
                f"{_fmt(a.lack_of_fit_p, '.3g')}, adjusted R² {_fmt(a.adj_r2)}, "
                f"predicted R² {_fmt(a.pred_r2)}, Adeq Precision "
                f"{_fmt(a.adeq_precision)}"
                + "".join(f"; {w}" for w in fit.warnings) + ".")
        parts.append(b.table(T.Table(
            f"responses_anova_{name}", f"ANOVA of {name} ({fit.model} model)",
            T.anova_frame(fit.anova, b.data.symbols), note=note)))
    return "".join(parts)


def _verification(b: _Builder) -> str:
    d, view = b.data, b.data.stage("verification")

    def render() -> str:
        s = d.verification
        lab = d.lead_lab or Target()
        parts = ['<div class="row">' + b.table(T.verification_summary_table(s, d.lead_target))
                 + b.table(T.verification_table(s)) + "</div>"]
        rounds = T.verification_rounds_table(d.optimum, s, d.symbols)
        if rounds is not None:
            parts.append(b.table(rounds))
        parts += [
                 b.figure("verification", "Verification replicates, their mean ± 1 std "
                          "(blue band) and the measurement (green).",
                          lambda: F.verification_figure(
                              s, d.lead_target, lab.std_deg))]
        parts += (_pile_comparison(b, s, view) if d.lead.is_angle else [
            '<p class="note">The verification piles show their angle, not the response this '
            "study leads with: no side-by-side comparison.</p>"])
        params = s.params
        if params:
            parts.append(b.table(T.Table("verification_params",
                                         "Full parameter set verified (SI units)",
                                         T._frame([{"parameter": k, "value": T._num(v)}
                                                   for k, v in params.items()],
                                                  ["parameter", "value"]))))
        return "".join(parts)

    return _section("verification", "Verification", view.status, _guard(b, view, render))


def _pile_comparison(b: _Builder, s: Verification, view: StageView) -> list[str]:
    """Each verification pile beside a measured photo (or the one pile and photo stored): the
    same boundary and flank-line fit on both, cf. the paper's Fig. 9."""
    d = b.data
    parts: list[str] = []
    photos = (d.target or Target()).photos
    with_fig = [p for p in photos if p.figure]
    goal = d.lead_target
    if with_fig and goal is not None:  # the photo closest to the target mean
        with_fig.sort(key=lambda p: abs(T._num(p.mean_deg) - goal)
                      if T._num(p.mean_deg) is not None else math.inf)
    photo_fig = with_fig[0].figure if with_fig else None
    pile = s.pile_png

    def resolve(p: str | None) -> Path | None:
        if not p:
            return None
        return study_image(p, d.study_dir)[0]

    # every verification replicate's pile beside a measured photo (cycled): both are the
    # diagnostic figure of demcal.measure's boundary and flank-line fit
    runs = sorted((r for r in view.runs if (r.artefacts or {}).get("pile_png")
                   and r.params == s.params),  # the last round's piles
                  key=lambda r: (r.point, r.replicate))
    shown = [p for p in photos if p.figure]
    if runs:
        parts.append("<h3>Each verification pile beside a measured photo</h3>")
        for k, r in enumerate(runs):
            ph = shown[k % len(shown)] if shown else None
            n_ph = photos.index(ph) + 1 if ph is not None else None
            cap = (f"Replicate {r.replicate + 1}: simulated pile, AoR "
                   f"{_fmt(r.aor_deg, '.2f', '°')} (side view with fitted flank lines)"
                   + (f", beside photo {n_ph} ({_fmt(ph.mean_deg, '.2f', '°')}, "
                      "boundary and fitted flank lines: the same method)" if ph is not None else
                      "; no photo is stored")
                   + ".")
            parts.append(b.figure(
                f"comparison_{k + 1}", cap,
                lambda ph=ph, r=r, n_ph=n_ph: F.comparison_figure(
                    resolve(ph.figure if ph is not None else None),
                    resolve(r.artefacts.get("pile_png")),
                    (f"photo {n_ph}: {_fmt(ph.mean_deg, '.2f', '°')}" if ph is not None
                     else "physical pile (photo)",
                     f"replicate {r.replicate + 1}: {_fmt(r.aor_deg, '.2f', '°')}"))))
    elif photo_fig or pile:
        parts.append(b.figure("comparison", "Physical pile (photo with its fitted flanks) "
                              "next to the simulated pile (side view with fitted lines), "
                              "cf. Fig. 9.",
                              lambda: F.comparison_figure(resolve(photo_fig),
                                                          resolve(pile))))
    else:
        parts.append('<p class="note">No photo or pile image is stored, so the side-by-side '
                     "comparison is not shown.</p>")
    return parts


def _excluded(b: _Builder) -> str:
    table = T.excluded_table(b.data)
    text = ("<p>These runs gave no angle (no pile formed, or the run failed) and are left out "
            "of every fit.</p>" if len(table.frame) else "<p>No run was excluded.</p>")
    return _section("excluded", "Excluded runs", None, text + b.table(table))


def _footer(b: _Builder) -> str:
    v = b.data.versions.line() or "versions not stored"
    probs = "".join(f'<p class="warn">{escape(p)}</p>' for p in b.problems)
    return (f'<footer><h2>Provenance</h2>{probs}<p class="meta">{escape(v)}'
            ". Every number here is in <code>report.json</code> and "
            "<code>tables/*.csv</code>.</p></footer>")


# ----------------------------------------------------------------------------------------- main
def build_report(study_dir: str | Path, out_dir: str | Path | None = None) -> Path:
    """Build the calibration report of a study from its run store.

    Parameters
    ----------
    study_dir : str or Path
        Study folder holding ``demcal.sqlite``.
    out_dir : str or Path, optional
        Output folder (default ``<study_dir>/report``).

    Returns
    -------
    Path
        The written ``report.html``; next to it ``report.json`` (every table's numbers, the
        stage statuses and summaries, the model diagnostics), ``tables/*.csv``,
        ``figures/*.png`` and, once an optimum is stored, the material card
        ``material.toml`` and ``material.json`` (see :mod:`demcal.virtual.material_card`).

    Raises
    ------
    InputError
        If the folder has no run store.
    """
    data = load_report_data(study_dir)
    out = Path(out_dir) if out_dir is not None else data.study_dir / "report"
    out.mkdir(parents=True, exist_ok=True)
    b = _Builder(data, out)
    card_files: list[str] = []
    try:
        b.card = M.material_card(data)
        if b.card is not None:
            card_files = [p.name for p in b.card.write(out)]
    except Exception as exc:  # a malformed store must not stop the report
        b.card = None
        msg = f"material card not built ({type(exc).__name__}: {exc})"
        log.warning(msg)
        b.problems.append(msg)
    if b.card is None:  # no stale card from an earlier build
        for name in ("material.toml", "material.json"):
            (out / name).unlink(missing_ok=True)
    lead = data.lead  # the stage sections are written for the angle: another lead's words
    body = "".join([_overview(b), _material(b), _stages(b), _measurement(b),
                    *(relabel_html(section(b), lead) for section in (
                        _rangefind, _screening, _steepest, _rsm, _optimize, _verification)),
                    _several_responses(b), relabel_html(_excluded(b), lead)])
    body += _footer(b)
    title = f"demcal calibration report: {data.title_name}"
    html_path = out / "report.html"
    html_path.write_text(page(title, body), encoding="utf-8")
    doc = {
        "title": title,
        "study_dir": str(data.study_dir),
        "stages": {n: {"status": v.status, "error": v.error, "n_runs": len(v.runs)}
                   for n, v in data.stages.items()},
        "target": None if data.target is None else data.target.to_summary(),
        "meta": data.meta,
        "summaries": {n: v.summary for n, v in data.stages.items() if v.summary},
        "tables": b.tables,
        "figures": b.figures,
        "material": b.card.to_dict() if b.card is not None else None,
        "material_files": card_files,
        "diagnostics": b.diagnostics,
        "problems": b.problems,
    }
    (out / "report.json").write_text(json.dumps(doc, indent=1, allow_nan=False),
                                     encoding="utf-8")
    log.info("report written to %s", html_path)
    return html_path


