"""One prepared GPU session: the CUDA backend checked, timed, and its precision per GPU-second.

GPU machines are lent for minutes, so this runs everything in one process (one compile) and
writes the JSON after every stage (a stage cut off by a time limit loses only itself):

1. ``check``: CUDA against the CPU on two small piles falling into a tube (positions after
   3000 steps, ~21 ms, with contacts from ~1500: equal to rounding, FMA on the GPU) and graph
   replay / plain launches / forced neighbour growth (bitwise equal to each other);
2. ``bench``: sphere-steps per second on settled beds (1000 and 10000 stalks, 16 worlds of
   1000);
3. ``standard``, ``small``: the angle-of-repose test (the fidelities' piles: 1200 and 300
   stalks) at a steep cohesive point (x8 0.0005
   J/m^2, x4 0.2, x3 0.6) with ``--standard-seeds`` / ``--small-seeds`` replicates batched as
   worlds of one engine (``benchmarks/precision.py``'s measurement: seed scatter, phases);
   ``fourth``: the standard test at the fourth cohesive point (``FOURTH``, seeds from 9501,
   ``--fourth-seeds``), against its 6 CPU piles (the CPU/GPU offset);
   ``pile1600``: 1600 stalks in a 62 mm tube (the standard fill's aspect) at the steep point,
   seeds from 501 (``--standard-seeds``): would a bigger standard pile scatter <= 2 deg?
4. ``paper``: the paper's fill at the dry reference point (optional);
5. ``bigbench``: a 100 000-stalk bed;
6. ``study``: a whole calibration (``--study``, default the corn stalk's standard study),
   every stage one batch of worlds on the GPU; its result JSON lands beside ``--json``
   (``<json stem>_result.json``) and in the report. It resumes from its store (``--study-dir``)
   if a time limit cut it off.

The AoR stages print each world's phase changes with the wall time. On the H100 (2026-11-26)
``paper`` (6 worlds, factory fill) had not finished after ~320 s while the 1200-stalk test
(12 worlds, packing fill; stage ``standard``, then called ``large``) took 118 s: that log
says where the time goes next time.

Usage (on the GPU machine)::

    python benchmarks/gpu_check.py --json gpu.json
    python benchmarks/gpu_check.py --stages check bench --json gpu.json
    python benchmarks/gpu_check.py --backend cpu --stages check --json cpu.json  # dry run
    python benchmarks/gpu_check.py --stages study --json $OUT/study.json  # the standard study
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
import traceback
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import cuda_check
import precision

#: a steep cohesive point at the top of the corn-stalk calibration region
STEEP = {"pp.surface_energy": 0.0005, "pp.rolling_friction": 0.2, "pp.static_friction": 0.6}
#: the fourth cohesive point of docs/precision.md (6 CPU piles, seeds 9501-9506: 47.40 +/- 1.80
#: deg; benchmarks/results/standard_fourth_point_cpu.json): the same seeds and more on the GPU
#: measure the CPU/GPU offset
FOURTH = {"pp.surface_energy": 0.00022, "pp.rolling_friction": 0.18,
          "pp.static_friction": 0.6, "pw.static_friction": 0.5, "pp.restitution": 0.35,
          "pw.rolling_friction": 0.1}
STAGES = ("check", "bench", "standard", "fourth", "pile1600", "small", "paper", "bigbench",
          "study")
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def parse_args() -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--backend", default="cuda", choices=["cuda", "cpu"])
    ap.add_argument("--stages", nargs="+", default=list(STAGES), choices=STAGES)
    ap.add_argument("--standard-seeds", type=int, default=12)
    ap.add_argument("--fourth-seeds", type=int, default=12)
    ap.add_argument("--small-seeds", type=int, default=18)
    ap.add_argument("--paper-seeds", type=int, default=6)
    ap.add_argument("--bench-steps", type=int, default=1000)
    ap.add_argument("--bench-settle", type=float, default=0.05, help="settling time, s")
    ap.add_argument("--piles", default="out/gpu_piles", help="folder for the saved piles")
    ap.add_argument("--study", default=str(EXAMPLES / "corn_stalk" / "study_standard.toml"),
                    help="the study the 'study' stage runs (its folder's files are copied)")
    ap.add_argument("--study-dir", default="out/gpu_study", help="where the study runs")
    ap.add_argument("--json", default="gpu_check.json")
    return ap.parse_args()


def stage_functions(args: argparse.Namespace) -> dict:
    """Each stage's work (a function returning its JSON-able numbers), by name."""
    backend = args.backend

    def checks() -> dict:
        out = {"compare_cpu": cuda_check.compare(backend, 3000)}
        if backend == "cuda":
            out["graphs"] = cuda_check.graph_and_growth(300)
        return out

    def bench(sizes: list[tuple[int, int]]) -> list[dict]:
        return [cuda_check.bench(backend, n, worlds, args.bench_settle, args.bench_steps)
                for n, worlds in sizes]

    def aor(case: str, n: int, seed0: int, sets: dict) -> dict:
        seeds = list(range(seed0, seed0 + n))
        return precision.run_case(case, seeds, Path(args.piles), backend, 1.0, sets,
                                  log_phases=True)

    def study() -> dict:
        import shutil

        from demcal.calibrate import calibrate

        src = Path(args.study).resolve()
        work = Path(args.study_dir)
        work.mkdir(parents=True, exist_ok=True)
        for f in src.parent.glob("*.toml"):  # the study and the files it names
            shutil.copy(f, work / f.name)
        t0 = time.perf_counter()
        result = calibrate(work / src.name, workers=1,
                           progress=lambda stage, done, total: print(
                               f"  {stage} {done}/{total} {time.perf_counter() - t0:.0f}s",
                               flush=True))
        Path(args.json).with_name(Path(args.json).stem + "_result.json").write_text(
            json.dumps(result, indent=1, default=str))
        return {k: result[k] for k in ("optimum", "predicted_aor_deg", "verification",
                                       "n_runs", "rsm_adequacy", "rsm_model")}

    return {
        "check": checks,
        "bench": lambda: bench([(1000, 1), (10000, 1), (1000, 16)]),
        "standard": lambda: aor("1200:0.056", args.standard_seeds, 501, STEEP),
        "fourth": lambda: aor("1200:0.056", args.fourth_seeds, 9501, FOURTH),
        "pile1600": lambda: aor("1600:0.062", args.standard_seeds, 501, STEEP),
        "small": lambda: aor("300:0.035", args.small_seeds, 501, STEEP),
        "paper": lambda: aor("paper", args.paper_seeds, 101, {}),
        "bigbench": lambda: bench([(100000, 1)]),
        "study": study,
    }


def versions(backend: str) -> dict:
    import numba

    out = {"python": platform.python_version(), "numba": numba.__version__}
    if backend == "cuda":
        import numba_cuda
        from numba import cuda

        out["numba_cuda"] = numba_cuda.__version__
        out["device"] = str(cuda.get_current_device().name)
    return out


def main() -> None:
    args = parse_args()
    report: dict = {"argv": sys.argv, "backend": args.backend, **versions(args.backend)}
    t_start = time.perf_counter()
    print(report, flush=True)
    stages = stage_functions(args)
    for name in args.stages:  # in the order given
        work = stages[name]
        t = time.perf_counter()
        try:
            report[name] = work()
        except Exception as exc:  # keep the other stages' numbers
            traceback.print_exc()
            report[name] = {"error": repr(exc)}
        report[name + "_wall_s"] = time.perf_counter() - t
        print(name, f"{report[name + '_wall_s']:.1f}s",
              json.dumps(report[name], default=str)[:1500], flush=True)
        report["elapsed_s"] = time.perf_counter() - t_start
        Path(args.json).write_text(json.dumps(report, indent=1, default=str))
    print("done", f"{time.perf_counter() - t_start:.1f}s", flush=True)


if __name__ == "__main__":
    main()
