"""Does a pile's initial packing decide its angle? Piles grown twice from one packing.

A run's packing (stalk positions, orientations and sizes before the fill settles) depends on
its seed only. Some seeds of the steep cohesive point (x8 0.0005 J/m^2, x4 0.2, x3 0.6,
standard fidelity) were run more than once along different trajectories: on an H100 on
2026-11-26 and again on 2026-11-27 (the batch's check interval had changed in between, so
some worlds followed another trajectory), and on this project's 2-core VM's CPU (other
rounding). This script reads those committed results, keeps the pairs of piles of one seed
that are not the same pile (angles more than ``--same`` deg apart), and prints how the two
angles of a pair correlate: a packing that sets the angle would show a clear positive r.

Usage::

    python -m uv run python benchmarks/packing_memory.py [--json out.json]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from scipy import stats

RESULTS = Path(__file__).resolve().parent / "results"


def _angles() -> dict[str, dict[int, float]]:
    """{run set: {seed: angle (deg)}} of the steep point's standard piles."""
    old = json.loads((RESULTS / "gpu_h100.json").read_text())["large"]["runs"]
    new = json.loads((RESULTS / "gpu_h100_2026-11-27.json").read_text())
    new = new["aor"]["standard_steep_seeds_501_512"]["piles"]
    cpu = json.loads((RESULTS / "precision.json").read_text())
    cpu = cpu["large_fidelity_second_point"]["runs"]
    return {"gpu_2026-11-26": {int(r["seed"]): float(r["gated"]) for r in old},
            "gpu_2026-11-27": {int(r["seed"]): float(r["aor_deg"]) for r in new},
            "cpu_2026-11-26": {int(r["seed"]): float(r["aor_deg"]) for r in cpu}}


def pairs(sets: dict[str, dict[int, float]], same: float) -> list[tuple[str, int, float, float]]:
    """(sets compared, seed, angle in the first, in the second) for the later GPU set against
    each other set, leaving out pairs closer than ``same`` deg (one trajectory run twice)."""
    ref = sets["gpu_2026-11-27"]
    out = []
    for name in ("gpu_2026-11-26", "cpu_2026-11-26"):
        for seed, a in sorted(sets[name].items()):
            if seed in ref and abs(a - ref[seed]) > same:
                out.append((name, seed, a, ref[seed]))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--same", type=float, default=0.05,
                    help="pairs closer than this (deg) are one trajectory run twice")
    ap.add_argument("--json", type=Path, help="write the pairs and the statistics here")
    args = ap.parse_args()
    sets = _angles()
    rows = pairs(sets, args.same)
    a = np.array([r[2] for r in rows])
    b = np.array([r[3] for r in rows])
    r_all = stats.pearsonr(a, b)
    gpu = np.array([r[0] == "gpu_2026-11-26" for r in rows])
    r_gpu = stats.pearsonr(a[gpu], b[gpu])
    ref = sets["gpu_2026-11-27"]
    unique = np.array([*ref.values(), *a])  # each pile once (a pile run twice counts once)
    out = {"pairs": len(rows), "r": float(r_all.statistic), "p": float(r_all.pvalue),
           "gpu_pairs": int(gpu.sum()), "r_gpu": float(r_gpu.statistic),
           "per_pile_std_from_pairs_deg": float(np.std(a - b, ddof=1) / np.sqrt(2)),
           "piles": int(unique.size), "std_of_the_piles_deg": float(np.std(unique, ddof=1)),
           "rows": [{"against": n, "seed": s, "aor_deg": x, "aor_2026_11_27_deg": y}
                    for n, s, x, y in rows]}
    for n, s, x, y in rows:
        print(f"seed {s}  {n:<15} {x:6.2f}   gpu_2026-11-27 {y:6.2f}")
    print(f"{out['pairs']} pairs grown from one packing along two trajectories: r = "
          f"{out['r']:.2f} (p = {out['p']:.2f}); the {out['gpu_pairs']} GPU pairs r = "
          f"{out['r_gpu']:.2f}; per-pile std from the pairs "
          f"{out['per_pile_std_from_pairs_deg']:.2f} deg, of the {out['piles']} piles "
          f"{out['std_of_the_piles_deg']:.2f}")
    if args.json:
        args.json.write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
