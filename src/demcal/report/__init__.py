"""The calibration report: the paper's tables and figures, rebuilt from the run store alone.

Typical use::

    from demcal import report

    path = report.build_report("studies/corn")          # -> studies/corn/report/report.html
    data = report.load_report_data("studies/corn")      # the same numbers, for a notebook
    fig = report.pareto_figure(data.screening.effects or [], data.symbols)
    card = report.material_card(data)                   # the calibrated material
    rs = report.diagnostics.refit(data.surface, "rsm")  # Design-Expert's checks

``build_report`` also writes the material card (``material.toml``, ``material.json``; see
``demcal.virtual.material_card``) and the model diagnostics (``report.diagnostics``).
Figures are matplotlib Figures (Agg canvas, no pyplot state); tables are pandas DataFrames
(``report.tables``), also written as CSV next to the HTML.
"""

from demcal.report import diagnostics, tables
from demcal.report.build import build_report
from demcal.report.data import STAGES, ReportData, StageView, load_report_data
from demcal.report.figures import (
    comparison_figure,
    measurement_figure,
    pareto_figure,
    predicted_actual_figure,
    rangefind_figure,
    steepest_figure,
    surface_figure,
    verification_figure,
)
from demcal.report.material import material_card, measurements_table, parameter_table
from demcal.report.model_figures import (
    boxcox_figure,
    pair_surface_figure,
    perturbation_figure,
    residual_figure,
)
from demcal.report.surface import StoredSurface, significant_pairs

__all__ = [
    "STAGES",
    "ReportData",
    "StageView",
    "StoredSurface",
    "boxcox_figure",
    "build_report",
    "comparison_figure",
    "diagnostics",
    "load_report_data",
    "material_card",
    "measurement_figure",
    "measurements_table",
    "pair_surface_figure",
    "parameter_table",
    "pareto_figure",
    "perturbation_figure",
    "predicted_actual_figure",
    "rangefind_figure",
    "residual_figure",
    "significant_pairs",
    "steepest_figure",
    "surface_figure",
    "tables",
    "verification_figure",
]
