"""Particle placement (the dynamic factory's and the packing fill's): time per attempt.

A region at the factory's height holds spheres already; ``--clumps`` stalks are tried
``--attempts`` times each (most fail, as in the paper fill once the tube's top is full), then
a quick fidelity's packing fill is built. Prints microseconds per attempt and the packing's
wall time. Compare versions with PYTHONPATH=<tree>/src.

Usage::

    python benchmarks/placement.py --clumps 4000
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from demcal.dem.shapes import stalk_template
from demcal.virtual.config import fidelity_config
from demcal.virtual.factory import SphereGrid, pack_cylinder, place_in_cylinder


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--clumps", type=int, default=4000)
    ap.add_argument("--attempts", type=int, default=5)
    args = ap.parse_args()
    tpl = stalk_template()
    rng0 = np.random.default_rng(0)
    n = 1500
    present = np.column_stack([rng0.uniform(-0.02, 0.02, n), rng0.uniform(-0.02, 0.02, n),
                               rng0.uniform(0.12, 0.15, n)])
    grid = SphereGrid(0.006)
    grid.add(present, np.full(n, 0.002))
    scales = np.random.default_rng(7).uniform(0.75, 1.25, args.clumps)
    # warm (compiles on first use)
    place_in_cylinder(tpl, scales[:5], radius=0.025, z_low=0.14, z_high=0.15,
                      rng=np.random.default_rng(2), grid=SphereGrid(0.006), attempts=1)
    t = time.perf_counter()
    placed, _, _ = place_in_cylinder(tpl, scales, radius=0.025, z_low=0.14, z_high=0.15,
                                     rng=np.random.default_rng(1), grid=grid,
                                     attempts=args.attempts)
    factory = time.perf_counter() - t
    cfg = fidelity_config("quick")
    t = time.perf_counter()
    pack_cylinder(tpl, np.random.default_rng(3).uniform(0.75, 1.05, cfg.fill.count), cfg,
                  np.random.default_rng(4))
    packing = time.perf_counter() - t
    tries = args.clumps * args.attempts
    print(f"factory: {factory:.2f} s for <= {tries} attempts ({len(placed)} placed), "
          f"{1e6 * factory / tries:.1f} us per attempt; quick packing fill {packing:.2f} s")


if __name__ == "__main__":
    main()
