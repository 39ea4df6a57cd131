"""Re-simulate calibration results on fresh seeds: does the optimum give the target angle?

Each result JSON (what ``demcal calibrate --json`` writes) holds ``optimum_full``, the whole
parameter set the study chose. This script runs every result's optimum ``--seeds`` times at one
fidelity, all of them as worlds of one engine (one batch: on a GPU the worlds share it; with
common seeds the results are compared pile for pile), and prints per result the mean angle,
its seed-to-seed standard deviation, the 95 % interval of the mean and the error against the
result's ``target_aor_deg``. Choose seeds no study used (the studies take theirs from
``seed``; verification's from far above it).

Usage::

    python benchmarks/resimulate.py examples/corn_stalk/result_standard.json --seeds 6 \\
        --seed 9001 --json out/resim.json
    python benchmarks/resimulate.py a.json b.json --fidelity standard --seeds 12 --backend cuda

The JSON is written after every pile, so a run cut off by a time limit keeps what finished.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from demcal.physical import summarize
from demcal.virtual.aor import run_aor
from demcal.virtual.config import fidelity_config


def summarise(angles: list[float], target: float | None) -> dict:
    """Mean, seed std, 95 % interval of the mean and relative error (deg, %) of some piles
    (the interval is :func:`demcal.physical.summarize`'s, the one the photos get)."""
    if not angles:
        return {"n": 0, "mean_deg": None}
    s = summarize(angles, name="angle of repose", unit="deg")
    out: dict = {"n": s.n_repeats, "mean_deg": s.mean}
    if s.std is not None:
        out.update(std_deg=s.std, ci_low_deg=s.ci_low, ci_high_deg=s.ci_high,
                   half_width_deg=s.mean - s.ci_low)
    if target:
        out["relative_error_percent"] = abs(s.mean - target) / target * 100.0
    return out


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", nargs="+", help="result JSON files with optimum_full")
    ap.add_argument("--fidelity", default="standard", help="test fidelity (default standard)")
    ap.add_argument("--seeds", type=int, default=6, help="piles per result (default 6)")
    ap.add_argument("--seed", type=int, default=9001, help="first seed (default 9001)")
    ap.add_argument("--backend", default="auto", help="auto, cpu or cuda")
    ap.add_argument("--json", help="write the piles and the summary here")
    args = ap.parse_args(argv)

    loaded = {p: json.loads(Path(p).read_text()) for p in args.results}
    names = list(loaded)
    n = args.seeds
    seeds = list(range(args.seed, args.seed + n))
    record: dict = {"fidelity": args.fidelity, "seeds": seeds, "backend": args.backend,
                    "results": {p: {"optimum_full": loaded[p]["optimum_full"],
                                    "target_aor_deg": loaded[p].get("target_aor_deg"),
                                    "piles": [None] * n} for p in names}}
    t0 = time.perf_counter()

    def save() -> None:
        record["elapsed_s"] = time.perf_counter() - t0
        if args.json:
            Path(args.json).parent.mkdir(parents=True, exist_ok=True)
            Path(args.json).write_text(json.dumps(record, indent=1, default=str))

    def on_result(run: int, result) -> None:
        name, i = names[run // n], run % n
        record["results"][name]["piles"][i] = {
            "seed": result.seed, "outcome": result.outcome, "aor_deg": result.aor_deg,
            "wall_s": time.perf_counter() - t0}
        print(f"  {name} seed {result.seed}: {result.outcome} {result.aor_deg} "
              f"({time.perf_counter() - t0:.0f} s)", flush=True)
        save()

    run_aor([loaded[p]["optimum_full"] for p in names for _ in seeds],
            config=fidelity_config(args.fidelity), seeds=seeds * len(names),
            backend=args.backend, on_result=on_result)
    print(f"{'result':<50} {'n':>3} {'mean':>7} {'std':>6} {'95 % interval':>15} {'error %':>8}")
    for p in names:
        entry = record["results"][p]
        angles = [x["aor_deg"] for x in entry["piles"] if x and x["aor_deg"] is not None]
        entry["summary"] = s = summarise(angles, entry["target_aor_deg"])
        ci = (f"{s['ci_low_deg']:.2f}-{s['ci_high_deg']:.2f}" if "ci_low_deg" in s else "-")
        mean = s["mean_deg"] if s["mean_deg"] is not None else float("nan")
        print(f"{p:<50} {s['n']:>3} {mean:>7.2f} {s.get('std_deg', float('nan')):>6.2f}"
              f" {ci:>15} {s.get('relative_error_percent', float('nan')):>8.2f}")
    save()
    return record


if __name__ == "__main__":
    main()
