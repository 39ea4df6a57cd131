"""The Bayesian strategy's stage summary, typed (demcal.summaries.bayes): read from stores of
any release, written back to the same keys, and read by the report and the material card."""

from __future__ import annotations

import math

from demcal.summaries.bayes import BayesSummary, MarkedPoint


def _stored(marks: bool = True) -> dict:
    """A stage summary as the strategy stores it (two factors, one ridge, one round)."""
    out = {
        "posterior": {"a": {"mean": 0.5, "median": 0.49, "ci95_low": 0.3, "ci95_high": 0.7},
                      "b": {"mean": 0.1, "median": 0.1, "ci95_low": 0.05, "ci95_high": 0.2}},
        "correlation": {"a": {"a": 1.0, "b": -0.9}, "b": {"a": -0.9, "b": 1.0}},
        "acceptance_fraction": 0.4, "map": {"a": 0.5, "b": 0.1}, "warnings": [],
        "identifiable": False, "reason": "a ridge", "n_runs": 16, "verification_runs": 4,
        "stopped": "budget",
        "ridges": [{"text": "a up 0.1 = b down 0.03", "parameters": ["a", "b"],
                    "direction_coded": [0.7, -0.7], "fraction": 0.8}],
        "ridge": ["a up 0.1 = b down 0.03"],
        "shrinkage": [{"response": "drum_deg", "ridge": "a up 0.1 = b down 0.03",
                       "shrinkage": 0.6, "extent_before": 1.2, "extent_after": 0.5,
                       "effective_samples": 300.0, "basis": "stated",
                       "source": "a drum study"}],
        "history": [{"round": 1, "n_runs": 12, "half_widths_coded": {"a": 0.4, "b": 0.5},
                     "acceptance_fraction": 0.4, "warnings": []}],
        "optimum": {"a": 0.5, "b": 0.1},
        "predicted": {"aor_deg": {"mean": 44.0, "std": 0.3}},
        "labs": {"aor_deg": {"mean": 44.12, "standard_error": 0.76, "unit": "deg"}},
        "notes": [], "settings": {"max_runs": 12, "batch": 2, "tolerance": 0.25, "seed": 1,
                                  "n_start": 10},
        "units": {"a": "-", "b": "-"},
        "marks": [{"label": "DOE", "values": {"a": 0.45, "b": 0.12}, "in_box": True,
                   "credibility": 0.3, "inside95": True}],
        "combinations": [{"responses": ["drum_deg"], "ridges": []}],
        "advice": ["'a up 0.1 = b down 0.03': adding drum_deg would shrink it most (60 % "
                   "expected, from its stated slopes)"],
        "surrogate_checks": [{"response": "aor_deg", "n": 12, "rms_z": 1.1, "max_abs_z": 3.4,
                              "limit": 3.04, "worst": {"a": 0.6, "b": 0.2}, "value": 50.0,
                              "predicted": 46.0, "rms_error": 1.5, "judged": True,
                              "misses_a_run": True}],
        "samples": {"a": [0.5, 0.6], "b": [0.1, 0.09]},
        "slices": {"aor_deg": {"a": {"x": [0.3, 0.7], "mean": [40.0, 48.0],
                                     "std": [0.5, 0.5]}}},
    }
    if not marks:  # a store written before marks, advice and verification rounds
        del out["marks"], out["combinations"], out["advice"], out["verification_runs"]
        del out["surrogate_checks"]
    return out


def test_a_stored_summary_reads_typed_and_writes_back_the_same_keys():
    stored = _stored()
    s = BayesSummary.from_summary(stored)
    assert s is not None and s.names == ["a", "b"]
    assert s.posterior["a"].ci95_high == 0.7 and s.ridges[0].parameters == ["a", "b"]
    assert s.shrinkage[0].response == "drum_deg" and s.history[0].half_widths_coded["b"] == 0.5
    assert s.labs["aor_deg"].standard_error == 0.76 and s.predicted["aor_deg"].std == 0.3
    assert s.marks == [MarkedPoint(label="DOE", values={"a": 0.45, "b": 0.12}, in_box=True,
                                   credibility=0.3, inside95=True)]
    assert s.slices["aor_deg"]["a"].mean == [40.0, 48.0] and s.verification_runs == 4
    assert s.surrogate_checks[0].worst == {"a": 0.6, "b": 0.2}
    assert s.surrogate_checks[0].misses_a_run  # 3.4 beyond the limit 3.04
    assert s.to_summary() == stored and list(s.to_summary()) == list(stored)
    assert list(s.in_result()) == [k for k in stored if k not in ("samples", "slices")]


def test_an_older_store_without_marks_and_no_posterior_read():
    old = _stored(marks=False)
    for row in old["shrinkage"]:  # written before stated candidates
        del row["basis"], row["source"]
    s = BayesSummary.from_summary(old)
    assert s is not None and s.marks == [] and s.advice == [] and s.combinations == []
    assert s.verification_runs == 0 and s.surrogate_checks == []
    assert s.shrinkage[0].basis == "runs" and s.shrinkage[0].source is None
    assert BayesSummary.from_summary(None) is None
    assert BayesSummary.from_summary({"error": "failed"}) is None
    odd = BayesSummary.from_summary({"posterior": {"a": {"mean": 1.0}}})
    assert odd is not None and math.isnan(odd.posterior["a"].ci95_low)


def test_the_report_s_verdict_on_a_surrogate_is_the_study_s():
    """The check's verdict is stored, not derived again: a check on too few runs is no
    verdict even with a z beyond the limit (the study warned of nothing)."""
    from demcal.report.bayes_section import bayes_tables, bayes_view

    def verdict(**row) -> str:
        stored = _stored()
        stored["surrogate_checks"][0].update(row)
        table = next(t for t in bayes_tables(bayes_view(stored))
                     if t.key == "bayes_surrogate_checks")
        return table.records()["rows"][0][-1]

    assert verdict() == "misses that run"
    assert verdict(misses_a_run=False) == "follows its runs"
    assert verdict(n=8, judged=False, misses_a_run=False) == "too few runs to judge"
