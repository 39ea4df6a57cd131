"""The report's figures, each a function of the stored data returning a matplotlib Figure.

The figures are built on :class:`matplotlib.figure.Figure` directly (no pyplot state, Agg
canvas), so they can be called from a notebook and displayed, or saved by the report. Angles
are in degrees; factor values in their own units.

>>> from demcal.summaries import PathStep, Steepest
>>> fig = steepest_figure(Steepest(factors=["a"], steps=[
...     PathStep(step=1, actual={"a": 0.1}, value=30.0, relative_error_percent=10.0),
...     PathStep(step=2, actual={"a": 0.2}, value=33.0, relative_error_percent=1.0)],
...     best_step=2), target=33.3)
>>> len(fig.axes)
2
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.image import imread

from demcal.report.surface import StoredSurface
from demcal.report.tables import term_label
from demcal.summaries import Anchor, Effect, RangeFind, Steepest, Surface, Target, Verification

__all__ = [
    "comparison_figure",
    "measurement_figure",
    "pareto_figure",
    "predicted_actual_figure",
    "rangefind_figure",
    "steepest_figure",
    "surface_figure",
    "verification_figure",
]

_PILE, _NOPILE, _TARGET, _SHADE = "#1f77b4", "#d62728", "#2ca02c", "#ffdd88"


def _figure(width: float, height: float) -> Figure:
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _num(v: Any) -> float:
    try:
        f = float(v)
    except (TypeError, ValueError):
        return math.nan
    return f


def _sym(name: str, symbols: Mapping[str, str] | None) -> str:
    return (symbols or {}).get(name, name)


# ---------------------------------------------------------------------------------- measurement
def measurement_figure(target: Target) -> Figure:
    """Each photo's angle (left, right and mean flank, deg) with the target mean ± std."""
    photos = target.photos
    fig = _figure(6.5, 3.0)
    ax = fig.add_subplot()
    x = np.arange(1, len(photos) + 1)
    for key, marker, label in (("left_deg", "<", "left flank"), ("right_deg", ">", "right flank"),
                               ("mean_deg", "o", "mean")):
        y = np.array([_num(getattr(p, key)) for p in photos])
        if np.isfinite(y).any():
            ax.plot(x, y, marker, ls="none", label=label, ms=7 if key == "mean_deg" else 5)
    aor, std = _num(target.aor_deg), _num(target.std_deg)
    if math.isfinite(aor):
        ax.axhline(aor, color=_TARGET, label=f"target {aor:.2f}°")
        if math.isfinite(std):
            ax.axhspan(aor - std, aor + std, color=_TARGET, alpha=0.15, label="± 1 std")
    ax.set_xlabel("photo")
    ax.set_ylabel("angle of repose (°)")
    ax.set_xticks(x if len(x) else [1])
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_title("Measured angle of repose")
    return fig


# -------------------------------------------------------------------------------- range finding
def rangefind_figure(found: RangeFind, target: float | None = None,
                     symbols: Mapping[str, str] | None = None) -> Figure:
    """One small plot per factor: AoR vs value, no-pile points marked, kept range shaded."""
    factors = found.factors
    n = max(len(factors), 1)
    cols = min(n, 4)
    rows = math.ceil(n / cols)
    fig = _figure(2.6 * cols + 0.4, 2.3 * rows + 0.3)
    axes = fig.subplots(rows, cols, squeeze=False)
    for ax in axes.flat[len(factors):]:
        ax.set_axis_off()
    for ax, f in zip(axes.flat, factors, strict=False):
        v = np.array([_num(p.value) for p in f.points])
        a = np.array([_num(p.response) for p in f.points])
        pile = np.array([p.outcome == "pile" and math.isfinite(_num(p.response))
                         for p in f.points], dtype=bool)
        if math.isfinite(_num(f.new_low)) and math.isfinite(_num(f.new_high)):
            ax.axvspan(_num(f.new_low), _num(f.new_high), color=_SHADE, alpha=0.6,
                       label="kept range")
        if pile.any():
            order = np.argsort(v[pile])
            ax.plot(v[pile][order], a[pile][order], "o-", color=_PILE, ms=4, label="pile")
        if (~pile).any():
            finite = a[np.isfinite(a)]
            y0 = finite.min() if finite.size else 0.0
            ax.plot(v[~pile], np.full((~pile).sum(), y0), "x", color=_NOPILE, ms=8, mew=2,
                    label="no pile")
        if target is not None:
            ax.axhline(target, color=_TARGET, lw=1, ls="--", label="target")
        sym = f.symbol or _sym(f.name, symbols)
        ax.set_title(f"{sym}: {f.name}", fontsize=8)
        ax.set_xlabel("value", fontsize=8)
        ax.set_ylabel("AoR (°)", fontsize=8)
        ax.tick_params(labelsize=7)
    if factors:
        axes.flat[0].legend(fontsize=6, loc="best")
    fig.suptitle("Range-finding scan", fontsize=10)
    return fig


# ------------------------------------------------------------------------------------ screening
def pareto_figure(effects: Sequence[Effect],
                  symbols: Mapping[str, str] | None = None) -> Figure:
    """Pareto chart of the screening effects: |effect| (deg), largest first, sign coloured,
    with each term's % contribution and significance marker."""
    rows = sorted(effects, key=lambda e: -abs(_num(e.effect)))
    fig = _figure(6.0, 0.35 * len(rows) + 1.2)
    ax = fig.add_subplot()
    labels = [term_label(e.term, symbols or {}) for e in rows]
    vals = np.array([abs(_num(e.effect)) for e in rows])
    colors = ["#ff7f0e" if _num(e.effect) >= 0 else "#1f77b4" for e in rows]
    y = np.arange(len(rows))[::-1]
    ax.barh(y, vals, color=colors)
    ax.set_yticks(y, labels)
    for yi, val, e in zip(y, vals, rows, strict=True):
        p = _num(e.p)
        mark = "**" if p < 0.01 else "*" if p < 0.05 else ""
        c = _num(e.contribution_percent)
        ax.text(val, yi, f" {c:.1f} % {mark}" if math.isfinite(c) else f" {mark}",
                va="center", fontsize=8)
    ax.set_xlim(0, (vals[np.isfinite(vals)].max() if np.isfinite(vals).any() else 1) * 1.3)
    ax.set_xlabel("|effect| on AoR (°)   (orange: raises AoR, blue: lowers)")
    ax.set_title("Pareto chart of screening effects (% contribution)")
    return fig


# ------------------------------------------------------------------------------------- steepest
def steepest_figure(path: Steepest, target: float | None = None,
                    symbols: Mapping[str, str] | None = None) -> Figure:
    """AoR (deg, left axis) and relative error (%, right axis) per step of the path."""
    steps = path.steps or []
    s = np.array([_num(x.step) for x in steps])
    a = np.array([_num(x.value) for x in steps])
    e = np.array([_num(x.relative_error_percent) for x in steps])
    fig = _figure(6.0, 3.6)
    ax = fig.add_subplot()
    ax2 = ax.twinx()
    ax2.bar(s, np.nan_to_num(e), width=0.5, color="#cccccc", label="relative error")
    ax2.set_ylabel("relative error (%)")
    ax.set_zorder(ax2.get_zorder() + 1)
    ax.patch.set_visible(False)
    ax.plot(s, a, "o-", color=_PILE, label="simulated AoR")
    bad = ~np.isfinite(a)
    if bad.any():
        ax.plot(s[bad], np.full(bad.sum(), np.nanmin(a) if np.isfinite(a).any() else 0), "x",
                color=_NOPILE, ms=8, mew=2, label="no pile")
    if target is not None:
        ax.axhline(target, color=_TARGET, ls="--", label=f"target {target:.2f}°")
    best = path.best_step
    if best is not None and best in list(s):
        i = list(s).index(best)
        ax.plot([s[i]], [a[i]], "o", ms=14, mfc="none", mec="k", label="best step")
    _anchor_marks(ax, path.anchor)
    ax.set_xlabel("step")
    ax.set_xticks(s if len(s) else [1])
    ax.set_ylabel("AoR (°)")
    names = ", ".join(_sym(n, symbols) for n in path.factors or [])
    ax.set_title(f"Path of steepest ascent ({names})")
    handles, labels = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(handles + h2, labels + l2, fontsize=8, loc="upper center",
              bbox_to_anchor=(0.5, -0.2), ncol=3)
    return fig


def _anchor_marks(ax: Any, anchor: Anchor | None) -> None:
    """The anchor's runs (the study's own test at path points) and the surface's centre."""
    if anchor is None:
        return
    runs = [r for r in anchor.runs if r.value is not None]
    if runs:
        ax.plot([r.step for r in runs], [r.value for r in runs], "s", color="#9467bd",
                mfc="none", ms=8, label=f"AoR, {anchor.fidelity or 'study'} test")
    centre = anchor.centre_step
    if centre is not None:
        ax.axvline(centre, color="k", ls=":", lw=1, label="surface centre")


# ------------------------------------------------------------------------------------------ rsm
def surface_figure(surface: Surface, pair: tuple[str, str],
                   hold: Mapping[str, float] | None = None, n_grid: int = 40) -> Figure:
    """3-D response surface and contour plot of AoR (deg) over one factor pair (cf. Fig. 8).

    Parameters
    ----------
    surface : Surface
        The response-surface stage (factors, coefficients_coded, runs).
    pair : (str, str)
        The two factors (names or symbols), on the x and y axes, in actual units.
    hold : dict, optional
        Actual values of the other factors (default: their centres).
    n_grid : int
        Grid points per axis.
    """
    from demcal.report.model_figures import pair_surface_figure

    return pair_surface_figure(StoredSurface.from_surface(surface), pair, hold, None, n_grid)


def predicted_actual_figure(surface: Surface) -> Figure:
    """Predicted (stored model) vs actual AoR (deg) of the design runs, with the 1:1 line."""
    surf = StoredSurface.from_surface(surface)
    actual, pred = [], []
    for r in surface.runs:
        y = _num(r.value)
        x = np.array([_num(r.coded.get(n)) for n in surf.names])
        if math.isfinite(y) and np.isfinite(x).all():
            actual.append(y)
            pred.append(float(surf.predict_coded(x[None, :])[0]))
    fig = _figure(3.8, 3.6)
    ax = fig.add_subplot()
    ax.plot(actual, pred, "o", color=_PILE)
    if actual:
        lo, hi = min(actual + pred), max(actual + pred)
        pad = 0.05 * (hi - lo or 1)
        ax.plot([lo - pad, hi + pad], [lo - pad, hi + pad], "k--", lw=1)
        ax.set_xlim(lo - pad, hi + pad)
        ax.set_ylim(lo - pad, hi + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("actual AoR (°)")
    ax.set_ylabel("predicted AoR (°)")
    ax.set_title("Predicted vs actual")
    return fig


# -------------------------------------------------------------------------------- verification
def verification_figure(ver: Verification, target: float | None = None,
                        target_std: float | None = None) -> Figure:
    """Verification replicates (deg) with their mean ± std and the measured target."""
    aors = np.array([_num(a) for a in ver.values])
    fig = _figure(6.5, 3.0)
    ax = fig.add_subplot()
    x = np.arange(1, len(aors) + 1)
    ok = np.isfinite(aors)
    ax.plot(x[ok], aors[ok], "o", color=_PILE, label="simulated replicate")
    if (~ok).any():
        ax.plot(x[~ok], np.full((~ok).sum(), np.nanmin(aors) if ok.any() else 0.0), "x",
                color=_NOPILE, ms=8, mew=2, label="no pile")
    mean, std = _num(ver.mean), _num(ver.std)
    if math.isfinite(mean):
        ax.axhline(mean, color=_PILE, lw=1, label=f"simulated mean {mean:.2f}°")
        if math.isfinite(std):
            ax.axhspan(mean - std, mean + std, color=_PILE, alpha=0.12)
    if target is not None:
        ax.axhline(target, color=_TARGET, ls="--", label=f"measured {target:.2f}°")
        if target_std is not None and math.isfinite(target_std):
            ax.axhspan(target - target_std, target + target_std,
                       color=_TARGET, alpha=0.10)
    ax.set_xticks(x if len(x) else [1])
    ax.set_xlabel("replicate")
    ax.set_ylabel("AoR (°)")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_title("Verification at the optimum")
    return fig


def comparison_figure(photo_png: str | Path | None, pile_png: str | Path | None,
                      labels: tuple[str, str] = ("physical pile (photo)",
                                                 "simulated pile (side view)")) -> Figure:
    """The photo's pile next to the simulated pile (cf. Fig. 9); a missing image is named."""
    fig = _figure(9.0, 3.8)
    for k, (path, label) in enumerate(zip((photo_png, pile_png), labels, strict=True)):
        ax = fig.add_subplot(1, 2, k + 1)
        ax.set_axis_off()
        ax.set_title(label, fontsize=10)
        if path is not None and Path(path).is_file():
            ax.imshow(imread(str(path)))
        else:
            ax.text(0.5, 0.5, "image not stored" if path is None else f"missing: {path}",
                    ha="center", va="center", fontsize=9, wrap=True)
    return fig
