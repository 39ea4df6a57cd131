"""Host driver of the CPU backend: calls the compiled chunk loop and grows arrays on overflow."""

from __future__ import annotations

import numba
import numpy as np

from demcal.dem import _config
from demcal.dem.backends import cpu
from demcal.dem.containers import alloc_buckets, alloc_neighbors, pack


class CpuBackend:
    """Runs a :class:`~demcal.dem.simulation.Simulation` on the CPU (arrays stay on the host).

    Implements :class:`~demcal.dem.backends.Backend`. The two neighbour buffers swap roles at
    each build: :attr:`parity` says which one is current (0: "a", 1: "b").
    """

    def __init__(self, sim):
        self.sim = sim
        self.parity = 0

    @property
    def neighbor_side(self) -> str:
        """The neighbour buffer holding the current list: "a" or "b"."""
        return "a" if self.parity == 0 else "b"

    def pull(self, *names: str) -> None:
        """Host arrays are the truth on the CPU: nothing to copy."""

    def push(self, *names: str) -> None:
        """Host arrays are the truth on the CPU: nothing to copy."""

    def push_all(self, parity: int = 0) -> None:
        """The host replaced its arrays (a snapshot): take them, with the current buffer."""
        self.parity = int(parity)

    def run_steps(self, n_steps: int) -> None:
        """Run ``n_steps`` steps; a small system runs on fewer threads (bitwise the same)."""
        sim = self.sim
        threads = numba.get_num_threads()
        per = _config.SPHERES_PER_THREAD
        if per > 0:
            a = sim.arrays
            n_live = int(np.count_nonzero(a["world_active"][a["c_world"]][a["s_clump"]]))
            numba.set_num_threads(max(1, min(threads, n_live // per)))
        try:
            self._run_steps(n_steps)
        finally:
            numba.set_num_threads(threads)

    def _run_steps(self, n_steps: int) -> None:
        sim = self.sim
        done = 0
        stats = sim.arrays["stats"]
        while done < n_steps:
            # packed again after a growth (new arrays)
            state = pack(sim.arrays, sim.params()._replace(threads=numba.get_num_threads()))
            steps, status, parity = cpu.run_chunk(n_steps - done, self.parity, state)
            self.parity = int(parity)
            done += int(steps)
            if status == cpu.STATUS_NEIGHBOR_OVERFLOW:
                self.grow(neighbors=int(stats[0]))
            elif status == cpu.STATUS_BUCKET_OVERFLOW:
                self.grow(buckets=int(stats[1]))

    def grow(self, neighbors: int = 0, buckets: int = 0) -> None:
        """Make room for ``neighbors`` slots per sphere and ``buckets`` spheres per bucket.

        Only the scratch neighbour buffer is reallocated (the next build fills it and carries
        the history over from the current one); the bucket slots are refilled at every build.
        """
        sim = self.sim
        if neighbors > 0:
            scratch = "b" if self.parity == 0 else "a"
            alloc_neighbors(sim.arrays, scratch, sim.n_spheres, int(neighbors * 1.25) + 4,
                            sim.carry_rolling)
        if buckets > 0:
            alloc_buckets(sim.arrays, int(buckets * 1.25) + 4)
