"""The material card: a calibrated material as a DEM user types it in, in TOML and JSON.

A card holds every parameter of the virtual test (:data:`demcal.virtual.PARAMETERS`: fixed and
calibrated, SI units), which of them were calibrated, the contact laws they belong to in
demcal's engine (:mod:`demcal.dem.contact`), the engine and test it was calibrated with, and
the verification in one line. ``demcal report`` (and so ``demcal calibrate``) writes
``material.toml`` and ``material.json`` next to ``report.html``; ``demcal simulate aor
--material FILE`` reads either back and runs the material as it is.

Floats are written with ``repr`` (shortest round-tripping decimal), so a value read back is
bit-for-bit the value written. See ``docs/material_card.md`` for the format.

>>> from demcal.virtual.presets import preset_parameters
>>> card = MaterialCard(parameters=preset_parameters("corn_stalk"),
...                     calibrated=("pp.static_friction",))
>>> parse_material_card(card.to_toml(), "card.toml").parameters == card.parameters
True
"""

from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from demcal.errors import InputError
from demcal.virtual.card_blocks import (
    CardEngine,
    CardPosterior,
    CardShape,
    CardTest,
    CardVerification,
    flatten,
    number,
)
from demcal.virtual.parameters import PARAMETERS

__all__ = [
    "CARD_FORMAT",
    "CARD_VERSION",
    "CONTACT_LAWS",
    "ROLLING_LAWS",
    "MaterialCard",
    "parameter_law",
    "parse_material_card",
    "read_material_card",
]

#: Value of ``card.format`` in every card.
CARD_FORMAT = "demcal-material-card"
#: Version of the card layout this module writes and reads.
CARD_VERSION = 1
#: The contact laws of demcal's engine that the parameters enter (see demcal.dem.contact).
CONTACT_LAWS: dict[str, str] = {
    "elastic": "Hertz-Mindlin: E* from 1/E* = (1-v1^2)/E1 + (1-v2^2)/E2 with E = 2 G (1 + v); "
               "G* from 1/G* = (2-v1)/G1 + (2-v2)/G2 (demcal.dem.contact.pair_modulus)",
    "normal": "Hertz-Mindlin with JKR cohesion, EDEM's version 1 (demcal.dem.contact."
              "jkr_normal): F = 4 E* a^3 / (3 R*) - 4 sqrt(pi gamma E*) a^1.5, pull-off "
              "3 pi gamma R*; plain Hertz (4/3 E* sqrt(R*) delta^1.5) when gamma = 0",
    "damping": "EDEM's Hertz-Mindlin damping: beta = ln e / sqrt(ln^2 e + pi^2), "
               "F_d = 2 sqrt(5/6) beta sqrt(S m*) v with S_n = 2 E* a, S_t = 8 G* a",
    "tangential": "Mindlin no-slip spring S_t = 8 G* a with damping and the Coulomb limit "
                  "mu_s F_rep (F_rep the repulsive part of the normal force) "
                  "(demcal.dem.contact.tangential_contact)",
    "mass": "solid density of the clump's spheres and of the walls",
}

#: The rolling-friction models of the engine (``AoRTestConfig.rolling_model``).
ROLLING_LAWS: dict[str, str] = {
    "A": "type A, EDEM's standard constant directional torque: T = -mu_r F_rep d "
         "omega / |omega| (d the contact arm, omega the sphere's angular velocity)",
    "C": "type C, elastic-plastic spring (EPSD): k_r = 2.25 S_n mu_r^2 R*^2 with S_n = 2 E* a, "
         "torque capped at mu_r R* F_rep (history-dependent; demcal.dem.contact.rolling_c)",
    "none": "no rolling resistance (rolling friction coefficients unused)",
}

#: The laws of the LAMMPS engine (``[executor] engine = "lammps"``) that the parameters enter:
#: LAMMPS' pair granular with demcal's parameters mapped as in demcal.virtual.lammps_laws.
LAMMPS_CONTACT_LAWS: dict[str, str] = {
    "elastic": "LAMMPS hertz/material with (E, nu) chosen so that LAMMPS' E* and G* are "
               "demcal's (1/E* = (1-v1^2)/E1 + (1-v2^2)/E2, 1/G* = (2-v1)/G1 + (2-v2)/G2)",
    "normal": "LAMMPS jkr when gamma > 0 (the hysteretic JKR, EDEM's version 2: no force on "
              "approach, pull-off 3/2 pi w R*), else Hertz",
    "damping": "LAMMPS damping coeff_restitution (= EDEM's 2 sqrt(5/6) beta sqrt(S_n m*)), "
               "tangential x_gamma_t = sqrt(4 G*/E*); with jkr: damping viscoelastic matched "
               "at a typical contact",
    "tangential": "LAMMPS tangential mindlin (k_t = 8 G* a), Coulomb limit mu_s |F_n| "
                  "(with jkr: mu_s |F_ne + 2 F_pulloff|)",
    "rolling": "LAMMPS rolling sds: torque capped at mu_r R* |F_n| (demcal's model C lever "
               "arm), spring k_roll = 4.5 E* a mu_r^2 at a typical contact, no damping",
    "mass": "clump mass and inertia tensor of demcal's union-of-spheres template (fix "
            "rigid/small infile)",
}

_LAW_OF = {"poisson": "elastic", "shear_modulus": "elastic", "density": "mass",
           "restitution": "damping", "static_friction": "tangential",
           "rolling_friction": "rolling", "surface_energy": "normal"}


def parameter_law(name: str) -> str:
    """The contact law a parameter belongs to: ``elastic``, ``mass``, ``damping``,
    ``tangential``, ``rolling`` or ``normal`` (JKR cohesion)."""
    return _LAW_OF.get(name.rpartition(".")[2], "")


@dataclass(frozen=True)
class MaterialCard:
    """A calibrated material: every parameter with its meaning, the engine and the verification.

    Attributes
    ----------
    parameters : dict of str -> float
        Every parameter of :data:`demcal.virtual.PARAMETERS`, SI units (surface energy J/m^2,
        density kg/m^3, moduli Pa; coefficients dimensionless).
    calibrated : tuple of str
        Names of the parameters found by the calibration (the others were fixed).
    symbols : dict of str -> str
        Paper-style symbols of the parameters (``x3``), where known.
    study : str
        Name of the study the card comes from.
    engine : CardEngine
        The engine the material was calibrated with: its name, version, backend and rolling
        model; for an external engine (``name`` ``"template"``) its command and template.
    test : CardTest
        The virtual test: ``kind`` (``aor`` or ``analytic``), ``fidelity`` and
        ``overrides`` (nested settings of :class:`demcal.virtual.AoRTestConfig`).
    verification : CardVerification
        ``line`` (one sentence) and the numbers behind it (``aor_mean_deg``, ``aor_std_deg``,
        ``n``, ``target_aor_deg``, ``relative_error_percent``, ``p_value``, ``consistent``).
    shape : CardShape or None
        The particle the parameters were calibrated with (informative: a run takes it from
        the test settings); None where the card has no ``[particle_shape]``.
    posterior : CardPosterior or None
        Only from a Bayesian calibration (``[strategy] kind = "bayes"``): ``identifiable``,
        ``reason``, ``ridge`` and ``advice`` (texts), ``parameters`` (per calibrated
        parameter ``mean``, ``median``, ``ci95_low``, ``ci95_high``, SI) and ``correlation``
        (per pair); None otherwise. Informative: a run takes the values of ``parameters``
        above.
    """

    parameters: dict[str, float]
    calibrated: tuple[str, ...] = ()
    symbols: dict[str, str] = field(default_factory=dict)
    study: str = ""
    engine: CardEngine = field(default_factory=CardEngine)
    test: CardTest = field(default_factory=CardTest)
    verification: CardVerification = field(default_factory=CardVerification)
    shape: CardShape | None = None
    posterior: CardPosterior | None = None

    @property
    def engine_name(self) -> str:
        """The engine the parameters are for: ``"demcal"``, ``"lammps"`` or ``"template"``
        (an external engine, :mod:`demcal.execute.template_engine`)."""
        return self.engine.name

    @property
    def rolling_model(self) -> str:
        """The rolling-friction model (``"A"`` unless the card says otherwise)."""
        return self.engine.rolling

    @property
    def is_external(self) -> bool:
        """Calibrated in an external engine driven through a template (``engine.name``
        ``"template"``): its values mean that engine's laws, which demcal does not know."""
        return self.engine.is_external

    def rows(self) -> list[dict[str, Any]]:
        """One row per parameter: name, symbol, value, unit, role, law, description."""
        out = []
        for name, value in self.parameters.items():
            spec = PARAMETERS.get(name)
            law = parameter_law(name)
            out.append({
                "parameter": name,
                "symbol": self.symbols.get(name) or (spec.symbol if spec else ""),
                "value": value, "unit": (spec.unit if spec else "") or "-",
                "role": "calibrated" if name in self.calibrated else "fixed",
                "law": law, "description": spec.description if spec else ""})
        return out

    def to_dict(self) -> dict[str, Any]:
        """The card as plain JSON-able data (the layout of ``material.json``)."""
        if self.engine_name == "lammps":
            laws = {k: LAMMPS_CONTACT_LAWS[k] for k in ("elastic", "normal", "damping",
                                                        "tangential", "rolling")}
        else:
            laws = {k: CONTACT_LAWS[k] for k in ("elastic", "normal", "damping", "tangential")}
            laws["rolling"] = ROLLING_LAWS.get(self.rolling_model, self.rolling_model)
        params = {}
        for r in self.rows():
            params[r["parameter"]] = {k: r[k] for k in ("value", "unit", "role", "symbol",
                                                          "law", "description")}
        engine = self.engine.to_table()
        if not self.is_external:  # an external engine's parameters mean its own laws
            engine.update(rolling_model=self.rolling_model, contact_laws=laws)
        out = {"card": {"format": CARD_FORMAT, "version": CARD_VERSION, "study": self.study},
               "engine": engine,
               "test": self.test.to_table(), "verification": self.verification.to_table()}
        if self.shape is not None:
            out["particle_shape"] = self.shape.to_table()
        if self.posterior is not None:
            out["posterior"] = self.posterior.to_table()
        out["parameters"] = params
        return out

    def to_json(self) -> str:
        """``material.json`` text (floats as ``repr``: they read back bit-exactly)."""
        return json.dumps(self.to_dict(), indent=1, allow_nan=False) + "\n"

    def to_toml(self) -> str:
        """``material.toml`` text (floats as ``repr``: they read back bit-exactly)."""
        d = self.to_dict()
        lines = ["# demcal material card: every parameter of the material in SI units, the",
                 "# contact laws they belong to and the verification. Run it again with",
                 "#   demcal simulate aor --material material.toml",
                 "# See docs/material_card.md.", ""]
        if self.is_external:
            lines[:4] = ["# demcal material card: every parameter of the material in SI units and",
                         "# the verification, calibrated in the EXTERNAL engine of [engine]: the",
                         "# values mean that engine's contact laws, not demcal's. See",
                         "# docs/external_engines.md."]
        lines += _toml_table("card", d["card"])
        engine = {k: v for k, v in d["engine"].items() if k != "contact_laws"}
        lines += _toml_table("engine", engine)
        if "contact_laws" in d["engine"]:
            lines += _toml_table("engine.contact_laws", d["engine"]["contact_laws"])
        test = {k: v for k, v in d["test"].items() if k != "overrides"}
        lines += _toml_table("test", test)
        lines += _toml_table("test.overrides", flatten(d["test"].get("overrides") or {}))
        ver = {k: v for k, v in d["verification"].items() if k != "responses"}
        lines += _toml_table("verification", ver)
        for name, row in (d["verification"].get("responses") or {}).items():
            lines += _toml_table(f"verification.responses.{_key(name)}", row)
        if "particle_shape" in d:
            lines += _toml_table("particle_shape", d["particle_shape"])
        if "posterior" in d:
            lines += _posterior_toml(d["posterior"])
        for name, row in d["parameters"].items():
            lines += _toml_table(f"parameters.{_key(name)}", row)
        return "\n".join(lines)

    def write(self, out_dir: str | Path, stem: str = "material") -> tuple[Path, Path]:
        """Write ``<stem>.toml`` and ``<stem>.json`` into ``out_dir``; return both paths."""
        out = Path(out_dir)
        toml_path, json_path = out / f"{stem}.toml", out / f"{stem}.json"
        toml_path.write_text(self.to_toml(), encoding="utf-8")
        json_path.write_text(self.to_json(), encoding="utf-8")
        return toml_path, json_path


# ------------------------------------------------------------------------------ TOML writing
def _key(name: str) -> str:
    bare = name.replace("_", "").replace("-", "").isalnum() and name.isascii()
    return name if bare else json.dumps(name)


def _value(v: Any, where: str) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise InputError(f"{where}: {v!r} cannot be written to a material card")
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_value(x, where) for x in v) + "]"
    raise InputError(f"{where}: a {type(v).__name__} cannot be written to a material card")


def _toml_table(header: str, values: Mapping[str, Any]) -> list[str]:
    lines = [f"[{header}]"]
    for k, v in values.items():
        if v is None:  # TOML has no null: a missing key reads back as None
            continue
        lines.append(f"{_key(str(k))} = {_value(v, f'{header}.{k}')}")
    return [*lines, ""]


def _posterior_toml(post: Mapping[str, Any]) -> list[str]:
    """``[posterior]`` (verdict, ridges), then a table per parameter's interval and per row
    of the correlation."""
    lines = _toml_table("posterior", {k: v for k, v in post.items()
                                      if not isinstance(v, Mapping)})
    for part in ("parameters", "correlation"):
        for name, row in (post.get(part) or {}).items():
            lines += _toml_table(f"posterior.{part}.{_key(name)}", row)
    return lines


# ------------------------------------------------------------------------------------ reading
def read_material_card(path: str | Path) -> MaterialCard:
    """Read and validate a material card (``.toml`` or ``.json``).

    Parameters
    ----------
    path : str or Path
        ``material.toml`` or ``material.json`` as written by :meth:`MaterialCard.write`.

    Returns
    -------
    MaterialCard

    Raises
    ------
    InputError
        One line naming the file and the bad field: unreadable file, wrong format or version,
        an unknown or missing parameter, a value that is not a number or out of its range, a
        unit other than the parameter's SI unit, or an unknown rolling model.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"--material: no file {str(p)!r}")
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{p.name}: cannot be read ({exc})") from None
    return parse_material_card(text, p.name)


def parse_material_card(text: str, name: str = "material card") -> MaterialCard:
    """Parse a card's text (TOML, or JSON when it starts with ``{``); see
    :func:`read_material_card`. ``name`` prefixes the error messages."""
    doc = _document(text, name)
    params: dict[str, float] = {}
    calibrated, symbols = [], {}
    for pname, entry in _table(doc, "parameters", name).items():
        params[pname], role, symbol = _parameter(pname, entry, name)
        if role == "calibrated":
            calibrated.append(pname)
        if symbol:
            symbols[pname] = symbol
    missing = [n for n in PARAMETERS if n not in params]
    if missing:
        raise InputError(f"{name}: parameters missing: {', '.join(missing)} (a card gives "
                         "every parameter)")
    shape = _table(doc, "particle_shape", name, required=False)
    posterior = _table(doc, "posterior", name, required=False)
    try:
        engine = CardEngine.from_table(_table(doc, "engine", name, required=False))
        test = CardTest.from_table(_table(doc, "test", name, required=False))
        shape_ = CardShape.from_table(shape) if shape else None
        verification = CardVerification.from_table(
            _table(doc, "verification", name, required=False))
        posterior_ = CardPosterior.from_table(posterior) if posterior else None
    except InputError as exc:
        raise InputError(f"{name}: {exc}") from None
    return MaterialCard(parameters=params, calibrated=tuple(calibrated), symbols=symbols,
                        study=str(_table(doc, "card", name).get("study") or ""),
                        engine=engine, test=test, verification=verification, shape=shape_,
                        posterior=posterior_)


def _document(text: str, name: str) -> dict[str, Any]:
    """The card's tables (TOML, or JSON when it starts with ``{``), its ``[card]`` checked."""
    try:
        if text.lstrip().startswith("{"):
            doc = json.loads(text)
        else:
            doc = tomllib.loads(text)
    except RecursionError:
        raise InputError(f"{name}: not a valid material card (nested too deeply)") from None
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{name}: not a valid material card ({msg})") from None
    if not isinstance(doc, dict):
        raise InputError(f"{name}: not a valid material card (no tables)")
    card = _table(doc, "card", name)
    if card.get("format") != CARD_FORMAT:
        raise InputError(f"{name}: card.format must be {CARD_FORMAT!r}; got "
                         f"{card.get('format')!r}")
    if card.get("version") != CARD_VERSION:
        raise InputError(f"{name}: card.version must be {CARD_VERSION}; got "
                         f"{card.get('version')!r} (written by another demcal version)")
    return doc


def _parameter(pname: str, entry: Any, name: str) -> tuple[float, str, str | None]:
    """One ``[parameters.NAME]`` entry checked: its value (SI), role and symbol."""
    spec = PARAMETERS.get(pname)
    if spec is None:
        raise InputError(f"{name}: unknown parameter {pname!r}; known: "
                         f"{', '.join(PARAMETERS)}")
    if not isinstance(entry, dict):
        entry = {"value": entry}
    value = number(entry, "value", f"{name}: parameters.{pname}")
    if value is None:
        raise InputError(f"{name}: parameters.{pname}.value must be a number; got None")
    unit = entry.get("unit")
    if unit is not None and unit not in (spec.unit, "-" if not spec.unit else spec.unit):
        raise InputError(f"{name}: parameters.{pname}.unit must be "
                         f"{spec.unit or '-'!r} (SI); got {unit!r}")
    try:
        checked = spec.check(value)
    except InputError as exc:
        raise InputError(f"{name}: parameters.{exc}") from None
    role = entry.get("role", "fixed")
    if role not in ("fixed", "calibrated"):
        raise InputError(f"{name}: parameters.{pname}.role must be 'fixed' or "
                         f"'calibrated'; got {role!r}")
    return checked, role, str(entry["symbol"]) if entry.get("symbol") else None


def _table(doc: Mapping[str, Any], key: str, name: str, *, required: bool = True) -> dict:
    value = doc.get(key)
    if value is None and not required:
        return {}
    if not isinstance(value, dict):
        raise InputError(f"{name}: the table [{key}] is missing" if value is None else
                         f"{name}: [{key}] must be a table; got {type(value).__name__}")
    return value
