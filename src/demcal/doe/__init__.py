"""Design of experiments: designs, response-surface models, ANOVA, optimisation.

Pure statistics (numpy, scipy, pandas); nothing here knows about DEM. Typical use::

    from demcal import doe

    space = doe.load_factors("factors.toml")          # or doe.FactorSpace([doe.Factor(...)])
    design = doe.box_behnken(space, center_points=3, seed=1)
    sheet = design.to_frame()                          # run order, actual and coded columns
    rs = doe.fit(design, aor_deg, model="quadratic")   # NaN responses are excluded
    print(rs.anova())                                  # Design-Expert's ANOVA table
    best = doe.optimize_target(rs, 44.12)              # settings that hit a target
"""

# The public names, imported on first use (demcal._lazy): a module that needs `doe.factors`
# does not load scipy.stats and pandas with it.
from demcal._lazy import exports

__getattr__, __dir__, __all__ = exports(__name__, {
    "AnovaRow": "anova",
    "AnovaTable": "anova",
    "FitStatistics": "anova",
    "anova_table": "anova",
    "backward_elimination": "anova",
    "screening_effects": "anova",
    "significance": "anova",
    "FRACTION_GENERATORS": "designs",
    "PB_GENERATORS": "designs",
    "Design": "designs",
    "box_behnken": "designs",
    "central_composite": "designs",
    "factorial": "designs",
    "latin_hypercube": "designs",
    "plackett_burman": "designs",
    "sobol": "designs",
    "steepest_path": "designs",
    "DesirabilityResult": "desirability",
    "DesirabilitySolution": "desirability",
    "ResponseGoal": "goal",
    "Search": "desirability",
    "climb": "desirability",
    "desirability_at": "desirability",
    "optimize_desirability": "desirability",
    "overall_desirability": "desirability",
    "surface_predictors": "desirability",
    "Factor": "factors",
    "FactorSpace": "factors",
    "as_factor_space": "factors",
    "load_factors": "factors",
    "ResponseSurface": "model",
    "UnbalancedBlocksError": "model",
    "fit": "model",
    "OptimizationResult": "optimize",
    "EffectResolution": "power",
    "replicates_to_resolve": "power",
    "Solution": "optimize",
    "optimize_target": "optimize",
    "target_desirability": "optimize",
    "MODELS": "terms",
    "model_matrix": "terms",
    "model_terms": "terms",
    "parse_term": "terms",
    "term_name": "terms",
})
