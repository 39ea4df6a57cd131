"""The report's "Bayesian calibration" section (``[strategy] kind = "bayes"``).

Reads the stored summary of the stage ``"bayes"`` (a
:class:`~demcal.summaries.bayes.BayesSummary`, written by
:mod:`demcal.calibrate.bayes_strategy`) once into the view it draws (:class:`BayesView`), so a
renamed field breaks :func:`bayes_view` and its test, not the page. Shows the posterior per
parameter (95 % credible intervals in the factors' units), the identifiability verdict and
its ridges, the expected shrinkage per response the runs report, the rounds of the loop, the
runs in order, a corner plot of the stored posterior samples with the best point marked, and
each surrogate along each factor through the best point against the lab's band.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from html import escape
from typing import Any, Protocol

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from demcal.report.html import badge
from demcal.report.tables import Table
from demcal.store import RunRecord
from demcal.summaries.bayes import (
    BayesSummary,
    MarkedPoint,
    ShrinkageRow,
    SurrogateCheckRow,
    SurrogateSlice,
)

#: marker and colour of the marked points on the corner plot, in order
MARK_STYLES = (("o", "tab:green"), ("s", "tab:orange"), ("D", "tab:purple"),
               ("^", "tab:brown"), ("v", "tab:pink"), ("P", "tab:olive"), ("*", "tab:cyan"),
               ("h", "tab:gray"))

__all__ = ["MARK_STYLES", "BayesView", "ParameterRow", "bayes_section",
           "bayes_tables", "bayes_view", "corner_figure", "slices_figure"]

#: The stage whose summary this section shows.
STAGE = "bayes"


@dataclass(frozen=True)
class ParameterRow:
    """One factor's posterior, in its own unit."""

    name: str
    unit: str
    mean: float
    median: float
    ci95_low: float
    ci95_high: float
    optimum: float


@dataclass(frozen=True)
class BayesView:
    """The stored Bayesian summary (:class:`~demcal.summaries.bayes.BayesSummary`) as the
    report draws it.

    ``correlation``: rows in the order of ``parameters``; ``history``: per round (runs, the
    coded 95 % half-widths by factor, acceptance fraction); ``shrinkage``: (response, ridge,
    expected shrinkage 0..1, what it is estimated from); ``labs``: (mean, standard error);
    ``samples``: thinned posterior samples by factor (actual units); ``slices``:
    ``{response: {factor: slice}}``.
    """

    parameters: tuple[ParameterRow, ...]
    correlation: tuple[tuple[float, ...], ...]
    identifiable: bool
    reason: str
    ridges: tuple[str, ...]
    shrinkage: tuple[tuple[str, str, float, str], ...]
    history: tuple[tuple[int, dict[str, float], float], ...]
    stopped: str
    n_runs: int
    labs: dict[str, tuple[float, float]]
    predicted: dict[str, float]
    notes: tuple[str, ...]
    warnings: tuple[str, ...]
    samples: dict[str, tuple[float, ...]]
    slices: dict[str, dict[str, SurrogateSlice]]
    marks: tuple[MarkedPoint, ...] = ()
    advice: tuple[str, ...] = ()
    combinations: tuple[tuple[tuple[str, ...], tuple[str, ...]], ...] = ()
    checks: tuple[SurrogateCheckRow, ...] = ()
    verification_runs: int = 0

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.parameters]


def bayes_view(summary: Mapping[str, Any]) -> BayesView | None:
    """The view of the stage's stored summary; None when the study has none.

    Raises
    ------
    KeyError
        A summary without the best point's value or a correlation of every factor (a
        damaged store: the section says so instead).
    """
    s = BayesSummary.from_summary(summary)
    if s is None:
        return None
    names = s.names
    return BayesView(
        parameters=tuple(ParameterRow(n, s.units.get(n) or "", p.mean, p.median, p.ci95_low,
                                      p.ci95_high, s.optimum[n])
                         for n, p in s.posterior.items()),
        correlation=tuple(tuple(float(s.correlation[a][b]) for b in names) for a in names),
        identifiable=s.identifiable, reason=s.reason, ridges=tuple(s.ridge),
        shrinkage=tuple((r.response, r.ridge, float(r.shrinkage), _basis(r))
                        for r in s.shrinkage),
        history=tuple((h.n_runs, dict(h.half_widths_coded), float(h.acceptance_fraction))
                      for h in s.history),
        stopped=s.stopped, n_runs=s.n_runs,
        labs={n: (float(v.mean), float(v.standard_error)) for n, v in s.labs.items()},
        predicted={n: float(v.mean) for n, v in s.predicted.items()},
        notes=tuple(s.notes), warnings=tuple(s.warnings),
        samples={n: tuple(map(float, v)) for n, v in s.samples.items()},
        slices=s.slices, marks=tuple(s.marks), advice=tuple(s.advice),
        combinations=tuple((tuple(c.responses), tuple(c.ridges)) for c in s.combinations),
        checks=tuple(s.surrogate_checks), verification_runs=s.verification_runs)


def _basis(row: ShrinkageRow) -> str:
    """What a shrinkage is estimated from, for people."""
    if row.basis != "stated":
        return "the runs' surrogate"
    return "stated slopes" + (f" ({row.source})" if row.source else "")


def _posterior_table(view: BayesView) -> Table:
    frame = pd.DataFrame([{
        "parameter": p.name, "unit": p.unit, "mean": p.mean, "median": p.median,
        "95 % low": p.ci95_low, "95 % high": p.ci95_high, "best point": p.optimum}
        for p in view.parameters])
    return Table("bayes_posterior", "Posterior per parameter (95 % credible intervals)", frame)


def _correlation_table(view: BayesView) -> Table:
    frame = pd.DataFrame([{"parameter": n, **dict(zip(view.names, row, strict=True))}
                          for n, row in zip(view.names, view.correlation, strict=True)])
    return Table("bayes_correlation", "Posterior correlation", frame)


def _history_table(view: BayesView) -> Table:
    frame = pd.DataFrame([{"round": i + 1, "runs": n,
                           **{f"half-width {k} (coded)": v for k, v in hw.items()},
                           "acceptance": acc} for i, (n, hw, acc) in enumerate(view.history)])
    note = f"stopped by {view.stopped} after {view.n_runs - view.verification_runs} runs"
    if view.verification_runs:
        note += (f"; the rows after it are the posterior conditioned on the verification "
                 f"rounds' piles as well ({view.verification_runs} runs in all)")
    return Table("bayes_history", "Rounds of the loop", frame, note=note)


def _responses_table(view: BayesView) -> Table:
    frame = pd.DataFrame([{"response": n, "lab": lab, "lab standard error": se,
                           "surrogate at best point": view.predicted.get(n)}
                          for n, (lab, se) in view.labs.items()])
    return Table("bayes_responses", "Lab values and the surrogates at the best point", frame)


def _shrinkage_table(view: BayesView) -> Table:
    frame = pd.DataFrame([{"response": r, "ridge or widest axis": ridge,
                           "expected shrinkage": s, "estimated from": basis}
                          for r, ridge, s, basis in view.shrinkage])
    return Table("bayes_shrinkage", "Which response would shrink the region", frame,
                 note="responses the runs report beside the study's, and the tests the study "
                      "states the slopes of ([[strategy.candidates]]); 0: no help, 1: gone")


def _combinations_table(view: BayesView) -> Table:
    frame = pd.DataFrame([{"responses added": " + ".join(added),
                           "ridges left": "; ".join(ridges) or "none: every parameter pinned"}
                          for added, ridges in view.combinations])
    return Table("bayes_combinations", "What one or two more responses would leave", frame,
                 note="a linear-Gaussian update of the posterior by each response's slopes "
                      "and lab standard error (expected, not measured)")


def _marks_table(view: BayesView) -> Table:
    frame = pd.DataFrame([{"point": m.label, **m.values,
                           "inside the 95 % region": "yes" if m.inside95 else "no",
                           "smallest region holding it": m.credibility}
                          for m in view.marks])
    return Table("bayes_marks", "Marked points against the posterior", frame,
                 note="the smallest highest-density region holding a point, as its posterior "
                      "mass (0: the best point; above 0.95: outside the 95 % region; 1: "
                      "outside the factor box)")


def _checks_table(view: BayesView) -> Table:
    frame = pd.DataFrame([{
        "response": c.response, "runs": c.n, "rms error (one run)": c.rms_error,
        "rms z": c.rms_z, "largest z": c.max_abs_z, "limit": c.limit,
        "that run": c.value, "the others predict": c.predicted,
        "verdict": ("misses that run" if c.misses_a_run else "follows its runs") if c.judged
        else "too few runs to judge"}
        for c in view.checks])
    return Table("bayes_surrogate_checks", "The surrogates against their own runs "
                 "(each run predicted from the others)", frame,
                 note="z: a run's error over the spread the surrogate predicts for one run "
                      "(rms about 1 when right); limit: the Bonferroni limit for that many "
                      "runs at 5 %, as Design-Expert's outlier plot; a run beyond it is one "
                      "the surrogate does not follow (a local feature or an outlier)")


def bayes_tables(view: BayesView) -> list[Table]:
    """The section's tables: posterior, correlation, responses, marked points, shrinkage,
    what one or two more responses would leave and the surrogates' checks (if any),
    rounds."""
    out = [_posterior_table(view), _correlation_table(view), _responses_table(view)]
    if view.marks:
        out.append(_marks_table(view))
    if view.shrinkage:
        out.append(_shrinkage_table(view))
    if view.combinations:
        out.append(_combinations_table(view))
    if view.checks:
        out.append(_checks_table(view))
    return [*out, _history_table(view)]


def runs_table(view: BayesView, runs: Sequence[RunRecord]) -> Table:
    """The loop's runs in order: settings, the lab responses' values and the outcome."""
    frame = pd.DataFrame([{"run": r.point + 1, **{n: r.params.get(n) for n in view.names},
                           **{n: r.response(n) for n in view.labs}, "outcome": r.outcome}
                          for r in sorted(runs, key=lambda r: r.point)])
    return Table("bayes_runs", "The runs, in the order the loop asked for them", frame)


def _label(p: ParameterRow) -> str:
    return f"{p.name} ({p.unit})" if p.unit.strip("-") else p.name


def _style(n: int) -> tuple[str, str]:
    return MARK_STYLES[n % len(MARK_STYLES)]


def corner_figure(view: BayesView) -> Figure:
    """Pairwise scatter and per-parameter histograms of the posterior samples (factors'
    units), the 95 % interval dashed and the best point marked."""
    names, k = view.names, len(view.names)
    fig = Figure(figsize=(2.4 * k + 0.6, 2.4 * k + 0.4), layout="constrained")
    FigureCanvasAgg(fig)
    axes = np.atleast_2d(fig.subplots(k, k, squeeze=False))
    for i, a in enumerate(view.parameters):
        for j, b in enumerate(view.parameters):
            ax = axes[i, j]
            if j > i:
                ax.set_axis_off()
                continue
            if i == j:
                ax.hist(view.samples[a.name], bins=30, color="tab:blue", alpha=0.7)
                for v in (a.ci95_low, a.ci95_high):
                    ax.axvline(v, color="k", ls="--", lw=0.8)
                ax.axvline(a.optimum, color="tab:red", lw=1.2)
                for n, m in enumerate(view.marks):
                    ax.axvline(m.values[a.name], color=_style(n)[1], lw=1.0, ls=":")
            else:
                ax.scatter(view.samples[b.name], view.samples[a.name], s=2, alpha=0.3)
                ax.plot(b.optimum, a.optimum, "x", color="tab:red", ms=8, mew=2)
                for n, m in enumerate(view.marks):
                    marker, color = _style(n)
                    ax.plot(m.values[b.name], m.values[a.name], marker, color=color, ms=7,
                            mfc="none", mew=1.5, label=m.label)
                ax.set_ylabel(_label(a) if j == 0 else "", fontsize=7)
            ax.set_xlabel(_label(b) if i == k - 1 else "", fontsize=7)
            ax.tick_params(labelsize=6)
    fig.suptitle(f"Posterior ({len(view.samples[names[0]])} samples); x: best point",
                 fontsize=9)
    if view.marks and k > 1:
        handles, labels = axes[1, 0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="upper right", fontsize=7, title="marked points",
                   title_fontsize=7)
    return fig


def slices_figure(view: BayesView) -> Figure:
    """Each response's surrogate along each factor through the best point: the mean with
    its 95 % band, the lab's mean with its 95 % band (grey), the best point (red) and the
    factor's 95 % credible interval (dashed)."""
    rows = [r for r in view.slices if r in view.labs]
    k = len(view.parameters)
    fig = Figure(figsize=(2.6 * k + 0.6, 2.2 * len(rows) + 0.5), layout="constrained")
    FigureCanvasAgg(fig)
    axes = np.atleast_2d(fig.subplots(len(rows), k, squeeze=False))
    for i, name in enumerate(rows):
        lab, se = view.labs[name]
        for j, p in enumerate(view.parameters):
            ax, sl = axes[i, j], view.slices[name][p.name]
            m, sd = np.asarray(sl.mean), np.asarray(sl.std)
            ax.axhspan(lab - 1.96 * se, lab + 1.96 * se, color="0.8")
            ax.fill_between(sl.x, m - 1.96 * sd, m + 1.96 * sd, color="tab:blue", alpha=0.25)
            ax.plot(sl.x, m, color="tab:blue", lw=1.2)
            ax.axvline(p.optimum, color="tab:red", lw=1)
            for v in (p.ci95_low, p.ci95_high):
                ax.axvline(v, color="k", ls="--", lw=0.7)
            ax.set_xlabel(_label(p) if i == len(rows) - 1 else "", fontsize=7)
            ax.set_ylabel(name if j == 0 else "", fontsize=7)
            ax.tick_params(labelsize=6)
    fig.suptitle("Surrogates through the best point; grey: the lab's 95 % band", fontsize=9)
    return fig


class _Builder(Protocol):
    """What the section needs of the report builder (demcal.report.build)."""

    data: Any
    problems: list[str]
    tables: dict[str, Any]

    def table(self, table: Table) -> str: ...

    def figure(self, key: str, caption: str, make: Callable[[], Figure]) -> str: ...


def _verdict(view: BayesView) -> str:
    ridges = "".join(f"<li>ridge: {escape(r)}</li>" for r in view.ridges)
    ridges += "".join(f"<li>next test: {escape(a)}</li>" for a in view.advice)
    notes = "".join(f'<p class="warn">{escape(n)}</p>' for n in (*view.warnings, *view.notes))
    return (f"<p><b>Verdict:</b> {escape(view.reason)} ({view.n_runs} runs, stopped by "
            f"{escape(view.stopped)}).</p>"
            + (f"<ul>{ridges}</ul>" if ridges else "") + notes)


def _body(b: _Builder, view: BayesView, runs: Sequence[RunRecord]) -> str:
    body = _verdict(view) + "".join(b.table(t) for t in bayes_tables(view))
    if view.samples:
        body += b.figure("bayes_corner", "Posterior corner plot", lambda: corner_figure(view))
    if any(r in view.labs for r in view.slices):
        body += b.figure("bayes_slices", "Surrogate slices with the lab band",
                         lambda: slices_figure(view))
    if runs:
        body += b.table(runs_table(view, runs))
    return body


def bayes_section(b: _Builder) -> str:
    """The section's HTML ("" for a study that never ran the Bayesian strategy).

    A stage still running (an interrupted study) shows its runs so far; a summary that
    cannot be read becomes a note (and one of the report's problems), not a failed report.
    """
    stage = b.data.stage(STAGE)
    if stage.status == "missing":
        return ""
    head = f"<h2>Bayesian calibration{badge(stage.status)}</h2>"
    before = set(b.tables)
    try:
        view = bayes_view(stage.summary)
        body = _body(b, view, stage.runs) if view is not None else (
            f"<p>{len(stage.runs)} runs of the loop stored; no posterior yet.</p>")
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        msg = (f"bayes: the stored summary could not be shown "
               f"({type(exc).__name__}: {exc})")
        b.problems.append(msg)
        for key in set(b.tables) - before:  # report.json keeps to the tables shown
            del b.tables[key]
        body = f'<p class="warn">{escape(msg)}</p>'
    return f'<section id="bayes">{head}{body}</section>'
