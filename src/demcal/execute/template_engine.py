"""One run of an external DEM code: fill its input template, run its command, read its result.

:func:`run_template` does a whole run inside whichever worker executes it (this process, a
local pool worker or a Dask worker), so a task is plain data
(:class:`demcal.execute.tasks.RunTask` with the engine in its ``TestDef``):

1. the run's own folder ``<runs_dir>/<stage>_<hash>/`` is emptied (a re-run replaces it);
2. the template is filled (:mod:`demcal.execute.template_fill`; a hook may add placeholders)
   and written there as the input file;
3. the command runs in that folder, in its own process group, with stdin closed and its
   stdout and stderr both kept in ``engine.log``; past ``timeout_s`` the whole group is
   killed (SIGTERM, then SIGKILL after :data:`KILL_GRACE_S`);
4. the result is read (:mod:`demcal.execute.engine_results`): spheres are measured by
   demcal (:func:`demcal.virtual.pile.measure_pile`, with the flank quality gates) into
   ``pile`` or ``scattered``; a value is the engine's own angle or outcome.

A run that fails in the engine ends with one of the typed outcomes :data:`ENGINE_FAILURES`
and a reason naming the log: ``engine_error`` (the command could not start, or its exit code
was not 0), ``no_result`` (its result file is missing or unreadable), ``timeout``.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import importlib.util
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from demcal.engine_guard import (
    engine_watchdog,
    kill_group,
    note_engine,
    stop_leftover_engine,
)
from demcal.errors import InputError
from demcal.execute.engine_results import ResultUnreadable, read_positions, read_value
from demcal.execute.signals import sigterm_raises
from demcal.execute.template_fill import fill
from demcal.results import RunResult

if TYPE_CHECKING:
    from demcal.execute.engine_spec import ResolvedEngine

__all__ = ["ENGINE_FAILURES", "KILL_GRACE_S", "LOG_NAME", "run_dir_name", "run_template"]

#: typed outcomes of a run the external engine did not finish
ENGINE_FAILURES = ("engine_error", "no_result", "timeout")
#: seconds between SIGTERM and SIGKILL of a timed-out engine's process group
KILL_GRACE_S = 5.0
#: the engine's stdout and stderr, in its run folder
LOG_NAME = "engine.log"
#: lines of the log's end quoted in a failure's reason
TAIL_LINES = 3
#: bytes read from the log's end to find them
TAIL_BYTES = 16 * 1024
#: measured pile values (angles in deg, lengths in m) copied to the top of a run's result
MEASURED_KEYS = ("aor_deg", "aor_left_deg", "aor_right_deg", "aor_std_deg", "pile_height_m",
                 "base_diameter_m")


def run_dir_name(key: str) -> str:
    """The run folder's name for a store key ``"<stage>:<hash>"``: ``<stage>_<hash>``."""
    stage, _, digest = key.partition(":")
    if not digest:
        digest = hashlib.sha256(key.encode()).hexdigest()[:16]
    return f"{stage}_{digest}"


class HookFailed(Exception):
    """The study's hook raised for this run: the run fails as ``engine_error``."""


def _load_hook(engine: ResolvedEngine) -> Callable[..., Any]:
    """The engine's hook function: from its Python file (:attr:`ResolvedEngine.hook_file`,
    which also decides what the study's input guard protects) or its module."""
    where, _, func = str(engine.hook).rpartition(":")
    try:
        if engine.hook_file is not None:
            name = "demcal_engine_hook_" + hashlib.sha256(where.encode()).hexdigest()[:12]
            spec = importlib.util.spec_from_file_location(name, engine.hook_file)
            if spec is None or spec.loader is None:
                raise ImportError(f"cannot load {where}")
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
        else:
            module = importlib.import_module(where)
    except (ImportError, OSError, SyntaxError) as exc:
        raise InputError(f"engine.hook: cannot import {where}: {exc}") from None
    hook = getattr(module, func, None)
    if not callable(hook):
        raise InputError(f"engine.hook: {where} has no function {func!r}")
    return hook


def _values(task: Any, engine: ResolvedEngine, run_dir: Path) -> dict[str, object]:
    values: dict[str, object] = dict(task.params)
    for sym, name in engine.symbols.items():
        values[sym] = task.params[name]
    values.update(seed=int(task.seed), run_dir=str(run_dir), run_key=task.key,
                  input=engine.input, dt_scale=float(task.dt_scale),
                  template_dir=str(Path(engine.template_path).parent),
                  python=sys.executable)
    if engine.hook:
        hook = _load_hook(engine)
        try:
            extra = hook(params=dict(task.params), seed=int(task.seed), run_dir=run_dir)
        except (Exception, SystemExit) as exc:  # the user's code: this run fails, typed
            raise HookFailed(f"engine.hook {engine.hook} raised {type(exc).__name__}: "
                             f"{str(exc)[:300]}") from None
        if extra is not None:
            if not isinstance(extra, dict):
                raise InputError(f"engine.hook: must return a dict of placeholders or None; "
                                 f"got {type(extra).__name__}")
            values.update({str(k): v for k, v in extra.items()})
    return values


def _tail(log: Path) -> str:
    """The log's last :data:`TAIL_LINES` lines, read from its end (a 300 MB log was read
    whole to quote three lines)."""
    try:
        with open(log, "rb") as fh:
            fh.seek(0, os.SEEK_END)
            fh.seek(max(0, fh.tell() - TAIL_BYTES))
            text = fh.read(TAIL_BYTES).decode("utf-8", errors="replace")
    except OSError:
        return ""
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    tail = " | ".join(lines[-TAIL_LINES:])
    return tail[-300:]


def _execute(cmd: list[str], run_dir: Path, log: Path, timeout: float) -> tuple[str | None, str]:
    """Run the command; return (failure outcome or None, what happened)."""
    with open(log, "wb") as out, sigterm_raises():
        try:
            proc = subprocess.Popen(cmd, cwd=run_dir, stdin=subprocess.DEVNULL, stdout=out,
                                    stderr=subprocess.STDOUT, start_new_session=True)
        except FileNotFoundError:
            return "engine_error", f"command not found: {cmd[0]!r} (is it on PATH?)"
        except PermissionError:
            return "engine_error", f"command not executable: {cmd[0]!r}"
        except OSError as exc:
            return "engine_error", f"cannot start {cmd[0]!r}: {exc.strerror}"
        note_engine(run_dir, proc.pid)
        # the watchdog ends the engine's group if this process dies first (kill -9)
        with engine_watchdog(proc.pid):
            try:
                code = proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                kill_group(proc, KILL_GRACE_S)
                return "timeout", f"no end within {timeout:g} s; the engine was killed"
            except BaseException:  # Ctrl-C, a terminated pool worker: take the engine down
                kill_group(proc, KILL_GRACE_S)
                raise
    if code != 0:
        return "engine_error", f"exit code {code}"
    return None, "exit code 0"


def run_template(task: Any, plot_path: str | None = None) -> dict[str, Any]:
    """Run one task on the external engine; return the executor's result dict.

    Parameters
    ----------
    task : RunTask
        The run (its ``test.external`` holds the engine, ``runs_dir`` among it).
    plot_path : str, optional
        Where to save a side view of a measured pile (PNG).

    Returns
    -------
    RunResult
        The outcome; the responses (``aor_deg`` for a pile, and every finite number of the
        engine's own result JSON by its key); ``detail`` holds ``engine`` (command, exit
        status, run folder, log), the measurement and ``artefacts`` (``run_dir``,
        ``engine_log``, ``pile_png``).

    Raises
    ------
    InputError
        The template names a placeholder no value is given for, or the hook fails to load:
        a mistake of the study, not of one run.
    """
    engine: ResolvedEngine = task.test.external
    t0 = time.perf_counter()
    run_dir = _fresh_run_dir(engine, task.key)
    log = run_dir / LOG_NAME
    try:
        cmd = _write_input(task, engine, run_dir)
    except HookFailed as exc:  # nothing to run: the run's failure, not the study's end
        cmd, (failure, what) = [], ("engine_error", str(exc))
    else:
        failure, what = _execute(cmd, run_dir, log, engine.timeout_s)
    info: dict[str, Any] = {"command": cmd, "status": what, "run_dir": str(run_dir),
                            "log": str(log), "engine_wall_time_s": time.perf_counter() - t0}
    artefacts = {"run_dir": str(run_dir), "engine_log": str(log)}
    result: dict[str, Any] = {"engine": info, "artefacts": artefacts, "seed": int(task.seed),
                              "params": dict(task.params)}
    out = {"key": task.key, "outcome": failure, "aor_deg": None, "reason": None,
           "result": result}
    if failure is None:
        try:
            read = _read_result(run_dir, engine.result, plot_path)
        except ResultUnreadable as exc:
            failure, what = "no_result", str(exc)
        else:
            _keep_measurement(read, result)
            out.update(outcome=read["outcome"], aor_deg=read["aor_deg"], reason=read["reason"])
    if failure is not None:
        out.update(outcome=failure, reason=_failure_reason(what, log))
    measured = result.get("measured") or {}
    result.update({k: measured[k] for k in MEASURED_KEYS if k in measured})
    result.update(outcome=out["outcome"], aor_deg=out["aor_deg"], reason=out["reason"])
    responses = {} if failure is not None else dict(result.get("engine_values") or {})
    if out["outcome"] == "pile":  # a pile demcal measured also has its height and base
        responses.update({k: result[k] for k in ("pile_height_m", "base_diameter_m")
                          if result.get(k) is not None}, aor_deg=out["aor_deg"])
    return RunResult(task.key, out["outcome"], responses=responses, reason=out["reason"],
                     wall_time_s=time.perf_counter() - t0, detail=result)


def _fresh_run_dir(engine: ResolvedEngine, key: str) -> Path:
    """The run's own folder under the engine's ``runs_dir``, emptied (a re-run replaces it)."""
    if engine.runs_dir is None:
        raise ValueError("the engine has no runs_dir (ResolvedEngine.for_runs)")
    run_dir = Path(engine.runs_dir) / run_dir_name(key)
    if run_dir.exists():
        stop_leftover_engine(run_dir)  # a killed study's engine: never two in one folder
        shutil.rmtree(run_dir)
    run_dir.mkdir(parents=True)
    return run_dir


def _write_input(task: Any, engine: ResolvedEngine, run_dir: Path) -> list[str]:
    """Fill the template into the run's input file; return the filled command line."""
    values = _values(task, engine, run_dir)
    (run_dir / engine.input).write_text(fill(engine.template_text, values,
                                             f"engine.template {engine.input}"))
    return [fill(a, values, "engine.command") for a in engine.command]


def _read_result(run_dir: Path, spec: dict[str, Any], plot_path: str | None) -> dict[str, Any]:
    """The finished run's ``outcome``, ``aor_deg``, ``reason`` (and ``measured`` or
    ``engine_values``), read as ``spec["kind"]`` says.

    Raises
    ------
    ResultUnreadable
        The result file is missing or cannot be read.
    """
    if spec["kind"] == "positions":
        return _measure(run_dir, spec, plot_path)
    return read_value(run_dir, spec)


def _keep_measurement(read: dict[str, Any], result: dict[str, Any]) -> None:
    """Move a read result's measurement (its figure among the artefacts) and engine values
    into the run's ``result``."""
    measured = read.pop("measured", None)
    if measured is not None:
        result["measured"] = measured
        if measured.get("figure"):
            result["artefacts"]["pile_png"] = measured["figure"]
    if read.get("engine_values"):
        result["engine_values"] = read["engine_values"]


def _failure_reason(what: str, log: Path) -> str:
    """A failed run's reason: what happened, the log's path and the end of the log."""
    tail = _tail(log)
    return f"{what} (log: {log}" + (f"; it ends: {tail}" if tail else "") + ")"


def _measure(run_dir: Path, spec: dict[str, Any], plot_path: str | None) -> dict[str, Any]:
    """Measure the spheres the engine wrote: ``pile`` with its angle, or ``scattered``."""
    from demcal.virtual.config import MeasurementOptions
    from demcal.virtual.pile import measure_pile

    centres, radii = read_positions(run_dir, spec)
    options = MeasurementOptions(**spec.get("measurement") or {})
    figure = None
    if plot_path is not None:
        with contextlib.suppress(OSError):  # a picture must not cost the measurement
            Path(plot_path).parent.mkdir(parents=True, exist_ok=True)
            figure = plot_path
    measured = measure_pile(centres, radii, options, figure=figure)
    measured["n_spheres"] = len(radii)
    if measured.get("error") or measured.get("aor_deg") is None:
        why = measured.get("error") or "no flank passed the quality gates"
        return {"outcome": "scattered", "aor_deg": None, "reason": why, "measured": measured}
    return {"outcome": "pile", "aor_deg": measured["aor_deg"], "reason": None,
            "measured": measured}
