"""Design of experiments: designs, response-surface models, ANOVA, optimisation."""
