"""Calibration studies: the study file (TOML, pydantic), the stages, the runner.

``demcal calibrate STUDY.toml`` runs :func:`demcal.calibrate.pipeline.calibrate`: rangefind ->
screening (Plackett-Burman) -> steepest ascent/descent -> response surface (BBD/CCD) ->
optimisation -> verification, every run stored in the study's RunStore as it ends.

Modules: :mod:`~demcal.calibrate.study` (schema, ``demcal init`` example),
:mod:`~demcal.calibrate.runner` (keys, resume, retry), :mod:`~demcal.calibrate.stages`,
:mod:`~demcal.calibrate.bayes_strategy` (``[strategy] kind = "bayes"``),
:mod:`~demcal.calibrate.classifier` (pile region), :mod:`~demcal.calibrate.external`
(run sheets), :mod:`~demcal.calibrate.pipeline`.

Store contract (writer: this package; reader: demcal.report)
============================================================

The study folder holds `demcal.sqlite` (demcal.store.RunStore, STORE_NAME). The report is
built from the store ALONE. Both sides code against this contract; the writer documents it in
the `demcal.calibrate` package docstring. JSON values only (None for NaN). Angles in degrees,
everything else SI. Parameter names are those of demcal.virtual.parameters.PARAMETERS
(e.g. "pp.static_friction"). Factor "symbol" is the paper-style short name ("x3").

## meta (RunStore.set_meta / meta)
- "study": the validated study (pydantic model_dump(mode="json"))
- "study_file": str, absolute path of the TOML;  "study_dir": str
- "target" (typed: demcal.summaries.Target): {"aor_deg": float, "std_deg": float|None,
             "n": int|None,
             "source": "value"|"photos",
             "photos": [{"file": str, "left_deg", "right_deg", "mean_deg",
                         "figure": str|None (PNG path, diagnostic figure)}]}
- "physical": dict|None — intrinsic properties if the study gives measurements
  (e.g. {"density_kg_m3":..., "shear_modulus_pa":..., "poisson":..., "friction": {...}})
- "fixed_params": {name: value}  (every parameter not a factor)
- "factors": [{"name", "symbol", "low", "high", "unit"}]  (ranges as given in the study)
- "versions" (typed: demcal.summaries.Versions): {"demcal", "python", "numpy",
  "engine_backend", "engine"; with the LAMMPS engine "lammps": the version `lmp -h` names,
  or None}
- "engine" (typed: demcal.summaries.EngineMeta): which engine made the runs: {"kind":
  "demcal", "name": "demcal", "backend"}, or an external one {"kind": "template", "name":
  "template: <command>", "command": [str], "template": str (path), "template_sha256": str,
  "result": {reader settings}}
- "result": the final JSON (same as `demcal calibrate --json`), once the study is done

## stages (RunStore.set_stage(name, status, summary)); status running|done|failed;
## a failed stage's summary holds {"error": str}
- "rangefind" (typed: demcal.summaries.RangeFind): {"factors": [{"name", "symbol", "low",
      "high", "new_low", "new_high", "points": [{"value", "outcome", "aor_deg"|None}],
      "reason": str|None}],
      "response_min_deg", "response_max_deg", "target_in_range": bool, "message": str}
- "screening" (typed: demcal.summaries.Screening, its runs DesignRun): {"design":
      "plackett_burman", "n_runs": int, "alpha": float,
      "factors": [{"name","symbol","low","high","unit"}], "dummies": [str],
      "runs": [{"point": int, "coded": {name: -1|1}, "actual": {name: value},
                "aor_deg": float|None, "outcome": str}],
      "anova": [AnovaTable.to_records() rows], "fit": FitStatistics.to_dict(),
      "effects": [{"term", "effect", "contribution_percent", "f", "p", "rank"}],
      "selected": [names], "excluded_points": [int], "message": str}
- "steepest" (typed: demcal.summaries.Steepest): {"factors": [names], "direction": {name: +1|-1},
      "steps": [{"step": int, "actual": {name: value}, "aor_deg": float|None,
                 "outcome": str, "relative_error_percent": float|None}],
      "best_step": int, "centre": {name: value}, "levels": {name: [low, centre, high]},
      "anchor" (only when the path ran at its own fidelity): {"fidelity", "runs": [{"step",
      "actual", "aor_deg", "outcome", "path_aor_deg"}], "crossing_step": float|None,
      "centre_step": float, "offset_deg": float|None, "message"},
      with several responses also "followed": [response names the path climbed], "climb":
      {"goals", "coefficients_coded": {response: {"intercept", name: float}}, "gradient":
      {name: float}, "centre_climb": float, "alone": {response: {name: +1|-1}}}, and per
      step "responses": {response: float|None}, "desirability": float|None}
- "rsm" (typed: demcal.summaries.Surface): {"design": "box_behnken"|"ccd",
      "factors": [{"name","symbol","low","high","unit"}],
      "runs": [{"point","coded","actual","aor_deg" (mean of the replicates),"outcome",
                "aor_runs_deg": [float] (each replicate), "aor_std_deg": float|None}],
      "anova": [records], "fit": FitStatistics.to_dict(), "lack_of_fit_p": float|None,
      "coefficients_coded": {term: value}, "coefficients_actual": {term: value},
      "equation_coded": str, "equation_actual": str, "adequate": bool,
      "adequacy": {"p_model", "lack_of_fit_p", "r2", "adj_r2", "pred_r2", "adeq_precision"}
      (of the design-point means; Design-Expert's rules, see surface_fit.adequacy),
      "replicates": int (replicates used, extra ones added while not adequate within
      stages.rsm.max_runs), "rounds": [{"replicates", "runs", "model", "removed_terms",
      "adequate", "failed", ...}], "model": "quadratic"|"reduced" (the one anova,
      coefficients and the optimum are of; stages.rsm.model), "removed_terms": [str],
      "anova_full": [records], "adequacy_full": {...} (the full quadratic model's),
      "warnings": [str], "excluded_points": [int], with several responses also "responses":
      {response: {"model", "adequate", "adequacy", "warnings", "excluded_points", "anova",
      "coefficients_coded", "equation_actual"}} (each other response's model over the same
      design)}
- "optimize" (typed: demcal.summaries.Optimum writes and reads it): {"target_aor_deg": float,
      "candidates": [{"params": {name: value}, "predicted_aor_deg": float,
                      "pi_low_deg": float|None, "pi_high_deg": float|None,
                      "p_pile": float|None}],  (ranked, best first)
      "chosen": {name: value}, "predicted_aor_deg": float,
      with several responses also "responses": {"goals": [{"name", "goal", "low", "high",
      "target", "weight", "importance"}], "desirability", "reachable", "unmet": [str]},
      "warnings" (only when a limit is out of reach) and per candidate "predicted" and
      "individual" ({response: float}),
      in a refinement round (demcal.calibrate.refine): "round": int (2, 3, ...),
      "surface_offset_deg": float (the correction applied: the surface was aimed at the
      target less it), "measured_offset_deg": float (earlier rounds' piles' means less the
      surface there, pooled), "offset_weight": float (the share applied: 1 after an
      unconfirmed round, N h / (N h + 1) when every pooled round was confirmed),
      "offset_from_rounds": [int] (the rounds pooled), "rounds": [the earlier rounds'
      summaries]}
- "verification": {"params": {name: value (full set)}, "aor_deg": [float|None],
      "outcomes": [str], "aor_mean_deg", "aor_std_deg", "relative_error_percent", "n",
      "pile_png": str|None (side view of a verification pile with fitted lines),
      "ci_low_deg", "ci_high_deg" (95 % t-interval of the mean), "p_value", "test",
      "consistent" (Welch t-test against the measurement when its spread is known, else a
      one-sample t-test; None with fewer than 2 piles), "half_width_deg" (of the 95 %
      interval), "half_width_goal_deg", "half_width_reached" (runs are added from n up to
      max_n until the half-width reaches the goal), "confirm_pi_low_deg",
      "confirm_pi_high_deg" (the response surface's 95 % prediction interval for the mean of
      the n runs at the optimum), "confirmed" (the mean inside it: Design-Expert's
      confirmation; in a refinement round, of the surface corrected by the offset, widened
      by the offset's own error), "target_in_interval" (the target inside
      ci_low_deg-ci_high_deg), in a refinement round "round" and "rounds" (as optimize's)}
- "bayes" (typed: demcal.summaries.BayesSummary; ``[strategy] kind = "bayes"``,
      demcal.calibrate.bayes_strategy; the DOE stages'
      summaries are dropped then, and this one when the DOE path runs): {"posterior":
      {name: {"mean", "median", "ci95_low", "ci95_high"}} (factors' units), "correlation":
      {name: {name: r}}, "identifiable": bool, "reason": str, "ridge": [str], "ridges":
      [{"text", "parameters", "direction_coded", "fraction"}], "shrinkage": [{"response",
      "ridge", "shrinkage", "extent_before", "extent_after", "effective_samples"}],
      "history": [{"round", "n_runs", "half_widths_coded": {name: float},
      "acceptance_fraction", "warnings"}], "stopped": "tolerance"|"budget", "n_runs": int,
      "optimum": {name: value} (the best sample), "predicted": {response: {"mean", "std"}},
      "labs": {response: {"mean", "standard_error", "unit"}}, "notes": [str], "warnings":
      [str], "settings": {...}, "units": {name: str}, "map", "acceptance_fraction",
      "samples": {name: [float]} (thinned posterior), "slices": {response: {name: {"x",
      "mean", "std"}}} (each surrogate along each factor through the best point)}; the
      strategy also writes "optimize" ({"chosen", "predicted_aor_deg", one candidate,
      "opts": "bayes", "source"}) and "verification" as above (no surface: "confirmed" None)

## runs (RunStore.record_run / runs(stage=...))
Each RunRecord: stage, point (design row index), replicate, params (full set), seed,
status done|failed, outcome (pile|column|plug|unsettled|unstable), aor_deg, result (the
AoRResult.to_dict() or the stand-in's dict), reason, attempts, timings, artefacts.

Also written (extra keys, readers may ignore them): steepest "message"; optimize
"classifier" and each candidate's "desirability"; verification "n_piles"; a retried run's
result "first_attempt"; meta "result" also holds "fidelity" (the test the verification and
the card ran, where it is demcal's or LAMMPS' AoR test; a stage at another names its own),
"optimum_full" (every parameter),
"n_runs_executed", "n_runs_used" (the runs this study's stages used; "n_runs" counts every
stored run, a reused store's others included), "ranges" (final factor ranges), "rounds"
(one row per verification round: its optimum, prediction, piles and confirmation; the
study's answer is the last),
"rsm_adequate" and "stages" (per stage: design, factors, responses, selected). Each stage
row's inputs_hash is a hash of the stage's inputs (ranges, options, fixed values, test); runs
are reused by run key, so a changed study re-runs only the runs whose key changed.
"""

# The public names, imported on first use (demcal._lazy): `demcal.calibrate.study` is read by
# every command and must not pull the pipeline's scipy, pandas and numba in with it.
from demcal._lazy import exports

__getattr__, __dir__, __all__ = exports(__name__, {
    "STAGES": "pipeline",
    "calibrate": "pipeline",
    "open_study": "pipeline",
    "StudyAccess": "pipeline",
    "ExternalPending": "runner",
    "Point": "runner",
    "Runner": "runner",
    "EXAMPLE_STUDY": "study",
    "Study": "study",
    "load_study": "study",
    "parse_study": "study",
})
