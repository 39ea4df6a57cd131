"""One calibration study end to end: target, fixed parameters, the stages, the result.

:func:`calibrate` opens (or resumes) the study's store ``<study dir>/demcal.sqlite``, writes
the meta keys, runs the enabled stages and stores the final result under meta ``"result"``.
Runs already stored are reused (see :mod:`demcal.calibrate.runner`), so calling it again
after an interruption, or after editing the study, runs only what is missing.
"""

from __future__ import annotations

import platform
from collections.abc import Callable
from dataclasses import dataclass, replace
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import numpy as np

from demcal.calibrate import refine
from demcal.calibrate import stages as st
from demcal.calibrate.responses import AOR, ResponseSpec, aor_spec
from demcal.calibrate.runner import Runner, RunnerOptions
from demcal.calibrate.study import Study, load_study, study_folder
from demcal.errors import InputError
from demcal.execute.local import GPU_CHUNK, default_chunk, default_workers
from demcal.execute.tasks import TestDef
from demcal.store import STAGES as STAGE_TITLES
from demcal.store import RunStore
from demcal.summaries import (
    CalibrationResult,
    DesignRun,
    FitStatistics,
    Optimum,
    ResultResponses,
    Screening,
    Steepest,
    StudyFactor,
    Surface,
    SurfaceFacts,
    Verification,
    by_key,
)
from demcal.summaries.provenance import EngineMeta, Versions
from demcal.summaries.spread import target_spread
from demcal.summaries.target import Target, TargetPhoto

__all__ = ["STAGES", "StudyAccess", "calibrate", "engine_meta", "open_study", "resolve_target",
           "test_def", "versions_meta"]

STAGES = tuple(STAGE_TITLES)  #: the stages in the order they run (demcal.store.STAGES)


def test_def(study: Study, folder: Path | None = None) -> TestDef:
    """The executor's description of the study's virtual test.

    With an external engine (``[engine]``), its runs are kept in ``<folder>/runs/`` (default:
    ``runs/`` in the current folder).
    """
    t = study.test
    engine = study.engine_data()
    if engine is not None:
        engine = engine.for_runs(((folder or Path.cwd()) / "runs").resolve(),
                                 {f.symbol: f.name for f in study.factors if f.symbol})
        return TestDef(kind=engine.kind, backend=study.backend, external=engine)
    ex = study.executor
    return TestDef(kind=t.kind, fidelity=t.fidelity, overrides=dict(t.overrides),
                   analytic=dict(t.analytic), backend=study.backend, engine=ex.engine,
                   lammps=ex.lammps)


def beside_tests(study: Study, test: TestDef) -> dict[str, TestDef]:
    """The tests run beside the study's (``[tests.drum]``), on the lift test's particles,
    rolling model and engine where the study's test is the engine's lift test (one
    material, two tests)."""
    drum = study.tests.drum
    if drum is None:
        return {}
    overrides: dict[str, Any] = {"drum": dict(drum.drum)}
    if test.kind == "aor":
        from demcal.virtual import fidelity_config

        config = fidelity_config(test.fidelity, **test.overrides)
        overrides.update(particle=config.particle.model_dump(mode="json"),
                         rolling_model=config.rolling_model)
    # the drum runs on the lift test's engine: demcal's, or LAMMPS started as the study says
    return {"drum": TestDef(kind="drum", fidelity=drum.fidelity, overrides=overrides,
                            backend=study.backend, engine=test.engine, lammps=test.lammps)}


def engine_meta(study: Study) -> EngineMeta:
    """The store's meta ``"engine"``: which engine produced the study's runs."""
    engine = study.engine_data()
    if engine is None:
        name = study.executor.engine  # demcal | lammps
        return EngineMeta(kind=name, name=name, backend=study.backend)
    return EngineMeta(kind=engine.kind, name=engine.name, command=list(engine.command),
                      template=engine.template_path, template_sha256=engine.template_sha256,
                      result=engine.result)


def versions_meta(study: Study) -> Versions:
    """The store's meta ``"versions"``: the software that makes the study's runs."""
    try:
        dv = version("demcal")
    except PackageNotFoundError:  # pragma: no cover
        dv = "unknown"
    lammps = None
    if study.executor.engine == "lammps":  # the LAMMPS the runs use (the material card says)
        from demcal.virtual.lammps_run import lammps_version

        lammps = lammps_version(study.executor.lammps)
    return Versions(demcal=dv, python=platform.python_version(), numpy=np.__version__,
                    engine_backend=study.backend, engine=study.executor.engine, lammps=lammps)


def resolve_target(study: Study, figures: Path | None = None) -> Target:
    """The target AoR (deg), the store's meta "target": from a value, photos or a file.

    With photos and ``figures`` (a folder), a diagnostic figure of each photo is saved there.
    """
    t = study.target
    if t.aor_deg is not None:
        return Target(aor_deg=float(t.aor_deg), std_deg=t.std_deg, n=t.n, source="value")
    if t.photos:
        from demcal.measure import photos_aor, plot_photo_aor

        table = photos_aor(t.photos)
        photos = []
        for i, r in enumerate(table.results):
            fig = None
            if figures is not None:
                figures.mkdir(parents=True, exist_ok=True)
                fig = str(figures / f"target_photo_{i + 1}.png")
                plot_photo_aor(r, fig)
            photos.append(TargetPhoto(file=r.source, left_deg=r.left_deg, right_deg=r.right_deg,
                                      mean_deg=r.mean_deg, figure=fig))
        std = table.std_deg
        return Target(aor_deg=table.mean_deg, std_deg=None if not np.isfinite(std) else std,
                      n=len(photos), source="photos", photos=photos)
    from demcal.physical import derive_parameters, load_measurements

    res = derive_parameters(load_measurements(t.measurements))
    if res.target_aor is None or res.target_aor.mean is None:
        raise InputError(f"target.measurements: {t.measurements} has no [measurements.aor] "
                         "angle_deg repeats")
    a = res.target_aor
    return Target(aor_deg=float(a.mean), std_deg=a.std, n=a.n_repeats, source="value")


def _fixed(study: Study) -> tuple[dict[str, float], dict[str, Any] | None]:
    from demcal.virtual import PARAMETERS, preset_parameters

    params = preset_parameters(study.material.preset)
    physical = None
    if study.material.measurements:
        from demcal.physical import derive_parameters, load_measurements

        res = derive_parameters(load_measurements(study.material.measurements))
        physical = res.to_dict()
        params.update({k: v for k, v in res.fixed_values().items() if k in PARAMETERS})
    params.update(study.material.overrides)
    for f in study.factors:
        params[f.name] = 0.5 * (f.low + f.high)
    return params, physical


@dataclass(frozen=True)
class StudyAccess:
    """How a study is opened for its stages (:func:`open_study`).

    Attributes
    ----------
    workers : int or None
        Local worker processes; None: the study's ``[executor] workers``, else one per core.
    dask : str or Client or None
        A Dask scheduler instead of the local pool; None: the study's ``[executor] dask``.
    external : bool
        External mode: run nothing, the stages' runs come from run sheets.
    progress : callable or None
        ``progress(stage, done, total)`` after each run.
    break_lock : bool
        Take over a writer lock whose holder is gone (:class:`demcal.store.RunStore`).
    """

    workers: int | None = None
    dask: Any = None
    external: bool = False
    progress: Callable[[str, int, int], None] | None = None
    break_lock: bool = False


def open_study(study_file: str | Path, access: StudyAccess | None = None) -> st.Context:
    """Load the study, open its store, write the meta keys and build the stage context.

    The store is opened (created) only once the study's inputs are read, with the study's
    writer lock (``access.break_lock``: see :class:`demcal.store.RunStore`).
    """
    access = access or StudyAccess()
    external = access.external
    path = Path(study_file).resolve()
    study = load_study(path)
    if external and study.tests.drum is not None:
        raise InputError("--external: the runs are made outside demcal, but [tests.drum] runs "
                         "inside demcal (its engine or LAMMPS); calibrate without --external, "
                         "or without the drum")
    if study.executor.engine == "lammps" and study.test.kind == "aor" and not external:
        from demcal.virtual.lammps_run import lammps_command

        lammps_command(study.executor.lammps)  # LammpsMissing (exit 2) before any work
    folder = study_folder(path)
    target = None if study.target is None else resolve_target(study, figures=folder / "figures")
    fixed, physical = _fixed(study)
    store = RunStore(folder, lock=True, break_lock=access.break_lock)
    factors = [StudyFactor(name=f.name, symbol=f.symbol, low=f.low, high=f.high,
                           unit=f.unit) for f in study.factors]
    store.set_meta("study", study.model_dump(mode="json"))
    store.set_meta("study_file", str(path))
    store.set_meta("study_dir", str(folder))
    # the angle's; None where another response leads
    store.set_meta("target", None if target is None else target.to_summary())
    store.set_meta("physical", physical)
    store.set_meta("fixed_params", {k: v for k, v in fixed.items()
                                    if k not in {f.name for f in study.factors}})
    store.set_meta("factors", [f.to_summary() for f in factors])
    store.set_meta("engine", engine_meta(study).to_summary())
    store.set_meta("versions", versions_meta(study).to_summary())
    ex = study.executor
    batched = study.test.kind == "aor" and study.engine is None  # worlds of demcal's engine
    chunk = ex.chunk or (default_chunk(study.backend, study.replicates) if batched else 1)
    # the CPU's default on a local pool: lone runs in full rounds, the rest batched here
    spread = batched and ex.chunk is None and chunk < GPU_CHUNK
    test = test_def(study, folder)
    runner = Runner(store, test, RunnerOptions(
        workers=access.workers or ex.workers or default_workers(),
        dask=access.dask if access.dask is not None else ex.dask, chunk=chunk, spread=spread,
        progress=access.progress, external=external, figures_dir=folder / "figures" / "runs",
        stage_tests=stage_tests(study, test),
        beside=beside_tests(study, test)))
    specs = _responses(study, target)
    labs = {s.name: lab for s in specs if (lab := s.lab(path.parent)) is not None}
    lead = labs.get(specs[0].name)
    if lead is None:  # a goal 'target' without its lab value: refused at the study's load
        raise InputError(f"responses: {specs[0].name!r} leads the study but has no lab value")
    # the lead where it is not the angle (the report's labels and target lines); None: the angle
    store.set_meta("lead", None if specs[0].name == AOR else {
        "name": specs[0].name, "unit": specs[0].unit, "mean": lead.mean, "std": lead.std,
        "n": lead.n})
    return st.Context(study, store, runner, fixed, lead.mean, factors,
                      target_std=lead.std, target_n=lead.n, responses=specs, labs=labs)


def stage_tests(study: Study, test: TestDef) -> dict[str, TestDef]:
    """The tests of the stages that run at their own fidelity, by stage; the path's anchor
    runs the surface's test (:func:`demcal.calibrate.steepest._surface_centre`)."""
    own = {name: replace(test, fidelity=fid) for name, fid in study.stage_fidelities().items()}
    if "rsm" in own:
        own["steepest_anchor"] = own["rsm"]
    return own


def _responses(study: Study, target: Target | None) -> list[ResponseSpec]:
    """Every response the study aims at, the lead first: the angle at the target the study
    resolved (its own ``[[responses]]`` goal and limits, if any) where it gives one, else its
    ``[[responses]]`` tables as given."""
    if target is None:
        return list(study.responses)
    own_aor = next((r for r in study.responses if r.name == AOR), None)
    return [aor_spec(own_aor, target), *study.other_responses()]


def _design_json(design: str | None, factors: list[StudyFactor], runs: list[DesignRun],
                 excluded: list[int]) -> dict[str, Any]:
    """A designed stage's part of the result: its design, factors and each point's angle."""
    return {"design": design, "factors": [f.name for f in factors],
            "responses": [{"point": r.point, "actual": r.actual, "aor_deg": r.value,
                           "outcome": r.outcome} for r in runs],
            "excluded_points": excluded}


def _stage_json(ctx: st.Context) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name in STAGES:
        s = getattr(ctx.results, name)
        if s is None:
            continue
        if name == "rangefind":
            out[name] = {"design": "one factor at a time",
                         "responses": [p.to_summary() for f in s.factors for p in f.points],
                         "ranges": {f.name: [f.new_low, f.new_high] for f in s.factors},
                         "message": s.message}
        elif name == "screening" and s.ran:  # a skipped screening: no runs
            out[name] = {**_design_json(s.design, s.factors, s.runs, s.excluded_points),
                         "selected": s.selected}
        elif name == "rsm":  # typed (demcal.summaries.Surface)
            out[name] = {**_design_json(s.design, s.factors, s.runs, s.excluded_points),
                         **({"fidelity": s.fidelity} if s.fidelity is not None else {}),
                         "adequate": s.adequate, "warnings": s.warnings,
                         "equation_actual": s.equation_actual,
                         "adequacy": None if s.adequacy is None else s.adequacy.to_summary(),
                         "replicates": s.replicates,
                         "rounds": None if s.rounds is None else [r.to_summary() for r in s.rounds]}
            continue
        elif name == "steepest" and s.ran:  # a disabled stage keeps only its levels
            stored = s.to_summary()
            out[name] = {"design": "steepest path", "factors": s.factors,
                         "responses": stored["steps"], "best_step": s.best_step,
                         "levels": s.levels,
                         **{k: stored[k] for k in ("anchor", "followed", "climb") if k in stored}}
        elif name == "optimize":  # typed (demcal.summaries.Optimum), no fidelity of its own
            out[name] = {"candidates": [c.to_summary() for c in s.candidates]}
            continue
        elif name == "verification":  # no fidelity of its own
            out[name] = by_key(s, ("values", "outcomes"))
            continue
        if name in out and s.fidelity is not None:  # the stage ran at its own fidelity
            out[name]["fidelity"] = s.fidelity
    return out


def calibrate(study_file: str | Path, *, workers: int | None = None, dask: Any = None,
              external: bool = False,
              progress: Callable[[str, int, int], None] | None = None) -> dict[str, Any]:
    """Run (or resume) the study; return the result JSON (also stored as meta "result";
    :meth:`CalibrationResult.from_summary` reads it typed).

    Raises :class:`demcal.calibrate.runner.ExternalPending` in external mode when a stage
    needs runs done outside demcal.
    """
    ctx = open_study(study_file, StudyAccess(workers=workers, dask=dask, external=external,
                                             progress=progress))
    try:
        return run_stages(ctx).to_summary()
    finally:
        ctx.store.close()


def run_stages(ctx: st.Context) -> CalibrationResult:
    """The stages in order (disabled ones skipped), then the result; with ``[strategy]
    kind = "bayes"`` the Bayesian strategy and its verification instead."""
    if ctx.study.strategy.kind == "bayes":  # imported here: scikit-learn only when used
        from demcal.calibrate.bayes_strategy import run_bayes

        return run_bayes(ctx)
    ctx.store.delete_stage("bayes")  # a study that ran the Bayesian strategy before
    s = ctx.study.stages
    for name in ("rangefind", "screening", "steepest"):
        if name == "rangefind" and not s.rangefind.enabled:
            ctx.store.delete_stage(name)
            continue
        if name == "screening" and not s.screening.enabled:
            # straight to the response surface: its factors are the ones given, or all
            refs = s.screening.factors or [f.name for f in ctx.study.factors]
            ctx.results.screening = Screening(
                selected=[ctx.study.factor(r).name for r in refs])
            ctx.store.delete_stage(name)
            continue
        if name == "steepest" and not s.steepest.enabled:
            sel = ctx.results.screening.selected
            given = [ctx.factor(n) for n in sel]
            ctx.results.steepest = Steepest(levels={
                f.name: [f.low, 0.5 * (f.low + f.high), f.high] for f in given})
            ctx.store.delete_stage(name)
            continue
        getattr(st, name)(ctx)
    st.rsm(ctx)
    refine.run_rounds(ctx)
    opt: Optimum = ctx.results.optimize
    surface: Surface = ctx.results.rsm
    ver: Verification = ctx.results.verification
    several = None
    if ctx.several and opt.responses is not None:  # every response against its lab value
        several = ResultResponses(goals=list(opt.responses.goals),
                                  desirability=opt.responses.desirability,
                                  predicted=dict(opt.best.predicted),
                                  verification=ver.responses)
    result = CalibrationResult(
        study=ctx.study.name, optimum=opt.chosen, optimum_full=ver.params,
        predicted_lead=opt.predicted_lead, target=ctx.target, lead=ctx.lead_label(),
        verification=ver, rounds=refine.round_rows([*opt.rounds, opt], [*ver.rounds, ver]),
        n_runs=ctx.store.count(),
        # the runs this study's stages used: a reused store may hold others (another study's,
        # or this one's under earlier settings), which n_runs counts
        n_runs_used=len({r.key for r in ctx.records} | ctx.runner.beside_keys),
        n_runs_executed=ctx.runner.executed,
        ranges={f.name: [f.low, f.high] for f in ctx.factors},
        surface=SurfaceFacts(adequate=surface.adequate,
                             adequacy=surface.adequacy or FitStatistics(),
                             model=surface.model_kind,
                             removed_terms=list(surface.removed_terms or []),
                             resolution=surface.resolution),
        stages=_stage_json(ctx), responses=several,
        spread=target_spread(opt, surface.ranges), fidelity=ctx.study.test_fidelity)
    ctx.store.set_meta("result", result.to_summary())
    return result
