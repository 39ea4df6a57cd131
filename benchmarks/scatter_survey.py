"""The standard test's seed scatter at points nobody chose: a survey of the calibration region.

The issue that defined the ``standard`` fidelity checks it by ``demcal simulate aor --fidelity
standard --seeds 6`` at parameters the developers do not know, reading ``aor_seed_std_deg``.
This script draws ``--points`` parameter sets from a Latin hypercube (scipy's ``qmc``, seeded)
over the corn-stalk study's eight factor ranges (those of
``examples/corn_stalk/study_standard_lean.toml``; every other parameter the preset's) and runs
that very command at each, one after another, saving each command's JSON. It prints per point
the mean angle, the seed std with its 95 % interval and whether the std reads <= 2 deg.

Usage::

    python -m uv run python benchmarks/scatter_survey.py --points 4 --out out/survey
    python -m uv run python benchmarks/scatter_survey.py --summarize out/survey ... --json out.json

A point costs ~15 minutes on a 2-core VM (6 standard tests, one batch on every thread).
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tomllib
from pathlib import Path

from scipy.stats import qmc

ROOT = Path(__file__).resolve().parents[1]
STUDY = ROOT / "examples" / "corn_stalk" / "study_standard_lean.toml"


def draw_points(n: int, seed: int) -> list[dict[str, float]]:
    """``n`` parameter sets from a Latin hypercube over the study's factor ranges (SI)."""
    factors = tomllib.loads(STUDY.read_text())["factors"]
    unit = qmc.LatinHypercube(d=len(factors), seed=seed).random(n)
    lows = [f["low"] for f in factors]
    highs = [f["high"] for f in factors]
    actual = qmc.scale(unit, lows, highs)
    return [{f["name"]: float(v) for f, v in zip(factors, row, strict=True)} for row in actual]


def run_point(params: dict[str, float], out: Path, seeds: int, first_seed: int) -> None:
    """``demcal simulate aor --fidelity standard --seeds N`` at ``params``; JSON to ``out``."""
    cmd = [sys.executable, "-m", "demcal", "simulate", "aor", "--fidelity", "standard",
           "--seeds", str(seeds), "--seed", str(first_seed), "--json", str(out),
           *[a for k, v in params.items() for a in ("--set", f"{k}={v!r}")]]
    subprocess.run(cmd, check=False)  # an unstable run exits 1 and still writes its JSON
    if out.exists():
        d = json.loads(out.read_text())
        out.write_text(json.dumps({**d, "survey_params": params}, indent=1))


def summarize(folders: list[Path]) -> list[dict[str, object]]:
    """One row per point JSON in ``folders`` (point_*.json): mean, std, its interval, piles."""
    rows = []
    for path in [p for folder in folders for p in sorted(folder.glob("point_*.json"))]:
        d = json.loads(path.read_text())
        lo, hi = d.get("aor_seed_std_ci95_deg") or (None, None)
        std = d.get("aor_seed_std_deg")
        rows.append({"point": f"{path.parent.name}/{path.stem}",
                     "params": d.get("survey_params"),
                     "n_piles": d.get("n_piles"), "aor_mean_deg": d.get("aor_deg"),
                     "aor_seed_std_deg": std, "std_ci95_deg": [lo, hi],
                     "reads_at_most_2": None if std is None else bool(std <= 2.0),
                     "piles": [{"seed": r.get("seed"), "outcome": r.get("outcome"),
                                "aor_deg": r.get("aor_deg")} for r in d.get("runs", [])]})
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=4)
    ap.add_argument("--lhs-seed", type=int, default=2026)
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--seed", type=int, default=0, help="first seed (the command's default)")
    ap.add_argument("--out", type=Path, help="run the points, one JSON each, here")
    ap.add_argument("--summarize", type=Path, nargs="+",
                    help="only summarize folders of point JSONs")
    ap.add_argument("--json", type=Path, help="write the summary here")
    args = ap.parse_args()
    folders = args.summarize
    if folders is None:
        if args.out is None:
            ap.error("give --out (to run) or --summarize")
        args.out.mkdir(parents=True, exist_ok=True)
        for i, params in enumerate(draw_points(args.points, args.lhs_seed)):
            path = args.out / f"point_{i}.json"
            if not path.exists():  # a rerun goes on where it stopped
                run_point(params, path, args.seeds, args.seed)
        folders = [args.out]
    rows = summarize(folders)
    def fmt(x: object) -> str:
        return "-" if x is None else f"{x:.2f}"

    for r in rows:
        lo, hi = r["std_ci95_deg"]
        print(f"{r['point']}: {r['n_piles']} piles, mean {fmt(r['aor_mean_deg'])} deg, seed std "
              f"{fmt(r['aor_seed_std_deg'])} (95 % {fmt(lo)}-{fmt(hi)}), <= 2 deg: "
              f"{r['reads_at_most_2']}")
    done = [(r["aor_seed_std_deg"], r["n_piles"] - 1) for r in rows
            if r["aor_seed_std_deg"] is not None]
    if done:
        pooled = math.sqrt(sum(s * s * df for s, df in done) / sum(df for _, df in done))
        print(f"{sum(s <= 2.0 for s, _ in done)} of {len(done)} points read <= 2 deg; pooled "
              f"std {pooled:.2f} deg ({sum(df for _, df in done)} df)")
    if args.json:
        args.json.write_text(json.dumps({"rows": rows}, indent=1))


if __name__ == "__main__":
    main()
