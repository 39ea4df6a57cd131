"""The study's ``[engine]`` table: an external DEM code driven through an input template.

A study that names an engine runs every virtual test in that code instead of demcal's own
engine (see ``docs/external_engines.md``)::

    [engine]
    kind = "template"                  # the only kind today; others (e.g. "lammps") may follow
    template = "in.aor.template"       # the input, with {placeholders}; relative to the study
    input = "in.aor"                   # the filled file's name in the run folder (default:
                                       # the template's name without a ".template" suffix)
    command = ["liggghts", "-in", "{input}"]   # or one string, split like a shell (no shell)
    timeout_s = 3600                   # one run's wall-time limit, s
    hook = "hook.py:fill"              # optional: a Python function giving more placeholders

    [engine.result]                    # what the engine leaves in its run folder
    kind = "positions"                 # spheres measured by demcal | "value": an angle
    file = "pile.csv"
    format = "csv"                     # csv | table | lammps_dump (positions)
    columns = { x = "x", y = "y", z = "z", radius = "radius" }
    length_scale = 1.0                 # file lengths x this = metres
    plate_z = 0.0                      # the plate's height in the file, m (after scaling)

Every value is validated here (pydantic), so a bad table is one line naming the field and
its allowed values before any run starts. Paths are resolved and the template is read by
:func:`load_engine` (the run store's identity of a run holds the template's SHA-256).
"""

from __future__ import annotations

import hashlib
import shlex
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    field_validator,
    model_validator,
)

from demcal.errors import InputError
from demcal.safety import read_text_input
from demcal.virtual.config import MeasurementOptions

__all__ = ["ENGINE_KINDS", "EngineSpec", "PositionsResult", "ResolvedEngine", "TemplateEngine",
           "ValueResult", "load_engine"]

#: engine kinds a study may name (``[engine] kind``)
ENGINE_KINDS = ("template",)
#: longest wall time of one engine run, s (30 days)
MAX_TIMEOUT_S = 30 * 86400.0


class _M(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


def _in_run_folder(v: str) -> str:
    """A result file's path: relative and inside the run folder (no absolute path, no
    ``..``); the reader also refuses a symlink out of the folder, made by the engine."""
    p = Path(v)
    if p.is_absolute() or ".." in p.parts or v.startswith("~"):
        raise ValueError(f"a path inside the run folder (no absolute path, no '..'); got {v!r}")
    return v


class Measurement(MeasurementOptions):
    """How demcal measures the spheres: :class:`demcal.virtual.config.MeasurementOptions`'s
    fields, with NaN and infinity refused like every number of the ``[engine]`` table."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class PositionsResult(_M):
    """Sphere centres and radii written by the engine; demcal measures the pile's angle.

    ``format``: ``csv`` (comma-separated with a header row; ``columns`` name the header's
    columns), ``table`` (whitespace-separated numbers, ``#`` comments, ``skip_rows`` header
    lines; ``columns`` are 0-based indices) or ``lammps_dump`` (a LAMMPS/LIGGGHTS text dump:
    the last snapshot's ``ITEM: ATOMS`` section; ``columns`` name its fields).
    """

    kind: Literal["positions"] = "positions"
    file: Annotated[str, AfterValidator(_in_run_folder)] = Field(min_length=1)
    format: Literal["csv", "table", "lammps_dump"] = "csv"
    columns: dict[Literal["x", "y", "z", "radius"], str | int] = Field(default_factory=dict)
    radius: float | None = Field(None, gt=0, le=10, description="one radius for every sphere "
                                 "when the file has no radius column, m")
    skip_rows: int = Field(0, ge=0, le=10_000, description="header lines of a table")
    length_scale: float = Field(1.0, gt=0, le=1e6, description="file length x this = m")
    plate_z: float = Field(0.0, ge=-1e3, le=1e3, description="plate height in the file's "
                           "frame, m (after length_scale)")
    measurement: Measurement = Measurement()

    @model_validator(mode="after")
    def _columns(self) -> PositionsResult:
        named = self.format != "table"
        default: dict[str, str | int] = ({"x": "x", "y": "y", "z": "z", "radius": "radius"}
                                         if named else {"x": 0, "y": 1, "z": 2, "radius": 3})
        if self.format == "lammps_dump" and "radius" not in self.columns and \
                self.radius is None:
            default["radius"] = "radius"
        cols = {**default, **self.columns}
        if self.radius is not None and "radius" not in self.columns:
            cols.pop("radius")
        for k, v in cols.items():
            if named and not isinstance(v, str):
                raise ValueError(f"columns.{k}: a {self.format} file's columns are named by "
                                 f"header; got {v!r}")
            if not named and (not isinstance(v, int) or isinstance(v, bool) or v < 0):
                raise ValueError(f"columns.{k}: a table's columns are 0-based indices; "
                                 f"got {v!r}")
        self.columns = cols  # type: ignore[assignment]
        return self


class ValueResult(_M):
    """A value the engine measured itself: a number, or JSON with ``key``: the angle (deg,
    ``aor_deg``, the default), or any response a study leads with (its first
    ``[[responses]]`` table's name, in its unit).

    The JSON object may instead give ``outcome`` (``column``, ``plug``, ``scattered``,
    ``unsettled``, ``unstable``) and ``reason`` for a run that measured nothing; its other
    finite numbers are responses by their keys.
    """

    kind: Literal["value"] = "value"
    file: Annotated[str, AfterValidator(_in_run_folder)] = Field(min_length=1)
    key: str = Field("aor_deg", min_length=1, description="the measured value's key in a "
                     "JSON file (default the angle's)")


class TemplateEngine(_M):
    """``[engine] kind = "template"``: fill an input template, run a command, read a result."""

    kind: Literal["template"] = "template"
    template: str = Field(min_length=1, description="input template, relative to the study")
    input: str | None = Field(None, description="filled input's file name in the run folder")
    command: list[str] | str
    timeout_s: float = Field(3600.0, gt=0, le=MAX_TIMEOUT_S)
    hook: str | None = Field(None, description="'file.py:function' or 'module:function'")
    result: PositionsResult | ValueResult = Field(discriminator="kind")

    @field_validator("command")
    @classmethod
    def _command(cls, v: list[str] | str) -> list[str]:
        if isinstance(v, str):
            try:
                v = shlex.split(v)
            except ValueError as exc:
                raise ValueError(f"cannot split the command string: {exc}") from None
        if not v or not v[0].strip():
            raise ValueError("give the program to run, e.g. [\"liggghts\", \"-in\", "
                             "\"{input}\"]")
        return list(v)

    @field_validator("input")
    @classmethod
    def _input(cls, v: str | None) -> str | None:
        if v is not None and (not v or Path(v).name != v or v in (".", "..")):
            raise ValueError(f"a plain file name (no folder); got {v!r}")
        return v

    @field_validator("hook")
    @classmethod
    def _hook(cls, v: str | None) -> str | None:
        if v is not None:
            where, colon, func = v.rpartition(":")
            if not colon or not where or not func.isidentifier():
                raise ValueError(f"'file.py:function' or 'module:function'; got {v!r}")
        return v


#: the engine kinds, one model each (a union once a second kind exists)
EngineSpec = TemplateEngine


def _read_text(path: Path, what: str) -> str:
    return read_text_input(path, f"study: engine.{what}")


@dataclass(frozen=True)
class ResolvedEngine:
    """The study's ``[engine]`` as its runs use it: paths resolved, the template read.

    Plain data (picklable: it travels to process-pool and dask workers inside
    :class:`demcal.execute.tasks.TestDef`), made once by :func:`load_engine`; the run folder
    and the factor symbols are added by the study (:meth:`for_runs`).

    Attributes
    ----------
    kind : str
        ``"template"``.
    template_path : str
        The template's absolute path (inside the study folder).
    template_text : str
        Its text, read once.
    template_sha256 : str
        Its SHA-256 (part of every run's identity).
    input : str
        The filled input's file name in the run folder.
    command : tuple of str
        The command line, with placeholders.
    timeout_s : float
        One run's wall-time limit, s.
    result : dict
        How the run's result is read: a dumped :class:`PositionsResult` or
        :class:`ValueResult` (JSON, part of the run identity).
    hook : str or None
        ``"<absolute path>.py:function"`` or ``"module:function"``.
    hook_sha256 : str or None
        A file hook's SHA-256.
    runs_dir : str or None
        Where the run folders are made (None until :meth:`for_runs`).
    symbols : dict str -> str
        Factor symbol -> parameter name (placeholders by symbol).
    """

    kind: str
    template_path: str
    template_text: str
    template_sha256: str
    input: str
    command: tuple[str, ...]
    timeout_s: float
    result: dict[str, Any]
    hook: str | None = None
    hook_sha256: str | None = None
    runs_dir: str | None = None
    symbols: dict[str, str] = field(default_factory=dict)

    @property
    def measures_positions(self) -> bool:
        """Whether demcal measures the spheres the engine writes (else the engine's value)."""
        return self.result["kind"] == "positions"

    @property
    def hook_file(self) -> Path | None:
        """The hook's Python file (None: no hook, or a module's)."""
        if self.hook is None:
            return None
        where = self.hook.rpartition(":")[0]
        return Path(where) if where.endswith(".py") else None

    @property
    def name(self) -> str:
        """The engine in one line: its kind and command."""
        return f"{self.kind}: {' '.join(self.command)}"

    def for_runs(self, runs_dir: str | Path, symbols: Mapping[str, str] | None = None,
                 ) -> ResolvedEngine:
        """The engine with its run folder (and the factor symbols) set."""
        return replace(self, runs_dir=str(runs_dir),
                       symbols=dict(self.symbols if symbols is None else symbols))

    def identity(self) -> dict[str, Any]:
        """What defines an engine run's result: the template's content, the input's name,
        the command, the hook and the result reader (not the timeout, not where runs are
        kept). A file format: every stored run's key hashes it."""
        return {"kind": self.kind, "template_sha256": self.template_sha256,
                "input": self.input, "command": list(self.command),
                "hook": self._hook_identity(), "result": self.result}

    def _hook_identity(self) -> str | None:
        """A file hook by its content's SHA-256 and function (the study may move), a
        module's hook by its name."""
        if self.hook is None:
            return None
        if self.hook_sha256:
            return f"sha256:{self.hook_sha256}:{self.hook.rpartition(':')[2]}"
        return str(self.hook)


def load_engine(spec: EngineSpec, base: Path, known: set[str]) -> ResolvedEngine:
    """Resolve the engine's paths, read its template and check its placeholders.

    Parameters
    ----------
    spec : TemplateEngine
        The validated ``[engine]`` table (paths as written).
    base : Path
        The study file's folder (relative paths are taken from it).
    known : set of str
        Placeholder names the runs will give (parameters, symbols and the built-ins); with a
        hook any other name is allowed here (the hook may give it) and checked per run.

    Returns
    -------
    ResolvedEngine
        The engine of :class:`demcal.execute.tasks.TestDef`, without its run folder.

    Raises
    ------
    InputError
        A file is missing or unreadable, or the template names an unknown placeholder.
    """
    from demcal.execute.template_fill import BUILTINS, placeholders

    template = (base / spec.template).resolve()
    if not template.is_relative_to(base.resolve()):  # copied into every run folder
        raise InputError(f"study: engine.template: {spec.template} lies outside the study "
                         f"folder {base} (an absolute or '..' path, or a symlink out of it); "
                         "keep the template beside the study")
    text = _read_text(template, "template")
    hook, hook_sha = spec.hook, None
    if hook is not None:
        where, _, func = hook.rpartition(":")
        if where.endswith(".py") or "/" in where or "\\" in where:
            path = (base / where).resolve()
            hook_sha = hashlib.sha256(_read_text(path, "hook").encode()).hexdigest()
            hook = f"{path}:{func}"
    names = placeholders(text) | {n for a in spec.command for n in placeholders(a)}
    unknown = sorted(names - known - set(BUILTINS))
    if unknown and hook is None:
        raise InputError(f"study: engine.template: unknown placeholder(s) "
                         f"{', '.join('{' + n + '}' for n in unknown)} in {template.name} or "
                         "the command; known: the parameter names, factor symbols and "
                         + ", ".join("{" + b + "}" for b in BUILTINS)
                         + " (write {{name}} for a literal {name})")
    name = spec.input or (template.name.removesuffix(".template") or template.name)
    return ResolvedEngine(
        kind=spec.kind, template_path=str(template), template_text=text,
        template_sha256=hashlib.sha256(text.encode()).hexdigest(), input=name,
        command=tuple(spec.command), timeout_s=float(spec.timeout_s), hook=hook,
        hook_sha256=hook_sha, result=spec.result.model_dump(mode="json"))
