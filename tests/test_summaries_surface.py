"""The typed response-surface summary (:class:`demcal.summaries.Surface`): the keys the rsm
stage stores, in order, with the angle alone and with several responses, and what stores of
earlier releases read back as."""

from __future__ import annotations

import gzip
import json
import shutil
import sqlite3
from pathlib import Path

from demcal.summaries import (
    AnovaFit,
    AnovaRecord,
    DesignRun,
    FitStatistics,
    ResponseModel,
    StudyFactor,
    Surface,
    SurfaceRound,
)

DATA = Path(__file__).parent / "data"

#: The keys the rsm stage stores, in order (demcal.calibrate.stages.rsm). The result JSON, the
#: report and old stores read these names: renaming a field must fail here.
SURFACE_KEYS = ["design", "factors", "runs", "excluded_points", "replicates", "anova", "fit",
                "lack_of_fit_p", "adequacy", "rounds", "model", "removed_terms", "anova_full",
                "adequacy_full", "coefficients_coded", "coefficients_actual", "equation_coded",
                "equation_actual", "adequate", "warnings"]
#: with several responses, every other response's model after the replicates
SEVERAL_KEYS = [*SURFACE_KEYS[:5], "responses", *SURFACE_KEYS[5:]]
#: each other response's model (demcal.calibrate.several.ResponseFit.summary)
RESPONSE_KEYS = ["model", "adequate", "adequacy", "warnings", "excluded_points", "anova",
                 "coefficients_coded", "equation_actual"]

FACTORS = [{"name": "pp.static_friction", "symbol": "x3", "low": 0.2, "high": 1.0, "unit": ""},
           {"name": "pp.rolling_friction", "symbol": "x4", "low": 0.0, "high": 0.4,
            "unit": ""}]
ADEQUACY = FitStatistics(p_model=1e-6, lack_of_fit_p=0.4, r2=0.99, adj_r2=0.98, pred_r2=0.95,
                         adeq_precision=30.0)
#: an ANOVA row's and the fit statistics' stored keys (AnovaRow.to_dict, FitStatistics.to_dict
#: of demcal.doe.anova)
ANOVA_KEYS = ["term", "ss", "df", "ms", "f", "p"]
FIT_KEYS = ["std_dev", "mean", "cv_percent", "press", "r2", "adj_r2", "pred_r2",
            "adeq_precision"]
ADEQUACY_KEYS = ["p_model", "lack_of_fit_p", "r2", "adj_r2", "pred_r2", "adeq_precision"]
#: a replicate round's row (demcal.calibrate.stages.rsm), its statistics flat in it
ROUND_KEYS = ["replicates", "runs", "blocks", "model", "removed_terms", "adequate", "failed",
              *ADEQUACY_KEYS]


def _surface(**extra) -> Surface:
    """As :func:`demcal.calibrate.stages.rsm` builds it (``lack_of_fit_p`` None: no test)."""
    return Surface(
        design="box_behnken", factors=[StudyFactor(**f) for f in FACTORS],
        runs=[DesignRun(point=0, coded={"pp.static_friction": -1.0},
                        actual={"pp.static_friction": 0.2}, value=35.0, outcome="pile",
                        replicates=[35.0], replicate_std=None)],
        excluded_points=[], replicates=1, anova=[AnovaRecord(term="pp.static_friction", p=0.001)],
        fit=AnovaFit(r2=0.99), lack_of_fit_p=None, adequacy=ADEQUACY,
        rounds=[SurfaceRound(replicates=1, runs=13, adequate=True, statistics=ADEQUACY)],
        model="quadratic",
        removed_terms=[], anova_full=[], adequacy_full=ADEQUACY,
        coefficients_coded={"intercept": 40.0, "pp.static_friction": 5.0},
        coefficients_actual={"intercept": 30.0, "pp.static_friction": 12.5},
        equation_coded="40 + 5 A", equation_actual="30 + 12.5 pp.static_friction",
        adequate=True, warnings=["no lack-of-fit test"], **extra)


def test_the_angle_s_surface_stores_the_keys_it_always_stored():
    surface = _surface()
    stored = surface.to_summary()
    assert list(stored) == SURFACE_KEYS and stored["lack_of_fit_p"] is None
    assert list(stored["anova"][0]) == ANOVA_KEYS and list(stored["fit"]) == FIT_KEYS
    assert list(stored["adequacy"]) == list(stored["adequacy_full"]) == ADEQUACY_KEYS
    assert list(stored["rounds"][0]) == ROUND_KEYS
    assert surface.rounds[0].statistics == ADEQUACY
    json.dumps(stored)  # plain JSON
    assert Surface.from_summary(stored) == surface
    assert surface.names == ["pp.static_friction", "pp.rolling_friction"]
    assert surface.model_kind == "quadratic"


def test_several_responses_store_each_model_after_the_replicates():
    drum = ResponseModel(model="reduced", adequate=True, adequacy=ADEQUACY, warnings=[],
                         excluded_points=[3], anova=[AnovaRecord(term="pp.rolling_friction")],
                         coefficients_coded={"intercept": 32.0}, equation_actual="32")
    surface = _surface(responses={"drum_deg": drum})
    stored = surface.to_summary()
    assert list(stored) == SEVERAL_KEYS
    assert list(stored["responses"]["drum_deg"]) == RESPONSE_KEYS
    assert list(stored["responses"]["drum_deg"]["adequacy"]) == ADEQUACY_KEYS
    assert list(stored["responses"]["drum_deg"]["anova"][0]) == ANOVA_KEYS
    back = Surface.from_summary(stored)
    assert back == surface and back.responses["drum_deg"].excluded_points == [3]


def test_an_old_store_s_surface_reads_and_writes_back_byte_for_byte(tmp_path):
    # the response surface a schema-1 store (the release before several responses) holds
    db = tmp_path / "old.sqlite"
    with gzip.open(DATA / "store_v1_analytic.sqlite.gz", "rb") as src, db.open("wb") as dst:
        shutil.copyfileobj(src, dst)
    con = sqlite3.connect(db)
    try:
        text = con.execute("SELECT summary_json FROM stages WHERE name = 'rsm'").fetchone()[0]
    finally:
        con.close()
    stored = json.loads(text)
    surface = Surface.from_summary(stored)
    assert surface.adequate is stored["adequate"] and surface.responses is None
    assert len(surface.names) == len(stored["factors"]) >= 2
    assert json.dumps(surface.to_summary()) == json.dumps(stored)


def test_missing_keys_take_their_defaults_and_unknown_keys_are_left_out():
    empty = Surface.from_summary(None)
    assert empty.runs == [] and empty.coefficients_coded == {} and empty.names == []
    # a store written before the model reduction and the replicate rounds
    old = {k: v for k, v in _surface().to_summary().items()
           if k not in ("model", "removed_terms", "anova_full", "adequacy_full", "rounds",
                        "replicates")}
    surface = Surface.from_summary({**old, "some_future_key": 1})
    assert surface.model is None and surface.model_kind == "quadratic"
    assert surface.to_summary() == old
    # a failed stage stores its design and runs beside the error
    failed = Surface.from_summary({"design": "ccd", "factors": FACTORS, "runs": [],
                                   "excluded_points": [0, 1], "error": "rsm: cannot fit"})
    assert failed.design == "ccd" and failed.adequate is None and not failed.coefficients_coded


def test_the_surface_s_ranges_are_its_factors():
    assert _surface().ranges == {"pp.static_friction": (0.2, 1.0),
                                 "pp.rolling_friction": (0.0, 0.4)}
