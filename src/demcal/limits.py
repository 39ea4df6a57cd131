"""Documented upper bounds of every count, size and seed that a user can give demcal.

An input beyond a bound is refused with one line (a :class:`demcal.errors.InputError`, exit
2) before anything is allocated or run. The bounds are far above any real study; they only
stop a typo (``1e9`` particles, a 20-digit seed) from taking the machine's memory or
overflowing an integer column. This module imports nothing of demcal, so every layer may
use it. See ``docs/hardening.md``.
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["MAX_CHUNK", "MAX_DESIGN_RUNS", "MAX_INPUT_FILE_BYTES", "MAX_PARTICLES_PER_RUN",
           "MAX_REPLICATES", "MAX_SEED", "MAX_SPHERES", "MAX_STUDY_SEED",
           "MAX_TEMPLATE_SPHERES", "MIN_TIME_STEP_S", "check_finite", "check_test_size",
           "check_time_step", "particles_of", "spheres_of"]

#: largest seed of ``demcal simulate`` and of the DoE run orders (fits numpy and SQLite)
MAX_SEED = 2**32 - 1
#: largest ``seed`` of a study; each run's seed adds at most 20 * 1000 + 10 050 to it
MAX_STUDY_SEED = 2_000_000_000
#: most replicates of ``demcal simulate aor --seeds`` (worlds of one batch)
MAX_REPLICATES = 256
#: most particles in one virtual test (``fill.count``, or ``fill.rate`` x ``filling_time``)
MAX_PARTICLES_PER_RUN = 200_000
#: most spheres in one batch of the engine: particles x spheres per particle x worlds
#: (about 1 kB each with contacts and neighbour lists: 5 GB at the bound)
MAX_SPHERES = 5_000_000
#: most spheres in one particle's clump template
MAX_TEMPLATE_SPHERES = 200
#: most runs of one DoE design (``demcal design ... --runs``)
MAX_DESIGN_RUNS = 100_000
#: most runs per executor task (``[executor] chunk``)
MAX_CHUNK = 100_000
#: largest text input read whole (study, factors, measurements TOML; run sheets)
MAX_INPUT_FILE_BYTES = 50 * 1024 * 1024
#: shortest time step of demcal's engine, s: a 0.1 mm glass bead's is ~2e-8 s; far below,
#: a run needs more steps than it could take in days (``particle.density = 1e-300`` hung)
MIN_TIME_STEP_S = 1e-9


def check_time_step(dt: float, what: str = "the time step") -> float:
    """``dt`` (s) if a run with it can end, else ValueError naming the bound and the
    parameters that set it."""
    if not (math.isfinite(dt) and dt >= MIN_TIME_STEP_S):
        raise ValueError(f"{what} would be {dt:.3g} s, below {MIN_TIME_STEP_S:g} s (a "
                         "fraction of the smallest sphere's Rayleigh step, which grows with "
                         "R sqrt(density / shear modulus)): the run would not end; check "
                         "particle.density (kg/m^3), particle.shear_modulus (Pa) and the "
                         "particle size")
    return dt


def check_finite(value: float, what: str) -> float:
    """``value`` as a float if it is a finite number, else ValueError naming ``what``."""
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{what} must be a finite number; got {value!r}")
    return v


def particles_of(config: Any) -> int:
    """Particles a virtual AoR test configuration will create (an upper estimate)."""
    fill = config.fill
    count = None if fill.count is None else int(fill.count)
    if getattr(fill, "method", "factory") == "packing" and count is not None:
        return count
    n = float(fill.rate) * float(fill.filling_time)
    made = int(n) + 1 if math.isfinite(n) and n < 1e18 else 10**18
    return made if count is None else min(count, made)


def spheres_of(config: Any, worlds: int = 1) -> int:
    """Spheres of ``worlds`` runs of a virtual AoR test configuration (an upper estimate)."""
    p = config.particle
    per = 1 if getattr(p, "template", None) == "sphere" else int(p.n_spheres)
    return particles_of(config) * per * int(worlds)


def check_test_size(config: Any, worlds: int = 1) -> None:
    """Refuse a virtual test that would create too many particles or spheres.

    Parameters
    ----------
    config : AoRTestConfig
        The test configuration (duck-typed: ``fill``, ``particle``).
    worlds : int
        Runs batched in one engine (replicates).

    Raises
    ------
    ValueError
        The particles of one run exceed :data:`MAX_PARTICLES_PER_RUN`, or the spheres of the
        batch exceed :data:`MAX_SPHERES`; the message names the bound.
    """
    n = particles_of(config)
    if n > MAX_PARTICLES_PER_RUN:
        raise ValueError(f"fill: {n:,} particles per run; at most {MAX_PARTICLES_PER_RUN:,} "
                         "(fill.count, or fill.rate x fill.filling_time)")
    s = spheres_of(config, worlds)
    if s > MAX_SPHERES:
        raise ValueError(f"{s:,} spheres in one batch ({n:,} particles x spheres per particle"
                         f" x {worlds} runs); at most {MAX_SPHERES:,}: use fewer particles or "
                         "replicates")
