"""The report's material section, Table 1, the measurements and the verification pictures."""

from __future__ import annotations

import dataclasses
import json
import tomllib
from pathlib import Path

from htmltables import read_tables, section
from paper_store import DATA, _png, build_paper_store

from demcal.display import readable
from demcal.physical.derive import derive_parameters
from demcal.report import build_report
from demcal.store import RunStore
from demcal.virtual import PARAMETERS
from demcal.virtual.material_card import read_material_card


def _with_physical(study: Path) -> None:
    meas = tomllib.loads((DATA / "measurements.toml").read_text())["measurements"]
    with RunStore(study) as store:
        store.set_meta("physical", derive_parameters(meas).to_dict())


def test_table_1_and_the_measurements_replace_the_raw_dump(tmp_path):
    study = build_paper_store(tmp_path / "study")
    _with_physical(study)
    path = build_report(study)
    html, doc = path.read_text("utf-8"), json.loads((path.parent / "report.json").read_text())
    assert doc["problems"] == []
    meas = section(html, "measurement")
    assert "derived." not in html and "raw." not in meas and "t-physical" not in html
    assert doc["meta"]["physical"]["raw"]["density"]["density_kg_m3"][0] == 116.15  # kept
    tables = read_tables(html)
    t1 = {r[0]: r for r in tables["t-parameters"]["rows"]}
    assert len(t1) == len(PARAMETERS)
    density = t1["solid density of the particle"]
    assert density[1] == "rho1" and density[3] == "kg/m^3"
    assert "measured (overflow method" in density[4] and "n = 5" in density[4]
    assert "std 8.8792" in density[4]
    friction = t1["particle-particle static friction coefficient"]
    assert friction[2] == "0.35-0.7" and friction[5] == "calibrated"
    assert "range of 10 repeats" in friction[4]
    lab = {r[0]: r for r in tables["t-lab_measurements"]["rows"]}
    assert lab["solid density of the particle"][2:] == ["114.36", "8.8792", "5",
                                                        "103.34-125.38", "101.42-126.14"]
    assert lab["angle of repose (target)"][4] == "5"
    assert lab["sliding angle, inclined plane (particle-particle)"][-1] == "20-37"
    # each photo's angle is in its thumbnail's caption
    assert "Photo 1 (pile_1.jpg): 44.62°" in meas


def test_each_verification_pile_is_shown_beside_a_photo(tmp_path):
    study = build_paper_store(tmp_path / "study")
    with RunStore(study) as store:
        for r in store.runs("verification"):
            png = _png(study / f"pile_{r.replicate}.png", f"pile {r.replicate}", 40.0)
            store.record_run(dataclasses.replace(r, artefacts={"pile_png": png}))
    path = build_report(study)
    doc = json.loads((path.parent / "report.json").read_text())
    assert doc["problems"] == []
    comp = sorted(f for f in doc["figures"] if "comparison" in f)
    assert comp == [f"figures/comparison_{k}.png" for k in range(1, 6)]
    ver = section(path.read_text("utf-8"), "verification")
    assert "Replicate 1: simulated pile, AoR 43.10°" in ver
    assert "beside photo 5 (42.77°" in ver and "the same method" in ver


def test_the_material_card_of_the_paper_store(paper_report):
    path = paper_report["html_path"]
    card = read_material_card(path.parent / "material.toml")
    doc = json.loads((path.parent / "report.json").read_text())
    params = doc["summaries"]["verification"]["params"]
    assert {k: v.hex() for k, v in card.parameters.items()} == \
        {k: float(params[k]).hex() for k in PARAMETERS}
    assert set(card.calibrated) == set(doc["summaries"]["optimize"]["chosen"])
    assert doc["material_files"] == ["material.toml", "material.json"]
    assert card.verification.line.startswith("verified AoR 43.82 ± ")
    rows = read_tables(path.read_text("utf-8"))["t-material_card"]["rows"]
    assert [r[0] for r in rows] == list(PARAMETERS)
    x3 = next(r for r in rows if r[0] == "pp.static_friction")
    # the table is for reading (6 significant digits); the card above keeps every bit
    assert x3[2] == readable(card.parameters["pp.static_friction"])
    assert x3[4:6] == ["calibrated", "tangential"]


def test_a_lammps_study_gives_a_lammps_card_with_model_c(tmp_path):
    """LAMMPS has no rolling model A: a LAMMPS card names its sds law's demcal twin, C."""
    study = build_paper_store(tmp_path / "study")
    with RunStore(study) as store:
        store.set_meta("versions", {**store.meta("versions"), "engine": "lammps"})
        store.set_meta("engine", {"kind": "lammps", "name": "lammps", "backend": "auto"})
    path = build_report(study)
    card = read_material_card(path.parent / "material.toml")
    assert card.engine_name == "lammps" and card.rolling_model == "C"
    laws = json.loads((path.parent / "material.json").read_text())["engine"]["contact_laws"]
    assert laws["rolling"].startswith("LAMMPS rolling sds")
    assert "these parameters are for LAMMPS" in section(path.read_text("utf-8"), "material")


def test_the_card_pins_the_fidelity_pile_so_a_renamed_fidelity_runs_the_same_test(tmp_path):
    """The card writes the fidelity's tube and fill under the study's overrides: read back,
    it resolves to the study's test even under another fidelity name."""
    from demcal.virtual import fidelity_config

    study = build_paper_store(tmp_path / "study")
    with RunStore(study) as store:
        meta = store.meta("study")
        meta["test"] = {"kind": "aor", "fidelity": "small", "overrides": {"dt_fraction": 0.15}}
        store.set_meta("study", meta)
    path = build_report(study)
    card = read_material_card(path.parent / "material.toml")
    assert card.test.fidelity == "small"
    overrides = card.test.overrides
    assert overrides["fill"] == {"method": "packing", "count": 300}
    assert overrides["geometry"] == {"cylinder_inner_diameter": 0.035}
    assert overrides["dt_fraction"] == 0.15
    assert fidelity_config("standard", **overrides) == fidelity_config(
        "small", dt_fraction=0.15)


def test_no_card_before_an_optimum(tmp_path):
    study = build_paper_store(tmp_path / "study", stages=("rangefind", "screening"))
    path = build_report(study)
    doc = json.loads((path.parent / "report.json").read_text())
    assert doc["problems"] == [] and doc["material"] is None
    assert not (path.parent / "material.toml").exists()
    assert "No calibrated parameter set" in section(path.read_text("utf-8"), "material")


def test_a_malformed_parameter_set_is_a_note_and_removes_a_stale_card(tmp_path):
    study = build_paper_store(tmp_path / "study")
    out = build_report(study).parent
    assert (out / "material.toml").is_file()
    with RunStore(study) as store:
        rec = store.stage("verification")
        bad = {**rec.summary, "params": {**rec.summary["params"], "pp.restitution": "high"}}
        store.set_stage("verification", "done", bad, inputs_hash=rec.inputs_hash)
    path = build_report(study)
    doc = json.loads((path.parent / "report.json").read_text())
    assert len(doc["problems"]) == 1 and "material card not built" in doc["problems"][0]
    assert not (out / "material.toml").exists() and not (out / "material.json").exists()
    assert "material card not built" in path.read_text("utf-8")


def test_before_the_verification_the_card_holds_the_optimum(tmp_path):
    study = build_paper_store(tmp_path / "study", stages=("rangefind", "screening",
                                                           "steepest", "rsm", "optimize"))
    path = build_report(study)
    doc = json.loads((path.parent / "report.json").read_text())
    assert doc["problems"] == []
    card = read_material_card(path.parent / "material.toml")
    chosen = doc["summaries"]["optimize"]["chosen"]
    assert all(card.parameters[k] == v for k, v in chosen.items())
    with RunStore(study) as store:
        held = store.runs("rsm")[0].params
    others = {k: v for k, v in held.items() if k not in chosen}
    assert others and all(card.parameters[k] == v for k, v in others.items())
    assert card.verification.line == "not verified"


def test_a_lammps_card_names_the_lammps_version_the_runs_used(tmp_path):
    """engine.version stays demcal's; engine.lammps_version is the LAMMPS the study ran."""
    study = build_paper_store(tmp_path / "study")
    with RunStore(study) as store:
        store.set_meta("versions", {**store.meta("versions"), "engine": "lammps",
                                    "lammps": "22 Jul 2025 - Update 4"})
        store.set_meta("engine", {"kind": "lammps", "name": "lammps", "backend": "auto"})
    path = build_report(study)
    card = read_material_card(path.parent / "material.toml")
    assert card.engine.lammps_version == "22 Jul 2025 - Update 4"
    assert card.engine.version == "0.test"
    from demcal.virtual.lammps_card import lammps_lines

    assert "# calibrated with LAMMPS 22 Jul 2025 - Update 4" in lammps_lines(card).text


def test_the_lammps_version_is_read_from_the_lmp_banner():
    from demcal.virtual.lammps_run import parse_lammps_version

    banner = ("\nLarge-scale Atomic/Molecular Massively Parallel Simulator - 22 Jul 2025 - "
              "Update 4\nGit info (HEAD / stable_22Jul2025_update4)\n")
    assert parse_lammps_version(banner) == "22 Jul 2025 - Update 4"
    assert parse_lammps_version("not LAMMPS") is None


def test_the_installed_lammps_names_its_version():
    import pytest

    from demcal.virtual.lammps_run import _find, lammps_version

    if _find("lmp") is None:
        pytest.skip("LAMMPS is not installed (the lammps extra)")
    assert lammps_version()
