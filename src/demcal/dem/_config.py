"""Tunables of the DEM engine, in one patchable place (SI units).

Tests patch these (``monkeypatch.setattr(demcal.dem._config, "NAME", value)``) before a
:class:`~demcal.dem.simulation.Simulation` is built; they are read when arrays are allocated
and when a run loop starts, never inside compiled kernels.
"""

from __future__ import annotations

import os

#: Verlet skin as a fraction of the largest sphere radius of the simulation. A larger skin
#: means fewer neighbour rebuilds but more candidate pairs per sphere.
SKIN_FRACTION: float = 0.25

#: Initial neighbour slots per sphere; grown automatically (x1.25) when a rebuild overflows.
NEIGHBOR_CAPACITY: int = 32

#: Initial sphere slots per hash-grid bucket; grown automatically when a bucket overflows.
BUCKET_CAPACITY: int = 16

#: Hash-grid buckets per sphere (rounded up to a power of two).
BUCKETS_PER_SPHERE: float = 2.0

#: Steps per compiled chunk between host checks (health, settle detection, insertion).
CHUNK_STEPS: int = 500

#: Largest overlap accepted, as a fraction of the smaller radius of the pair; beyond it the
#: world is flagged and the run stops with :class:`~demcal.errors.SimulationUnstable`.
MAX_OVERLAP_FRACTION: float = 0.5

#: Largest clump speed accepted, m/s; beyond it the run stops (energy blow-up).
MAX_SPEED: float = 100.0

#: Default fraction of the Rayleigh time step used as the time step (EDEM's 20 %).
DT_FRACTION: float = 0.2

#: CPU backend: live spheres per thread below which a run uses fewer threads (a second thread
#: gives little on a small system: the quick AoR test, 1050 spheres, took 123 us per step on
#: one thread and 113 us on two, 200 us when idle threads slept between loops; the
#: 7000-sphere bed of benchmarks/engine.py takes ~1.05 ms on one and 0.77-0.87 ms on two).
#: 0 always uses every thread. Environment: DEMCAL_SPHERES_PER_THREAD.
SPHERES_PER_THREAD: int = int(os.environ.get("DEMCAL_SPHERES_PER_THREAD", "2000"))

#: Visit only each sphere's candidate walls (those within reach at the last neighbour build,
#: :func:`~demcal.dem.kernels.wall_candidates`); False visits every wall at every step. Both
#: give bitwise the same results (a test checks it). Measured on one thread: the 7000-sphere
#: bed of benchmarks/engine.py (five walls) 1.64 -> 1.05-1.1 ms per step, the quick AoR test
#: (plate and tube) 195-200 -> 153-165 us per step.
WALL_CANDIDATES: bool = True
