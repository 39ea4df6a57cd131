"""Range finding: each factor scanned at the others' centre, the part of its range kept
where the test measures, ranges moved within hard limits toward the target, and a target out
of every reach said after the scan (its runs kept). With several responses, each other
response's span over the scans is said beside the lead's."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from demcal.calibrate.context import Context, point_means
from demcal.calibrate.runner import Point
from demcal.errors import StudyError
from demcal.store import RunRecord
from demcal.summaries import RangeFind, ScanFactor, ScanPoint, ScanReach

__all__ = ["rangefind"]


def _feasible(values: np.ndarray, piles: np.ndarray) -> tuple[float, float] | None:
    """Largest contiguous run of pile points (a single point: +/- half a grid step)."""
    best: tuple[int, int] | None = None
    i = 0
    while i < len(values):
        if piles[i]:
            j = i
            while j + 1 < len(values) and piles[j + 1]:
                j += 1
            if best is None or j - i > best[1] - best[0]:
                best = (i, j)
            i = j + 1
        else:
            i += 1
    if best is None:
        return None
    a, b = best
    if a == b:
        half = 0.5 * (values[1] - values[0])
        return float(max(values[0], values[a] - half)), float(min(values[-1], values[a] + half))
    return float(values[a]), float(values[b])


def rangefind(ctx: Context) -> RangeFind:
    """Scan each listed factor at the others' centre; keep the part of its range with piles.

    Where the target lies outside every response the scans saw and the factors may move
    (``move_ranges``, by default where ``hard_limits`` are set), each factor with a measured
    slope moves half its width the way that reaches the target, within its hard limits, and
    is scanned again (at most ``max_moves`` times).
    """
    opts = ctx.study.stages.rangefind
    names = [ctx.study.factor(r).name for r in (opts.factors or [f.name for f in ctx.factors])]
    ctx.begin("rangefind", {"factors": ctx.factor_rows(), "opts": opts.model_dump(mode="json"),
                            "fixed": ctx.fixed})
    hard = {ctx.study.factor(k).name: v for k, v in opts.hard_limits.items()}
    may_move = bool(hard) if opts.move_ranges is None else opts.move_ranges
    moves: list[str] = []
    for attempt in range(opts.max_moves + 1):
        scans, lines, others = _scan(ctx, names)
        seen = [p.response for f in scans for p in f.points if p.response is not None]
        if not seen:
            _no_pile_anywhere(ctx, scans)
        lo, hi = min(seen), max(seen)
        inside = lo <= ctx.target <= hi
        slopes = {name: line[0] for name, line in lines.items()}
        if inside or not may_move or attempt == opts.max_moves \
                or not _move_ranges(ctx, slopes, hard, ctx.target > hi, moves):
            break
    for scan in scans:
        ctx.set_range(scan.name, scan.new_low, scan.new_high)
    msg = _scan_message(ctx, (lo, hi), slopes)
    if moves:
        msg += "; ranges moved within hard limits: " + "; ".join(moves)
    if others is not None:
        msg += "; " + _others_message(others)
    found = RangeFind(fidelity=ctx.own_fidelity("rangefind").get("fidelity"), factors=scans,
                      response_min=lo, response_max=hi, target_in_range=inside, message=msg,
                      responses=others)
    if not inside:
        _refuse_out_of_reach(ctx, found, _reach(ctx, scans, lines, hard))
    ctx.store.set_stage("rangefind", "done", found.to_summary(),
                        inputs_hash=ctx.store.stage("rangefind").inputs_hash)
    ctx.results.rangefind = found
    return found


def _scan(ctx: Context, names: list[str]
          ) -> tuple[list[ScanFactor], dict[str, tuple[float, float]], list[ScanReach] | None]:
    """Run every factor's scan at the others' centre: each factor's points, the range kept
    (the longest contiguous run of piles) and why it was cut; each factor's scan line
    (slope, intercept) over its piles, where it formed two or more; and every other
    response's span over the scans (None with one response)."""
    opts = ctx.study.stages.rangefind
    points, index = [], []
    for fi, name in enumerate(names):
        f = ctx.factor(name)
        for j, v in enumerate(np.linspace(f.low, f.high, opts.points)):
            pt = 100 * fi + j
            for r in range(ctx.reps("rangefind")):
                points.append(Point(pt, r, ctx.full({name: float(v)}), ctx.seed(pt, r, 0)))
            index.append((name, float(v), pt))
    recs = ctx.run("rangefind", points)
    y, outcomes = point_means(recs, 100 * len(names), ctx.lead.name)
    scans, lines = [], {}
    for name in names:
        f = ctx.factor(name)
        pts = [(v, pt) for n, v, pt in index if n == name]
        vals = np.array([v for v, _ in pts])
        ys = np.array([y[pt] for _, pt in pts])
        piles = ~np.isnan(ys)
        feas = _feasible(vals, piles)
        reason = None
        new_low, new_high = f.low, f.high
        if feas is None:
            reason = (f"no pile anywhere in {f.low:g}..{f.high:g} "
                      f"({', '.join(sorted({outcomes[pt] for _, pt in pts}))})")
        else:
            new_low, new_high = feas
            cut = [f"{v:g} ({outcomes[pt]})" for v, pt in pts if np.isnan(y[pt])]
            if cut:
                reason = ("no pile at " + ", ".join(cut) + f"; range cut to "
                          f"{new_low:g}..{new_high:g}")
        if piles.sum() >= 2:
            lines[name] = tuple(float(c) for c in np.polyfit(vals[piles], ys[piles], 1))
        scans.append(ScanFactor(
            name=name, symbol=f.symbol, low=f.low, high=f.high, new_low=new_low,
            new_high=new_high, reason=reason,
            points=[ScanPoint(value=float(v), outcome=outcomes[pt],
                              response=None if np.isnan(y[pt]) else float(y[pt]))
                    for v, pt in pts]))
    return scans, lines, _other_responses(ctx, recs, 100 * len(names))


def _other_responses(ctx: Context, recs: Sequence[RunRecord], n_points: int
                     ) -> list[ScanReach] | None:
    """Every response but the lead over the scans' points: the span measured and whether
    the lab value lies in it (None for a study of one response). The ranges follow the
    lead alone; this says which other lab value the scans did not reach."""
    if not ctx.several:
        return None
    out = []
    for spec in ctx.responses[1:]:
        y, _ = point_means(recs, n_points, spec.name)
        seen = y[~np.isnan(y)]
        lab = ctx.labs.get(spec.name)
        target = None if lab is None else float(lab.mean)
        low, high = (float(seen.min()), float(seen.max())) if seen.size else (None, None)
        inside = None if target is None or low is None else bool(low <= target <= high)
        out.append(ScanReach(name=spec.name, low=low, high=high, lab=target,
                             in_range=inside))
    return out


def _others_message(others: Sequence[ScanReach]) -> str:
    """The other responses' spans in a clause of the stage's message."""
    parts = []
    for r in others:
        if r.low is None or r.high is None:
            parts.append(f"{r.name} not measured by the scans")
            continue
        span = f"{r.name} {r.low:.2f}..{r.high:.2f}"
        if r.lab is None:
            parts.append(span + " (no lab value)")
        elif r.in_range:
            parts.append(span + f" (lab {r.lab:g} inside)")
        else:
            parts.append(span + f" (lab {r.lab:g} outside: no scan reached it)")
    return "the other responses over the scans: " + ", ".join(parts)


def _no_pile_anywhere(ctx: Context, scans: list[ScanFactor]) -> None:
    """Fail the stage: no scan formed a pile."""
    found = RangeFind(fidelity=ctx.own_fidelity("rangefind").get("fidelity"), factors=scans,
                      target_in_range=False, message="no pile formed in any scan")
    ctx.store.set_stage("rangefind", "failed",
                        {**found.to_summary(), "error": found.message})
    raise StudyError("rangefind: no pile formed anywhere in the scanned ranges; lower "
                     "the cohesion (e.g. pp.surface_energy) or widen the ranges")


def _scan_message(ctx: Context, seen: tuple[float, float], slopes: Mapping[str, float]) -> str:
    """Whether the target lies in the response the scans saw, and if not, which way each
    factor must move to reach it (the steepest scan line first)."""
    lo, hi = seen
    target, u = ctx.target, ctx.unit
    if lo <= target <= hi:
        return f"target {target:g}{u} lies in the response seen ({lo:.2f}..{hi:.2f}{u})"
    way = "raise" if target > hi else "lower"
    drivers = [f"{n} ({'up' if (s > 0) == (way == 'raise') else 'down'})"
               for n, s in sorted(slopes.items(), key=lambda kv: -abs(kv[1]))]
    return (f"target {target:g}{u} lies outside the response seen ({lo:.2f}.."
            f"{hi:.2f}{u}): ranges must move to {way} {ctx.lead_words}: "
            + (", ".join(drivers) or "no factor with a measurable slope"))


def _move_ranges(ctx: Context, slopes: Mapping[str, float],
                 hard: Mapping[str, tuple[float, float]], want_up: bool,
                 moves: list[str]) -> bool:
    """Move each factor with hard limits and a measured slope half its width the way that
    raises (``want_up``) or lowers the response, inside its hard limits; say each move in
    ``moves``. Returns whether any range moved."""
    moved = False
    for name, s in slopes.items():
        if name not in hard or s == 0:
            continue
        f = ctx.factor(name)
        width = f.high - f.low
        shift = width / 2 * (1 if (s > 0) == want_up else -1)
        h_lo, h_hi = hard[name]
        new_lo = min(max(f.low + shift, h_lo), h_hi - width)
        new_lo = max(new_lo, h_lo)
        new_hi = min(new_lo + width, h_hi)
        if abs(new_lo - f.low) > 1e-12 * max(1.0, width):
            moves.append(f"{name}: {f.low:g}..{f.high:g} -> {new_lo:g}..{new_hi:g}")
            ctx.set_range(name, new_lo, new_hi)
            moved = True
    return moved


def _reach(ctx: Context, scans: Sequence[ScanFactor],
           lines: Mapping[str, tuple[float, float]],
           hard: Mapping[str, tuple[float, float]]) -> tuple[float, float] | None:
    """The response range the factors may reach within their hard limits, deg, or None
    where the scans cannot tell.

    ``lines``: each factor's scan line (slope, intercept) over its piles, as range finding
    fitted them. The response at the design centre is
    the mean of those lines there, and each factor adds its line's change from its centre to
    the hard limit that raises (or lowers) the response most: additive and linear, the
    steepest path's own model. None unless every factor of the study was scanned, formed at
    least two piles and has hard limits (a factor free to move can reach any angle).
    """
    if {s.name for s in scans} != {f.name for f in ctx.factors}:
        return None
    centre, up, down = [], 0.0, 0.0
    for s in scans:
        if s.name not in lines or s.name not in hard:  # under two piles, or free
            return None
        slope, icpt = lines[s.name]
        c = 0.5 * (s.new_low + s.new_high)
        centre.append(icpt + slope * c)
        ends = [slope * (h - c) for h in hard[s.name]]
        up, down = up + max(ends), down + min(ends)
    base = float(np.mean(centre))
    return base + down, base + up


def _refuse_out_of_reach(ctx: Context, found: RangeFind,
                         reach: tuple[float, float] | None) -> None:
    """Stop the study after range finding (its runs kept) when the target lies beyond what
    the factors may reach within their hard limits, with 10 % of that span as a margin for
    the curvature and interactions a scan one factor at a time does not see."""
    if reach is None:
        return
    low, high = reach
    margin = 0.1 * (high - low)
    if low - margin <= ctx.target <= high + margin:
        return
    err = (f"rangefind: target {ctx.target:g}{ctx.unit} is out of reach: within the hard "
           f"limits the scans reach {low:.2f}..{high:.2f}{ctx.unit} (each factor's scan line, "
           "added); widen hard_limits, add a factor, or check the target")
    ctx.store.set_stage("rangefind", "failed",
                        replace(found, reach=[low, high], error=err).to_summary())
    raise StudyError(err)
