"""A real RunStore holding the paper's study (Tables 2-4, 6, 7), fits computed with demcal.doe.

Used by the report tests and to render the demo report. Numbers: Table 2 (five photo angles,
mean 44.12 deg), Table 3 (screening ranges), Table 4 (Plackett-Burman runs), Table 6 (path of
steepest ascent), Table 7 (Box-Behnken runs); the screening and BBD ANOVA, effects, fit
statistics and the optimum are computed here by demcal.doe, so they are the real ones. The
range-finding scan and the five verification replicates (mean 43.82 deg as in the text) are
invented test data, the paper has none.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from demcal import doe
from demcal.calibrate.verify import compare_to_target
from demcal.store import RunRecord, RunStore, run_key
from demcal.summaries import Verification, stored_key

DATA = Path(__file__).resolve().parents[2] / "examples" / "corn_stalk"
TARGET = 44.12
PHOTOS = [44.62, 45.21, 46.09, 41.89, 42.77]
SYMBOL = {"particle.poisson": "x1", "pp.restitution": "x2", "pp.static_friction": "x3",
          "pp.rolling_friction": "x4", "pw.restitution": "x5", "pw.static_friction": "x6",
          "pw.rolling_friction": "x7", "pp.surface_energy": "x8"}
NAME = {v: k for k, v in SYMBOL.items()}
TABLE3 = {"x1": (0.2, 0.4), "x2": (0.25, 0.5), "x3": (0.35, 0.7), "x4": (0.01, 0.02),
          "x5": (0.3, 0.6), "x6": (0.4, 0.8), "x7": (0.01, 0.02), "x8": (0.01, 0.02)}
FIXED = {"particle.density": 114.36, "particle.shear_modulus": 2.5e6, "wall.poisson": 0.3,
         "wall.shear_modulus": 7.9e10, "wall.density": 7850.0, "pw.surface_energy": 0.0}
BBD = ["x3", "x4", "x8"]
LEVELS = {"x3": (0.55, 0.65, 0.75), "x4": (0.09, 0.12, 0.15), "x8": (0.08, 0.10, 0.12)}
VERIFY = [43.1, 44.5, 43.9, 44.2, 43.4]  # mean 43.82 deg (the paper's text)
ALL_STAGES = ("rangefind", "screening", "steepest", "rsm", "optimize", "verification")


def _png(path: Path, title: str, slope_deg: float) -> str:
    """A small diagnostic-style PNG (a pile outline with fitted flank lines)."""
    fig = Figure(figsize=(3, 2), dpi=60)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    t = math.tan(math.radians(slope_deg))
    ax.fill([-1, 0, 1], [0, t, 0], color="0.6")
    ax.plot([-1, 0, 1], [0, t, 0], "r-")
    ax.set_title(title, fontsize=8)
    ax.set_aspect("equal")
    fig.savefig(path)
    return str(path)


def _mid(sym: str) -> float:
    lo, hi = TABLE3[sym]
    return (lo + hi) / 2


def _params(**over: float) -> dict[str, float]:
    p = dict(FIXED)
    p.update({NAME[s]: _mid(s) for s in TABLE3})
    p.update(over)
    return p


def _record(store: RunStore, stage: str, point: int, params: dict, aor: float | None,
            outcome: str = "pile", replicate: int = 0, reason: str | None = None) -> None:
    seed = 1000 + point * 10 + replicate
    store.record_run(RunRecord(
        key=run_key(stage, params, seed), stage=stage, point=point, replicate=replicate,
        params=params, seed=seed, status="done", outcome=outcome,
        responses={} if aor is None else {"aor_deg": aor},
        result={"aor_deg": aor, "outcome": outcome}, reason=reason, wall_time_s=1.0))


def screening_fit() -> doe.ResponseSurface:
    """The linear fit of Table 4 with parameter names as factor names."""
    t4 = pd.read_csv(DATA / "table4_pb.csv").set_index("run")
    coded = t4[list(TABLE3)].rename(columns=NAME)
    return doe.fit(coded, t4["aor_deg"], model="linear", response_name="AoR")


def rsm_fit() -> doe.ResponseSurface:
    """The quadratic fit of Table 7 (coded), factors named by parameter."""
    t7 = pd.read_csv(DATA / "table7_bbd.csv").set_index("run")
    space = doe.FactorSpace([doe.Factor(NAME[s], LEVELS[s][0], LEVELS[s][2]) for s in BBD])
    return doe.fit(t7[BBD].rename(columns=NAME), t7["aor_deg"], model="quadratic",
                   factors=space, units="coded", response_name="AoR")


def build_paper_store(study_dir: Path, stages: Iterable[str] = ALL_STAGES,
                      fail: dict[str, str] | None = None, running: Iterable[str] = (),
                      photos: bool = True) -> Path:
    """Write the paper's study into ``study_dir/demcal.sqlite``; return ``study_dir``.

    ``stages`` are stored as done, ``fail`` maps stages to an error stored as failed,
    ``running`` stages are stored as running with the summary so far.
    """
    study_dir.mkdir(parents=True, exist_ok=True)
    stages, fail, running = set(stages), dict(fail or {}), set(running)
    store = RunStore(study_dir)

    def put(name: str, summary: dict) -> None:
        if name in fail:
            store.set_stage(name, "failed", {"error": fail[name]})
        elif name in running:
            store.set_stage(name, "running", summary)
        elif name in stages:
            store.set_stage(name, "done", summary)

    photo_rows = []
    for i, a in enumerate(PHOTOS):
        fig = _png(study_dir / f"photo_{i + 1}_diag.png", f"photo {i + 1}: {a} deg", a) \
            if photos else None
        photo_rows.append({"file": f"photos/pile_{i + 1}.jpg", "left_deg": None,
                           "right_deg": None, "mean_deg": a, "figure": fig})
    store.set_meta("study", {"name": "corn stalk (paper)", "target": {"aor_deg": TARGET}})
    store.set_meta("study_file", str(study_dir / "study.toml"))
    store.set_meta("study_dir", str(study_dir))
    store.set_meta("target", {"aor_deg": float(np.mean(PHOTOS)),
                              "std_deg": float(np.std(PHOTOS, ddof=1)), "n": len(PHOTOS),
                              "source": "photos" if photos else "value",
                              "photos": photo_rows if photos else []})
    store.set_meta("physical", {"density_kg_m3": 114.36, "shear_modulus_pa": 2.5e6,
                                "poisson": 0.3, "moisture_percent": 11.63,
                                "friction": {"pp.static_friction": [0.35, 0.75],
                                             "pw.static_friction": [0.4, 0.7]}})
    store.set_meta("fixed_params", FIXED)
    store.set_meta("factors", [{"name": NAME[s], "symbol": s, "low": lo, "high": hi,
                                "unit": "J/m^2" if s == "x8" else ""}
                               for s, (lo, hi) in TABLE3.items()])
    store.set_meta("versions", {"demcal": "0.test", "python": "3", "numpy": np.__version__,
                                "engine_backend": "stand-in"})

    # ---- range finding (invented: the paper has none); x4's low end gives no pile
    rf_factors = []
    for k, (s, (lo, hi)) in enumerate(TABLE3.items()):
        values = np.linspace(lo, 2 * hi, 4)
        pts = []
        for j, v in enumerate(values):
            if s == "x4" and j == 0:
                pts.append({"value": float(v), "outcome": "column", "aor_deg": None})
                _record(store, "rangefind", 10 * k + j, _params(**{NAME[s]: float(v)}), None,
                        "column", reason="no pile: the material stayed a column")
            else:
                a = 33.0 + 4.0 * j * (1 if s in BBD else 0.2)
                pts.append({"value": float(v), "outcome": "pile", "aor_deg": a})
                _record(store, "rangefind", 10 * k + j, _params(**{NAME[s]: float(v)}), a)
        rf_factors.append({"name": NAME[s], "symbol": s, "low": lo, "high": hi,
                           "new_low": float(values[1]) if s == "x4" else lo,
                           "new_high": 2 * hi, "points": pts,
                           "reason": "no pile below" if s == "x4" else None})
    put("rangefind", {"factors": rf_factors, "response_min_deg": 33.0,
                      "response_max_deg": 45.0, "target_in_range": True,
                      "message": "target inside the scanned AoR range"})

    # ---- screening: Table 4 and its real fit
    rs = screening_fit()
    t4 = pd.read_csv(DATA / "table4_pb.csv")
    runs = []
    for _, row in t4.iterrows():
        coded = {NAME[s]: int(row[s]) for s in TABLE3}
        actual = {NAME[s]: TABLE3[s][0] if row[s] < 0 else TABLE3[s][1] for s in TABLE3}
        runs.append({"point": int(row["run"]), "coded": coded, "actual": actual,
                     "aor_deg": float(row["aor_deg"]), "outcome": "pile"})
        _record(store, "screening", int(row["run"]), _params(**actual), float(row["aor_deg"]))
    eff = rs.effects()
    effects = [{"term": str(t), "effect": float(r["effect"]),
                "contribution_percent": float(r["contribution_percent"]), "f": float(r["f"]),
                "p": float(r["p"]), "rank": int(r["rank"])} for t, r in eff.iterrows()]
    anova = rs.anova()
    put("screening", {"design": "plackett_burman", "n_runs": 12, "alpha": 0.05,
                      "factors": [{"name": NAME[s], "symbol": s, "low": lo, "high": hi,
                                   "unit": ""} for s, (lo, hi) in TABLE3.items()],
                      "dummies": [], "runs": runs, "anova": anova.to_records(),
                      "fit": anova.fit.to_dict(), "effects": effects,
                      "selected": [NAME[s] for s in BBD], "excluded_points": [],
                      "message": "x8, x4, x3 significant"})

    # ---- steepest ascent: Table 6
    t6 = pd.read_csv(DATA / "table6_steepest.csv")
    steps = []
    for _, row in t6.iterrows():
        actual = {NAME[s]: float(row[s]) for s in BBD}
        steps.append({"step": int(row["run"]), "actual": actual,
                      "aor_deg": float(row["aor_deg"]), "outcome": "pile",
                      "relative_error_percent": float(row["relative_error_percent"])})
        _record(store, "steepest", int(row["run"]), _params(**actual), float(row["aor_deg"]))
    put("steepest", {"factors": [NAME[s] for s in BBD],
                     "direction": {NAME[s]: 1 for s in BBD}, "steps": steps, "best_step": 4,
                     "centre": steps[3]["actual"],
                     "levels": {NAME[s]: list(LEVELS[s]) for s in BBD}})

    # ---- response surface: Table 7 and its real quadratic fit
    rq = rsm_fit()
    t7 = pd.read_csv(DATA / "table7_bbd.csv")
    rruns = []
    for _, row in t7.iterrows():
        coded = {NAME[s]: int(row[s]) for s in BBD}
        actual = {NAME[s]: LEVELS[s][int(row[s]) + 1] for s in BBD}
        rruns.append({"point": int(row["run"]), "coded": coded, "actual": actual,
                      "aor_deg": float(row["aor_deg"]), "outcome": "pile"})
        _record(store, "rsm", int(row["run"]), _params(**actual), float(row["aor_deg"]))
    qa = rq.anova()
    put("rsm", {"design": "box_behnken",
                "factors": [{"name": NAME[s], "symbol": s, "low": LEVELS[s][0],
                             "high": LEVELS[s][2], "unit": "J/m^2" if s == "x8" else ""}
                            for s in BBD],
                "runs": rruns, "anova": qa.to_records(), "fit": qa.fit.to_dict(),
                "lack_of_fit_p": qa["Lack of Fit"].p,
                "coefficients_coded": {k: float(v) for k, v in rq.coefficients_coded.items()},
                "coefficients_actual": {k: float(v) for k, v in rq.coefficients_actual.items()},
                "equation_coded": rq.equation(units="coded"),
                "equation_actual": rq.equation(units="actual"), "adequate": True,
                "warnings": [], "excluded_points": []})

    # ---- optimum: demcal.doe.optimize_target on the real fit
    res = doe.optimize_target(rq, TARGET, n_solutions=4, seed=1)
    cands = [{"params": dict(sol.actual), "predicted_aor_deg": float(sol.predicted),
              "pi_low_deg": float(sol.pi[0]), "pi_high_deg": float(sol.pi[1]), "p_pile": None}
             for sol in res.solutions]
    put("optimize", {"target_aor_deg": TARGET, "candidates": cands,
                     "chosen": cands[0]["params"],
                     "predicted_aor_deg": cands[0]["predicted_aor_deg"]})

    # ---- verification (invented replicates with the paper's mean 43.82 deg)
    vparams = _params(**cands[0]["params"])
    for i, a in enumerate(VERIFY):
        _record(store, "verification", 0, vparams, a, replicate=i)
    mean = float(np.mean(VERIFY))
    cmp = dataclasses.asdict(compare_to_target(np.array(VERIFY), TARGET))
    put("verification", {"params": vparams, "aor_deg": VERIFY, "outcomes": ["pile"] * 5,
                         "aor_mean_deg": mean, "aor_std_deg": float(np.std(VERIFY, ddof=1)),
                         "relative_error_percent": 100 * abs(mean - TARGET) / TARGET, "n": 5,
                         "pile_png": _png(study_dir / "pile_side.png", "simulated pile",
                                          mean) if photos else None,
                         **{stored_key(Verification, k): v for k, v in cmp.items()}})
    store.close()
    return study_dir


if __name__ == "__main__":  # python tests/report/paper_store.py DIR -> builds the demo report
    import sys

    from demcal.report import build_report

    out = build_paper_store(Path(sys.argv[1]))
    print(build_report(out))
