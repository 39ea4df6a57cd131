"""demcal's rotating drum against the same drum in LAMMPS, laws matched.

Both engines run the same drum (fidelity ``standard`` unless told: 90 mm x 40 mm, 40 % full,
30 rpm, 100 frames) on the same material: the ``corn_stalk_dry`` preset (no cohesion) with
rolling model C (LAMMPS' ``rolling sds``: the same cap and lever arm), a rough wall
(``pw.static_friction`` 0.9, so that the wall carries the bed) and no rolling friction at the
wall (LAMMPS' wall contacts have no spin, so its wall rolling torque would act on a particle's
spin relative to the ground where demcal's acts on its spin relative to the turning wall;
with none the laws match). The seeds give both engines the same particle sizes; the fills
differ (demcal's in falling rounds, LAMMPS' placed at once) and are forgotten once the flow
is steady, so runs pair by nothing but their material.

One invocation runs one engine (run two at once, one per core), writing every run to its
``--json`` as it ends; ``--summarize`` merges the files and writes each engine's mean,
seed-to-seed std and standard error, and the difference of the means with its standard
error (the two standard errors in quadrature)::

    python benchmarks/drum_lammps_compare.py --engine demcal --seeds 6 --json demcal.json
    python benchmarks/drum_lammps_compare.py --engine lammps --seeds 6 --json lammps.json
    python benchmarks/drum_lammps_compare.py --summarize demcal.json lammps.json \
        --json benchmarks/results/drum_lammps_compare.json

CPU time: demcal's is this process' (``time.process_time``); LAMMPS' is its child
processes' (``resource.getrusage(RUSAGE_CHILDREN)``), so either is robust to other load.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import resource
import time
from pathlib import Path

import numpy as np

from demcal.virtual.drum_settings import drum_settings
from demcal.virtual.presets import preset_parameters

#: the matched-law material over the preset
MATERIAL = {"pw.static_friction": 0.9, "pw.rolling_friction": 0.0}


def _children_cpu() -> float:
    use = resource.getrusage(resource.RUSAGE_CHILDREN)
    return use.ru_utime + use.ru_stime


def one_run(engine: str, fidelity: str, seed: int) -> dict:
    """One drum run on ``engine``: its outcome, angles (deg), particles, CPU and wall (s)."""
    params = preset_parameters("corn_stalk_dry", MATERIAL)
    settings = drum_settings(fidelity, {"rolling_model": "C"})
    cpu, child, wall = time.process_time(), _children_cpu(), time.perf_counter()
    if engine == "lammps":
        from demcal.virtual.lammps_drum import run_drum_lammps

        (r,) = run_drum_lammps([params], settings=settings, seeds=[seed])
    else:
        from demcal.virtual.drum import run_drum

        (r,) = run_drum([params], settings=settings, seeds=[seed], backend="cpu")
    cpu_s = (_children_cpu() - child) if engine == "lammps" else time.process_time() - cpu
    return {"engine": engine, "fidelity": fidelity, "seed": seed, "outcome": r.outcome,
            "reason": r.reason, "dynamic_aor_deg": r.dynamic_aor_deg,
            "com_angle_deg": r.com_angle_deg,
            "surface_fluctuation_deg": r.surface_fluctuation_deg,
            "n_particles": r.n_particles, "sim_time_s": r.sim_time_s,
            "steady_at_s": r.phase_times_s.get("steady"), "cpu_s": cpu_s,
            "wall_s": time.perf_counter() - wall}


def stats(values: list[float]) -> dict:
    """n, mean, seed-to-seed std and standard error of the mean."""
    a = np.array(values, dtype=float)
    std = float(a.std(ddof=1)) if len(a) > 1 else math.nan
    return {"n": len(a), "mean": float(a.mean()), "seed_std": std,
            "sem": std / math.sqrt(len(a))}


def summarize(runs: list[dict]) -> dict:
    """Per engine: the dynamic and centre-of-mass angles' statistics over measured runs, the
    CPU per run; and LAMMPS less demcal with its standard error."""
    out: dict = {}
    for engine in ("demcal", "lammps"):
        mine = [r for r in runs if r["engine"] == engine]
        ok = [r for r in mine if r["dynamic_aor_deg"] is not None]
        if not ok:
            continue
        out[engine] = {"dynamic": stats([r["dynamic_aor_deg"] for r in ok]),
                       "com": stats([r["com_angle_deg"] for r in ok]),
                       "surface_fluctuation_mean_deg": float(np.mean(
                           [r["surface_fluctuation_deg"] for r in ok])),
                       "outcomes": [r["outcome"] for r in mine],
                       "cpu_s_per_run": float(np.mean([r["cpu_s"] for r in mine]))}
    if "demcal" in out and "lammps" in out:
        for key in ("dynamic", "com"):
            a, b = out["demcal"][key], out["lammps"][key]
            out[f"{key}_difference_deg"] = b["mean"] - a["mean"]
            out[f"{key}_difference_se_deg"] = math.hypot(a["sem"], b["sem"])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", choices=["demcal", "lammps"], default="demcal")
    ap.add_argument("--fidelity", default="standard")
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--seed0", type=int, default=0)
    ap.add_argument("--summarize", nargs="+", type=Path, metavar="RUNS.json",
                    help="merge these runs files and summarise them into --json")
    ap.add_argument("--json", type=Path, required=True)
    a = ap.parse_args()
    if a.summarize:
        runs = [r for path in a.summarize for r in json.loads(path.read_text())["runs"]]
        metas = [json.loads(path.read_text())["meta"] for path in a.summarize]
        a.json.write_text(json.dumps({"meta": metas, "summary": summarize(runs),
                                      "runs": runs}, indent=1))
        print(json.dumps(summarize(runs), indent=1))
        return
    meta = {"machine": platform.machine(), "python": platform.python_version(),
            "engine": a.engine, "fidelity": a.fidelity, "material": "corn_stalk_dry",
            "overrides": MATERIAL, "rolling_model": "C", "started": time.ctime()}
    runs: list[dict] = []
    for seed in range(a.seed0, a.seed0 + a.seeds):
        runs.append(one_run(a.engine, a.fidelity, seed))
        r = runs[-1]
        print(f"{a.engine} seed {seed}: {r['outcome']} {r['dynamic_aor_deg']} deg, "
              f"cpu {r['cpu_s']:.0f} s, wall {r['wall_s']:.0f} s", flush=True)
        a.json.write_text(json.dumps({"meta": meta, "runs": runs}, indent=1))


if __name__ == "__main__":
    main()
