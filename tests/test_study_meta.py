"""The store's meta ``study`` and ``factors``, typed (demcal.summaries.study_meta): the
settings the report and the material card show are read from the study's own dump, so a
renamed study field fails here, and stores of any release (or a crafted one) still read."""

from __future__ import annotations

from pathlib import Path

from demcal.calibrate.study import load_study, parse_study
from demcal.summaries import StudyFactor, StudyMeta

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_every_setting_the_report_shows_reads_from_the_study_s_dump():
    study = load_study(EXAMPLES / "corn_stalk" / "study_lammps_standard.toml")
    data = study.model_dump(mode="json")
    data["stages"]["screening"]["enabled"] = False
    data["material"]["overrides"] = {"particle.density": 250.0}
    data["test"]["overrides"] = {"rolling_model": "C"}
    study = parse_study(data, base=EXAMPLES / "corn_stalk")
    meta = StudyMeta.from_summary(study.model_dump(mode="json"))
    assert meta.name == study.name
    assert meta.backend == study.backend
    assert meta.engine == study.executor.engine == "lammps"
    assert (meta.test.kind, meta.test.fidelity) == (study.test.kind, study.test.fidelity)
    assert meta.test.fidelity == "standard"
    assert meta.test.overrides == {"rolling_model": "C"}
    assert meta.material.preset == study.material.preset == "corn_stalk"
    assert meta.material.overrides == {"particle.density": 250.0}
    assert "screening" in meta.disabled_stages and "rsm" not in meta.disabled_stages


def test_a_study_s_factors_store_as_they_always_did_and_read_back():
    study = load_study(EXAMPLES / "analytic" / "study.toml")
    for f in study.factors:
        stored = StudyFactor(name=f.name, symbol=f.symbol, low=f.low, high=f.high,
                             unit=f.unit).to_summary()
        assert list(stored) == ["name", "symbol", "low", "high", "unit"]
        back = StudyFactor.from_summary(stored)
        assert (back.name, back.symbol, back.low, back.high, back.unit) == (
            f.name, f.symbol, f.low, f.high, f.unit)


def test_old_empty_and_crafted_study_meta_read_with_the_study_file_s_defaults():
    empty = StudyMeta.from_summary(None)
    assert (empty.name, empty.backend, empty.engine) == (None, "auto", "demcal")
    assert (empty.test.kind, empty.test.fidelity, empty.test.overrides) == ("aor", "quick", {})
    assert empty.material.preset is None and empty.disabled_stages == ()
    odd = StudyMeta.from_summary({"name": "", "test": "aor", "material": {"preset": None,
                                  "overrides": None}, "executor": None,
                                  "stages": {"rsm": {"enabled": False}, "x": 3}})
    assert odd.name is None and odd.test.fidelity == "quick"
    assert odd.material.overrides == {} and odd.engine == "demcal"
    assert odd.disabled_stages == ("rsm",)
