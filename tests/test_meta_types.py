"""The store's meta ``versions``, ``engine`` and ``target``, typed (demcal.summaries.provenance,
demcal.summaries.target): written by the calibration as before, read back by the report and
the angle's response from stores of any release."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from demcal.calibrate.pipeline import engine_meta, resolve_target, versions_meta
from demcal.calibrate.responses import aor_spec
from demcal.calibrate.study import load_study, parse_study
from demcal.summaries import EngineMeta, Target, TargetPhoto, Versions

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_a_demcal_study_stores_the_keys_it_always_stored():
    study = load_study(EXAMPLES / "analytic" / "study.toml")
    versions = versions_meta(study).to_summary()
    assert list(versions) == ["demcal", "python", "numpy", "engine_backend", "engine"]
    assert versions["numpy"] == np.__version__ and versions["engine"] == "demcal"
    assert engine_meta(study).to_summary() == {"kind": "demcal", "name": "demcal",
                                               "backend": study.backend}
    assert not engine_meta(study).external


def test_a_template_engine_is_external_and_stores_its_command_and_template():
    study = load_study(EXAMPLES / "stand_in_engine" / "study.toml")
    meta = engine_meta(study)
    stored = meta.to_summary()
    assert meta.external and meta.kind == "template"
    assert list(stored) == ["kind", "name", "command", "template", "template_sha256", "result"]
    assert stored["name"] == "template: " + " ".join(meta.command or [])
    assert len(stored["template_sha256"]) == 64 and Path(stored["template"]).is_file()


def test_a_lammps_study_names_its_lammps_version_and_its_engine_is_built_in(monkeypatch):
    import demcal.virtual.lammps_run as lammps_run

    monkeypatch.setattr(lammps_run, "lammps_version", lambda settings: "22 Jul 2025 - Update 4")
    data = load_study(EXAMPLES / "analytic" / "study.toml").model_dump(mode="json")
    data["executor"]["engine"] = "lammps"
    data["test"] = {"kind": "aor", "fidelity": "quick"}
    study = parse_study(data, base=EXAMPLES / "analytic")
    versions = versions_meta(study)
    assert versions.lammps == "22 Jul 2025 - Update 4" and versions.engine == "lammps"
    assert versions.to_summary()["lammps"] == "22 Jul 2025 - Update 4"
    assert not engine_meta(study).external


def test_old_and_empty_stores_read():
    assert Versions.from_summary(None).line() == ""
    old = Versions.from_summary({"demcal": "0.1", "python": "3.11", "numpy": "1.26",
                                 "engine_backend": "cpu", "unknown_key": 1})
    assert old.line() == "demcal 0.1, python 3.11, numpy 1.26, engine_backend cpu"
    assert old.engine is None and old.lammps is None
    assert not EngineMeta.from_summary(None).external
    assert EngineMeta.from_summary({"kind": "template", "name": "template: x"}).external


def test_a_target_from_measurements_feeds_the_angle_s_response():
    """The corn stalk's five photos of Table 2 as a measurements file (the photo path's stored
    form is tests/calibrate/test_targets.py's)."""
    target = resolve_target(load_study(EXAMPLES / "corn_stalk" / "study.toml"))
    assert round(target.aor_deg, 2) == 44.12 and target.n == 5 and target.source == "value"
    assert Target.from_summary(target.to_summary()) == target
    spec = aor_spec(None, target)
    assert spec.target == target.aor_deg and spec.std == target.std_deg and spec.n == 5


def test_a_target_value_and_an_old_or_crafted_one_read():
    assert Target(aor_deg=44.12, std_deg=1.1, n=5, source="value").to_summary() == {
        "aor_deg": 44.12, "std_deg": 1.1, "n": 5, "source": "value", "photos": []}
    crafted = Target.from_summary({"aor_deg": 40.0, "photos": [{"file": "a.jpg"}, 3, "x"],
                                   "colour": "red"})
    assert crafted.photos == [TargetPhoto(file="a.jpg")] and crafted.std_deg is None
