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

# The public names, imported on first use (demcal._lazy): matplotlib loads only when a figure
# or the report is asked for.
from demcal._lazy import exports

__getattr__, __dir__, __all__ = exports(__name__, {
    "diagnostics": "diagnostics",
    "tables": "tables",
    "build_report": "build",
    "STAGES": "data",
    "ReportData": "data",
    "StageView": "data",
    "load_report_data": "data",
    "comparison_figure": "figures",
    "measurement_figure": "figures",
    "pareto_figure": "figures",
    "predicted_actual_figure": "figures",
    "rangefind_figure": "figures",
    "steepest_figure": "figures",
    "surface_figure": "figures",
    "verification_figure": "figures",
    "material_card": "material",
    "measurements_table": "material",
    "parameter_table": "material",
    "boxcox_figure": "model_figures",
    "pair_surface_figure": "model_figures",
    "perturbation_figure": "model_figures",
    "residual_figure": "model_figures",
    "StoredSurface": "surface",
    "significant_pairs": "surface",
})
