"""Precision of the virtual angle-of-repose test per CPU-second, by pile size.

For each case (a fill of N stalks in a tube of diameter D, or the paper's factory fill) it runs
``--seeds`` replicates as batched worlds of one engine, at one parameter set, and prints:

- the seed-to-seed standard deviation of the AoR, measured three ways on the *same* piles:
  ``gated`` (demcal's default: flank quality gates, median over flanks), ``legacy`` (the mean
  of every fitted flank, no gates: demcal before the gates) and ``profile`` (the azimuthal
  surface-profile method);
- the within-pile spread of the flank angles (median over the piles of each pile's spread);
- the wall time per test (the batch's wall time / replicates), the CPU time per test (all
  threads; robust to other load on the machine) and the wall time per phase (fill, fill
  settle, lift, pile settle: each check's wall time shared among the worlds still running);
- the replicates that give a standard error of the design-point mean <= ``--se`` deg and
  their cost in wall-seconds.

The final spheres of every run are saved (``--out``, ``.npz``), so the piles can be measured
again (``--remeasure``) without simulating.

Usage::

    python benchmarks/precision.py                        # 150, 300, 450, 600 stalks, 6 seeds
    python benchmarks/precision.py --cases 450:0.040 paper --seeds 6 --json out.json
    python benchmarks/precision.py --remeasure out/precision --json out.json
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import time
from pathlib import Path

import numpy as np

from demcal import measure
from demcal.measure.quality import COMBINE_METHODS, combine_angles
from demcal.virtual.aor import run_aor
from demcal.virtual.config import fidelity_config
from demcal.virtual.pile import measure_pile
from demcal.virtual.presets import preset_parameters

#: the issue's reference point: no cohesion, mu_s 0.55, mu_r 0.15
BASE = {"pp.surface_energy": 0.0, "pp.rolling_friction": 0.15}
DEFAULT_CASES = ["150:0.030", "300:0.035", "450:0.040", "600:0.045"]


def test_overrides(items: list[str]) -> dict:
    """``--test`` items (``rolling_model=C``, ``phases.lift_speed=0.05``) -> nested overrides."""
    out: dict = {}
    for item in items:
        key, _, text = item.partition("=")
        try:
            value: object = float(text)
        except ValueError:
            value = text
        *path, leaf = key.split(".")
        node = out
        for part in path:
            node = node.setdefault(part, {})
        node[leaf] = value
    return out


def case_config(case: str, test: dict | None = None):
    """``N:D`` (packing fill of N stalks in a tube of D m) or ``paper`` -> test config, with
    ``test`` (nested overrides of the test configuration) on top."""
    test = test or {}
    if case == "paper":
        return fidelity_config("paper", **test)
    count, _, diam = case.partition(":")
    fill = {"count": int(count), **test.get("fill", {})}
    geometry = {"cylinder_inner_diameter": float(diam or 0.030), **test.get("geometry", {})}
    rest = {k: v for k, v in test.items() if k not in ("fill", "geometry")}
    return fidelity_config("quick", fill=fill, geometry=geometry, **rest)


def measure_saved(path: Path, config) -> dict:
    """A saved pile measured the three ways (see the module docstring)."""
    with np.load(path) as data:
        centres, radii = data["centres"], data["radii"]
    out: dict = {"file": str(path)}
    try:
        m = measure_pile(centres, radii, config.measurement)
        if m.get("error"):
            return {**out, "error": m["error"]}
        sil = measure.pile_aor_silhouette(centres, radii, n_views=config.measurement.n_views,
                                          gates=None, combine="mean")
    except Exception as exc:  # a benchmark reports, never stops
        return {**out, "error": repr(exc)}
    out.update(gated=m["aor_deg"], profile=m.get("aor_profile_deg"),
               spread=m.get("aor_std_deg"), n_flanks=m.get("n_flanks"),
               n_rejected=m.get("n_rejected"))
    accepted = [v[f"{side}_deg"] for v in m["views"] for side in ("left", "right")
                if v[f"{side}_deg"] is not None and v[f"{side}_rejected"] is None]
    for how in COMBINE_METHODS:
        out[f"gated_{how}"] = combine_angles(accepted, how)
    every = [a for v in sil.views for a in v.angles]
    out["legacy"] = float(np.mean(every)) if every else None
    out["legacy_spread"] = float(np.std(every, ddof=1)) if len(every) > 1 else None
    return out


def _std(values: list) -> float | None:
    v = [x for x in values if x is not None]
    return float(np.std(v, ddof=1)) if len(v) > 1 else None


def summarise(name: str, measured: list[dict], wall_per_test: float | None,
              phase_wall: dict, n_particles: list[int], se: float) -> dict:
    """Table row of one case from its measured piles and timings."""
    ok = [m for m in measured if "error" not in m]
    gated = [m["gated"] for m in ok]
    std = _std(gated)
    reps = None if std is None else max(1, math.ceil((std / se) ** 2))
    row = {
        "case": name, "n_runs": len(measured), "n_piles": len(ok),
        "n_particles": n_particles,
        "aor_mean_deg": float(np.mean(gated)) if gated else None,
        "seed_std_gated_deg": std,
        "seed_std_legacy_deg": _std([m["legacy"] for m in ok]),
        "seed_std_profile_deg": _std([m["profile"] for m in ok]),
        **{f"seed_std_gated_{how}_deg": _std([m.get(f"gated_{how}") for m in ok])
           for how in COMBINE_METHODS},
        "flank_spread_gated_deg": float(np.median([m["spread"] for m in ok
                                                   if m["spread"] is not None] or [math.nan])),
        "flank_spread_legacy_deg": float(np.median([m["legacy_spread"] for m in ok
                                                    if m["legacy_spread"] is not None]
                                                   or [math.nan])),
        "flanks_rejected_mean": float(np.mean([m["n_rejected"] or 0 for m in ok]))
        if ok else None,
        "wall_per_test_s": wall_per_test,
        "phase_wall_per_test_s": phase_wall,
        "replicates_for_se": reps,
        "wall_per_design_point_s": None if reps is None or wall_per_test is None
        else reps * wall_per_test,
        "runs": measured,
    }
    return row


def run_case(case: str, seeds: list[int], out_dir: Path, backend: str, se: float,
             sets: dict[str, float] | None = None, test: dict | None = None,
             log_phases: bool = False) -> dict:
    """Simulate one case's replicates as one batch, save the piles, measure them.

    ``log_phases`` prints each world's phase changes with the wall time (a run cut off by a
    time limit then still says where its time went).
    """
    config = case_config(case, test)
    params = preset_parameters("corn_stalk", {**BASE, **(sets or {})})
    folder = out_dir / case.replace(":", "_")
    paths = [folder / f"seed{s}.npz" for s in seeds]
    n = len(seeds)
    live = set(range(n))
    last = dict.fromkeys(range(n), 0.0)
    phase_wall: dict[str, float] = {}
    seen: dict[int, str] = {}

    def on_progress(run: int, phase: str, t: float, wall: float) -> None:
        # each live world reports once per check: its share of the check's wall time goes
        # to the phase it is in
        phase_wall[phase] = phase_wall.get(phase, 0.0) + (wall - last[run]) / max(1, len(live))
        last[run] = wall
        if log_phases and seen.get(run) != phase:
            seen[run] = phase
            print(f"  {case} world {run}: {phase} at t = {t:.3f} s, wall {wall:.1f} s",
                  flush=True)

    def on_result(run: int, result) -> None:
        live.discard(run)

    t0, c0 = time.perf_counter(), time.process_time()
    results = run_aor([params] * n, config=config, seeds=seeds, backend=backend,
                      progress=on_progress, on_result=on_result, pile_paths=paths)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    measured = []
    for r, p in zip(results, paths, strict=True):
        m = measure_saved(p, config) if r.outcome == "pile" else {
            "file": str(p), "error": f"outcome {r.outcome}: {r.reason}"}
        m["seed"], m["outcome"], m["sim_time_s"] = r.seed, r.outcome, r.sim_time_s
        m["phase_times_s"] = r.phase_times_s
        measured.append(m)
    timing = {"wall_per_test_s": wall / n, "batch_wall_s": wall, "cpu_per_test_s": cpu / n,
              "phase_wall_per_test_s": {k: v / n for k, v in phase_wall.items()},
              "n_particles": [r.n_particles for r in results],
              "sim_phase_times_s": [r.phase_times_s for r in results]}
    (folder / "timing.json").write_text(json.dumps(timing, indent=1))
    row = summarise(case, measured, timing["wall_per_test_s"],
                    timing["phase_wall_per_test_s"], timing["n_particles"], se)
    row["batch_wall_s"] = wall
    row["cpu_per_test_s"] = timing["cpu_per_test_s"]
    return row


def remeasure(folder: Path, se: float, test: dict | None = None) -> list[dict]:
    """Measure saved piles again (one sub-folder per case, as written by a run)."""
    rows = []
    for sub in sorted(p for p in folder.iterdir() if p.is_dir()):
        case = sub.name.replace("_", ":")
        config = case_config(case, test)
        measured = [measure_saved(p, config) for p in sorted(sub.glob("seed*.npz"))]
        tfile = sub / "timing.json"
        t = json.loads(tfile.read_text()) if tfile.exists() else {}
        rows.append(summarise(case, measured, t.get("wall_per_test_s"),
                              t.get("phase_wall_per_test_s", {}), t.get("n_particles", []), se))
        rows[-1]["cpu_per_test_s"] = t.get("cpu_per_test_s")
    return rows


def _f(x, fmt=".2f") -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, fmt)


def print_table(rows: list[dict]) -> None:
    head = (f"{'case':>10} {'piles':>5} {'AoR':>6} {'std':>5} {'legacy':>6} {'profile':>7} "
            f"{'spread':>6} {'s/test':>7} {'cpu/test':>8} {'fill':>6} {'settle':>6} "
            f"{'lift':>6} {'pile':>6} {'reps':>4} {'s/point':>7}")
    print(head)
    for r in rows:
        ph = r["phase_wall_per_test_s"]
        print(f"{r['case']:>10} {r['n_piles']:>2}/{r['n_runs']:<2} {_f(r['aor_mean_deg']):>6} "
              f"{_f(r['seed_std_gated_deg']):>5} {_f(r['seed_std_legacy_deg']):>6} "
              f"{_f(r['seed_std_profile_deg']):>7} {_f(r['flank_spread_gated_deg']):>6} "
              f"{_f(r['wall_per_test_s'], '.0f'):>7} {_f(r.get('cpu_per_test_s'), '.0f'):>8} "
              f"{_f(ph.get('fill'), '.0f'):>6} "
              f"{_f(ph.get('fill_settle'), '.0f'):>6} {_f(ph.get('lift'), '.0f'):>6} "
              f"{_f(ph.get('pile_settle'), '.0f'):>6} {_f(r['replicates_for_se'], 'd'):>4} "
              f"{_f(r['wall_per_design_point_s'], '.0f'):>7}  (gated std by combine: "
              + ", ".join(f"{h} {_f(r[f'seed_std_gated_{h}_deg'])}" for h in COMBINE_METHODS)
              + ")", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=DEFAULT_CASES,
                    help="N:D (stalks : tube diameter m, packing fill) or 'paper'")
    ap.add_argument("--seeds", type=int, default=6, help="replicates per case (batched)")
    ap.add_argument("--seed0", type=int, default=101, help="first seed")
    ap.add_argument("--se", type=float, default=1.0, help="target standard error, deg")
    ap.add_argument("--backend", default="cpu", choices=["cpu", "cuda", "auto"])
    ap.add_argument("--out", default="out/precision", help="folder for the saved piles")
    ap.add_argument("--remeasure", help="measure the piles saved in this folder; no runs")
    ap.add_argument("--json", help="write the numbers to this file")
    ap.add_argument("--set", dest="sets", nargs="*", default=[],
                    help="parameter overrides NAME=VALUE (SI) on top of the reference point")
    ap.add_argument("--test", dest="tests", nargs="*", default=[],
                    help="test configuration overrides KEY=VALUE, dotted for nested fields "
                         "(rolling_model=C, dt_fraction=0.1, phases.lift_speed=0.05)")
    args = ap.parse_args()
    test = test_overrides(args.tests)
    sets = {k: float(v) for k, _, v in (a.partition("=") for a in args.sets)}
    machine = {"platform": platform.platform(), "cpus": os.cpu_count(),
               "backend": args.backend}
    rows: list[dict] = []

    def dump() -> None:
        if args.json:
            Path(args.json).write_text(json.dumps(
                {"machine": machine, "params": {**BASE, **sets}, "test": test,
                 "se_target_deg": args.se,
                 "cases": rows},
                indent=1, default=float))

    if args.remeasure:
        rows = remeasure(Path(args.remeasure), args.se, test)
        print_table(rows)
        dump()
        return
    seeds = list(range(args.seed0, args.seed0 + args.seeds))
    for case in args.cases:
        t0 = time.perf_counter()
        rows.append(run_case(case, seeds, Path(args.out), args.backend, args.se, sets, test))
        print(f"# {case}: {time.perf_counter() - t0:.0f} s for {len(seeds)} seeds", flush=True)
        print_table(rows[-1:])
        dump()
    print_table(rows)
    dump()


if __name__ == "__main__":
    main()
