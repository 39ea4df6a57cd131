"""Design-Expert's diagnostic plots of a model, as matplotlib Figures (Agg, no pyplot).

- :func:`residual_figure`: normal probability plot of the externally studentized residuals,
  residuals vs predicted, residuals vs run, predicted vs actual, Cook's distance and leverage
  against the run, with their limits; flagged runs are labelled by design point;
- :func:`boxcox_figure`: ln SS_E against lambda with the minimum, the 95 % interval and the
  current lambda = 1;
- :func:`perturbation_figure`: the predicted AoR as each factor moves from -1 to +1 (coded)
  through a reference point, others held, with the target;
- :func:`pair_surface_figure`: 3-D surface and contour over one factor pair with the target
  contour drawn (in red) where the target is reached.

Angles are in degrees; factors in coded units (perturbation) or their own units (surfaces).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from demcal.report.diagnostics import Diagnostics
from demcal.report.surface import StoredSurface

__all__ = ["boxcox_figure", "pair_contours_figure", "pair_surface_figure",
           "perturbation_figure", "residual_figure", "target_reached"]

_PT, _LIM, _FLAG, _TARGET = "#1f77b4", "#c62828", "#d62728", "#d62728"


def _figure(width: float, height: float) -> Figure:
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _label_flagged(ax, x, y, labels, flags) -> None:
    for xi, yi, lab, f in zip(x, y, labels, flags, strict=True):
        if f and np.isfinite(xi) and np.isfinite(yi):
            ax.annotate(str(lab), (xi, yi), textcoords="offset points", xytext=(4, 3),
                        fontsize=7, color=_FLAG)


@dataclass(frozen=True)
class _Runs:
    """What every residual panel marks: the studentized residuals, their outlier limit, the
    runs beyond it, the runs' labels and their positions on a run axis."""

    t: np.ndarray
    lim: float
    out: np.ndarray
    labels: list
    runs: np.ndarray
    run_axis: str

    @classmethod
    def of(cls, diag: Diagnostics) -> _Runs:
        t, lim = diag.studentized, diag.outlier_limit
        out = np.abs(np.nan_to_num(t)) > lim if math.isfinite(lim) else np.zeros(diag.n, bool)
        labels = list(diag.labels)
        try:  # the design point of each run (the run order of demcal's designs)
            runs = np.array([float(v) for v in labels])
            run_axis = "design point (run order)"
        except (TypeError, ValueError):
            runs, run_axis = np.arange(1, diag.n + 1, dtype=float), "run"
        return cls(t=t, lim=lim, out=out, labels=labels, runs=runs, run_axis=run_axis)

    def limits(self, ax) -> None:
        """The zero line and the outlier limits either side."""
        ax.axhline(0, color="k", lw=0.6)
        if math.isfinite(self.lim):
            for s in (-self.lim, self.lim):
                ax.axhline(s, color=_LIM, lw=1, ls="--")


def residual_figure(diag: Diagnostics, title: str = "") -> Figure:
    """The six residual diagnostics of one model in a 2 x 3 grid (see module doc)."""
    fig = _figure(10.5, 6.4)
    axes = fig.subplots(2, 3)
    r = _Runs.of(diag)
    _normal_plot(axes[0, 0], diag, r)
    _residual_plots(axes[0, 1], axes[0, 2], diag, r)
    _predicted_vs_actual(axes[1, 0], diag)
    _influence_plots(axes[1, 1], axes[1, 2], diag, r)
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def _normal_plot(ax, diag: Diagnostics, r: _Runs) -> None:
    """The studentized residuals against their normal quantiles, the N(0, 1) line."""
    ax.plot(r.t, diag.normal_quantile, "o", color=_PT, ms=4)
    if np.isfinite(r.t).sum() >= 2:
        lo, hi = np.nanmin(r.t), np.nanmax(r.t)
        ax.plot([lo, hi], [lo, hi], "k-", lw=0.8)  # N(0, 1): quantile = residual
    ax.set_xlabel("externally studentized residual")
    ax.set_ylabel("normal quantile")
    ax.set_title("Normal plot of residuals", fontsize=9)
    _label_flagged(ax, r.t, diag.normal_quantile, r.labels, r.out)


def _residual_plots(by_predicted, by_run, diag: Diagnostics, r: _Runs) -> None:
    """The studentized residuals against the predictions and against the run order."""
    by_predicted.plot(diag.predicted, r.t, "o", color=_PT, ms=4)
    r.limits(by_predicted)
    by_predicted.set_xlabel("predicted AoR (°)")
    by_predicted.set_ylabel("studentized residual")
    by_predicted.set_title("Residuals vs predicted", fontsize=9)
    _label_flagged(by_predicted, diag.predicted, r.t, r.labels, r.out)
    by_run.plot(r.runs, r.t, "o-", color=_PT, ms=4, lw=0.6)
    r.limits(by_run)
    by_run.set_xlabel(r.run_axis)
    by_run.set_ylabel("studentized residual")
    by_run.set_title("Residuals vs run", fontsize=9)
    _label_flagged(by_run, r.runs, r.t, r.labels, r.out)


def _predicted_vs_actual(ax, diag: Diagnostics) -> None:
    """The predictions against the measured values, the line where they agree."""
    ax.plot(diag.actual, diag.predicted, "o", color=_PT, ms=4)
    both = np.concatenate([diag.actual, diag.predicted])
    if both.size:
        lo, hi = float(both.min()), float(both.max())
        pad = 0.05 * (hi - lo or 1.0)
        ax.plot([lo - pad, hi + pad], [lo - pad, hi + pad], "k--", lw=0.8)
    ax.set_xlabel("actual AoR (°)")
    ax.set_ylabel("predicted AoR (°)")
    ax.set_title("Predicted vs actual", fontsize=9)


def _influence_plots(cooks, leverage, diag: Diagnostics, r: _Runs) -> None:
    """Cook's distance and the leverage per run, each against its limit."""
    cflag = np.nan_to_num(diag.cooks) > diag.cooks_limit
    cooks.vlines(r.runs, 0, np.nan_to_num(diag.cooks), color=np.where(cflag, _FLAG, _PT))
    cooks.plot(r.runs, diag.cooks, "o", color=_PT, ms=3)
    if math.isfinite(diag.cooks_limit):
        cooks.axhline(diag.cooks_limit, color=_LIM, ls="--", lw=1)
    cooks.set_xlabel(r.run_axis)
    cooks.set_ylabel("Cook's distance")
    cooks.set_title("Cook's distance", fontsize=9)
    _label_flagged(cooks, r.runs, diag.cooks, r.labels, cflag)
    lflag = diag.leverage > diag.leverage_limit + 1e-12
    leverage.vlines(r.runs, 0, diag.leverage, color=np.where(lflag, _FLAG, _PT))
    leverage.plot(r.runs, diag.leverage, "o", color=_PT, ms=3)
    leverage.axhline(diag.leverage_limit, color=_LIM, ls="--", lw=1)
    leverage.set_ylim(0, max(1.0, float(np.nanmax(diag.leverage)) * 1.05))
    leverage.set_xlabel(r.run_axis)
    leverage.set_ylabel("leverage")
    leverage.set_title("Leverage (limit 2p/n)", fontsize=9)
    _label_flagged(leverage, r.runs, diag.leverage, r.labels, lflag)


def boxcox_figure(diag: Diagnostics) -> Figure:
    """Box-Cox plot: ln(SS_E) against lambda, best lambda, 95 % interval, current lambda."""
    fig = _figure(4.2, 3.3)
    ax = fig.add_subplot()
    if diag.boxcox_lambda.size == 0:
        ax.text(0.5, 0.5, "Box-Cox not computed\n(response not positive or no residual df)",
                ha="center", va="center", transform=ax.transAxes)
        ax.set_axis_off()
        return fig
    ax.plot(diag.boxcox_lambda, diag.boxcox_ln_ss, color=_PT)
    ax.axhline(diag.boxcox_ci_ln_ss, color=_LIM, ls="--", lw=1, label="95 % limit")
    ax.axvline(diag.boxcox_best, color="k", lw=1, label=f"best λ = {diag.boxcox_best:.2f}")
    ax.axvspan(diag.boxcox_low, diag.boxcox_high, color="#ffdd88", alpha=0.4,
               label=f"95 % interval {diag.boxcox_low:.2f} to {diag.boxcox_high:.2f}")
    ax.axvline(1.0, color="#2ca02c", lw=1.2, ls=":", label="current λ = 1")
    ax.set_xlabel("lambda")
    ax.set_ylabel("ln(residual SS)")
    ax.set_title(f"Box-Cox: recommended transform {diag.recommended}", fontsize=9)
    ax.legend(fontsize=7, loc="upper center")
    return fig


def _reference(surf: StoredSurface, hold: Mapping[str, float] | None) -> np.ndarray:
    base = (surf.low + surf.high) / 2
    for name, value in (hold or {}).items():
        if name in surf.names or name in surf.symbols:
            base[surf.index(name)] = float(value)
    return base


def perturbation_figure(surf: StoredSurface, hold: Mapping[str, float] | None = None,
                        target: float | None = None) -> Figure:
    """Perturbation plot: AoR (deg) as each factor moves over its coded range (-1 to +1)
    through the reference point (``hold``, actual units; default the centre), the others held
    there; x is the deviation from the reference in coded units (Design-Expert's plot), so
    every curve passes through the reference's prediction at 0."""
    base = surf.to_coded(_reference(surf, hold))
    dev = np.linspace(-1.0, 1.0, 41)
    fig = _figure(4.4, 3.3)
    ax = fig.add_subplot()
    for i, sym in enumerate(surf.symbols):  # factor i over its range, through the reference
        pts = np.tile(base, (dev.size, 1))
        pts[:, i] = dev
        ax.plot(dev - base[i], surf.predict_coded(pts), label=sym)
    ax.plot([0.0], surf.predict_coded(base[None, :]), "k.", ms=8)
    if target is not None:
        ax.axhline(target, color=_TARGET, ls="--", lw=1, label="target")
    ax.axvline(0, color="0.6", lw=0.6)
    ax.set_xlabel("deviation from the reference point (coded units)")
    ax.set_ylabel("predicted AoR (°)")
    ax.set_title("Perturbation", fontsize=9)
    ax.legend(fontsize=7)
    return fig


def target_reached(surf: StoredSurface, pair: tuple[str, str],
                   hold: Mapping[str, float] | None, target: float | None,
                   n_grid: int = 40) -> bool:
    """True when the model's AoR crosses the target over the pair's region (others held)."""
    if target is None:
        return False
    try:
        _, _, zz, _, _ = _grid(surf, pair, hold, n_grid)
    except Exception:
        return False
    return bool(np.nanmin(zz) <= target <= np.nanmax(zz))


def _grid(surf: StoredSurface, pair, hold, n_grid):
    i, j = surf.index(pair[0]), surf.index(pair[1])
    base = _reference(surf, hold)
    gi = np.linspace(surf.low[i], surf.high[i], n_grid)
    gj = np.linspace(surf.low[j], surf.high[j], n_grid)
    xx, yy = np.meshgrid(gi, gj)
    pts = np.tile(base, (xx.size, 1))
    pts[:, i], pts[:, j] = xx.ravel(), yy.ravel()
    zz = surf.predict_coded(surf.to_coded(pts)).reshape(xx.shape)
    return xx, yy, zz, (i, j), base


def pair_surface_figure(surf: StoredSurface, pair: tuple[str, str],
                        hold: Mapping[str, float] | None = None,
                        target: float | None = None, n_grid: int = 40) -> Figure:
    """3-D surface and contour of AoR (deg) over one factor pair with the target contour.

    Parameters
    ----------
    surf : StoredSurface
        The response surface (:meth:`StoredSurface.from_surface`: with its design points,
        drawn as dots).
    pair : (str, str)
        Factor names or symbols (x and y axes, actual units).
    hold : dict, optional
        Actual values of the other factors (default their centres).
    target : float, optional
        Target AoR, deg: drawn as a red contour where the surface reaches it.
    n_grid : int
        Grid points per axis.
    """
    xx, yy, zz, (i, j), base = _grid(surf, pair, hold, n_grid)
    reached = target is not None and np.nanmin(zz) <= target <= np.nanmax(zz)
    fig = _figure(9.5, 3.9)
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    ax3.plot_surface(xx, yy, zz, cmap="viridis", edgecolor="none", alpha=0.85)
    if reached:
        ax3.contour(xx, yy, zz, levels=[target], colors=_TARGET, linewidths=2)
    ax3.set_xlabel(surf.symbols[i])
    ax3.set_ylabel(surf.symbols[j])
    ax3.set_zlabel("AoR (°)")
    ax3.view_init(elev=25, azim=-130)
    ax3.set_box_aspect(None, zoom=0.82)
    ax = fig.add_subplot(1, 2, 2)
    cs = ax.contourf(xx, yy, zz, levels=12, cmap="viridis")
    lines = ax.contour(xx, yy, zz, levels=cs.levels[::2], colors="k", linewidths=0.5)
    ax.clabel(lines, fontsize=7, fmt="%.1f")
    fig.colorbar(cs, ax=ax, label="AoR (°)")
    if reached:
        tl = ax.contour(xx, yy, zz, levels=[target], colors=_TARGET, linewidths=2)
        ax.clabel(tl, fontsize=7, fmt=f"target {target:.2f}°")
    points = np.empty((0, len(surf.names))) if surf.points is None else surf.points
    ax.plot(points[:, i], points[:, j], "o", mfc="white", mec="k", ms=5)
    ax.plot([base[i]], [base[j]], "*", color=_TARGET, ms=10)
    ax.set_xlabel(f"{surf.symbols[i]} ({surf.names[i]})")
    ax.set_ylabel(f"{surf.symbols[j]} ({surf.names[j]})")
    others = [f"{surf.symbols[k]} = {base[k]:.4g}" for k in range(len(base)) if k not in (i, j)]
    state = ("" if target is None else
             "; target reached (red)" if reached else "; target not reached here")
    fig.suptitle(f"AoR over {surf.symbols[i]} and {surf.symbols[j]}"
                 + (f" ({', '.join(others)})" if others else "") + state, fontsize=10)
    return fig


def pair_contours_figure(surf: StoredSurface, pairs: list[tuple[str, str]],
                         hold: Mapping[str, float] | None = None,
                         target: float | None = None, n_grid: int = 30) -> Figure:
    """Contour plots of AoR (deg) over several factor pairs in one figure (small multiples),
    each with the target contour in red where it is reached; for the screening model.

    Parameters
    ----------
    surf : StoredSurface
        The model (the screening's main effects, refitted).
    pairs : list of (str, str)
        Factor pairs (names or symbols), at most 6 are drawn.
    hold : dict, optional
        Actual values of the other factors (default their centres).
    target : float, optional
        Target AoR, deg.
    n_grid : int
        Grid points per axis.
    """
    pairs = list(pairs)[:6]
    cols = min(3, max(1, len(pairs)))
    rows = math.ceil(len(pairs) / cols) or 1
    fig = _figure(3.4 * cols, 2.9 * rows)
    for k, pair in enumerate(pairs):
        ax = fig.add_subplot(rows, cols, k + 1)
        xx, yy, zz, (i, j), _ = _grid(surf, pair, hold, n_grid)
        cs = ax.contourf(xx, yy, zz, levels=10, cmap="viridis")
        fig.colorbar(cs, ax=ax, label="AoR (°)")
        if target is not None and np.nanmin(zz) <= target <= np.nanmax(zz):
            ax.contour(xx, yy, zz, levels=[target], colors=_TARGET, linewidths=2)
        ax.set_xlabel(surf.symbols[i])
        ax.set_ylabel(surf.symbols[j])
    if not pairs:
        fig.add_subplot().set_axis_off()
    return fig
