"""The calibration stages, each a function of a :class:`Context` that writes its summary.

rangefind -> screening -> steepest -> rsm -> optimize -> verification. Every stage makes its
design points, has the runner run (or find) them, and stores a summary whose keys are the
contract documented in :mod:`demcal.calibrate`. A run without a pile is stored with its
outcome and never enters a fit as a number: its design point is excluded and listed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from demcal import doe
from demcal.calibrate import anchor, several
from demcal.calibrate.classifier import PileClassifier
from demcal.calibrate.responses import LabValue, ResponseSpec
from demcal.calibrate.rounds import (
    Offset,
    Rounds,
    stored_rounds,
    with_rounds,
)
from demcal.calibrate.runner import Point, Runner
from demcal.calibrate.study import Study
from demcal.calibrate.verify import (
    compare_to_target,
    confirmation,
    interval_half_width,
    pure_error_std,
    verification_seed,
    verification_size,
)
from demcal.errors import InputError, StudyError
from demcal.store import RunRecord, RunStore, params_hash
from demcal.summaries import (
    Anchor,
    AnchorRun,
    Candidate,
    DesignRun,
    Effect,
    Optimum,
    PathStep,
    RangeFind,
    ResponseModel,
    ResponseVerification,
    ScanFactor,
    ScanPoint,
    Screening,
    Steepest,
    Surface,
    Verification,
)
from demcal.virtual import PARAMETERS

__all__ = ["Context", "adequacy", "choose_model", "optimize", "rangefind", "rsm", "screening",
           "steepest", "verification"]


@dataclass
class Context:
    """State shared by the stages of one study.

    ``fixed``: full parameter set with every factor at its current centre (SI);
    ``factors``: current ranges [{"name","symbol","low","high","unit"}];
    ``records``: every run the stages used (for the pile classifier);
    ``target_std``, ``target_n``: spread (deg) and count of the measured AoR, when known.
    """

    study: Study
    store: RunStore
    runner: Runner
    fixed: dict[str, float]
    target: float
    factors: list[dict[str, Any]]
    records: list[RunRecord] = field(default_factory=list)
    results: dict[str, Any] = field(default_factory=dict)
    target_std: float | None = None
    target_n: int | None = None
    rounds: Rounds = field(default_factory=Rounds)
    #: every response the study aims at, the angle first (:mod:`demcal.calibrate.several`)
    responses: list[ResponseSpec] = field(default_factory=list)
    #: their lab values by name
    labs: dict[str, LabValue] = field(default_factory=dict)

    @property
    def several(self) -> bool:
        """Does the study aim at more responses than the angle?"""
        return len(self.responses) > 1

    def full(self, actual: dict[str, float]) -> dict[str, float]:
        """The fixed set with ``actual`` factor values applied (floats)."""
        out = dict(self.fixed)
        out.update({k: float(v) for k, v in actual.items()})
        return out

    def reps(self, stage: str) -> int:
        """Replicates per design point of a stage: its own ``replicates`` or the study's."""
        own = getattr(getattr(self.study.stages, stage), "replicates", None)
        return int(own if own is not None else self.study.replicates)

    def factor(self, name: str) -> dict[str, Any]:
        return next(f for f in self.factors if f["name"] == name)

    def seed(self, point: int, replicate: int, copy: int | None = None) -> int:
        """Seed of a run.

        By default distinct per design row (``point``), so replicated centre points differ.
        With the study's ``common_seeds`` (common random numbers) every design point of a
        stage gets the same seed set (one seed per replicate), so the differences between
        points are not blurred by the particle packings; identical rows (centre points) still
        differ through ``copy``, their rank among the identical rows.
        """
        if self.study.common_seeds and copy is not None:
            return int(self.study.seed + 1000 * replicate + copy)
        return int(self.study.seed + 1000 * replicate + point)

    def own_fidelity(self, stage: str) -> dict[str, str]:
        """``{"fidelity": name}`` when the stage runs at its own fidelity, else ``{}``."""
        fid = self.study.stage_fidelities().get(stage)
        return {"fidelity": fid} if fid is not None else {}

    def run(self, stage: str, points: Sequence[Point]) -> list[RunRecord]:
        recs = self.runner.run(stage, points)
        self.records.extend(recs)
        return recs

    def begin(self, stage: str, inputs: Any) -> str:
        h = params_hash({"inputs": inputs, "test": self.runner.stage_hash(stage)})
        self.store.set_stage(stage, "running", {}, inputs_hash=h)
        return h


def _clip(name: str, value: float) -> float:
    spec = PARAMETERS[name]
    lo = spec.low if not spec.low_open else spec.low + 1e-9
    hi = spec.high if not spec.high_open else spec.high - 1e-9
    return float(min(max(value, lo), hi))


def _space(factors: Sequence[dict[str, Any]]) -> doe.FactorSpace:
    return doe.FactorSpace([doe.Factor(f["name"], f["low"], f["high"], f.get("unit") or "")
                            for f in factors])


def _point_responses(recs: Sequence[RunRecord], n_points: int) -> tuple[np.ndarray, list[str]]:
    """Mean AoR per design point over its replicates; NaN if any replicate formed no pile."""
    y, outcome, _ = _point_runs(recs, n_points)
    return y, outcome


def _point_runs(recs: Sequence[RunRecord], n_points: int
                ) -> tuple[np.ndarray, list[str], list[list[float]]]:
    """Per design point: mean AoR (NaN if any replicate formed no pile), outcome, and the
    replicates' angles in replicate order (empty for a point without a pile)."""
    y = np.full(n_points, math.nan)
    outcome = ["pile"] * n_points
    runs: list[list[float]] = [[] for _ in range(n_points)]
    by: dict[int, list[RunRecord]] = {}
    for r in recs:
        by.setdefault(r.point, []).append(r)
    for i in range(n_points):
        rs = sorted(by.get(i, []), key=lambda r: r.replicate)
        bad = [r.outcome for r in rs if r.outcome != "pile" or r.aor_deg is None]
        if bad or not rs:
            outcome[i] = bad[0] if bad else "missing"
        else:
            runs[i] = [float(r.aor_deg) for r in rs]  # type: ignore[arg-type]
            y[i] = float(np.mean(runs[i]))
    return y, outcome, runs


def _copies(design: doe.Design) -> list[int]:
    """Rank of each row among the rows with identical coded settings (0 for a unique row)."""
    seen: dict[tuple[float, ...], int] = {}
    out = []
    for row in np.round(design.coded, 9):
        key = tuple(float(v) for v in row)
        out.append(seen.get(key, 0))
        seen[key] = out[-1] + 1
    return out


def _design_points(ctx: Context, design: doe.Design, replicates: Sequence[int]
                   ) -> list[Point]:
    actual = design.actual
    copies = _copies(design)
    pts = []
    for i in range(design.n_runs):
        values = {n: float(actual[i, j]) for j, n in enumerate(design.names)}
        for r in replicates:
            pts.append(Point(i, r, ctx.full(values), ctx.seed(i, r, copies[i])))
    return pts


def _replicated(design: doe.Design, runs: list[list[float]], n_reps: int
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
    if not (math.isfinite(lo) and math.isfinite(hi) and math.isfinite(hi - lo)):
        return (f"the responses are not finite numbers of a usable size (from {lo:.6g} to "
                f"{hi:.6g} {unit}); check the test's results")
    if hi - lo <= 1e-9 * max(1.0, abs(hi)):
        return (f"the response does not vary: all {y.size} runs gave {hi:.6g} {unit}; the "
                "factors' ranges move nothing the test measures (widen them) or the test "
                "gives a constant (check its result)")
    return None


def _fit_rows(rep_design: doe.Design, y_rows: np.ndarray, n_reps: int, common_seeds: bool
              ) -> tuple[doe.ResponseSurface, list[str]]:
    """The quadratic fitted to every replicate row; with common seeds, in blocks.

    With ``common_seeds`` replicate k of every design point shares seed set k, so each
    replicate round is a block (Design-Expert's): its shared offset leaves the residual and the
    pure error. A run without a pile unbalances the blocks; then the rows are fitted without
    blocks and a note (the list returned) says so.
    """
    if (flat := no_variation(y_rows)) is not None:  # a clear statement, not a 0/0 in the ANOVA
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


def _run_rows(design: doe.Design, y: np.ndarray, outcomes: list[str],
              runs: list[list[float]]) -> list[DesignRun]:
    """Each design point's settings, its mean response (None: excluded), outcome and
    replicates."""
    actual = design.actual
    return [DesignRun(
        point=i, coded={n: float(design.coded[i, j]) for j, n in enumerate(design.names)},
        actual={n: float(actual[i, j]) for j, n in enumerate(design.names)},
        value=None if math.isnan(y[i]) else float(y[i]), outcome=outcomes[i],
        replicates=runs[i],
        replicate_std=float(np.std(runs[i], ddof=1)) if len(runs[i]) > 1 else None)
        for i in range(design.n_runs)]


def _exclusion_note(excluded: list[int], outcomes: list[str]) -> str:
    if not excluded:
        return "every design point formed a pile"
    kinds = sorted({outcomes[i] for i in excluded})
    return (f"{len(excluded)} design point(s) formed no pile ({', '.join(kinds)}): points "
            f"{', '.join(str(i) for i in excluded)} are stored with their outcome and excluded "
            "from the fit")


# ------------------------------------------------------------------------------ rangefind
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
    names = [ctx.study.factor(r).name for r in (opts.factors or [f["name"] for f in ctx.factors])]
    ctx.begin("rangefind", {"factors": ctx.factors, "opts": opts.model_dump(mode="json"),
                            "fixed": ctx.fixed})
    hard = {ctx.study.factor(k).name: v for k, v in opts.hard_limits.items()}
    may_move = bool(hard) if opts.move_ranges is None else opts.move_ranges
    moves: list[str] = []
    for attempt in range(opts.max_moves + 1):
        scans, lines = _scan(ctx, names)
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
        f = ctx.factor(scan.name)
        f["low"], f["high"] = scan.new_low, scan.new_high
        ctx.fixed[scan.name] = 0.5 * (f["low"] + f["high"])
    msg = _scan_message(ctx.target, (lo, hi), slopes)
    if moves:
        msg += "; ranges moved within hard limits: " + "; ".join(moves)
    found = RangeFind(fidelity=ctx.own_fidelity("rangefind").get("fidelity"), factors=scans,
                      response_min=lo, response_max=hi, target_in_range=inside, message=msg)
    if not inside:
        _refuse_out_of_reach(ctx, found, _reach(ctx, scans, lines, hard))
    ctx.store.set_stage("rangefind", "done", found.to_summary(),
                        inputs_hash=ctx.store.stage("rangefind").inputs_hash)
    ctx.results["rangefind"] = found
    return found


def _scan(ctx: Context, names: list[str]
          ) -> tuple[list[ScanFactor], dict[str, tuple[float, float]]]:
    """Run every factor's scan at the others' centre: each factor's points, the range kept
    (the longest contiguous run of piles) and why it was cut; and each factor's scan line
    (slope, intercept) over its piles, where it formed two or more."""
    opts = ctx.study.stages.rangefind
    points, index = [], []
    for fi, name in enumerate(names):
        f = ctx.factor(name)
        for j, v in enumerate(np.linspace(f["low"], f["high"], opts.points)):
            pt = 100 * fi + j
            for r in range(ctx.reps("rangefind")):
                points.append(Point(pt, r, ctx.full({name: float(v)}), ctx.seed(pt, r, 0)))
            index.append((name, float(v), pt))
    y, outcomes = _point_responses(ctx.run("rangefind", points), 100 * len(names))
    scans, lines = [], {}
    for name in names:
        f = ctx.factor(name)
        pts = [(v, pt) for n, v, pt in index if n == name]
        vals = np.array([v for v, _ in pts])
        ys = np.array([y[pt] for _, pt in pts])
        piles = ~np.isnan(ys)
        feas = _feasible(vals, piles)
        reason = None
        new_low, new_high = f["low"], f["high"]
        if feas is None:
            reason = (f"no pile anywhere in {f['low']:g}..{f['high']:g} "
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
            name=name, symbol=f["symbol"], low=f["low"], high=f["high"], new_low=new_low,
            new_high=new_high, reason=reason,
            points=[ScanPoint(value=float(v), outcome=outcomes[pt],
                              response=None if np.isnan(y[pt]) else float(y[pt]))
                    for v, pt in pts]))
    return scans, lines


def _no_pile_anywhere(ctx: Context, scans: list[ScanFactor]) -> None:
    """Fail the stage: no scan formed a pile."""
    found = RangeFind(fidelity=ctx.own_fidelity("rangefind").get("fidelity"), factors=scans,
                      target_in_range=False, message="no pile formed in any scan")
    ctx.store.set_stage("rangefind", "failed",
                        {**found.to_summary(), "error": found.message})
    raise StudyError("rangefind: no pile formed anywhere in the scanned ranges; lower "
                     "the cohesion (e.g. pp.surface_energy) or widen the ranges")


def _scan_message(target: float, seen: tuple[float, float], slopes: Mapping[str, float]) -> str:
    """Whether the target lies in the response the scans saw, and if not, which way each
    factor must move to reach it (the steepest scan line first)."""
    lo, hi = seen
    if lo <= target <= hi:
        return f"target {target:g} deg lies in the response seen ({lo:.2f}..{hi:.2f} deg)"
    way = "raise" if target > hi else "lower"
    drivers = [f"{n} ({'up' if (s > 0) == (way == 'raise') else 'down'})"
               for n, s in sorted(slopes.items(), key=lambda kv: -abs(kv[1]))]
    return (f"target {target:g} deg lies outside the response seen ({lo:.2f}.."
            f"{hi:.2f} deg): ranges must move to {way} the AoR: "
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
        width = f["high"] - f["low"]
        shift = width / 2 * (1 if (s > 0) == want_up else -1)
        h_lo, h_hi = hard[name]
        new_lo = min(max(f["low"] + shift, h_lo), h_hi - width)
        new_lo = max(new_lo, h_lo)
        new_hi = min(new_lo + width, h_hi)
        if abs(new_lo - f["low"]) > 1e-12 * max(1.0, width):
            moves.append(f"{name}: {f['low']:g}..{f['high']:g} -> {new_lo:g}..{new_hi:g}")
            f["low"], f["high"] = new_lo, new_hi
            ctx.fixed[name] = 0.5 * (new_lo + new_hi)
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
    if {s.name for s in scans} != {f["name"] for f in ctx.factors}:
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
    err = (f"rangefind: target {ctx.target:g} deg is out of reach: within the hard limits the "
           f"scans reach {low:.2f}..{high:.2f} deg (each factor's scan line, added); widen "
           "hard_limits, add a factor, or check the target")
    ctx.store.set_stage("rangefind", "failed",
                        replace(found, reach=[low, high], error=err).to_summary())
    raise StudyError(err)


# ------------------------------------------------------------------------------ screening
def screening(ctx: Context) -> Screening:
    """Plackett-Burman design, linear fit, effects and ANOVA, the significant factors."""
    opts = ctx.study.stages.screening
    h = ctx.begin("screening", {"factors": ctx.factors, "opts": opts.model_dump(mode="json"),
                                "fixed": ctx.fixed, "reps": ctx.reps("screening")})
    space = _space(ctx.factors)
    try:
        design = doe.plackett_burman(space, n_runs=opts.runs, randomize=False)
    except InputError as exc:
        raise InputError(f"stages.screening.runs: {exc}") from None
    recs = ctx.run("screening", _design_points(ctx, design, range(ctx.reps("screening"))))
    y, outcomes, point_runs = _point_runs(recs, design.n_runs)
    excluded = [i for i in range(design.n_runs) if math.isnan(y[i])]
    ran = Screening(
        fidelity=ctx.own_fidelity("screening").get("fidelity"), design="plackett_burman",
        n_runs=design.n_runs, alpha=opts.alpha, factors=[dict(f) for f in ctx.factors],
        dummies=[f"dummy{j + 1}" for j in range(design.dummies.shape[1])],
        runs=_run_rows(design, y, outcomes, point_runs), excluded_points=excluded)
    try:
        if (flat := no_variation(y)) is not None:  # no effect to screen: say it, now
            raise InputError(flat)
        rs = doe.fit(design, y, model="linear")
        if rs.df_resid < 1:
            raise InputError("no residual degrees of freedom")
    except InputError as exc:
        err = (f"screening: the linear model cannot be fitted ({exc}); "
               + _exclusion_note(excluded, outcomes) + ". Run range finding or narrow the "
               "ranges to the pile region")
        ctx.store.set_stage("screening", "failed", replace(ran, error=err).to_summary(),
                            inputs_hash=h)
        raise StudyError(err) from None
    effects = [Effect(term=str(t), effect=float(r["effect"]),
                      contribution_percent=float(r["contribution_percent"]),
                      f=None if not np.isfinite(r["f"]) else float(r["f"]),
                      p=None if not np.isfinite(r["p"]) else float(r["p"]), rank=int(r["rank"]))
               for t, r in rs.effects().iterrows()]
    selected, why = _select(ctx, effects, len(space))
    table = rs.anova()
    found = replace(ran, anova=table.to_records(), fit=table.fit.to_dict(), effects=effects,
                    selected=selected, message=f"selected {', '.join(selected)} ({why}); "
                    + _exclusion_note(excluded, outcomes))
    ctx.store.set_stage("screening", "done", found.to_summary(), inputs_hash=h)
    ctx.results["screening"] = found
    ctx.results["_screening_model"] = rs
    ctx.results["_screening_runs"] = (design, recs)  # the other responses' first-order models
    return found


def _select(ctx: Context, effects: list[Effect], k: int) -> tuple[list[str], str]:
    """The factors the next stage varies, and why: those the study gives, else the
    significant ones (at most ``max_factors``), filled up to ``min_factors`` by effect rank."""
    opts = ctx.study.stages.screening
    if opts.factors:
        return [ctx.study.factor(r).name for r in opts.factors], "factors given in the study"
    sig = [e.term for e in effects if e.p is not None and e.p < opts.alpha]
    selected = sig[:opts.max_factors]
    why = f"{len(sig)} significant at alpha={opts.alpha:g}"
    need = min(opts.min_factors, k)
    for e in effects:
        if len(selected) >= need:
            break
        if e.term not in selected:
            selected.append(e.term)
    if len(selected) > len(sig[:opts.max_factors]):
        why += f"; filled up to {need} by effect rank"
    return selected, why


# ------------------------------------------------------------------------------ steepest
def _path_direction(ctx: Context, selected: list[str]
                    ) -> tuple[dict[str, float], bool, several.PathClimb | None]:
    """The path's coefficients (only their signs matter) and whether it climbs them.

    The angle alone: its screening model's coefficients, climbed toward the target. Several
    responses: the gradient of their overall desirability (:func:`several.path_climb`), climbed;
    where it is flat at the centre (every goal met there) the angle's direction stands.
    """
    rs = ctx.results["_screening_model"]
    climb = several.path_climb(ctx, selected) if ctx.several else None
    if climb is not None and not climb.flat:
        return dict(climb.gradient), True, climb
    coefs = {n: float(rs.coefficients_coded[n]) for n in selected}
    return coefs, ctx.target > float(rs.coefficients_coded["intercept"]), climb


def _step_values(ctx: Context, recs: Sequence[RunRecord], n_points: int
                 ) -> list[dict[str, float | None]]:
    """Per path step, every response's mean over its replicates (None: the step lacks it)."""
    per = {spec.name: several.point_values(recs, n_points, spec.name) for spec in ctx.responses}
    return [{name: float(np.mean(v[i])) if v[i] else None for name, v in per.items()}
            for i in range(n_points)]


def _best_step(miss: Sequence[float | None]) -> int | None:
    """The first step with a result, then on while the miss (lower is better) does not grow;
    None when no step has one."""
    have = [i for i, e in enumerate(miss) if e is not None]
    if not have:
        return None
    best = have[0]
    for i in range(best + 1, len(miss)):
        if miss[i] is None or miss[i] > miss[best]:  # type: ignore[operator]
            break
        best = i
    return best


def _path_summary(ctx: Context, climb: several.PathClimb | None, recs: Sequence[RunRecord],
                  steps: list[PathStep]) -> tuple[Steepest, list[PathStep], list[float | None]]:
    """Several responses: the summary's ``followed`` and ``climb``, the steps with each one's
    ``responses`` and ``desirability``, and the misses the best step is chosen by (``[]``
    for the angle alone: its relative error)."""
    if climb is None:
        return Steepest(), steps, []
    values = _step_values(ctx, recs, len(steps))
    steps = [replace(row, responses=v, desirability=d)
             for row, v, d in zip(steps, values, climb.desirability(values), strict=True)]
    if climb.flat:
        return Steepest(followed=[ctx.responses[0].name], climb=climb.summary()), steps, []
    return (Steepest(followed=[g.name for g in climb.goals], climb=climb.summary()), steps,
            climb.misses(values))


def steepest(ctx: Context) -> Steepest:
    """Path from the screening effects toward the target; best step = centre of the RSM.

    With several responses the path climbs their overall desirability (:func:`_path_direction`)
    and its best step is the last before the measured desirability falls.
    """
    opts = ctx.study.stages.steepest
    rs = ctx.results["_screening_model"]
    selected = ctx.results["screening"].selected
    h = ctx.begin("steepest", {"sel": selected, "factors": ctx.factors,
                               "opts": opts.model_dump(mode="json"), "fixed": ctx.fixed,
                               "coef": {k: float(v) for k, v in rs.coefficients_coded.items()},
                               **({"responses": [r.model_dump(mode="json")
                                                 for r in ctx.responses]}
                                  if ctx.several else {})})
    coefs, ascent, climb = _path_direction(ctx, selected)
    sign = {n: (1 if ascent else -1) * (1 if c >= 0 else -1) for n, c in coefs.items()}
    space = _space([ctx.factor(n) for n in selected])
    if opts.step == "auto":
        step_c = 2.0 / (opts.steps - 1)
        start = {n: -float(sign[n]) for n in selected}
    else:
        step_c = float(opts.step)
        start = {n: 0.0 for n in selected}
    n_points = opts.steps
    while True:
        design = doe.steepest_path({n: (c if c != 0 else 1e-12) for n, c in coefs.items()},
                                   factors=space, n_points=n_points,
                                   steps={n: step_c for n in selected}, start=start,
                                   direction="ascent" if ascent else "descent", units="coded")
        actual = design.actual
        path = [{n: _clip(n, actual[i, j]) for j, n in enumerate(design.names)}
                for i in range(design.n_runs)]
        pts = [Point(i, r, ctx.full(path[i]), ctx.seed(i, r, 0))
               for i in range(len(path)) for r in range(ctx.reps("steepest"))]
        recs = ctx.run("steepest", pts)  # earlier steps are stored: only new ones run
        y, outcomes = _point_responses(recs, len(path))
        err = [None if math.isnan(v) else abs(v - ctx.target) / ctx.target * 100 for v in y]
        steps = [PathStep(step=i, actual=path[i],
                          value=None if math.isnan(y[i]) else float(y[i]),
                          outcome=outcomes[i], relative_error_percent=err[i])
                 for i in range(len(path))]
        followed, steps, miss = _path_summary(ctx, climb, recs, steps)
        best = _best_step(miss or err)
        if best is None:
            msg = "steepest: no step of the path formed a pile"
            ctx.store.set_stage("steepest", "failed", Steepest(error=msg).to_summary(),
                                inputs_hash=h)
            raise StudyError(msg)
        # the miss still falls at the last step: go on along the path (bounded)
        if best < len(path) - 1 or n_points >= opts.max_steps or path[-1] == path[-2]:
            break
        n_points = min(opts.max_steps, n_points + 2)
    what = "desirability falls" if miss else "relative error grows"
    if best == len(path) - 1:
        message = (f"the {'desirability still rises' if miss else 'relative error still falls'}"
                   f" at the last step ({len(path)} steps, max_steps {opts.max_steps}): the "
                   "target may lie beyond the path")
    else:
        message = f"after step {best} the {what} or no pile forms: step {best} is the centre"
    step_actual = {n: abs(step_c) * space[n].half_range for n in selected}
    centre, anchored = _surface_centre(ctx, path, y, best, message)
    levels = _levels(ctx, selected, centre, step_actual)
    found = replace(followed, fidelity=ctx.own_fidelity("steepest").get("fidelity"),
                    factors=selected, direction=sign, steps=steps, best_step=best,
                    centre={n: levels[n][1] for n in selected}, levels=levels,
                    message=message if anchored is None else anchored[1],
                    anchor=None if anchored is None else anchored[0])
    ctx.store.set_stage("steepest", "done", found.to_summary(), inputs_hash=h)
    ctx.results["steepest"] = found
    return found


def _levels(ctx: Context, selected: list[str], centre: Mapping[str, float],
            step_actual: Mapping[str, float]) -> dict[str, list[float]]:
    """The response surface's low, centre and high of each factor: a path step either side of
    the centre, inside the parameter's bounds and the range finding's pile region."""
    found = ctx.results.get("rangefind")
    levels = {}
    for n in selected:
        lo = _clip(n, centre[n] - step_actual[n])
        hi = _clip(n, centre[n] + step_actual[n])
        scan = None if found is None else found.factor(n)
        if scan is not None and scan.reason:  # keep the rangefind's pile region
            lo, hi = max(lo, min(scan.new_low, centre[n])), min(
                hi, max(scan.new_high, centre[n]))
        if not hi > lo:
            lo, hi = centre[n] - step_actual[n] / 2, centre[n] + step_actual[n] / 2
        levels[n] = [lo, 0.5 * (lo + hi), hi]
    return levels


def _surface_centre(ctx: Context, path: list[dict[str, float]], y: np.ndarray, best: int,
                    path_message: str
                    ) -> tuple[dict[str, float], tuple[Anchor, str] | None]:
    """The response surface's centre on the path, and where it was anchored, the anchor and
    the stage's message.

    The best step of the path, unless the path ran at its own fidelity and
    ``anchor_rounds`` > 0: then the study's own test is run at path points around it
    (:mod:`demcal.calibrate.anchor`) and the centre is where that test crosses the target;
    the stage's message (``path_message``, what the path itself found) then says so too.
    """
    rounds = ctx.study.stages.steepest.anchor_rounds
    path_fid = ctx.study.stage_fidelities().get("steepest")
    if path_fid is None or rounds < 1 or len(path) < 2:
        return dict(path[best]), None
    path_aor = [float(v) for v in y]
    got: dict[int, RunRecord] = {}
    want: tuple[int, ...] | None = anchor.first_pair(best, len(path))
    cross, piles = None, {}
    for _ in range(rounds):
        if not want:
            break
        pts = [Point(s, 0, ctx.full(path[s]), ctx.seed(s, 0, 0)) for s in want]
        got.update(zip(want, ctx.run(_ANCHOR_STAGE, pts), strict=True))
        piles = {s: float(r.aor_deg) for s, r in got.items()
                 if r.outcome == "pile" and r.aor_deg is not None}
        cross = anchor.crossing(piles, ctx.target)
        if cross is not None:
            break
        want = anchor.next_pair(path_aor, piles, ctx.target)
    step, message = _anchor_step(ctx, piles, cross, best)
    centre_step = anchor.surface_centre(step, len(path))
    runs = [AnchorRun(step=s, actual=path[s],
                      value=r.aor_deg if r.outcome == "pile" else None, outcome=r.outcome,
                      path_value=None if math.isnan(path_aor[s]) else path_aor[s])
            for s, r in sorted(got.items())]
    anchored = Anchor(fidelity=ctx.study.test.fidelity, runs=runs, crossing_step=cross,
                      centre_step=centre_step, offset=anchor.offset(path_aor, piles),
                      message=message)
    return anchor.path_point(path, centre_step), (anchored, (
        f"the path's best step at its own test ({path_fid}) is {best} ({path_message}); "
        f"{message}; the response surface is centred at step {centre_step:.2f}"))


def _anchor_step(ctx: Context, piles: Mapping[int, float], cross: float | None, best: int
                 ) -> tuple[float, str]:
    """The anchored step the surface is centred on, and why."""
    fid = ctx.study.test.fidelity
    if cross is not None:
        return cross, (f"the study's test ({fid}) crosses the target {ctx.target:.2f} deg at "
                       f"step {cross:.2f} of the path")
    if not piles:
        return float(best), (f"no anchored point formed a pile at the study's test ({fid}): "
                             f"the path's best step {best} is the centre")
    near = min(piles, key=lambda s: abs(piles[s] - ctx.target))
    return float(near), (f"the study's test ({fid}) did not reach the target {ctx.target:.2f} "
                         f"deg at the anchored steps {sorted(piles)}: step {near} (closest, "
                         f"{piles[near]:.2f} deg) is the centre; the target may lie beyond "
                         "the path or the ranges")


#: the stage name of the anchor's runs (the study's own test, in the steepest stage)
_ANCHOR_STAGE = "steepest_anchor"


# ------------------------------------------------------------------------------ rsm
def adequacy(model: Any, lof_p: float | None) -> tuple[bool, list[str], dict[str, Any]]:
    """Is a response-surface model adequate, as Design-Expert judges it?

    Inadequate when: the model is not significant (p >= 0.05); the lack of fit is
    significant (p < 0.05); adjusted R^2 < 0.7; predicted R^2 is negative or more than 0.2
    below the adjusted R^2 (the model does not predict new runs); or Adeq Precision (signal
    to noise) < 4. Returns (adequate, the failed rules as warnings, the statistics).
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
    stats_ = {"p_model": p_model, "lack_of_fit_p": lof_p, "r2": float(model.r2),
              "adj_r2": adj, "pred_r2": pred if math.isfinite(pred) else None,
              "adeq_precision": adeq if math.isfinite(adeq) else None}
    return not fails, fails, stats_


def _lof_p(table: Any) -> float | None:
    for row in table.rows:
        if row.source == "Lack of Fit" and math.isfinite(row.p):
            return float(row.p)
    return None


def _judged(rows: Any, means: Any) -> dict[str, Any]:
    """A model's ANOVA (rows: every replicate), lack of fit and adequacy (of the means)."""
    table = rows.anova()
    lof_p = _lof_p(table)
    adequate, fails, stats_ = adequacy(means, lof_p)
    return {"rows": rows, "table": table, "lof_p": lof_p, "adequate": adequate,
            "failed": fails, "adequacy": stats_}


def choose_model(kind: str, alpha_out: float, rows: Any, means: Any) -> dict[str, Any]:
    """The response-surface model the optimum is read from, judged as Design-Expert would.

    ``rows`` is the full quadratic fitted to every replicate, ``means`` the same model fitted
    to the design-point means (the same coefficients: the replication is balanced). R^2,
    predicted R^2 and Adeq Precision are the means' (the rows' R^2 is capped by the run-to-run
    noise however many replicates are run); the ANOVA and its lack of fit are the rows'.

    ``kind``: ``"quadratic"`` keeps the full model; ``"reduced"`` removes terms by
    hierarchical backward elimination (p > ``alpha_out`` in the rows' ANOVA, as
    Design-Expert's "backward" model reduction) and judges the reduced model; ``"auto"`` keeps
    the full model when it is adequate and reduces it otherwise. A reduction that would leave
    no factor term keeps the full model. Returns :func:`_judged`'s keys for the chosen model
    plus ``model`` ("quadratic" or "reduced"), ``removed_terms``, ``full`` (the full
    model's judgement) and ``notes`` (what to tell the user).
    """
    full = _judged(rows, means)
    out = {**full, "model": "quadratic", "removed_terms": [], "full": full, "notes": []}
    if kind == "quadratic" or (kind == "auto" and full["adequate"]):
        return out
    reduced = rows.reduce(alpha_out=alpha_out, hierarchical=True)
    if reduced is rows or len(reduced.terms) < 2:
        return out
    kept = set(reduced.term_names)
    removed = [t for t in rows.term_names if t not in kept]
    means_r = reduced if rows is means else means.with_terms(list(reduced.terms))
    why = ("the full quadratic model is not adequate: " + "; ".join(full["failed"])
           if not full["adequate"] else "the full quadratic model is in 'anova_full'")
    note = (f"the optimum is read from the reduced model (backward elimination, alpha out "
            f"{alpha_out:g}; removed: {', '.join(removed)}); {why}")
    return {**_judged(reduced, means_r), "model": "reduced", "removed_terms": removed,
            "full": full, "notes": [note]}


def rsm(ctx: Context) -> Surface:
    """Box-Behnken (or face-centred CCD) around the centre, quadratic model, full ANOVA.

    Every replicate is a row of the fit and the ANOVA (pure error from the replicates, lack
    of fit against it); R^2, predicted R^2 and Adeq Precision are those of the design-point
    means (the same coefficients), which is what the optimum is read from. When the model is
    not adequate (:func:`adequacy`) and the stage's run budget (``stages.rsm.max_runs``)
    allows, one more replicate of every design point is run and the model refitted, until it
    is adequate or the budget is spent:
    more replicates rather than an optimum read off noise.
    """
    opts = ctx.study.stages.rsm
    levels = ctx.results["steepest"].levels
    factors = [{**ctx.factor(n), "low": lv[0], "high": lv[2]} for n, lv in levels.items()]
    h = ctx.begin("rsm", {"factors": factors, "opts": opts.model_dump(mode="json"),
                          "fixed": ctx.fixed, "reps": ctx.reps("rsm"),
                          "crn": ctx.study.common_seeds})
    space = _space(factors)
    try:
        if opts.design == "bbd":
            design = doe.box_behnken(space, center_points=opts.center_points, randomize=False)
        else:
            design = doe.central_composite(space, kind="face", center_points=opts.center_points,
                                           randomize=False)
    except InputError as exc:
        raise InputError(f"stages.rsm.design: {exc}") from None
    design_name = "box_behnken" if opts.design == "bbd" else "ccd"
    n_reps = ctx.reps("rsm")
    budget = opts.max_runs if opts.max_runs is not None else design.n_runs * n_reps
    rounds: list[dict[str, Any]] = []
    while True:
        recs = ctx.run("rsm", _design_points(ctx, design, range(n_reps)))
        y, outcomes, runs = _point_runs(recs, design.n_runs)
        excluded = [i for i in range(design.n_runs) if math.isnan(y[i])]
        run_rows = _run_rows(design, y, outcomes, runs)
        base = {"design": design_name, "factors": factors, "runs": run_rows,
                "excluded_points": excluded, "replicates": n_reps}  # what a failure stores
        rep_design, y_rows = _replicated(design, runs, n_reps)
        try:
            model, block_notes = _fit_rows(rep_design, y_rows, n_reps, ctx.study.common_seeds)
            if model.df_resid < 1:
                raise InputError("no residual degrees of freedom")
        except InputError as exc:
            err = f"rsm: the quadratic model cannot be fitted ({exc}); " + _exclusion_note(
                excluded, outcomes)
            ctx.store.set_stage("rsm", "failed", {**base, "error": err}, inputs_hash=h)
            raise StudyError(err) from None
        full = doe.fit(design, y, model="quadratic") if n_reps > 1 else model
        choice = choose_model(opts.model, opts.alpha_out, model, full)
        model, table, lof_p = choice["rows"], choice["table"], choice["lof_p"]
        adequate, fails, stats_ = choice["adequate"], choice["failed"], choice["adequacy"]
        rounds.append({"replicates": n_reps, "runs": design.n_runs * n_reps,
                       "blocks": model.block_df + 1 if model.block_df else 0,
                       "model": choice["model"], "removed_terms": choice["removed_terms"],
                       "adequate": adequate, "failed": fails, **stats_})
        more = design.n_runs * (n_reps + 1)
        if adequate or not opts.add_replicates or more > budget:
            break
        n_reps += 1
    warnings = []
    if excluded:
        warnings.append(_exclusion_note(excluded, outcomes))
    warnings += fails
    if lof_p is None:
        warnings.append("no lack-of-fit test (no replicated points with spare df)")
    if not adequate:
        spent = design.n_runs * n_reps
        warnings.append(
            f"the model is not adequate after {n_reps} replicate(s) of each design point "
            f"({spent} runs; budget stages.rsm.max_runs = {budget}): its optimum is a guess "
            "within the noise; raise the budget or the fidelity, or narrow the ranges")
    warnings += choice["notes"]
    warnings += block_notes
    responses, response_warnings = _other_responses(ctx, design, recs, n_reps)
    warnings += response_warnings
    surface = Surface(
        design=design_name, factors=factors, runs=run_rows, excluded_points=excluded,
        replicates=n_reps, responses=responses, anova=table.to_records(),
        fit=table.fit.to_dict(), lack_of_fit_p=lof_p, adequacy=stats_, rounds=rounds,
        model=choice["model"], removed_terms=choice["removed_terms"],
        anova_full=choice["full"]["table"].to_records(),
        adequacy_full=choice["full"]["adequacy"],
        coefficients_coded={k: float(v) for k, v in model.coefficients_coded.items()},
        coefficients_actual={k: float(v) for k, v in model.coefficients_actual.items()},
        equation_coded=model.equation(units="coded"),
        equation_actual=model.equation(units="actual"), adequate=bool(adequate),
        warnings=warnings)
    ctx.store.set_stage("rsm", "done", surface.to_summary(), inputs_hash=h)
    ctx.results["rsm"] = surface
    ctx.results["_rsm_model"] = model
    return surface


def _other_responses(ctx: Context, design: doe.Design, recs: Sequence[RunRecord], n_reps: int
                     ) -> tuple[dict[str, ResponseModel] | None, list[str]]:
    """Fit every response beside the angle (a several-response study): the models go to
    ``ctx.results["_response_fits"]``; returns their stored form and their warnings (None
    and none, and nothing done, for the angle alone)."""
    if not ctx.several:
        return None, []
    fits = several.fit_responses(ctx, design, recs, n_reps)
    ctx.results["_response_fits"] = fits
    return ({name: f.summary() for name, f in fits.items()},
            [w for f in fits.values() for w in f.warnings])


# ------------------------------------------------------------------------------ optimize
def optimize(ctx: Context) -> Optimum:
    """Settings whose predicted AoR equals the target, ranked; only inside the pile region.

    In a refinement round (``ctx.rounds.number`` > 1, :mod:`demcal.calibrate.refine`) the
    surface is corrected by the offset the earlier rounds measured at their optima
    (:meth:`Rounds.offset`): the optimum is where the surface reads the
    target minus that offset, searched from the previous optimum, so it moves along the
    target contour instead of jumping to another branch of it.
    """
    opts = ctx.study.stages.optimize
    model = ctx.results["_rsm_model"]
    k = ctx.rounds.number
    measured = ctx.rounds.offset(model)
    offset = measured.applied
    aim = ctx.target - offset
    opts_json = opts.model_dump(mode="json")
    if ctx.rounds.stored is None:  # before begin() marks the stage running
        ctx.rounds.stored = stored_rounds(ctx.store.stage("optimize"))
    h = ctx.begin("optimize", {"rsm": ctx.results["rsm"].coefficients_coded,
                               "opts": opts_json, "target": ctx.target,
                               **({"round": k, "offset": offset} if k > 1 else {})})
    clf = PileClassifier.fit(ctx.records, [(f.name, f.low, f.high) for f in ctx.study.factors])
    names = list(model.names)

    def constraint(x: np.ndarray) -> np.ndarray:
        return clf.p_pile_grid(ctx.fixed, names, x) >= opts.min_p_pile

    if ctx.several:
        found = several.optimize_summary(ctx, clf, constraint, offset, ctx.rounds.stored.get(k))
        return _store_optimum(ctx, _in_round(found, k, measured), h)
    kept = _stored_optimum(ctx.rounds.stored.get(k), (ctx.target, aim), model, constraint,
                           opts_json)
    if kept is not None:  # a resume (on this or another machine): the decision stands
        return _store_optimum(ctx, kept, h)
    prev = ctx.rounds.optimize[-1].chosen if ctx.rounds.optimize else None
    near = prev or {n: ctx.results["steepest"].levels[n][1] for n in names}
    try:
        res = doe.optimize_target(model, aim, constraint=constraint, near=near,
                                  n_solutions=opts.n_solutions, n_starts=opts.n_starts,
                                  units="actual", seed=ctx.study.seed)
    except InputError as exc:
        err = f"optimize: no setting inside the pile region hits the target ({exc})"
        ctx.store.set_stage("optimize", "failed", {"error": err}, inputs_hash=h)
        raise StudyError(err) from None
    if not res.solutions:
        err = "optimize: no setting inside the design region and the pile region hits the target"
        ctx.store.set_stage("optimize", "failed", {"error": err}, inputs_hash=h)
        raise StudyError(err)
    cands = []
    for s in res.solutions:
        full = ctx.full(s.actual or {})
        cands.append(Candidate(
            params={n: float(s.actual[n]) for n in names},  # type: ignore[index]
            predicted_aor_deg=float(s.predicted) + offset,
            pi_low_deg=float(s.pi[0]) + offset if math.isfinite(s.pi[0]) else None,
            pi_high_deg=float(s.pi[1]) + offset if math.isfinite(s.pi[1]) else None,
            p_pile=float(clf.p_pile([full])[0]), desirability=float(s.desirability)))
    found = Optimum(target_aor_deg=ctx.target, candidates=cands, chosen=cands[0].params,
                    predicted_aor_deg=cands[0].predicted_aor_deg, classifier=clf.describe(),
                    opts=opts_json)
    return _store_optimum(ctx, _in_round(found, k, measured), h)


def _in_round(found: Optimum, k: int, measured: Offset) -> Optimum:
    """``found`` as the optimum of round ``k``: a refinement round's also says which offset
    it was aimed by (round 1 stores what it always did)."""
    if k == 1:
        return found
    return replace(found, round=k, surface_offset_deg=measured.applied,
                   offset_from_rounds=measured.rounds, measured_offset_deg=measured.deg,
                   offset_weight=measured.weight)


def _store_optimum(ctx: Context, found: Optimum, h: str) -> Optimum:
    stored = found.in_round(ctx.rounds.optimize)
    ctx.store.set_stage("optimize", "done", stored.to_summary(), inputs_hash=h)
    ctx.results["optimize"] = stored
    return stored


#: how far (deg) the current surface may put a stored optimum from the target and still keep it
KEEP_OPTIMUM_TOL_DEG = 1e-6


def _stored_optimum(prior: Optimum | None, target: tuple[float, float], model: Any,
                    constraint: Any, opts: dict[str, Any]) -> Optimum | None:
    """The stored optimum of this round (``prior``, or None) if it still solves the current
    problem.

    The optimizer is numerical: the same runs refitted on another machine (other BLAS, other
    numpy) move its answer in the 8th digit, and the verification's stored runs, keyed by
    their exact parameters, would be run again. A stored optimum is kept when the stage
    finished for the same target and settings (``opts``; summaries written before they were
    stored count as the same), its factors are the model's, the current surface predicts the
    target there within :data:`KEEP_OPTIMUM_TOL_DEG` and it lies inside the pile region. A
    surface fitted to other runs moves the prediction far more and the optimum is found anew.
    ``target`` is (the target, what the surface must read: the target less a refinement
    round's offset).
    """
    if prior is None:
        return None
    if (prior.target_aor_deg != target[0] or (prior.opts is not None and prior.opts != opts)
            or set(prior.chosen) != set(model.names) or prior.responses is not None):
        # (responses: the optimum of a study that aimed at several: not this one's)
        return None
    x = np.array([[float(prior.chosen[n]) for n in model.names]])
    if abs(float(model.predict(x, units="actual")[0]) - target[1]) > KEEP_OPTIMUM_TOL_DEG:
        return None
    return prior if bool(np.all(constraint(x))) else None


# ------------------------------------------------------------------------------ verification
def verification(ctx: Context) -> dict[str, Any]:
    """Replicate runs at the chosen optimum, on fresh seeds: mean, spread, error to the target.

    Starts with ``stages.verification.n`` runs; while the 95 % interval of the mean is wider
    than ``half_width_deg`` either side, or would be at the response surface's pure error
    (the test's scatter measured with many degrees of freedom), adds the runs needed, up to
    ``max_n`` (:func:`verification_size`).
    """
    opts = ctx.study.stages.verification
    params = ctx.full(ctx.results["optimize"].chosen)
    sigma, sigma_df = pure_error_std(ctx.results.get("_rsm_model"))
    k = ctx.rounds.number
    h = ctx.begin("verification", {"params": params, "n": opts.n,
                                   **({"round": k} if k > 1 else {})})
    n = opts.n
    while True:
        pts = [Point(0, i, params, verification_seed(ctx.study.seed, k, i)) for i in range(n)]
        recs = ctx.run("verification", pts)
        aors = [r.aor_deg if r.outcome == "pile" else None for r in recs]
        vals = np.array([a for a in aors if a is not None])
        if opts.half_width_deg is None or vals.size < 2 or vals.size < len(recs):
            break
        want = verification_size(vals, opts.half_width_deg, max(opts.max_n, opts.n), sigma)
        if want <= n:
            break
        n = want
    mean = float(vals.mean()) if vals.size else None
    std = float(vals.std(ddof=1)) if vals.size > 1 else (0.0 if vals.size else None)
    rel = None if mean is None else abs(mean - ctx.target) / ctx.target * 100.0
    png = next((r.artefacts.get("pile_png") for r in recs if r.artefacts.get("pile_png")), None)
    hw = interval_half_width(vals)
    model = ctx.results.get("_rsm_model")
    tol = opts.tolerance_percent
    checks = several.check_responses(ctx, recs) if ctx.several else None
    ver = Verification(
        params=params, aor_deg=aors, outcomes=[r.outcome for r in recs], aor_mean_deg=mean,
        aor_std_deg=std, relative_error_percent=rel, n=n, n_piles=int(vals.size),
        pile_png=png, half_width_deg=hw if math.isfinite(hw) else None,
        half_width_goal_deg=opts.half_width_deg,
        half_width_reached=bool(opts.half_width_deg is not None and hw <= opts.half_width_deg),
        sized_with_std_deg=sigma, sized_with_df=sigma_df,
        **compare_to_target(vals, ctx.target, ctx.target_std, ctx.target_n),
        tolerance_percent=tol,
        within_tolerance=None if tol is None or rel is None else bool(rel <= tol),
        **confirmation(model, ctx.results["optimize"].chosen, vals,
                       offset=ctx.rounds.offset(model)),
        responses=None if checks is None else {
            name: ResponseVerification.from_summary(c.to_dict()) for name, c in checks.items()},
        round=k if k > 1 else None)
    summary = with_rounds(ver.to_summary(), ctx.rounds.verification)
    ctx.store.set_stage("verification", "done", summary, inputs_hash=h)
    ctx.results["verification"] = summary
    return summary
