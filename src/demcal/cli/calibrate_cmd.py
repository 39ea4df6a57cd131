"""``demcal calibrate``, ``demcal init`` and ``demcal import``: run a calibration study."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import typer
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from rich.table import Table

from demcal.calibrate.study import Study, study_folder
from demcal.cli import app
from demcal.cli._common import (
    EXIT_INTERRUPTED,
    EXIT_TERMINATED,
    check_output_dir,
    check_output_file,
    check_report_problems,
    cli_errors,
    console,
    styled,
    with_options,
)
from demcal.display import readable
from demcal.errors import InputError
from demcal.summaries.result import CalibrationResult


def _print_result(result: CalibrationResult) -> None:
    table = Table(title=f"calibrated parameters ({result.study})")
    table.add_column("parameter")
    table.add_column("value", justify="right")
    for name, value in result.optimum.items():
        table.add_row(name, readable(value))
    console.print(table)
    v = result.verification
    mean = "n/a" if v.mean is None else f"{v.mean:.2f}"
    std = "n/a" if v.std is None else f"{v.std:.2f}"
    rel = "n/a" if v.relative_error_percent is None else f"{v.relative_error_percent:.2f} %"
    lead = result.lead_name
    name, u = lead.label, lead.after_number()
    predicted = "n/a" if result.predicted_lead is None else f"{result.predicted_lead:.2f}{u}"
    console.print(f"target {name} {result.target:.2f}{u}; predicted {predicted}; "
                  f"verification ({v.n} runs): {mean} +/- {std}{u}, relative error {rel}; "
                  f"{_runs_stored(result)}")
    _print_verification(result)
    _print_responses(result)
    _print_bayes(result)
    _print_surface(result)


def _print_surface(result: CalibrationResult) -> None:
    """The response surface's fit statistics and, when it is not adequate, a warning."""
    s = result.surface
    if s is None:  # the Bayesian strategy's: no response surface
        return
    if s.adequacy.known:
        a = s.adequacy

        def f(value: float | None, fmt: str) -> str:
            return "n/a" if value is None else format(value, fmt)
        console.print(f"response surface ({s.label()}): adjusted R^2 {f(a.adj_r2, '.3f')}, "
                      f"predicted R^2 {f(a.pred_r2, '.3f')}, Adeq Precision "
                      f"{f(a.adeq_precision, '.2f')}, model p {f(a.p_model, '.3g')}, lack of "
                      f"fit p {f(a.lack_of_fit_p, '.3g')}", highlight=False)
    if result.spread is not None:  # the target met far apart: one response, no point
        console.print(styled(("note:", "yellow"),
                             f" {result.spread.line(result.lead_name.after_number())}"),
                      highlight=False)
    if not s.adequate:  # None too: a surface whose adequacy could not be judged
        console.print(styled(("warning:", "yellow"), " the response-surface model is not "
                             "adequate (see the rsm stage's warnings): its optimum is a guess "
                             "within the noise"))
        if s.resolution is not None:
            console.print(f"  {s.resolution}", highlight=False)


def _runs_stored(result: CalibrationResult) -> str:
    """How many runs the store holds, how many this study used, how many ran now."""
    stored = result.n_runs
    used = stored if result.n_runs_used is None else result.n_runs_used
    other = "" if used >= stored else (
        f", {stored - used} of them not used by this study's stages (another study's, or "
        "this study's under earlier settings)")
    return f"{stored} runs stored{other} ({result.n_runs_executed} run now)"


def _print_responses(result: CalibrationResult) -> None:
    """Every response beside the angle: its lab value, the surface's prediction at the
    optimum and its verification (several-response studies)."""
    several = result.responses
    if several is None:
        return
    predicted = several.predicted  # the Bayesian strategy's: posterior means
    for name, check in (several.verification or {}).items():
        lab = (check.lab or {}).get("mean")
        verdict = {True: "consistent", False: "NOT consistent", None: "not judged"}[
            check.consistent]
        console.print(
            f"{name}: lab {readable(lab) if lab is not None else 'n/a'}; predicted "
            f"{'n/a' if predicted.get(name) is None else readable(predicted[name], 5)}; "
            f"verification ({check.n} "
            f"runs): {'n/a' if check.mean is None else readable(check.mean, 5)} +/- "
            f"{'n/a' if check.std is None else readable(check.std, 3)}, {verdict} with the lab",
            highlight=False)
    if several.desirability is not None:
        console.print(f"overall desirability at the optimum: {several.desirability:.3f}",
                      highlight=False)


def _print_bayes(result: CalibrationResult) -> None:
    """The posterior's 95 % intervals and the identifiability verdict (strategy bayes)."""
    b = result.bayes
    if b is None:
        return
    for name, p in b.posterior.items():
        console.print(f"{name}: median {p.median:.4g}, 95 % credible interval "
                      f"{p.ci95_low:.4g}-{p.ci95_high:.4g}", highlight=False)
    extra = b.verification_runs
    also = f" and {extra} of the verification rounds'" if extra else ""
    console.print(f"{b.reason} ({result.n_runs_strategy} runs{also}, stopped by "
                  f"{b.stopped})", highlight=False)
    # per ridge, the candidate that helps most (every pair: the result's shrinkage, the report)
    for line in b.advice:
        console.print(line, highlight=False)
    for line in b.warnings:  # the posterior's and its surrogates'
        console.print(styled(("warning:", "yellow"), " " + line))


def _print_rounds(result: CalibrationResult) -> None:
    """One line per verification round when the study refined its optimum."""
    rounds = result.rounds
    if len(rounds) < 2:
        return
    for r in rounds:
        mean = "n/a" if r.mean is None else f"{r.mean:.2f} deg"
        word = {True: "confirmed", False: "not confirmed", None: "no confirmation"}[
            r.confirmed]
        params = ", ".join(f"{k} {readable(v, 4)}" for k, v in r.optimum.items())
        aimed = "" if r.surface_offset is None else (
            f" (aimed by {r.surface_offset:+.2f} deg: "
            f"{1.0 if r.offset_weight is None else r.offset_weight:.2f} of the "
            f"{r.measured_offset or 0.0:+.2f} measured)")
        console.print(f"round {r.round}: {params}{aimed}: verification {mean} on "
                      f"{r.n_piles} piles, {word}", highlight=False)
    how = ("took the best point of the posterior conditioned on the earlier rounds' piles "
           "as well (stages.verification.max_rounds)" if result.strategy == "bayes"
           else "aimed the surface by the offset the earlier rounds' piles measured (all of "
           "it after an unconfirmed round, the piles' share of the information after "
           "confirmed ones; stages.verification.max_rounds)")
    console.print(f"the optimum above is round {rounds[-1].round}'s: each later round {how}",
                  highlight=False)
    if result.strategy != "bayes" and result.surface is not None and not result.surface.adequate:
        console.print(styled(("note:", "yellow"), " the surface is not adequate, so each aim "
                             "moved the optimum within the noise: the rounds' piles, not the "
                             "surface, say where the target lies"), highlight=False)


def _print_verification(result: CalibrationResult) -> None:
    """The verification against the measurement, the surface's promise and the target."""
    _print_rounds(result)
    v = result.verification
    u = result.lead_name.after_number()
    n_rounds = max(len(result.rounds), 1)
    if v.p_value is not None:
        verdict = ("consistent with", "") if v.consistent else ("differs from", "yellow")
        console.print(styled(f"verification: 95 % interval {v.ci_low:.2f}-"
                             f"{v.ci_high:.2f}{u}, ", verdict, " the measurement "
                             f"(p = {v.p_value:.3g}, {v.test})"))
    if v.confirmed is not None:
        word = ("confirmed", "") if v.confirmed else ("not confirmed", "yellow")
        console.print(styled(
            f"confirmation: the response surface"
            f"{' (corrected by the last offset)' if n_rounds > 1 else ''}"
            f" predicted {result.predicted_lead:.2f}"
            f"{u}, 95 % interval for the mean of {v.n} runs "
            f"{v.confirm_pi_low:.2f}-{v.confirm_pi_high:.2f}: ", word,
            # an inadequate surface's interval is wide: inside it says little
            " (by a surface that is not adequate: its wide interval confirms little)"
            if v.confirmed and result.surface is not None and not result.surface.adequate
            else ""))
    tol, hw, target = v.tolerance_percent, v.half_width, result.target
    if v.within_tolerance is False:
        console.print(styled(("note:", "yellow"), f" the verification misses the target by "
                             f"{v.relative_error_percent:.2f} %, more than the study's "
                             f"tolerance of {tol:g} % (after {n_rounds} round(s); raise "
                             "stages.verification.max_rounds to refine further)"),
                      highlight=False)
    if tol is not None and hw is not None and tol * target / 100 < hw:
        console.print(styled(("note:", "yellow"), f" the tolerance ({tol:g} % = "
                             f"{tol * target / 100:.2f}{u}) is narrower "
                             f"than the verification's 95 % interval (+/- {hw:.2f}{u}): "
                             "whether a round meets it is partly chance"), highlight=False)
    if v.target_in_interval is False and v.mean is not None:
        off = v.mean - target
        again = ("conditions the posterior on these piles too and verifies its new best point"
                 if result.strategy == "bayes" else
                 "aims the surface by the offset these piles measured")
        console.print(styled(("note:", "yellow"), f" the target {target:.2f}"
                             f"{u} lies outside the verification's 95 % interval: the "
                             f"calibrated {'angle' if u == ' deg' else 'value'} is "
                             f"{off:+.2f}{u} from it (after {n_rounds} round(s); with a higher "
                             f"stages.verification.max_rounds the next round {again})"),
                      highlight=False)


def _print_demonstration_worth(result: CalibrationResult) -> None:
    """The last lines of a quick-fidelity study: what its answer is worth.

    A first run of the README's main command is the quick demonstration; its verification
    (3 small piles) has a 95 % interval of about +/- 11 deg, which a newcomer easily takes for
    the product's accuracy. So its end says so, with the interval it measured, and names the
    study to run for a calibration to use.
    """
    v = result.verification
    lo, hi = v.ci_low, v.ci_high
    interval = (f"its verification's 95 % interval is {lo:.1f}-{hi:.1f} deg "
                f"(+/- {(hi - lo) / 2:.1f} deg on {v.n} piles)"
                if lo is not None and hi is not None else
                "its verification has no interval (too few piles)")
    console.print(styled(("this is a demonstration:", "yellow"),
                         f" the quick fidelity's piles are small, and {interval}, so this "
                         "answer shows the workflow, not a calibration to use. The calibration "
                         "to use is the standard study: [test] fidelity = \"standard\" "
                         "(examples/corn_stalk/study_standard.toml, docs/precision.md)"),
                  highlight=False)


def _is_quick_demonstration(study: Study) -> bool:
    """Whether a study verifies at the quick fidelity (demcal's own angle-of-repose test)."""
    return study.test.kind == "aor" and study.test.fidelity == "quick"


def _build_report(study_dir: Path) -> Path:
    from demcal.report import build_report

    return Path(build_report(study_dir))


def _refuse_json_onto_inputs(study: Path, json_out: Path | None) -> None:
    """Refuse a ``--json`` that is the study file, its store or any file the study reads
    (written at the end, it would replace them: every run lost)."""
    if json_out is None:
        return
    from demcal.calibrate.study import load_study
    from demcal.cli._outputs import refuse_overwrites, study_inputs

    refuse_overwrites({"--json": json_out}, study_inputs(study))  # before parsing the study
    refuse_overwrites({"--json": json_out}, study_inputs(study, load_study(study)))


@dataclass(frozen=True)
class CalibrateOptions:
    """The options of ``demcal calibrate``, typed (:func:`~demcal.cli._common.with_options`)."""

    study: Annotated[Path, typer.Argument(help="Study file (TOML); see `demcal init`.")]
    json_out: Annotated[Path | None, typer.Option("--json", help="Write the result as JSON.")] \
        = None
    external: Annotated[bool, typer.Option(
        "--external", help="Run nothing: write the next stage's run sheet (CSV) and stop.")] \
        = False
    dask: Annotated[str | None, typer.Option(help="Dask scheduler address (tcp://...).")] \
        = None
    dask_timeout: Annotated[float | None, typer.Option(
        "--dask-timeout", help="Give up after this many seconds with no Dask worker "
        "(default: the study's, else wait and say so).")] = None
    workers: Annotated[int | None, typer.Option(
        min=1, max=1024, help="Local worker processes, 1-1024 (default: the study's, else the "
        "CPU count).")] = None
    report: Annotated[bool, typer.Option(help="Build the HTML report at the end.")] = True
    break_lock: Annotated[bool, typer.Option(
        "--break-lock", help="Take the study's writer lock even if another host holds it "
        "(only when that process is gone).")] = False


@app.command("calibrate")
@cli_errors
@with_options(CalibrateOptions)
def calibrate_cmd(o: CalibrateOptions) -> None:
    """Run (or resume) a calibration study; print the calibrated parameters."""
    dask = _checked_inputs(o)
    outcome = _run(o, dask)
    if outcome is None:  # --external: a run sheet was written
        return
    result, demonstration = outcome
    # every file first (the JSON, the card or report), the console last: a console that
    # is gone (a closed pipe, a hung-up terminal) or blocks costs no result
    if o.json_out is not None:
        o.json_out.write_text(json.dumps(result.to_summary(), indent=2))
    lines, report_path = _write_card_or_report(study_folder(o.study), o.report)
    _print_result(result)
    if o.json_out is not None:
        console.print(f"result: {o.json_out}")
    for line in lines:
        console.print(line, markup=False, highlight=False)
    if report_path is not None:
        check_report_problems(report_path)
    if demonstration:  # last, where a first run's reader looks
        _print_demonstration_worth(result)


def _checked_inputs(o: CalibrateOptions) -> str | None:
    """Every input and output path checked before the first run (not after the whole
    study); the Dask scheduler's address, checked (None: local workers)."""
    check_output_file(o.json_out, "--json")
    if not Path(o.study).is_file():
        raise InputError(f"study file not found (or not a file): {o.study}")
    _refuse_json_onto_inputs(o.study, o.json_out)
    if o.report:
        check_output_dir(study_folder(o.study) / "report", "report folder")
    if o.dask_timeout is not None and not 0 < o.dask_timeout <= 7 * 86400:
        raise InputError(f"--dask-timeout must be in (0, 604800] s; got {o.dask_timeout!r}")
    if o.dask is None:
        return None
    from demcal.execute.dask_exec import check_address

    return check_address(o.dask)


def _progress(external: bool) -> tuple[Progress, Callable[[str, int, int], None]]:
    """The stages' progress bars and the callback that feeds them; they start at the first
    run's progress, so an early error prints one line and nothing else."""
    columns = (TextColumn("{task.description}", markup=False), BarColumn(),
               MofNCompleteColumn(), TimeElapsedColumn(), TextColumn("left"),
               TimeRemainingColumn())
    progress = Progress(*columns, console=console, transient=False, disable=external)
    tasks: dict[str, int] = {}

    def on_progress(stage: str, done: int, total: int) -> None:
        if not tasks:
            progress.start()
        if stage not in tasks:
            tasks[stage] = progress.add_task(stage, total=total)
        progress.update(tasks[stage], completed=done, total=total)

    return progress, on_progress


def _run(o: CalibrateOptions, dask: str | None) -> tuple[CalibrationResult, bool] | None:
    """Run the study's stages: its result and whether it is the quick demonstration; None
    where ``--external`` wrote the next run sheet. A Ctrl-C or SIGTERM says how many runs
    are stored and exits with its code."""
    from demcal.calibrate.external import write_run_sheet
    from demcal.calibrate.pipeline import StudyAccess, open_study, run_stages
    from demcal.calibrate.runner import ExternalPending

    progress, on_progress = _progress(o.external)
    try:
        ctx = open_study(o.study, StudyAccess(workers=o.workers, dask=dask, external=o.external,
                                              progress=on_progress, break_lock=o.break_lock))
        ctx.runner.dask_timeout = o.dask_timeout if o.dask_timeout is not None else \
            ctx.study.executor.dask_timeout
        try:
            return run_stages(ctx), _is_quick_demonstration(ctx.study)
        except (KeyboardInterrupt, SystemExit) as stop:
            code = EXIT_INTERRUPTED if isinstance(stop, KeyboardInterrupt) else stop.code
            if code not in (EXIT_INTERRUPTED, EXIT_TERMINATED):
                raise
            progress.stop()
            how = "interrupted:" if code == EXIT_INTERRUPTED else "terminated (SIGTERM):"
            console.print(styled((how, "yellow"), f" {ctx.store.count()} finished runs are "
                                 f"stored; run `demcal calibrate {o.study}` again to resume"))
            raise typer.Exit(code) from None
        except ExternalPending as pending:
            progress.stop()
            names = [r.name for r in ctx.responses]
            path = write_run_sheet(pending, ctx.runner, study_folder(o.study), names)
            console.print(f"{pending.stage}: {len(pending.points)} runs to do externally; run "
                          f"sheet: {path}\nfill {', '.join(names)} (or outcome) and run "
                          f"`demcal import {path.name} --study {o.study}`, then `demcal "
                          "calibrate` again")
            return None
        finally:
            ctx.store.close()
    finally:
        progress.stop()


def _write_card_or_report(study_dir: Path, report: bool) -> tuple[list[str], Path | None]:
    """Write the report (with its material card), or the card alone; return the lines
    that name them and the report's path (None: no report)."""
    if report:
        path = _build_report(study_dir)
        if path is None:
            return [], None
        lines = [f"report: {path}"]
        if (path.parent / "material.toml").is_file():
            lines.append(f"material card: {path.parent / 'material.toml'}")
        return lines, path
    from demcal.report.material import write_material_card

    try:  # the material card all the same (report/material.toml)
        files = write_material_card(study_dir)
    except OSError as exc:  # the result is stored; the card can be written by `report`
        return [f"note: no material card written ({exc.strerror}: {exc.filename}); "
                "`demcal report` writes it"], None
    return [f"material card: {files[0]}"], None


@app.command("init")
@cli_errors
def init_cmd(
    path: Annotated[Path, typer.Argument(help="Where to write the example study.")]
    = Path("study.toml"),
    force: Annotated[bool, typer.Option(help="Overwrite an existing file.")] = False,
) -> None:
    """Write a commented example study file."""
    from demcal.calibrate.study import EXAMPLE_STUDY

    if path.exists() and not force:
        raise InputError(f"{path} exists; use --force to overwrite")
    path.write_text(EXAMPLE_STUDY)
    console.print(f"wrote {path}")


@app.command("import")
@cli_errors
def import_cmd(
    results: Annotated[Path, typer.Argument(help="Filled run sheet (CSV).")],
    study: Annotated[Path, typer.Option(help="The study file the sheet belongs to.")],
    break_lock: Annotated[bool, typer.Option(
        "--break-lock", help="Take the study's writer lock even if another host holds it "
        "(only when that process is gone).")] = False,
) -> None:
    """Store the responses of an externally run sheet; `demcal calibrate` then goes on."""
    from demcal.calibrate.external import import_results
    from demcal.calibrate.pipeline import StudyAccess, open_study
    from demcal.store import STORE_NAME

    if not (study_folder(study) / STORE_NAME).is_file():  # a sheet comes from a store
        raise InputError(f"no run store {STORE_NAME} next to {study}: run `demcal calibrate "
                         f"{study} --external` first, it writes the run sheets")
    ctx = open_study(study, StudyAccess(external=True, break_lock=break_lock))
    try:
        n = import_results(results, ctx.runner, [r.name for r in ctx.responses])
    finally:
        ctx.store.close()
    console.print(f"stored {n} runs from {results}")
