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

from demcal.doe.anova import (
    AnovaRow,
    AnovaTable,
    FitStatistics,
    anova_table,
    backward_elimination,
    screening_effects,
    significance,
)
from demcal.doe.designs import (
    FRACTION_GENERATORS,
    PB_GENERATORS,
    Design,
    box_behnken,
    central_composite,
    factorial,
    latin_hypercube,
    plackett_burman,
    sobol,
    steepest_path,
)
from demcal.doe.desirability import (
    DesirabilityResult,
    DesirabilitySolution,
    ResponseGoal,
    Search,
    climb,
    desirability_at,
    optimize_desirability,
    overall_desirability,
    surface_predictors,
)
from demcal.doe.factors import Factor, FactorSpace, as_factor_space, load_factors
from demcal.doe.model import ResponseSurface, UnbalancedBlocksError, fit
from demcal.doe.optimize import (
    OptimizationResult,
    Solution,
    optimize_target,
    target_desirability,
)
from demcal.doe.terms import MODELS, model_matrix, model_terms, parse_term, term_name

__all__ = [
    "FRACTION_GENERATORS",
    "MODELS",
    "PB_GENERATORS",
    "AnovaRow",
    "AnovaTable",
    "Design",
    "DesirabilityResult",
    "DesirabilitySolution",
    "Factor",
    "FactorSpace",
    "FitStatistics",
    "OptimizationResult",
    "ResponseGoal",
    "ResponseSurface",
    "Search",
    "Solution",
    "UnbalancedBlocksError",
    "anova_table",
    "as_factor_space",
    "backward_elimination",
    "box_behnken",
    "central_composite",
    "climb",
    "desirability_at",
    "factorial",
    "fit",
    "latin_hypercube",
    "load_factors",
    "model_matrix",
    "model_terms",
    "optimize_desirability",
    "optimize_target",
    "overall_desirability",
    "parse_term",
    "plackett_burman",
    "screening_effects",
    "significance",
    "sobol",
    "steepest_path",
    "surface_predictors",
    "target_desirability",
    "term_name",
]
