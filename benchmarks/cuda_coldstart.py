"""Cold start of the CUDA backend: how long a new process takes to its first time steps.

Run it twice in a row on a GPU machine: the first process compiles the kernels and writes
them to numba's on-disk cache (``src/demcal/dem/backends/__pycache__``), the second loads
them. Each run prints one JSON line (and appends it to ``--json`` when given)::

    python benchmarks/cuda_coldstart.py --json coldstart.json   # compiles (cold)
    python benchmarks/cuda_coldstart.py --json coldstart.json   # from the cache

``import_s`` is importing demcal's engine and numba-cuda, ``first_steps_s`` building a
1000-stalk bed on the GPU and its first 10 steps (kernel compile or cache load, graph
capture), ``next_steps_s`` the next 10 steps (a warm call, for scale), ``total_s`` the
process's time to its first steps.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

T0 = time.perf_counter()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--backend", default="cuda", choices=["cuda", "cpu"])
    ap.add_argument("--clumps", type=int, default=1000)
    ap.add_argument("--json", default=None, help="append the result to this JSON list")
    args = ap.parse_args()

    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    from cuda_check import bed_world

    from demcal.dem.backends import cuda as cuda_backend
    from demcal.dem.simulation import Simulation

    t_import = time.perf_counter() - T0
    cache_dir = Path(cuda_backend.__file__).parent / "__pycache__"
    cached_before = len(list(cache_dir.glob("cuda.*.nbi"))) if cache_dir.is_dir() else 0
    t = time.perf_counter()
    sim = Simulation([bed_world(args.clumps, 0)], backend=args.backend)
    sim.advance(10)
    _ = sim.time  # synchronise
    t_first = time.perf_counter() - t
    t = time.perf_counter()
    sim.advance(10)
    _ = sim.time
    out = {"backend": args.backend, "n_spheres": sim.n_spheres,
           "cache_enabled": bool(cuda_backend._CACHE), "cached_kernels_before": cached_before,
           "import_s": t_import, "first_steps_s": t_first,
           "next_steps_s": time.perf_counter() - t, "total_s": time.perf_counter() - T0}
    print(json.dumps(out), flush=True)
    if args.json:
        path = Path(args.json)
        runs = json.loads(path.read_text()) if path.is_file() else []
        path.write_text(json.dumps([*runs, out], indent=1))


if __name__ == "__main__":
    main()
