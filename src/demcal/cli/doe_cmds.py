"""``demcal design``, ``demcal analyze`` and ``demcal optimize``: the DoE statistics on files.

Run sheets are CSV files. Columns ``run``, ``std``, ``point_type`` and ``block`` are
bookkeeping; every other column but the response is a factor unless ``--columns`` names the
factors. Factor values are coded (-1 .. +1) unless a factors file is given (then actual; say
``--units coded`` for a coded sheet with a factors file, to get actual-unit coefficients).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import numpy as np
import typer
from rich.table import Table

from demcal import doe
from demcal.cli import app
from demcal.cli._common import (
    check_output_file,
    cli_errors,
    console,
    log,
    styled,
    with_options,
)
from demcal.cli._outputs import refuse_overwrites
from demcal.cli.optimize_goals import GoalsRun, check_goal_options, optimize_goals
from demcal.doe.goal import REACHED
from demcal.errors import InputError
from demcal.limits import MAX_DESIGN_RUNS, MAX_SEED, check_finite
from demcal.safety import regular_input, repeated_column

if TYPE_CHECKING:  # pandas loads when a sheet is read, not with `demcal --help`
    import pandas as pd

BOOKKEEPING = ("run", "std", "point_type", "block")

design_app = typer.Typer(
    name="design",
    help="Write a run sheet (CSV: run order, actual and coded columns) for a design.",
    no_args_is_help=True,
)
app.add_typer(design_app, name="design")

FactorsOpt = Annotated[
    Path, typer.Option("--factors", help="Factors TOML file (\\[factors.NAME] low/high).")
]
OutOpt = Annotated[Path | None, typer.Option("--out", help="Write the run sheet to this CSV file.")]
SeedOpt = Annotated[int | None, typer.Option("--seed", help="Seed of the random run order.")]
RandOpt = Annotated[
    bool, typer.Option("--randomize/--no-randomize", help="Randomise the run order.")
]


# ------------------------------------------------------------------------------------ helpers
def _bounded(value: float | None, option: str, lo: float, hi: float) -> None:
    """Refuse (one line) a number outside [lo, hi] or not finite; None passes."""
    if value is None:
        return
    if not (math.isfinite(value) and lo <= value <= hi):
        raise InputError(f"{option} must be in {lo:.6g}..{hi:.12g}; got {value!r}")


def _fmt(v: Any, digits: int = 4) -> str:
    if v is None:
        return ""
    if isinstance(v, float | np.floating):
        if not math.isfinite(v):
            return ""
        return f"{v:.{digits}g}" if abs(v) >= 1e-3 or v == 0 else f"{v:.3e}"
    return str(v)


def _fmt_p(p: float) -> str:
    if p is None or not math.isfinite(p):
        return ""
    return "< 0.0001" if p < 1e-4 else f"{p:.4f}"


def _parse_assignments(text: str | None, option: str) -> dict[str, float]:
    """``"x3=0.1,x4=0.03"`` -> {"x3": 0.1, "x4": 0.03}."""
    out: dict[str, float] = {}
    if not text:
        return out
    for item in text.split(","):
        item = item.strip()
        if not item:
            continue
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise InputError(
                f"{option}: expected NAME=VALUE pairs separated by commas; got {item!r}"
            )
        try:
            number = float(value)
        except ValueError:
            raise InputError(
                f"{option}: value of {name.strip()!r} must be a number; got {value!r}"
            ) from None
        if not math.isfinite(number):
            raise InputError(
                f"{option}: value of {name.strip()!r} must be a finite number; got {value!r}"
            )
        out[name.strip()] = number
    return out


def _parse_ranges(text: str | None, option: str) -> dict[str, tuple[float, float]]:
    """``"x3=0.55:0.65,x4=0.1:0.15"`` -> {"x3": (0.55, 0.65), ...}."""
    out: dict[str, tuple[float, float]] = {}
    if not text:
        return out
    for item in text.split(","):
        name, sep, value = item.strip().partition("=")
        lo, sep2, hi = value.partition(":")
        try:
            if not sep or not sep2:
                raise ValueError
            out[name.strip()] = (check_finite(lo, "low"), check_finite(hi, "high"))
        except ValueError:
            raise InputError(
                f"{option}: expected NAME=LOW:HIGH pairs; got {item.strip()!r}"
            ) from None
    return out


def _write_sheet(design: doe.Design, out: Path | None) -> None:
    frame = design.to_frame()
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        frame.to_csv(out, index=False, float_format="%.10g")
        log.info("wrote %s", out)
    table = Table(title=f"{design.kind.replace('_', ' ')}: {design.n_runs} runs")
    for c in frame.columns:
        table.add_column(str(c), justify="right")
    for _, row in frame.iterrows():
        table.add_row(*[_fmt(v, 6) for v in row.tolist()])
    console.print(table)
    for key, value in design.info.items():
        if key in ("aliases", "letters") or value is None:
            continue
        console.print(f"{key}: {value}", highlight=False)
    aliases = design.info.get("aliases")
    if aliases:
        console.print("aliases (effects of order <= 3):", highlight=False)
        for eff, al in aliases.items():
            console.print(
                f"  [{eff}] = [{eff}] + " + " + ".join(f"[{a}]" for a in al)
                if al
                else f"  [{eff}]",
                highlight=False,
            )
    if out is not None:
        console.print(f"run sheet written to {out}", highlight=False)


def _read_csv(path: Path) -> pd.DataFrame:
    if not path.exists():
        raise InputError(f"runs file {str(path)!r} does not exist")
    regular_input(path, "runs file")  # a named pipe would block the read
    import pandas as pd
    try:
        frame = pd.read_csv(path, skipinitialspace=True)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise InputError(f"runs file {str(path)!r} is not a readable CSV: {exc}") from None
    if (twice := repeated_column(path)) is not None:
        raise InputError(f"runs file {str(path)!r}: the column {twice!r} appears twice in the "
                         "header; give each column one name")
    frame.columns = [str(c).strip() for c in frame.columns]
    if frame.empty:
        raise InputError(f"runs file {str(path)!r} has no rows")
    return frame


@dataclass(frozen=True)
class SurfaceRequest:
    """What ``analyze``, ``optimize`` and ``design steepest`` fit: the run sheet, the
    response column, the model, the factors file, the factor columns (comma-separated; None:
    the factors file's, else the ``_coded`` columns, else every other column), their units
    and an optional block column."""

    runs: Path
    response: str
    model: str
    factors: Path | None = None
    columns: str | None = None
    units: str | None = None
    block: str | None = None


def _load_surface(req: SurfaceRequest) -> doe.ResponseSurface:
    """Read a run sheet and fit the model (the shared front half of analyze and optimize)."""
    import pandas as pd

    frame = _read_csv(req.runs)
    if req.block is not None and req.block not in frame.columns:
        raise InputError(f"--block: column {req.block!r} not found in {req.runs.name}; "
                         "columns: " + ", ".join(frame.columns))
    y = _response_values(frame, req)
    space = doe.load_factors(req.factors) if req.factors is not None else None
    names = _factor_columns(frame, req, space)
    x = frame[names].copy()
    renamed = {c: c[: -len("_coded")] for c in names if c.endswith("_coded")}
    x = x.rename(columns=renamed)
    units = "coded" if renamed and req.units is None else req.units
    if "run" in frame.columns and frame["run"].notna().all():
        x.index = pd.Index(frame["run"].tolist())
    else:
        x.index = pd.RangeIndex(1, len(frame) + 1)
    if units not in (None, "coded", "actual"):
        raise InputError(f"--units must be 'coded' or 'actual'; got {units!r}")
    if req.model not in doe.MODELS:
        raise InputError(f"--model must be one of {', '.join(doe.MODELS)}; got {req.model!r}")
    return doe.fit(
        x, y, model=req.model, factors=space,
        units=units,  # type: ignore[arg-type]
        response_name=req.response,
        blocks=frame[req.block].tolist() if req.block is not None else None,
    )


def _response_values(frame: pd.DataFrame, req: SurfaceRequest) -> np.ndarray:
    """The response column as floats (an empty cell: NaN, a run without a result); a column
    that is missing or holds text is an input error naming the first bad row."""
    import pandas as pd

    response = req.response
    if response not in frame.columns:
        raise InputError(f"--response: column {response!r} not found in {req.runs.name}; "
                         "columns: " + ", ".join(frame.columns))
    y = pd.to_numeric(frame[response], errors="coerce")
    bad = y.isna() & frame[response].notna() & (frame[response].astype(str).str.strip() != "")
    if bad.any():
        raise InputError(
            f"--response: column {response!r} is not numeric "
            f"(row {int(np.flatnonzero(bad)[0]) + 1}: "
            f"{frame[response][bad].iloc[0]!r}); leave a cell empty for a run without a result"
        )
    return y.to_numpy(dtype=float)


def _factor_columns(frame: pd.DataFrame, req: SurfaceRequest,
                    space: doe.FactorSpace | None) -> list[str]:
    """The sheet's factor columns: ``--columns``, else the factors file's free factors, else
    the ``_coded`` columns, else every column but the response, the block and the sheet's
    bookkeeping; each checked to exist and to be neither the response nor the block."""
    if req.columns:
        names = [c.strip() for c in req.columns.split(",") if c.strip()]
    elif space is not None:
        names = list(space.free.names)
    else:
        names = [c for c in frame.columns if c.endswith("_coded")] or [
            c for c in frame.columns
            if c not in (req.response, req.block) and c not in BOOKKEEPING]
    if not names:
        raise InputError("--columns: no factor columns left in the runs file")
    missing = [n for n in names if n not in frame.columns]
    if missing:
        raise InputError(
            f"--columns: column(s) {', '.join(missing)} not found in {req.runs.name}; columns: "
            + ", ".join(frame.columns)
        )
    if req.response in names:
        raise InputError(f"--columns: the response {req.response!r} cannot be a factor")
    if req.block is not None and req.block in names:
        raise InputError(f"--block: the block column {req.block!r} cannot be a factor")
    return names


def _is_two_level(rs: doe.ResponseSurface) -> bool:
    return bool(np.all(np.isclose(np.abs(rs.coded), 1.0)))


def _clean(v: Any) -> Any:
    if isinstance(v, float | np.floating):
        return float(v) if math.isfinite(v) else None
    if isinstance(v, np.integer):
        return int(v)
    return v


def analysis_dict(rs: doe.ResponseSurface) -> dict[str, Any]:
    """The JSON document of ``demcal analyze`` (also used by the tests)."""
    table = rs.anova()
    coded = {k: _clean(v) for k, v in rs.coefficients_coded.items()}
    if rs.factors is not None:
        actual = {k: _clean(v) for k, v in rs.coefficients_actual.items()}
    else:  # no levels: the columns' own units are the coded ones
        actual = dict(coded)
    out: dict[str, Any] = {
        "response": rs.response_name,
        "model": rs.model,
        "factors": list(rs.names),
        "terms": list(rs.term_names),
        "n_runs": rs.n_runs,
        "excluded_runs": [_clean(v) for v in rs.excluded_runs],
        "coefficients_coded": coded,
        "coefficients_actual": actual,
        "standard_errors": {k: _clean(v) for k, v in rs.bse.items()},
        "vif": {k: _clean(v) for k, v in rs.vif.items()},
        "anova": table.to_records(),
        "fit": {
            "std_dev": _clean(rs.std_dev),
            "mean": _clean(rs.mean),
            "cv_percent": _clean(rs.cv_percent),
            "press": _clean(rs.press),
            "r2": _clean(rs.r2),
            "adj_r2": _clean(rs.adj_r2),
            "pred_r2": _clean(rs.pred_r2),
            "adeq_precision": _clean(rs.adeq_precision),
        },
        "equation_coded": rs.equation(units="coded"),
    }
    if rs.factors is not None:
        out["equation_actual"] = rs.equation(units="actual")
    if rs.model == "linear" and _is_two_level(rs):
        eff = rs.effects()
        out["effects"] = [
            {
                "term": str(t),
                "effect": _clean(r["effect"]),
                "ss": _clean(r["ss"]),
                "contribution_percent": _clean(r["contribution_percent"]),
                "f": _clean(r["f"]),
                "p": _clean(r["p"]),
                "rank": int(r["rank"]),
            }
            for t, r in eff.iterrows()
        ]
    return out


def _coefficients_table(rs: doe.ResponseSurface) -> Table:
    """Each term's coded coefficient, standard error and VIF, and its actual coefficient
    where the model has factors."""
    c = Table(title="Coefficients")
    c.add_column("Term")
    c.add_column("Coded", justify="right")
    c.add_column("Std. Error", justify="right")
    c.add_column("VIF", justify="right")
    if rs.factors is not None:
        c.add_column("Actual", justify="right")
    vif = rs.vif
    for name, b in rs.coefficients_coded.items():
        row = [str(name), _fmt(b, 5), _fmt(rs.bse[name], 4), _fmt(vif.get(name, float("nan")), 4)]
        if rs.factors is not None:
            row.append(_fmt(rs.coefficients_actual[name], 6))
        c.add_row(*row)
    return c


def _print_analysis(rs: doe.ResponseSurface) -> None:
    table = rs.anova()
    if rs.excluded_runs:
        console.print(
            f"excluded {len(rs.excluded_runs)} run(s) without a response: "
            + ", ".join(str(v) for v in rs.excluded_runs),
            highlight=False,
        )
    t = Table(title=f"ANOVA, {rs.model} model of {rs.response_name} (partial SS, Type III)")
    for c in ("Source", "Sum of Squares", "df", "Mean Square", "F Value", "p-value", ""):
        t.add_column(c, justify="left" if c == "Source" else "right")
    for r in table.rows:
        t.add_row(
            r.source,
            _fmt(r.ss, 6),
            str(r.df),
            _fmt(r.ms, 6),
            _fmt(r.f),
            _fmt_p(r.p),
            r.significance,
        )
    console.print(t)
    console.print("** p < 0.01, * p < 0.05", highlight=False)
    f = table.fit
    s = Table(title="Fit statistics", show_header=False)
    s.add_column("statistic")
    s.add_column("value", justify="right")
    for label, v in (
        ("Std. Dev.", f.std_dev),
        ("Mean", f.mean),
        ("C.V. %", f.cv_percent),
        ("PRESS", f.press),
        ("R-Squared", f.r2),
        ("Adj R-Squared", f.adj_r2),
        ("Pred R-Squared", f.pred_r2),
        ("Adeq Precision", f.adeq_precision),
    ):
        s.add_row(label, _fmt(v, 5))
    console.print(s)
    console.print(_coefficients_table(rs))
    if rs.model == "linear" and _is_two_level(rs):
        eff = rs.effects()
        e = Table(title="Screening effects (Pareto order)")
        for col in ("Rank", "Term", "Effect", "SS", "% Contribution", "p-value", ""):
            e.add_column(col, justify="right")
        for term, r in eff.iterrows():
            e.add_row(
                str(r["rank"]),
                str(term),
                _fmt(r["effect"]),
                _fmt(r["ss"]),
                _fmt(r["contribution_percent"]),
                _fmt_p(r["p"]),
                r["significance"],
            )
        console.print(e)


# ----------------------------------------------------------------------------------- designs
@design_app.command("pb")
@cli_errors
def design_pb(
    factors: FactorsOpt,
    runs: Annotated[int | None, typer.Option("--runs", help="Runs: multiple of 4, 8-48.")] = None,
    out: OutOpt = None,
    seed: SeedOpt = None,
    randomize: RandOpt = True,
) -> None:
    """Plackett-Burman screening design (unused columns are dummies)."""
    _bounded(seed, "--seed", 0, MAX_SEED)
    _bounded(runs, "--runs", 1, MAX_DESIGN_RUNS)
    space = doe.load_factors(factors)
    _write_sheet(doe.plackett_burman(space, n_runs=runs, randomize=randomize, seed=seed), out)


@design_app.command("bbd")
@cli_errors
def design_bbd(
    factors: FactorsOpt,
    center_points: Annotated[
        int | None,
        typer.Option("--center-points", help="Centre runs (default 5; 6 for 6-7 factors)."),
    ] = None,
    out: OutOpt = None,
    seed: SeedOpt = None,
    randomize: RandOpt = True,
) -> None:
    """Box-Behnken design (3-7 varied factors)."""
    _bounded(seed, "--seed", 0, MAX_SEED)
    _bounded(center_points, "--center-points", 0, 1000)
    space = doe.load_factors(factors)
    d = doe.box_behnken(space, center_points=center_points, randomize=randomize, seed=seed)
    _write_sheet(d, out)


@dataclass(frozen=True)
class CcdOptions:
    """The options of ``demcal design ccd``, typed
    (:func:`~demcal.cli._common.with_options`)."""

    factors: FactorsOpt
    kind: Annotated[
        str, typer.Option("--kind", help="circumscribed, inscribed or face.")
    ] = "circumscribed"
    alpha: Annotated[
        str, typer.Option("--alpha", help="rotatable, orthogonal or a number.")
    ] = "rotatable"
    center_points: Annotated[
        int | None, typer.Option("--center-points", help="Centre runs.")
    ] = None
    generators: Annotated[
        str | None, typer.Option("--generators", help="Fractional core, e.g. 'E=ABCD'.")
    ] = None
    out: OutOpt = None
    seed: SeedOpt = None
    randomize: RandOpt = True


@design_app.command("ccd")
@cli_errors
@with_options(CcdOptions)
def design_ccd(o: CcdOptions) -> None:
    """Central composite design."""
    _bounded(o.seed, "--seed", 0, MAX_SEED)
    _bounded(o.center_points, "--center-points", 0, 1000)
    space = doe.load_factors(o.factors)
    a: Any = o.alpha
    if o.alpha not in ("rotatable", "orthogonal"):
        try:
            a = float(o.alpha)
        except ValueError:
            raise InputError(
                f"--alpha must be rotatable, orthogonal or a number; got {o.alpha!r}"
            ) from None
    d = doe.central_composite(
        space,
        kind=o.kind,  # type: ignore[arg-type]
        alpha=a,
        center_points=o.center_points,
        generators=o.generators,
        randomize=o.randomize,
        seed=o.seed,
    )
    _write_sheet(d, o.out)


@dataclass(frozen=True)
class FactorialOptions:
    """The options of ``demcal design factorial``, typed
    (:func:`~demcal.cli._common.with_options`)."""

    factors: FactorsOpt
    fraction: Annotated[int, typer.Option("--fraction", help="p of a 2^(k-p) fraction.")] = 0
    generators: Annotated[
        str | None, typer.Option("--generators", help="e.g. 'E=ABC F=BCD' (letters A, B, ...).")
    ] = None
    center_points: Annotated[int, typer.Option("--center-points", help="Centre runs.")] = 0
    out: OutOpt = None
    seed: SeedOpt = None
    randomize: RandOpt = True


@design_app.command("factorial")
@cli_errors
@with_options(FactorialOptions)
def design_factorial(o: FactorialOptions) -> None:
    """Two-level full or fractional factorial (resolution and aliases are printed)."""
    _bounded(o.seed, "--seed", 0, MAX_SEED)
    _bounded(o.center_points, "--center-points", 0, 1000)
    space = doe.load_factors(o.factors)
    d = doe.factorial(
        space,
        fraction=o.fraction,
        generators=o.generators,
        center_points=o.center_points,
        randomize=o.randomize,
        seed=o.seed,
    )
    _write_sheet(d, o.out)


@design_app.command("lhs")
@cli_errors
def design_lhs(
    factors: FactorsOpt,
    runs: Annotated[int, typer.Option("--runs", help="Number of points.")],
    out: OutOpt = None,
    seed: SeedOpt = None,
) -> None:
    """Latin hypercube sample of the factor box."""
    _bounded(seed, "--seed", 0, MAX_SEED)
    _bounded(runs, "--runs", 1, MAX_DESIGN_RUNS)
    _write_sheet(doe.latin_hypercube(doe.load_factors(factors), runs, seed=seed), out)


@design_app.command("sobol")
@cli_errors
def design_sobol(
    factors: FactorsOpt,
    runs: Annotated[int, typer.Option("--runs", help="Number of points (power of 2 best).")],
    out: OutOpt = None,
    seed: SeedOpt = None,
) -> None:
    """Scrambled Sobol sequence over the factor box."""
    _bounded(seed, "--seed", 0, MAX_SEED)
    _bounded(runs, "--runs", 1, MAX_DESIGN_RUNS)
    _write_sheet(doe.sobol(doe.load_factors(factors), runs, seed=seed), out)


@dataclass(frozen=True)
class SteepestOptions:
    """The options of ``demcal design steepest``, typed
    (:func:`~demcal.cli._common.with_options`)."""

    factors: FactorsOpt
    from_runs: Annotated[
        Path | None,
        typer.Option("--from-runs", help="Screening run sheet to fit a first-order model on."),
    ] = None
    response: Annotated[
        str | None, typer.Option("--response", help="Response column of --from-runs.")
    ] = None
    runs_factors: Annotated[
        Path | None,
        typer.Option("--runs-factors", help="Factors of --from-runs if its values are actual."),
    ] = None
    coef: Annotated[
        str | None, typer.Option("--coef", help="Coded coefficients instead: 'x3=1.29,x4=1.83'.")
    ] = None
    move: Annotated[
        str | None, typer.Option("--move", help="Factors that move, e.g. 'x3,x4,x8'.")
    ] = None
    steps: Annotated[
        str | None, typer.Option("--steps", help="Per-factor steps: 'x3=0.1,x4=0.03'.")
    ] = None
    step: Annotated[
        float, typer.Option("--step", help="Step of the largest-effect factor (proportional).")
    ] = 1.0
    start: Annotated[
        str | None, typer.Option("--start", help="First point: 'x3=0.35,x4=0.03'.")
    ] = None
    points: Annotated[int, typer.Option("--points", help="Runs on the path.")] = 5
    units: Annotated[
        str, typer.Option("--units", help="Units of steps/start: coded or actual.")
    ] = "actual"
    direction: Annotated[str, typer.Option("--direction", help="ascent or descent.")] = "ascent"
    out: OutOpt = None


@design_app.command("steepest")
@cli_errors
@with_options(SteepestOptions)
def design_steepest(o: SteepestOptions) -> None:
    """Path of steepest ascent/descent from a screening fit or given coefficients."""
    _bounded(o.points, "--points", 2, 1000)
    _bounded(o.step, "--step", -1e6, 1e6)
    space = doe.load_factors(o.factors)
    if (o.from_runs is None) == (o.coef is None):
        raise InputError("give either --from-runs (with --response) or --coef")
    if o.from_runs is not None:
        if not o.response:
            raise InputError("--response is required with --from-runs")
        rs = _load_surface(SurfaceRequest(o.from_runs, o.response, "linear", o.runs_factors))
        coefficients: Any = {k: v for k, v in rs.coefficients_coded.items() if k in rs.names}
    else:
        coefficients = _parse_assignments(o.coef, "--coef")
    d = doe.steepest_path(
        coefficients,
        factors=space,
        n_points=o.points,
        step=o.step,
        steps=_parse_assignments(o.steps, "--steps") or None,
        move=[m.strip() for m in o.move.split(",")] if o.move else None,
        start=_parse_assignments(o.start, "--start") or None,
        direction=o.direction,  # type: ignore[arg-type]
        units=o.units,  # type: ignore[arg-type]
    )
    _write_sheet(d, o.out)


# ------------------------------------------------------------------------- analyze / optimize
ResponseOpt = Annotated[str, typer.Option("--response", help="Response column.")]
ModelOpt = Annotated[str, typer.Option("--model", help="linear, 2fi or quadratic.")]
FactorsFileOpt = Annotated[
    Path | None,
    typer.Option("--factors", help="Factors TOML: factor columns and actual units."),
]
ColumnsOpt = Annotated[
    str | None, typer.Option("--columns", help="Factor columns, e.g. 'x3,x4,x8'.")
]
UnitsOpt = Annotated[
    str | None,
    typer.Option(
        "--units",
        help="Units of the factor columns: coded or actual (default: actual with --factors).",
    ),
]
JsonOpt = Annotated[Path | None, typer.Option("--json", help="Write the results as JSON here.")]


@dataclass(frozen=True)
class AnalyzeOptions:
    """The options of ``demcal analyze``, typed (:func:`~demcal.cli._common.with_options`)."""

    runs: Annotated[Path, typer.Argument(help="Run sheet (CSV) with a response column.")]
    response: ResponseOpt
    model: ModelOpt = "quadratic"
    factors: FactorsFileOpt = None
    columns: ColumnsOpt = None
    units: UnitsOpt = None
    reduce: Annotated[
        float | None,
        typer.Option("--reduce", help="Backward elimination (hierarchical) with this alpha out."),
    ] = None
    block: Annotated[
        str | None,
        typer.Option("--block", help="Block column (Design-Expert's blocks, e.g. the seed set "
                     "or day of each run); every block must hold the same design points."),
    ] = None
    json_out: JsonOpt = None


@app.command("analyze")
@cli_errors
@with_options(AnalyzeOptions)
def analyze(o: AnalyzeOptions) -> None:
    """Fit a model to a run sheet and print Design-Expert's ANOVA and fit statistics."""
    check_output_file(o.json_out, "--json", make_parents=True)
    refuse_overwrites({"--json": o.json_out}, [(o.runs, "the run sheet"), (o.factors, "factors")])
    rs = _load_surface(SurfaceRequest(o.runs, o.response, o.model, o.factors, o.columns,
                                      o.units, o.block))
    if o.reduce is not None:
        rs = rs.reduce(alpha_out=o.reduce)
    _print_analysis(rs)
    if not rs.ss_total > 0:  # 0/0 above: say why every statistic is 0 or n/a
        console.print(f"note: {o.response} does not vary (every run gave the same value): there "
                      "is no effect to estimate", highlight=False)
    if o.json_out is not None:
        o.json_out.parent.mkdir(parents=True, exist_ok=True)
        o.json_out.write_text(json.dumps(analysis_dict(rs), indent=2))
        console.print(f"results written to {o.json_out}", highlight=False)


def _optimize_headline(frame: Any, response: str, target: float, model: str) -> str:
    """The solutions table's title; a target no setting reaches (every desirability 0:
    every prediction outside the limits) is called unreachable, and one the best setting
    only approaches (desirability below :data:`~demcal.doe.goal.REACHED`) not reached, never
    "predicted to give"."""
    best = float(frame["desirability"].max()) if len(frame) else 0.0
    if best >= REACHED:
        return f"Settings predicted to give {response} = {target:g} ({model} model)"
    closest = "" if not len(frame) else \
        f"; the closest settings predict {float(frame['predicted'].iloc[0]):.5g}"
    if best > 0:
        return (f"Target {response} = {target:g} is not reached within the factors' ranges "
                f"({model} model, best desirability {best:.3g}{closest})")
    return (f"Target {response} = {target:g} is unreachable within the factors' ranges "
            f"({model} model, desirability 0{closest})")


@dataclass(frozen=True)
class OptimizeOptions:
    """The options of ``demcal optimize``, typed (:func:`~demcal.cli._common.with_options`)."""

    runs: Annotated[Path, typer.Argument(help="Run sheet (CSV) with a response column.")]
    response: Annotated[str | None, typer.Option("--response", help="Response column.")] = None
    target: Annotated[
        float | None, typer.Option("--target", help="Target response value.")
    ] = None
    goals: Annotated[
        Path | None,
        typer.Option("--goals", help="Several responses at once: a TOML file of "
                     "[\\[responses]] (name, goal, low, high, target, weight, importance, model)."),
    ] = None
    model: ModelOpt = "quadratic"
    factors: FactorsFileOpt = None
    columns: ColumnsOpt = None
    units: UnitsOpt = None
    fix: Annotated[
        str | None, typer.Option("--fix", help="Hold factors: 'x3=0.55' (actual with --factors).")
    ] = None
    ranges: Annotated[
        str | None, typer.Option("--range", help="Search ranges: 'x4=0.1:0.15'.")
    ] = None
    near: Annotated[
        str | None, typer.Option("--near", help="Prefer solutions near 'x3=0.6,x4=0.12'.")
    ] = None
    lower: Annotated[
        float | None, typer.Option("--lower", help="Desirability lower limit.")
    ] = None
    upper: Annotated[
        float | None, typer.Option("--upper", help="Desirability upper limit.")
    ] = None
    solutions: Annotated[int, typer.Option("--solutions", help="Distinct solutions to list.")] = 5
    seed: Annotated[int, typer.Option("--seed", help="Seed of the starting points.")] = 0
    json_out: JsonOpt = None


@app.command("optimize")
@cli_errors
@with_options(OptimizeOptions)
def optimize_cmd(o: OptimizeOptions) -> None:
    """Propose factor settings whose predicted response hits --target (ranked), or that
    maximise the overall desirability of several responses (--goals)."""
    check_output_file(o.json_out, "--json", make_parents=True)
    refuse_overwrites({"--json": o.json_out}, [(o.runs, "the run sheet"), (o.factors, "factors"),
                                             (o.goals, "the goals")])
    check_goal_options(o.goals, o.response, o.target)
    if o.goals is not None:
        _bounded(o.solutions, "--solutions", 1, 1000)
        _bounded(o.seed, "--seed", 0, MAX_SEED)
        run = GoalsRun(o.runs, o.goals, o.model, lambda name, mdl, cols: _load_surface(
            SurfaceRequest(o.runs, name, mdl, o.factors, cols, o.units)))
        optimize_goals(run, o.columns, o.solutions, o.seed, o.json_out)
        return
    assert o.response is not None and o.target is not None  # check_goal_options
    for value, option in ((o.target, "--target"), (o.lower, "--lower"), (o.upper, "--upper")):
        _bounded(value, option, -1e300, 1e300)
    _bounded(o.solutions, "--solutions", 1, 1000)
    _bounded(o.seed, "--seed", 0, MAX_SEED)
    rs = _load_surface(SurfaceRequest(o.runs, o.response, o.model, o.factors, o.columns,
                                      o.units))
    res = doe.optimize_target(
        rs,
        o.target,
        lower=o.lower,
        upper=o.upper,
        fixed=_parse_assignments(o.fix, "--fix") or None,
        bounds=_parse_ranges(o.ranges, "--range") or None,
        near=_parse_assignments(o.near, "--near") or None,
        n_solutions=o.solutions,
        seed=o.seed,
    )
    frame = res.to_frame()
    t = Table(title=_optimize_headline(frame, o.response, o.target, rs.model))
    for c in ("rank", *rs.names, "predicted", "desirability", "95% CI", "95% PI"):
        t.add_column(c, justify="right")
    for _, row in frame.iterrows():
        t.add_row(
            str(row["rank"]),
            *[_fmt(row[n], 4) for n in rs.names],
            _fmt(row["predicted"], 5),
            f"{row['desirability']:.3f}",
            f"{row['ci_low']:.4g}-{row['ci_high']:.4g}",
            f"{row['pi_low']:.4g}-{row['pi_high']:.4g}",
        )
    console.print(t)
    console.print(
        f"desirability limits: lower {res.lower:g}, target {res.target:g}, upper {res.upper:g}; "
        f"95 % CI of the mean and PI of one run",
        highlight=False,
    )
    if res.outside:
        console.print(styled(("warning:", "yellow"), f" {', '.join(res.outside)} held or "
                             "searched outside the design's range (--fix, --range): the model "
                             "extrapolates there, and its predictions are a guess"))
    if o.json_out is not None:
        doc = {
            "response": o.response,
            "model": rs.model,
            "target": o.target,
            "lower": res.lower,
            "upper": res.upper,
            "excluded_runs": [_clean(v) for v in rs.excluded_runs],
            "outside_design": list(res.outside),
            "solutions": [
                {k: _clean(v) for k, v in rec.items()} for rec in frame.to_dict(orient="records")
            ],
        }
        o.json_out.parent.mkdir(parents=True, exist_ok=True)
        o.json_out.write_text(json.dumps(doc, indent=2))
