"""Typed stage summaries: what a calibration stage stores and what the report, the material
card and the result JSON read back.

A stage's summary lives in the run store as JSON. ``from_summary``
(:meth:`RangeFind.from_summary`, :meth:`Screening.from_summary`,
:meth:`Steepest.from_summary`, :meth:`Surface.from_summary`, :meth:`Optimum.from_summary`,
:meth:`Verification.from_summary`, :meth:`BayesSummary.from_summary`, and the result JSON's
:meth:`CalibrationResult.from_summary`) reads one written by any
release (a key it lacks takes its default, as older stores lack the newer keys; keys it does
not know are left out), and ``to_summary`` writes this release's keys in a fixed order.
Readers use the attributes, so renaming a field breaks the code that reads it and its tests,
not a cell of the report. Fields have the response's generic names (``value``, ``mean``,
``predicted_lead``); a field whose stored key keeps the angle's name (``aor_mean_deg``)
declares it once (``stored_as``), and :func:`by_key` gives fields under those keys for the
file formats built from them (the result JSON).
"""

from demcal.summaries._stored import by_key, stored_key
from demcal.summaries.anova import AnovaFit, AnovaRecord, anova_records
from demcal.summaries.bayes import BayesSummary
from demcal.summaries.design import DesignRun
from demcal.summaries.optimum import Candidate, Goal, Optimum, ResponsesOptimum
from demcal.summaries.provenance import EngineMeta, Versions
from demcal.summaries.rangefind import RangeFind, ScanFactor, ScanPoint, ScanReach
from demcal.summaries.result import CalibrationResult, ResultResponses, ResultRound, SurfaceFacts
from demcal.summaries.screening import Effect, Screening, ScreeningModel
from demcal.summaries.steepest import Anchor, AnchorRun, PathStep, Steepest
from demcal.summaries.study_meta import StudyFactor, StudyMaterial, StudyMeta, StudyTest
from demcal.summaries.surface import FitStatistics, ResponseModel, Surface, SurfaceRound
from demcal.summaries.target import Target, TargetPhoto
from demcal.summaries.verification import ResponseVerification, Verification

__all__ = ["Anchor", "AnchorRun", "AnovaFit", "AnovaRecord", "BayesSummary", "CalibrationResult",
           "Candidate", "DesignRun", "Effect", "EngineMeta", "FitStatistics", "Goal", "Optimum",
           "PathStep", "RangeFind", "ResponseModel", "ResponseVerification", "ResponsesOptimum",
           "ResultResponses", "ResultRound", "ScanFactor", "ScanPoint", "ScanReach", "Screening",
           "ScreeningModel", "Steepest", "StudyFactor", "StudyMaterial", "StudyMeta", "StudyTest",
           "Surface", "SurfaceFacts", "SurfaceRound", "Target", "TargetPhoto", "Verification",
           "Versions", "anova_records", "by_key", "stored_key"]
