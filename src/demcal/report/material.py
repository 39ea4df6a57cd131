"""The calibrated material and its inputs, as the report shows them.

- :func:`material_card` builds the :class:`~demcal.virtual.material_card.MaterialCard` of a
  study from its store (the verified parameter set, else the optimum with the fixed values);
- :func:`card_table` is that card as the report's first table;
- :func:`parameter_table` is the paper's Table 1: every parameter with its symbol, value or
  range, unit and source (measured with n and spread, literature, preset or calibrated);
- :func:`measurements_table` is the compact table of the lab measurements: mean ± std, n,
  95 % interval, range.

Values in the tables are SI (angles in degrees) except where a column names another unit.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

from demcal.display import readable
from demcal.report import responses as RS
from demcal.report.data import Lead, ReportData
from demcal.report.tables import Table, _frame, _num, format_cell
from demcal.summaries import Optimum, Target, Verification
from demcal.summaries.bayes import BayesSummary
from demcal.summaries.physical_meta import MeasuredQuantity
from demcal.virtual.card_blocks import (
    CardEngine,
    CardInterval,
    CardPosterior,
    CardResponseCheck,
    CardShape,
    CardTest,
    CardVerification,
)
from demcal.virtual.material_card import MaterialCard, parameter_law
from demcal.virtual.parameters import PARAMETERS

__all__ = ["card_table", "material_card", "measurement_label", "measurements_table",
           "parameter_table", "verification_line", "write_material_card"]


def verification_line(ver: Verification, target: Target | None,
                      lead: Lead | None = None) -> str:
    """One sentence: the verified lead (the AoR) mean ± std (n) against the measurement,
    error, p, verdict. ``lead``: the study's lead where it is not the angle (``target`` then
    holds its lab value)."""
    mean, std = _num(ver.mean), _num(ver.std)
    if mean is None:
        return ("not verified" if not ver.done else
                f"verification formed no pile ({ver.n_piles} of {ver.n} runs)")
    t = target or Target()
    lead = lead or Lead()
    label, u = lead.label, lead.after_number(degree_sign=True)
    out = f"verified {label} {mean:.2f}"
    out += f" ± {std:.2f}{u}" if std is not None else u
    out += f" (n = {ver.n})"
    goal = _num(t.aor_deg)
    if goal is not None:
        tstd = _num(t.std_deg)
        out += f" vs measured {goal:.2f}" + (f" ± {tstd:.2f}{u}" if tstd is not None else u)
        if t.n:
            out += f" (n = {t.n})"
    rel = _num(ver.relative_error_percent)
    if rel is not None:
        out += f"; relative error {rel:.2f} %"
    p = _num(ver.p_value)
    if p is not None:
        out += f"; p = {p:.3g}"
    if ver.consistent is not None:
        out += ", consistent" if ver.consistent else ", differs"
    if ver.confirmed is not None:
        out += ("; the response surface's prediction confirmed" if ver.confirmed else
                "; the response surface's prediction not confirmed")
    return out


def _engine(data: ReportData) -> tuple[CardEngine, CardTest, CardShape | None]:
    """Engine, test and particle shape of the study (from its test settings)."""
    study = data.study
    test = study.test
    versions, external = data.versions, data.engine
    if external.external:  # a template engine made the runs
        return (CardEngine(name=str(external.kind), version=str(versions.demcal or ""),
                           command=" ".join(external.command or []),
                           template=str(external.template or ""),
                           template_sha256=str(external.template_sha256 or "")),
                CardTest(kind=str(external.kind)), None)
    name = versions.engine or study.engine
    engine = CardEngine(
        name=str(name), version=str(versions.demcal or ""),
        backend=str(versions.engine_backend or study.backend), rolling_model="A",
        # `version` stays demcal's
        lammps_version=str(versions.lammps) if name == "lammps" and versions.lammps else None)
    shape = None
    try:
        from demcal.virtual.config import fidelity_config

        cfg = fidelity_config(test.fidelity, **test.overrides)
        # LAMMPS has no model A: its rolling sds is model C's law (docs/lammps.md)
        rolling = "C" if name == "lammps" and cfg.rolling_model != "none" else cfg.rolling_model
        engine = replace(engine, rolling_model=rolling, dt_fraction=cfg.dt_fraction)
        p = cfg.particle
        shape = CardShape(template=p.template, length_m=p.length, diameter_m=p.diameter,
                          n_spheres=p.n_spheres, size_min=p.size_min, size_max=p.size_max)
    except Exception:  # a study of another version: the engine's defaults, no shape
        if test.overrides.get("rolling_model"):
            engine = replace(engine, rolling_model=str(test.overrides["rolling_model"]))
    from demcal.virtual.config import fidelity_overrides

    # the fidelity's tube and fill written out: the card runs the same pile if the name later
    # means another (as "standard" did: 300 stalks until 2026-11-27, 1200 since)
    return engine, CardTest(kind=test.kind, fidelity=test.fidelity, overrides=fidelity_overrides(
        test.fidelity, dict(test.overrides))), shape


def _verification_block(ver: Verification, opt: Optimum,
                        data: ReportData) -> CardVerification:
    """The card's [verification]: its line, the numbers behind it, the round it is from."""
    lead = data.lead
    several = RS.responses_view(data.surface, opt, ver)
    responses = {} if several is None else {  # every response at the optimum and verified
        r.name: CardResponseCheck(
            lab=r.lab_mean, predicted=r.predicted, mean=r.verified_mean, std=r.verified_std,
            n=r.verified_n, relative_error_percent=r.relative_error_percent,
            consistent=r.consistent) for r in several.rows}
    refined = ver.round_number > 1  # a refinement round's (demcal.calibrate.refine)
    return CardVerification(
        line=verification_line(ver, data.lead_lab, lead),
        lead=None if lead.is_angle else lead.name,
        aor_mean_deg=ver.mean, aor_std_deg=ver.std, n=ver.n,
        relative_error_percent=ver.relative_error_percent, p_value=ver.p_value,
        consistent=ver.consistent, ci_low_deg=ver.ci_low, ci_high_deg=ver.ci_high,
        confirm_pi_low_deg=ver.confirm_pi_low, confirm_pi_high_deg=ver.confirm_pi_high,
        confirmed=ver.confirmed, target_in_interval=ver.target_in_interval,
        target_aor_deg=data.lead_target, predicted_aor_deg=opt.predicted_lead,
        desirability=None if several is None else several.desirability, responses=responses,
        round=ver.round_number if refined else None,
        surface_offset_deg=opt.surface_offset if refined else None,
        measured_offset_deg=opt.measured_offset if refined else None,
        offset_weight=opt.offset_weight if refined else None)


def material_card(data: ReportData) -> MaterialCard | None:
    """The study's material card, or None when no full parameter set is stored.

    The parameters are the verification's (exactly the set that was run), else the stored
    result's ``optimum_full``, else the optimum merged into the parameters of the
    response-surface runs (which hold every other parameter where the optimum has it) and the
    fixed values; a parameter still missing comes from the study's material preset.
    """
    ver = data.verification
    opt = data.optimum
    result = data.result
    chosen = opt.chosen or (result.optimum if result is not None else {})
    params = ver.params or (result.optimum_full if result is not None else None)
    if not params:
        if not chosen:
            return None
        # the response-surface runs hold every other parameter where the optimum has it
        held = next((r.params for r in reversed(data.stage("rsm").runs) if r.params), None)
        params = {**data.fixed_params, **(held or {}), **chosen}
    params = {k: float(v) for k, v in params.items() if k in PARAMETERS}
    missing = [k for k in PARAMETERS if k not in params]
    if missing:
        from demcal.virtual.presets import PRESETS

        base = PRESETS.get(str(data.study.material.preset), PRESETS["corn_stalk"])
        for k in missing:
            params[k] = float(base[k])
    params = {k: params[k] for k in PARAMETERS}  # the canonical order
    engine, test, shape = _engine(data)
    symbols = dict(data.symbols)
    for name, spec in PARAMETERS.items():
        symbols.setdefault(name, spec.symbol)
    verification = _verification_block(ver, opt, data)
    return MaterialCard(parameters=params, calibrated=tuple(k for k in chosen if k in params),
                        symbols=symbols, study=data.title_name,
                        engine=engine, test=test, verification=verification, shape=shape,
                        posterior=_posterior_block(data.stage("bayes").summary))


def _posterior_block(stored: Mapping[str, Any]) -> CardPosterior | None:
    """The card's [posterior] from a Bayesian study's stage summary (None for a DOE study):
    the verdict, the ridges, what would shrink each, each parameter's interval and the
    correlation (SI)."""
    bayes = BayesSummary.from_summary(stored)
    if bayes is None or not bayes.posterior:
        return None
    return CardPosterior(
        identifiable=bool(bayes.identifiable), reason=str(bayes.reason),
        ridge=[str(r) for r in bayes.ridge], advice=[str(a) for a in bayes.advice],
        parameters={n: CardInterval(mean=float(p.mean), median=float(p.median),
                                    ci95_low=float(p.ci95_low), ci95_high=float(p.ci95_high))
                    for n, p in bayes.posterior.items()},
        correlation={a: {b: float(r) for b, r in row.items()}
                     for a, row in bayes.correlation.items()})


def write_material_card(study_dir: str | Path,
                        out_dir: str | Path | None = None) -> tuple[Path, Path] | None:
    """Write ``material.toml`` and ``material.json`` of a study without the report.

    Parameters
    ----------
    study_dir : str or Path
        Study folder holding ``demcal.sqlite``.
    out_dir : str or Path, optional
        Output folder (default ``<study_dir>/report``, where the report puts them).

    Returns
    -------
    (Path, Path) or None
        The two files, or None when the store has no optimum yet.
    """
    from demcal.report.data import load_report_data

    data = load_report_data(study_dir)
    card = material_card(data)
    if card is None:
        return None
    out = Path(out_dir) if out_dir is not None else data.study_dir / "report"
    out.mkdir(parents=True, exist_ok=True)
    return card.write(out)


def card_table(card: MaterialCard) -> Table:
    """The material card as a table: parameter, symbol, value (rounded for reading), unit,
    role, contact law.

    The values are :func:`demcal.display.readable` (6 significant digits: 0.3, not
    0.30000000000000004); the card's files keep every digit.
    """
    rows = [{"parameter": r["parameter"], "symbol": r["symbol"], "value": readable(r["value"]),
             "unit": r["unit"], "role": r["role"], "contact law": r["law"],
             "meaning": r["description"]} for r in card.rows()]
    return Table("material_card", "Calibrated material (as typed into the DEM code)",
                 _frame(rows, ["parameter", "symbol", "value", "unit", "role", "contact law",
                               "meaning"]),
                 note="Values in SI units, rounded to 6 significant digits for reading; "
                      "material.toml / material.json hold the exact values (type those, or "
                      "load the card, for the exact round trip).")


# ------------------------------------------------------------------------------ Table 1
def _range_text(lo: Any, hi: Any) -> str:
    a, b = _num(lo), _num(hi)
    if a is None or b is None:
        return ""
    return f"{format_cell(a)}-{format_cell(b)}"


def _spread_text(s: MeasuredQuantity) -> str:
    n = s.n_repeats
    if s.range_only:
        return f"n = {n}, range {_range_text(s.minimum, s.maximum)}"
    std = _num(s.std)
    out = f"n = {n}"
    if std is not None:
        out += f", std {format_cell(std)}"
    return out


def parameter_table(data: ReportData, card: MaterialCard | None = None) -> Table:
    """The paper's Table 1: every parameter with symbol, value or range, unit and source.

    ``value or range`` is the fixed value, or the range the calibration searched (the
    study's, after range finding); ``source`` is measured (with n and spread), literature
    or the material preset; ``used`` is the value in the material card.
    """
    bench = data.physical
    factors = {f.name: f for f in data.factors}
    ranges = {} if (result := data.result) is None else result.ranges
    fixed = data.fixed_params
    material = data.study.material
    preset, overrides = material.preset, material.overrides
    rows = []
    for name, spec in PARAMETERS.items():
        phys = bench.rows.get(name)
        given = factors.get(name)
        symbol = (given.symbol if given else None) or (phys and phys.symbol) or spec.symbol
        if given is not None:
            lo, hi = given.low, given.high
            value = _range_text(lo, hi)
            if name in ranges and list(ranges[name]) != [lo, hi]:
                value += f" (searched {_range_text(*ranges[name])})"
            source = (phys and phys.source) or "range given in the study"
        elif name in fixed:
            value = format_cell(_num(fixed[name]))
            source = (phys and phys.source) or ("study file" if name in overrides or not preset
                                                else f"material preset {preset}")
        elif phys:
            value = phys.display or ""
            source = phys.source or ""
        else:
            value, source = "", "not stored"
        s = bench.summaries.get(name)
        if s is not None and "measured" in str(source) and "n =" not in str(source):
            source = f"{source}; {_spread_text(s)}"
        used = card.parameters.get(name) if card is not None else None
        rows.append({"parameter": spec.description, "symbol": symbol, "value or range": value,
                     "unit": spec.unit or "-", "source": source,
                     "role": ("calibrated" if card is not None and name in card.calibrated
                              else "factor" if name in factors else "fixed"),
                     "used": used, "law": parameter_law(name)})
    return Table("parameters", "Model parameters (cf. Table 1)",
                 _frame(rows, ["parameter", "symbol", "value or range", "unit", "source",
                               "role", "used", "law"]),
                 note="'used' is the value in the material card (the verified set); 'factor' "
                      "rows were varied in screening but fixed afterwards.")


def measurements_table(data: ReportData) -> Table:
    """The lab measurements, compact: quantity, unit, mean ± std, n, 95 % interval, range."""
    bench = data.physical
    rows, names = [], set()
    for key, s in bench.summaries.items():
        names.add(str(s.name or key))
        rows.append(_measurement_row(str(s.name or key), s))
    t = data.target or Target()
    if t.aor_deg is not None and "aor_deg" not in names:
        if bench.target_aor is not None:
            rows.append(_measurement_row("aor_deg", bench.target_aor))
        else:
            rows.append({"quantity": "angle of repose (target)", "unit": "deg",
                         "mean": _num(t.aor_deg), "std": _num(t.std_deg),
                         "n": t.n, "95 % interval": "", "range": ""})
    return Table("lab_measurements", "Measurements (mean ± std, n, 95 % interval)",
                 _frame(rows, ["quantity", "unit", "mean", "std", "n", "95 % interval",
                               "range"]))


_WHO = {"particle": "particle", "wall": "wall", "pp": "particle-particle",
        "pw": "particle-wall"}
_WHAT = {"youngs_modulus": "Young's modulus", "inclination_deg": "sliding angle, inclined plane",
         "length": "length", "diameter": "diameter", "moisture_percent": "moisture content",
         "aor_deg": "angle of repose (target)"}


def measurement_label(name: str) -> str:
    """Readable name of a measured quantity (``pp.inclination_deg`` -> ``sliding angle,
    inclined plane (particle-particle)``)."""
    spec = PARAMETERS.get(name)
    if spec is not None:
        return spec.description
    who, _, what = name.rpartition(".")
    text = _WHAT.get(what, what.replace("_", " "))
    return f"{text} ({_WHO.get(who, who)})" if who else text


def _measurement_row(name: str, s: MeasuredQuantity) -> dict[str, Any]:
    label = measurement_label(name)
    level = _num(s.ci_level)
    lo, hi = _num(s.ci_low), _num(s.ci_high)
    ci = "" if lo is None or hi is None else _range_text(lo, hi)
    if ci and level is not None and not math.isclose(level, 0.95):
        ci += f" ({level * 100:g} %)"
    return {"quantity": label, "unit": s.unit or "-", "mean": _num(s.mean),
            "std": _num(s.std), "n": s.n_repeats, "95 % interval": ci,
            "range": "" if _num(s.minimum) == _num(s.maximum)
            else _range_text(s.minimum, s.maximum)}
