"""Precision of the rotating-drum test per CPU-second, and its response to friction.

For each fidelity (``quick``, ``standard``) it runs, one run at a time in this process:

- ``--seeds`` replicates at the base point: the seed-to-seed standard deviation of the dynamic
  angle (and of the centre-of-mass angle), the mean surface fluctuation, the CPU time per run
  (``time.process_time``: all threads of this process, robust to other load) and its wall time;
- ``--pair-seeds`` replicates at each end of three one-factor contrasts: particle-particle
  sliding friction 0.3 against 0.7, rolling friction 0.03 against 0.2 and surface energy 0
  against 5e-4 J/m^2, each contrast's difference with its standard error (from the two ends'
  seed-to-seed scatter).

The base point is the ``corn_stalk_dry`` preset on a rough wall (``pw.static_friction`` 0.9:
a drum's wall is roughened so that it carries the bed; at the preset's 0.55 the wall caps the
bed's tilt, and at 0.3 the bed slides on it). Every run's result is written to ``--json`` as
soon as it ends, so a run stopped early keeps what it measured.

Usage::

    python benchmarks/drum_precision.py --json benchmarks/results/drum_precision.json
    python benchmarks/drum_precision.py --fidelities quick --seeds 4 --pair-seeds 2
    python benchmarks/drum_precision.py --fidelities standard --drum frames=100 \
        --contrasts sliding_friction
    python benchmarks/drum_precision.py --fidelities standard --drum frames=100 --seeds 0 \
        --contrasts cohesion --json benchmarks/results/drum_cohesion_standard.json
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import time
from pathlib import Path

import numpy as np

from demcal.virtual.drum import run_drum
from demcal.virtual.drum_settings import drum_settings
from demcal.virtual.presets import preset_parameters

BASE = {"pw.static_friction": 0.9}
CONTRASTS = {
    "sliding_friction": ("pp.static_friction", 0.3, 0.7),
    "rolling_friction": ("pp.rolling_friction", 0.03, 0.2),
    # the corn-stalk standard studies' range of surface energy (JKR cohesion), J/m^2
    "cohesion": ("pp.surface_energy", 0.0, 5e-4),
}


def one_run(fidelity: str, overrides: dict[str, float], seed: int, drum: dict) -> dict:
    """One drum run: its outcome, angles (deg), particles, CPU and wall time (s); ``drum``:
    drum settings over the fidelity's."""
    params = preset_parameters("corn_stalk_dry", {**BASE, **overrides})
    settings = drum_settings(fidelity, {"drum": drum})
    cpu, wall = time.process_time(), time.perf_counter()
    (r,) = run_drum([params], settings=settings, seeds=[seed], backend="cpu")
    return {"fidelity": fidelity, "overrides": overrides, "seed": seed, "outcome": r.outcome,
            "reason": r.reason, "dynamic_aor_deg": r.dynamic_aor_deg,
            "com_angle_deg": r.com_angle_deg,
            "surface_fluctuation_deg": r.surface_fluctuation_deg,
            "n_particles": r.n_particles, "sim_time_s": r.sim_time_s,
            "cpu_s": time.process_time() - cpu, "wall_s": time.perf_counter() - wall}


def stats(runs: list[dict], key: str = "dynamic_aor_deg") -> dict:
    """Mean, seed-to-seed std and standard error of ``key`` over the measured runs."""
    vals = np.array([r[key] for r in runs if r[key] is not None])
    n = len(vals)
    std = float(vals.std(ddof=1)) if n > 1 else None
    return {"n": n, "mean": float(vals.mean()) if n else None, "seed_std": std,
            "sem": None if std is None else std / math.sqrt(n)}


def summarize(runs: list[dict], fidelity: str) -> dict:
    """Per fidelity: the base point's scatter and cost, each contrast's difference."""
    mine = [r for r in runs if r["fidelity"] == fidelity]
    base = [r for r in mine if not r["overrides"]]
    out = {"base": {**stats(base), "com": stats(base, "com_angle_deg"),
                    "surface_fluctuation_mean_deg": stats(base, "surface_fluctuation_deg")["mean"],
                    "outcomes": [r["outcome"] for r in base],
                    "cpu_s_per_run": float(np.mean([r["cpu_s"] for r in base])) if base else None,
                    "n_particles": base[0]["n_particles"] if base else None}}
    for name, (param, lo, hi) in CONTRASTS.items():
        ends = [stats([r for r in mine if r["overrides"] == {param: v}]) for v in (lo, hi)]
        diff = se = None
        if ends[0]["mean"] is not None and ends[1]["mean"] is not None:
            diff = ends[1]["mean"] - ends[0]["mean"]
            if ends[0]["sem"] is not None and ends[1]["sem"] is not None:
                se = math.hypot(ends[0]["sem"], ends[1]["sem"])
        out[name] = {"parameter": param, "low": lo, "high": hi, "at_low": ends[0],
                     "at_high": ends[1], "difference_deg": diff, "difference_se_deg": se}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fidelities", nargs="+", default=["quick", "standard"])
    ap.add_argument("--seeds", type=int, default=6, help="replicates at the base point")
    ap.add_argument("--pair-seeds", type=int, default=3, help="replicates per contrast end")
    ap.add_argument("--json", type=Path, default=Path("drum_precision.json"))
    ap.add_argument("--drum", nargs="*", default=[], metavar="NAME=VALUE",
                    help="drum settings over the fidelity's, e.g. frames=100")
    ap.add_argument("--contrasts", nargs="*", default=list(CONTRASTS), choices=list(CONTRASTS))
    args = ap.parse_args()
    drum = {k: json.loads(v) for k, _, v in (a.partition("=") for a in args.drum)}
    runs: list[dict] = []
    meta = {"machine": platform.machine(), "python": platform.python_version(),
            "base": {"preset": "corn_stalk_dry", **BASE}, "drum": drum,
            "started": time.ctime()}
    for fid in args.fidelities:
        jobs = [({}, s) for s in range(args.seeds)]
        for param, lo, hi in (CONTRASTS[c] for c in args.contrasts):
            jobs += [({param: v}, 100 + s) for v in (lo, hi) for s in range(args.pair_seeds)]
        for overrides, seed in jobs:
            runs.append(one_run(fid, overrides, seed, drum))
            r = runs[-1]
            print(f"{fid} {overrides or 'base'} seed {seed}: {r['outcome']} "
                  f"{r['dynamic_aor_deg']} deg, {r['cpu_s']:.1f} CPU-s", flush=True)
            summary = {f: summarize(runs, f) for f in args.fidelities
                       if any(x["fidelity"] == f for x in runs)}
            args.json.write_text(json.dumps({"meta": meta, "summary": summary, "runs": runs},
                                            indent=1))


if __name__ == "__main__":
    main()
