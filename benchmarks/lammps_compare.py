"""demcal's engine against LAMMPS on the same AoR test: the same packing, laws matched.

Cases (corn stalk, mu_s 0.55, mu_r 0.14, the given fidelity; same seeds, so both engines
start from the same packing):

- ``demcal_A``: demcal's default rolling model A (EDEM's constant torque, centre-of-mass arm);
- ``demcal_C``: demcal's rolling model C (EPSD spring, lever arm R*);
- ``lammps``: LAMMPS with the mapping of demcal.virtual.lammps_laws (rolling sds = model C,
  demcal's damping, moduli, masses and inertia);
- ``demcal_C_jkr`` / ``lammps_jkr``: the same with a small cohesion (gamma = 0.01 J/m^2:
  demcal's JKR version 1 against LAMMPS' hysteretic jkr).

Each run is written to the JSON file as it ends, by case and seed, with its case's summary
(a partial file is usable). A second call with the same file runs only the seeds it lacks, so
a comparison too long for one sitting (the paper fidelity: ~1400 CPU-s per LAMMPS run) is
finished over several, the file committed between them::

    python benchmarks/lammps_compare.py --seeds 4 --out benchmarks/results/lammps_compare.json
    python benchmarks/lammps_compare.py --fidelity paper --seeds 6 --cases demcal_C,lammps \
        --jobs 2 --out benchmarks/results/lammps_compare_paper.json
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time
from pathlib import Path

from demcal.virtual import fidelity_config, preset_parameters, run_aor
from demcal.virtual.aor import AoRResult
from demcal.virtual.lammps_run import LammpsOptions, RunReporting, run_aor_lammps

CASES = {
    "demcal_A": ("demcal", "A", 0.0),
    "demcal_C": ("demcal", "C", 0.0),
    "lammps": ("lammps", "C", 0.0),
    "demcal_C_jkr": ("demcal", "C", 0.01),
    "lammps_jkr": ("lammps", "C", 0.01),
}


def _summary(runs: list[dict]) -> dict:
    angles = [r["aor_deg"] for r in runs if r["outcome"] == "pile" and r["aor_deg"] is not None]
    out = {"n": len(runs), "n_piles": len(angles),
           "outcomes": [r["outcome"] for r in runs],
           "aor_deg": [round(a, 2) for a in angles],
           "wall_s": [round(r["wall_time_s"], 1) for r in runs]}
    if angles:
        out["mean_deg"] = round(statistics.fmean(angles), 2)
    if len(angles) > 1:
        sd = statistics.stdev(angles)
        out["seed_std_deg"] = round(sd, 2)
        out["sem_deg"] = round(sd / len(angles) ** 0.5, 2)
    return out


#: what is kept of each run (the whole result holds every view's fit: too much to commit)
RUN_KEYS = ("outcome", "aor_deg", "n_particles", "fill_level_m", "bulk_density_kg_m3",
            "sim_time_s", "sphere_steps", "wall_time_s")


def _run_case(name: str, args: argparse.Namespace, doc: dict, out: Path) -> None:
    """The case's seeds its entry in ``doc`` lacks, each saved to ``out`` as it ends."""
    engine, rolling, gamma = CASES[name]
    params = preset_parameters("corn_stalk_dry", {"pp.rolling_friction": 0.14,
                                                  "pp.surface_energy": gamma})
    config = fidelity_config(args.fidelity, rolling_model=rolling)
    case = doc["cases"].setdefault(name, {"engine": engine, "rolling_model": rolling,
                                          "pp.surface_energy": gamma, "runs": {}})
    runs: dict = case.setdefault("runs", {})
    todo = [s for s in range(args.seed0, args.seed0 + args.seeds) if str(s) not in runs]
    t0 = time.perf_counter()

    def save(_i: int, res: AoRResult) -> None:
        nonlocal t0
        d = res.to_dict()
        runs[str(res.seed)] = {k: d.get(k) for k in RUN_KEYS}
        ordered = [runs[k] for k in sorted(runs, key=int)]
        case.update(seeds=sorted(int(k) for k in runs), **_summary(ordered))
        case["elapsed_s"] = round(case.get("elapsed_s", 0.0) + time.perf_counter() - t0, 1)
        t0 = time.perf_counter()  # the next run's time starts here
        out.write_text(json.dumps(doc, indent=1) + "\n")
        print(name, res.seed, res.outcome, res.aor_deg, flush=True)

    if engine == "lammps":
        run_aor_lammps([params] * len(todo), config=config, seeds=todo,
                       options=LammpsOptions(np=args.np, jobs=args.jobs),
                       reporting=RunReporting(on_result=save))
    else:  # one seed at a time, so that each is saved as it ends
        for i, seed in enumerate(todo):
            save(i, run_aor([params], config=config, seeds=[seed], backend="cpu")[0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fidelity", default="quick")
    ap.add_argument("--seeds", type=int, default=4, help="seeds SEED0..SEED0+N-1")
    ap.add_argument("--seed0", type=int, default=0)
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--np", type=int, default=1, help="LAMMPS MPI ranks")
    ap.add_argument("--jobs", type=int, default=1, help="LAMMPS runs at once")
    ap.add_argument("--out", default="benchmarks/results/lammps_compare.json")
    args = ap.parse_args()
    out = Path(args.out)
    doc = json.loads(out.read_text()) if out.exists() else {}
    if doc.get("fidelity", args.fidelity) != args.fidelity:
        raise SystemExit(f"{out} holds the {doc['fidelity']} fidelity; name another --out")
    doc.update({"fidelity": args.fidelity, "machine": platform.processor() or platform.machine(),
                "params": "corn_stalk_dry, pp.rolling_friction 0.14 (mu_s 0.55)"})
    doc.setdefault("cases", {})
    for name in args.cases.split(","):
        _run_case(name, args, doc, out)


if __name__ == "__main__":
    main()
