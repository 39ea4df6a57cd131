"""The Bayesian strategy against the DOE path on planted problems (the analytic stand-in).

Two problems over the same three factors (static friction 0.2-1.0, rolling friction 0-0.4,
wall friction 0.3-0.8; planted 0.7, 0.15, 0.65), each calibrated by both strategies on the
same stand-in and seeds:

- ``three``: the angle, a drum angle and a bulk density, each linear in the factors with its
  own gradient (run scatter 0.2 deg, 0.2 deg, 0.5 kg/m^3; lab std 0.5, n 5): one point fits.
- ``angle``: the angle alone: a plane of settings fits it; the DOE path returns one point
  of it, the Bayesian strategy the region and the ridge.

Per (problem, strategy, seed): runs, wall time, the coded error of the answer (the DOE
optimum, the posterior median) from the planted point, and for the Bayesian strategy the
95 % interval widths (coded), the verdict, and whether the DOE optimum of the same seed lies
inside every 95 % interval. Not demcal's DEM engine: the issue's benchmark on synthetic
DEM targets needs far more CPU than this machine has (docs/bayes.md, "Not done yet").

    python3 -m uv run python benchmarks/bayes_vs_doe.py --json benchmarks/results/bayes_vs_doe.json
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path
from typing import Any

from demcal.calibrate import calibrate

FACTORS = {"pp.static_friction": (0.2, 1.0), "pp.rolling_friction": (0.0, 0.4),
           "pw.static_friction": (0.3, 0.8)}
PLANTED = {"pp.static_friction": 0.7, "pp.rolling_friction": 0.15, "pw.static_friction": 0.65}
CENTRE = {"pp.static_friction": 0.6, "pp.rolling_friction": 0.2, "pw.static_friction": 0.55}
#: name: (base, slopes per unit of each factor, run scatter)
RESPONSES = {"aor_deg": (30.0, (15.0, 25.0, 2.0), 0.2),
             "drum_deg": (35.0, (5.0, 60.0, 1.0), 0.2),
             "bulk_density_kg_m3": (200.0, (-10.0, 20.0, 80.0), 0.5)}


def _truth(name: str) -> float:
    base, slopes, _ = RESPONSES[name]
    return base + sum(s * (PLANTED[f] - CENTRE[f]) for s, f in zip(slopes, FACTORS, strict=True))


def _linear(slopes: tuple[float, ...]) -> str:
    return "{ " + ", ".join(f'"{f}" = {s}' for f, s in zip(FACTORS, slopes, strict=True)) + " }"


def study_text(problem: str, strategy: str, seed: int, n_start: int | None = None) -> str:
    """The study file of one case (``n_start``: the Bayesian start, default 9 per factor)."""
    lines = [f'name = "{problem} {strategy}"', f"seed = {seed}", "replicates = 1",
             "[material]", 'preset = "corn_stalk"']
    for name, (lo, hi) in FACTORS.items():
        lines += ["[[factors]]", f'name = "{name}"', f"low = {lo}", f"high = {hi}"]
    for name in RESPONSES if problem == "three" else ["aor_deg"]:
        lines += ["[[responses]]", f'name = "{name}"', f"target = {_truth(name)!r}",
                  "std = 0.5", "n = 5"]
    base, slopes, noise = RESPONSES["aor_deg"]
    centre = "{ " + ", ".join(f'"{f}" = {c}' for f, c in CENTRE.items()) + " }"
    lines += ["[test]", 'kind = "analytic"', "[test.analytic]", f"base_deg = {base}",
              f"noise_deg = {noise}", f"centre = {centre}", f"linear = {_linear(slopes)}"]
    for name, (b, s, n) in RESPONSES.items():  # planted in both problems: the drum and
        if name != "aor_deg":                  # the density are what could shrink a ridge
            lines += [f"[test.analytic.responses.{name}]", f"base = {b}", f"noise = {n}",
                      f"linear = {_linear(s)}"]
    lines += ["[stages.rangefind]", "enabled = false", "[stages.screening]", "enabled = false",
              "[stages.steepest]", "enabled = false", "[stages.optimize]", "n_starts = 12",
              "[stages.verification]", "n = 4",
              "[strategy]", f'kind = "{strategy}"', "batch = 6", "max_runs = 60",
              *([f"n_start = {n_start}"] if n_start else []),
              "[executor]", "workers = 1"]
    return "\n".join(lines) + "\n"


def coded_error(point: dict[str, float]) -> float:
    """Largest coded distance (fractions of the half range) from the planted point."""
    return max(abs(point[f] - PLANTED[f]) / (0.5 * (hi - lo)) for f, (lo, hi) in FACTORS.items())


def run_case(problem: str, strategy: str, seed: int, folder: Path,
             n_start: int | None = None) -> dict[str, Any]:
    """Calibrate one case in ``folder``; its numbers."""
    path = folder / f"{problem}_{strategy}_{seed}_{n_start}.toml"
    path.write_text(study_text(problem, strategy, seed, n_start))
    t0 = time.perf_counter()
    res = calibrate(path, workers=1)
    out: dict[str, Any] = {"problem": problem, "strategy": strategy, "seed": seed,
                           "n_start": n_start,
                           "wall_s": round(time.perf_counter() - t0, 2),
                           "runs": res["n_runs_executed"],
                           "verified_aor_deg": res["verification"]["aor_mean_deg"]}
    if strategy == "doe":
        out.update(answer=res["optimum"], coded_error=coded_error(res["optimum"]))
        return out
    post = res["posterior"]
    out.update(answer={f: p["median"] for f, p in post.items()},
               coded_error=coded_error({f: p["median"] for f, p in post.items()}),
               ci95=post, identifiable=res["identifiable"], ridge=res["ridge"],
               widths_coded={f: (p["ci95_high"] - p["ci95_low"]) / (hi - lo) * 2
                             for (f, p), (lo, hi) in zip(post.items(), FACTORS.values(),
                                                         strict=True)},
               planted_inside=all(p["ci95_low"] <= PLANTED[f] <= p["ci95_high"]
                                  for f, p in post.items()),
               shrinkage=[{k: s[k] for k in ("response", "ridge", "shrinkage")}
                          for s in res["shrinkage"]])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for problem in ("three", "angle"):
            for seed in args.seeds:
                doe = run_case(problem, "doe", seed, Path(tmp))
                cases = [doe, run_case(problem, "bayes", seed, Path(tmp))]
                if problem == "three":  # a smaller start: 12 runs, 4 per factor
                    cases.append(run_case(problem, "bayes", seed, Path(tmp), n_start=12))
                for bayes in cases[1:]:
                    bayes["doe_optimum_inside"] = all(
                        p["ci95_low"] <= doe["answer"][f] <= p["ci95_high"]
                        for f, p in bayes["ci95"].items())
                rows += cases
                for r in cases:
                    start = f"/{r['n_start']}" if r["n_start"] else ""
                    print(f"{problem:5s} {r['strategy'] + start:8s} seed {seed}: "
                          f"{r['runs']:3d} runs, "
                          f"{r['wall_s']:5.1f} s, coded error {r['coded_error']:.3f}"
                          + (f", widths {[round(w, 3) for w in r['widths_coded'].values()]}"
                             f", identifiable {r['identifiable']}, planted inside "
                             f"{r['planted_inside']}, DOE optimum inside "
                             f"{r['doe_optimum_inside']}" if r["strategy"] == "bayes" else ""))
    if args.json is not None:
        args.json.write_text(json.dumps({"problems": ["three", "angle"], "planted": PLANTED,
                                         "factors": FACTORS, "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
