"""demcal's engine against LAMMPS on the same AoR test: the same packing, laws matched.

Cases (corn stalk, mu_s 0.55, mu_r 0.14, the given fidelity; same seeds, so both engines
start from the same packing):

- ``demcal_A``: demcal's default rolling model A (EDEM's constant torque, centre-of-mass arm);
- ``demcal_C``: demcal's rolling model C (EPSD spring, lever arm R*);
- ``lammps``: LAMMPS with the mapping of demcal.virtual.lammps_laws (rolling sds = model C,
  demcal's damping, moduli, masses and inertia);
- ``demcal_C_jkr`` / ``lammps_jkr``: the same with a small cohesion (gamma = 0.01 J/m^2:
  demcal's JKR version 1 against LAMMPS' hysteretic jkr).

Each case's runs are written to the JSON file as they end (a partial file is usable)::

    python benchmarks/lammps_compare.py --seeds 4 --out benchmarks/results/lammps_compare.json
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time
from pathlib import Path

from demcal.virtual import fidelity_config, preset_parameters, run_aor
from demcal.virtual.lammps_run import LammpsOptions, run_aor_lammps

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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fidelity", default="quick")
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--np", type=int, default=1, help="LAMMPS MPI ranks")
    ap.add_argument("--out", default="benchmarks/results/lammps_compare.json")
    args = ap.parse_args()
    out = Path(args.out)
    doc = json.loads(out.read_text()) if out.exists() else {}
    doc.update({"fidelity": args.fidelity, "machine": platform.processor() or platform.machine(),
                "params": "corn_stalk_dry, pp.rolling_friction 0.14 (mu_s 0.55)"})
    doc.setdefault("cases", {})
    seeds = list(range(args.seeds))
    for name in args.cases.split(","):
        engine, rolling, gamma = CASES[name]
        params = preset_parameters("corn_stalk_dry", {"pp.rolling_friction": 0.14,
                                                      "pp.surface_energy": gamma})
        config = fidelity_config(args.fidelity, rolling_model=rolling)
        t0 = time.perf_counter()
        if engine == "lammps":
            res = run_aor_lammps([params] * len(seeds), config=config, seeds=seeds,
                                 options=LammpsOptions(np=args.np))
        else:
            res = run_aor([params] * len(seeds), config=config, seeds=seeds, backend="cpu")
        runs = [r.to_dict() for r in res]
        doc["cases"][name] = {"engine": engine, "rolling_model": rolling,
                              "pp.surface_energy": gamma, "seeds": seeds,
                              "elapsed_s": round(time.perf_counter() - t0, 1),
                              **_summary(runs)}
        out.write_text(json.dumps(doc, indent=1) + "\n")
        print(name, json.dumps(doc["cases"][name]), flush=True)


if __name__ == "__main__":
    main()
