"""Host driver of the CPU backend: calls the compiled chunk loop and grows arrays on overflow."""

from __future__ import annotations

import numba
import numpy as np

from demcal.dem import _config
from demcal.dem.backends import cpu


class CpuRunner:
    """Runs a :class:`~demcal.dem.simulation.Simulation` on the CPU (arrays stay on the host)."""

    def __init__(self, sim):
        self.sim = sim

    def pull(self, *names: str) -> None:
        """Host arrays are the truth on the CPU: nothing to copy."""

    def push(self, *names: str) -> None:
        """Host arrays are the truth on the CPU: nothing to copy."""

    def push_all(self) -> None:
        """Host arrays are the truth on the CPU: nothing to copy."""

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
        while done < n_steps:
            a = sim.arrays
            steps, status, parity = cpu.run_chunk(
                n_steps - done,
                sim.parity,
                a["s_pos"],
                a["s_ref"],
                a["s_radius"],
                a["s_clump"],
                a["s_material"],
                a["s_offset"],
                a["s_cellkey"],
                a["s_force"],
                a["s_torque"],
                a["s_roll"],
                a["s_wall_force"],
                a["c_pos"],
                a["c_quat"],
                a["c_vel"],
                a["c_veval"],
                a["c_angmom"],
                a["c_omega"],
                a["c_mass"],
                a["c_inertia"],
                a["c_world"],
                a["c_state"],
                a["c_first"],
                a["c_count"],
                a["nb_count_a"],
                a["nb_index_a"],
                a["nb_hist_a"],
                a["nb_rhist_a"],
                a["nb_count_b"],
                a["nb_index_b"],
                a["nb_hist_b"],
                a["nb_rhist_b"],
                a["bucket_count"],
                a["bucket_members"],
                np.int64(len(a["bucket_count"]) - 1),
                a["grid_lo"],
                1.0 / sim.cell_size,
                sim.skin + sim.contact_margin,
                sim.wall_reach_extra,
                0.5 * sim.skin,
                a["wall_type"],
                a["wall_origin"],
                a["wall_geom"],
                a["wall_vel"],
                a["wall_material"],
                a["w_hist"],
                a["w_rhist"],
                a["s_wall_near"],
                a["wall_ref"],
                a["pair_params"],
                a["world_dt"],
                a["world_gravity"],
                a["world_active"],
                a["world_lo"],
                a["world_hi"],
                a["world_time"],
                a["world_steps"],
                sim.rolling_model,
                sim.contact_margin,
                float(_config.MAX_OVERLAP_FRACTION),
                a["flag_rebuild"],
                a["flag_nan"],
                a["flag_overlap"],
                a["stats"],
            )
            sim.parity = int(parity)
            done += int(steps)
            if status == cpu.STATUS_NEIGHBOR_OVERFLOW:
                sim._grow_neighbors(int(a["stats"][0]), "a" if sim.parity == 0 else "b")
            elif status == cpu.STATUS_BUCKET_OVERFLOW:
                sim._grow_buckets(int(a["stats"][1]))
