"""CUDA backend: numba.cuda kernels around the shared bodies, replayed as a CUDA graph.

One time step is six small kernels, one thread per element:

1. ``bin``: put each active sphere in its bucket (atomic), remember its reference position
   (only when the rebuild flag is set; buckets are emptied by ``commit`` after each build);
2. ``search``: fill each sphere's neighbour slots into the scratch buffer ("b"), sorted, with
   the history carried over from the current buffer ("a"), and mark its candidate walls;
3. ``commit``: copy scratch to current (unless a buffer overflowed), empty the used buckets;
4. ``finish``: one thread clears the rebuild flag and records the wall positions of the
   build (a wall moving half the skin from there triggers the next one), or raises the halt
   flag on overflow;
5. ``forces`` and 6. ``clumps``: the shared bodies of :mod:`demcal.dem.kernels`; the first
   threads of ``clumps`` also move their world's walls and advance its clock.

Neighbour-slot arrays live on the device in column-major (Fortran) order, so that consecutive
threads read consecutive addresses (coalesced) while the kernel bodies index them as usual.

Every kernel returns at once when the halt flag is set, so an overflow mid-chunk makes the rest
of the chunk a no-op; the host then grows the arrays and continues: nothing is lost. The rebuild
kernels return at once when no rebuild is due, so a step costs three idle launches then. Launch
overhead from Python (tens of microseconds per kernel) would dominate at these sizes, so the
steps are captured once into a CUDA graph (several steps per graph) and replayed.

The neighbour order is made canonical by sorting (binning order is not deterministic on the
GPU), so GPU runs are reproducible run to run; they differ from CPU runs by rounding (FMA).
"""

from __future__ import annotations

import logging
import os

import numpy as np

if not hasattr(np, "row_stack"):  # numba-cuda 0.30 calls np.row_stack, gone in numpy 2.4+
    setattr(np, "row_stack", np.vstack)  # noqa: B010

from numba import cuda

from demcal.dem import _config
from demcal.dem.kernels import (
    ACTIVE,
    CELL_BITS,
    CELL_MAX,
    ROLLING_C,
    advance_world,
    cell_bucket,
    cell_coords,
    cell_key,
    clump_step,
    neighbor_search,
    sphere_forces,
    wall_candidates,
)

log = logging.getLogger("demcal.dem")


def _simulator() -> bool:
    return os.environ.get("NUMBA_ENABLE_CUDASIM", "0") == "1"


def _unwrapping(fn):
    """Under the CUDA simulator, call the compiled CPU body on the plain numpy arrays.

    The simulator hands kernels wrapped arrays that compiled functions cannot take; the
    per-element bodies are the same code on both targets, so the simulator checks the
    kernels' glue (indexing, flags, atomics, buffers) around them.
    """

    def call(*args):
        return fn(*[a._item._ary if hasattr(a, "_item") else a for a in args])

    return call


if _simulator():
    cell_bucket = _unwrapping(cell_bucket)
    cell_coords = _unwrapping(cell_coords)
    cell_key = _unwrapping(cell_key)
    clump_step = _unwrapping(clump_step)
    advance_world = _unwrapping(advance_world)
    neighbor_search = _unwrapping(neighbor_search)
    sphere_forces = _unwrapping(sphere_forces)
    wall_candidates = _unwrapping(wall_candidates)

THREADS = 64
#: steps captured in one CUDA graph (the graph is replayed ceil(n / GRAPH_STEPS) times)
GRAPH_STEPS = 20

_KERNELS = None
#: optional register cap of the force kernel (``DEMCAL_CUDA_MAXREG``), for tuning
_MAXREG = int(os.environ.get("DEMCAL_CUDA_MAXREG", "0"))


def _build_kernels():
    """Compile (lazily) the CUDA kernels; returns a namespace of them."""
    global _KERNELS
    if _KERNELS is not None:
        return _KERNELS

    @cuda.jit
    def k_bin(halt, flag_rebuild, s_pos, s_clump, c_state, c_world, grid_lo, inv_cell,
              bucket_count, bucket_members, mask, s_cellkey, s_ref, stats):
        if halt[0] != 0 or flag_rebuild[0] == 0:
            return
        i = cuda.grid(1)
        if i >= s_pos.shape[0]:
            return
        s_ref[i, 0] = s_pos[i, 0]
        s_ref[i, 1] = s_pos[i, 1]
        s_ref[i, 2] = s_pos[i, 2]
        c = s_clump[i]
        if c_state[c] != ACTIVE:
            s_cellkey[i] = -1
            return
        w = c_world[c]
        ix, iy, iz = cell_coords(w, s_pos[i, 0], s_pos[i, 1], s_pos[i, 2], grid_lo, inv_cell)
        s_cellkey[i] = cell_key(w, ix, iy, iz)
        b = cell_bucket(w, ix, iy, iz, mask)
        n = cuda.atomic.add(bucket_count, b, 1)
        if n < bucket_members.shape[1]:
            bucket_members[b, n] = i
        cuda.atomic.max(stats, 1, n + 1)

    @cuda.jit
    def k_search(halt, flag_rebuild, s_pos, s_radius, s_clump, c_state, c_world, s_cellkey,
                 grid_lo, inv_cell, bucket_count, bucket_members, mask, extra, old_count,
                 old_index, old_hist, old_rhist, new_count, new_index, new_hist, new_rhist,
                 carry_rolling, stats, wall_type, wall_origin, wall_geom, wall_extra,
                 s_wall_near, w_hist, w_rhist, s_wall_force):
        if halt[0] != 0 or flag_rebuild[0] == 0:
            return
        if stats[1] > bucket_members.shape[1]:
            return
        i = cuda.grid(1)
        if i >= s_pos.shape[0]:
            return
        neighbor_search(i, i + 1, s_pos, s_radius, s_clump, c_state, c_world, s_cellkey,
                        grid_lo, inv_cell, bucket_count, bucket_members, mask, extra,
                        old_count, old_index, old_hist, old_rhist, new_count, new_index,
                        new_hist, new_rhist, carry_rolling)
        cuda.atomic.max(stats, 0, new_count[i])
        wall_candidates(i, i + 1, s_pos, s_radius, s_clump, c_state, c_world, wall_type,
                        wall_origin, wall_geom, wall_extra, s_wall_near, w_hist, w_rhist,
                        s_wall_force, carry_rolling)

    @cuda.jit
    def k_commit(halt, flag_rebuild, stats, bucket_cap, src_count, src_index, src_hist,
                 src_rhist, dst_count, dst_index, dst_hist, dst_rhist, carry_rolling,
                 s_cellkey, bucket_count, mask):
        if halt[0] != 0 or flag_rebuild[0] == 0:
            return
        cap = dst_index.shape[1]
        if stats[0] > cap or stats[1] > bucket_cap:
            return
        i = cuda.grid(1)
        if i >= dst_count.shape[0]:
            return
        # empty this sphere's bucket for the next build (idempotent writes of 0)
        key = s_cellkey[i]
        if key >= 0:
            iz = key & CELL_MAX
            iy = (key >> CELL_BITS) & CELL_MAX
            ix = (key >> (2 * CELL_BITS)) & CELL_MAX
            w = key >> (3 * CELL_BITS)
            bucket_count[cell_bucket(w, ix, iy, iz, mask)] = 0
        n = src_count[i]
        dst_count[i] = n
        for k in range(min(n, cap)):
            dst_index[i, k] = src_index[i, k]
            dst_hist[i, k, 0] = src_hist[i, k, 0]
            dst_hist[i, k, 1] = src_hist[i, k, 1]
            dst_hist[i, k, 2] = src_hist[i, k, 2]
            if carry_rolling:
                dst_rhist[i, k, 0] = src_rhist[i, k, 0]
                dst_rhist[i, k, 1] = src_rhist[i, k, 1]
                dst_rhist[i, k, 2] = src_rhist[i, k, 2]

    @cuda.jit
    def k_finish(halt, flag_rebuild, stats, nb_cap, bucket_cap, wall_origin, wall_ref):
        if halt[0] != 0 or flag_rebuild[0] == 0:
            return
        if cuda.grid(1) != 0:
            return
        if stats[0] > nb_cap or stats[1] > bucket_cap:
            halt[0] = 1
        else:
            for w in range(wall_origin.shape[0]):
                for k in range(wall_origin.shape[1]):
                    wall_ref[w, k, 0] = wall_origin[w, k, 0]
                    wall_ref[w, k, 1] = wall_origin[w, k, 1]
                    wall_ref[w, k, 2] = wall_origin[w, k, 2]
            flag_rebuild[0] = 0
            stats[2] += 1
            stats[0] = 0
            stats[1] = 0

    @cuda.jit(**({"max_registers": _MAXREG} if _MAXREG else {}))
    def k_forces(halt, s_pos, s_radius, s_clump, s_material, c_pos, c_veval, c_omega, c_mass,
                 c_world, c_state, nb_count, nb_index, nb_hist, nb_rhist, wall_type,
                 wall_origin, wall_geom, wall_vel, wall_material, w_hist, w_rhist, s_wall_near,
                 pair_params, world_dt, world_active, rolling_model, contact_margin,
                 max_overlap_fraction, s_force, s_torque, s_roll, s_wall_force, flag_overlap):
        if halt[0] != 0:
            return
        i = cuda.grid(1)
        if i >= s_pos.shape[0]:
            return
        sphere_forces(i, i + 1, s_pos, s_radius, s_clump, s_material, c_pos, c_veval, c_omega,
                      c_mass, c_world, c_state, nb_count, nb_index, nb_hist, nb_rhist,
                      wall_type, wall_origin, wall_geom, wall_vel, wall_material, w_hist,
                      w_rhist, s_wall_near, pair_params, world_dt, world_active, rolling_model,
                      contact_margin, max_overlap_fraction, s_force, s_torque, s_roll,
                      s_wall_force, flag_overlap)

    @cuda.jit
    def k_clumps(halt, c_pos, c_quat, c_vel, c_veval, c_angmom, c_omega, c_mass, c_inertia,
                 c_world, c_state, c_first, c_count, s_offset, s_pos, s_ref, s_force, s_torque,
                 s_roll, world_dt, world_gravity, world_active, world_lo, world_hi, half_skin,
                 flag_rebuild, flag_nan, wall_origin, wall_vel, world_time, world_steps, stats,
                 wall_ref):
        if halt[0] != 0:
            return
        c = cuda.grid(1)
        # the first threads also move their world's walls and clock (read next step only)
        if c == 0:
            stats[3] += 1
        if c < world_dt.shape[0]:
            advance_world(c, world_dt, world_active, world_time, world_steps, wall_origin,
                          wall_vel, wall_ref, half_skin, flag_rebuild)
        if c >= c_pos.shape[0]:
            return
        clump_step(c, c + 1, c_pos, c_quat, c_vel, c_veval, c_angmom, c_omega, c_mass,
                   c_inertia, c_world, c_state, c_first, c_count, s_offset, s_pos, s_ref,
                   s_force, s_torque, s_roll, world_dt, world_gravity, world_active, world_lo,
                   world_hi, half_skin, flag_rebuild, flag_nan)

    class K:
        pass

    ns = K()
    for name, fn in list(locals().items()):
        if name.startswith("k_"):
            setattr(ns, name, fn)
    _KERNELS = ns
    return ns


def _blocks(n: int) -> int:
    return max(1, (int(n) + THREADS - 1) // THREADS)


class CudaRunner:
    """Runs a :class:`~demcal.dem.simulation.Simulation` on a CUDA GPU.

    Device copies of every array live in :attr:`dev`; ``pull``/``push`` copy named arrays
    between host and device in place (so captured graphs stay valid). Buffer "a" is always
    the current neighbour list and "b" the scratch one.
    """

    def __init__(self, sim):
        from demcal.errors import InputError

        if not _simulator() and not cuda.is_available():
            raise InputError("backend 'cuda' was requested but numba finds no CUDA GPU; "
                             "use backend='cpu' or 'auto'")
        self.cuda = cuda
        self.sim = sim
        self.k = _build_kernels()
        self.stream = cuda.stream()
        self.use_graphs = (not _simulator()) and os.environ.get("DEMCAL_CUDA_GRAPHS", "1") != "0"
        self._graph = None
        self.dev: dict = {}
        self._fresh: set[str] = set()  # arrays whose host copy equals the device copy
        self.sim.parity = 0
        # both neighbour buffers share one capacity on the GPU
        a = sim.arrays
        cap = max(a["nb_index_a"].shape[1], a["nb_index_b"].shape[1])
        if a["nb_index_a"].shape[1] != cap:
            sim._alloc_neighbors("a", cap)
        if a["nb_index_b"].shape[1] != cap:
            sim._alloc_neighbors("b", cap)
        a["halt"] = np.zeros(1, dtype=np.int32)
        self._to_device_layout()
        a["bucket_count"][:] = 0
        self.upload_all()

    def _to_device_layout(self) -> None:
        """Slot arrays (sphere x neighbour/wall slot) in Fortran order on the device.

        A thread walks its own sphere's slots, so slot k of consecutive spheres should be
        adjacent (coalesced). Per-sphere and per-clump vectors stay row-major: their x, y, z
        share a cache line, which matters for the random gathers of neighbour data.
        """
        sim = self.sim
        for name, arr in sim.arrays.items():
            if arr.ndim >= 2 and name.split("_")[0] in ("nb", "w") and \
                    arr.shape[0] == sim.n_spheres:
                sim.arrays[name] = np.asfortranarray(arr)

    # ---------------------------------------------------------------- transfers
    def upload_all(self) -> None:
        self._to_device_layout()
        self.dev = {k: self.cuda.to_device(v, stream=self.stream)
                    for k, v in self.sim.arrays.items()}
        self.stream.synchronize()
        self._graph = None
        self._fresh = set(self.dev)

    def push_all(self) -> None:
        self.sim.parity = 0
        self.upload_all()

    def pull(self, *names: str) -> None:
        """Copy arrays device -> host; an array already copied since the last step is skipped."""
        todo = [n for n in names if n not in self._fresh]
        for n in todo:
            self.dev[n].copy_to_host(self.sim.arrays[n], stream=self.stream)
        if todo:
            self.stream.synchronize()
        self._fresh.update(todo)

    def push(self, *names: str) -> None:
        for n in names:
            host = self.sim.arrays[n]
            dev = self.dev[n]
            if host.shape != dev.shape:
                self._to_device_layout()
                self.dev[n] = self.cuda.to_device(self.sim.arrays[n], stream=self.stream)
                self._graph = None
                self._fresh.add(n)
                continue
            if dev.is_f_contiguous() and not dev.is_c_contiguous():
                host = np.asfortranarray(host)
            else:
                host = np.ascontiguousarray(host)
            self.sim.arrays[n] = host
            dev.copy_to_device(host, stream=self.stream)
            self._fresh.add(n)
        self.stream.synchronize()

    # ---------------------------------------------------------------- stepping
    def _launch_step(self) -> None:
        d = self.dev
        sim = self.sim
        k = self.k
        s = self.stream
        n_s = sim.n_spheres
        n_c = sim.n_clumps
        nb = _blocks(n_s)
        mask = np.int64(len(sim.arrays["bucket_count"]) - 1)
        inv_cell = 1.0 / sim.cell_size
        extra = sim.skin + sim.contact_margin
        carry = sim.rolling_model == ROLLING_C
        nb_cap = d["nb_index_a"].shape[1]
        bcap = d["bucket_members"].shape[1]
        k.k_bin[nb, THREADS, s](
            d["halt"], d["flag_rebuild"], d["s_pos"], d["s_clump"], d["c_state"], d["c_world"],
            d["grid_lo"], inv_cell, d["bucket_count"], d["bucket_members"], mask,
            d["s_cellkey"], d["s_ref"], d["stats"])
        k.k_search[nb, THREADS, s](
            d["halt"], d["flag_rebuild"], d["s_pos"], d["s_radius"], d["s_clump"], d["c_state"],
            d["c_world"], d["s_cellkey"], d["grid_lo"], inv_cell, d["bucket_count"],
            d["bucket_members"], mask, extra, d["nb_count_a"], d["nb_index_a"], d["nb_hist_a"],
            d["nb_rhist_a"], d["nb_count_b"], d["nb_index_b"], d["nb_hist_b"], d["nb_rhist_b"],
            carry, d["stats"], d["wall_type"], d["wall_origin"], d["wall_geom"],
            sim.wall_reach_extra, d["s_wall_near"], d["w_hist"], d["w_rhist"], d["s_wall_force"])
        k.k_commit[nb, THREADS, s](
            d["halt"], d["flag_rebuild"], d["stats"], bcap, d["nb_count_b"], d["nb_index_b"],
            d["nb_hist_b"], d["nb_rhist_b"], d["nb_count_a"], d["nb_index_a"], d["nb_hist_a"],
            d["nb_rhist_a"], carry, d["s_cellkey"], d["bucket_count"], mask)
        k.k_finish[1, 32, s](d["halt"], d["flag_rebuild"], d["stats"], nb_cap, bcap,
                             d["wall_origin"], d["wall_ref"])
        k.k_forces[nb, THREADS, s](
            d["halt"], d["s_pos"], d["s_radius"], d["s_clump"], d["s_material"], d["c_pos"],
            d["c_veval"], d["c_omega"], d["c_mass"], d["c_world"], d["c_state"],
            d["nb_count_a"], d["nb_index_a"], d["nb_hist_a"], d["nb_rhist_a"], d["wall_type"],
            d["wall_origin"], d["wall_geom"], d["wall_vel"], d["wall_material"], d["w_hist"],
            d["w_rhist"], d["s_wall_near"], d["pair_params"], d["world_dt"], d["world_active"],
            sim.rolling_model, sim.contact_margin, float(_config.MAX_OVERLAP_FRACTION),
            d["s_force"], d["s_torque"], d["s_roll"], d["s_wall_force"], d["flag_overlap"])
        k.k_clumps[_blocks(max(n_c, sim.n_worlds)), THREADS, s](
            d["halt"], d["c_pos"], d["c_quat"], d["c_vel"], d["c_veval"], d["c_angmom"],
            d["c_omega"], d["c_mass"], d["c_inertia"], d["c_world"], d["c_state"],
            d["c_first"], d["c_count"], d["s_offset"], d["s_pos"], d["s_ref"], d["s_force"],
            d["s_torque"], d["s_roll"], d["world_dt"], d["world_gravity"], d["world_active"],
            d["world_lo"], d["world_hi"], 0.5 * sim.skin, d["flag_rebuild"], d["flag_nan"],
            d["wall_origin"], d["wall_vel"], d["world_time"], d["world_steps"], d["stats"],
            d["wall_ref"])

    def _capture(self):
        """Capture GRAPH_STEPS steps into an executable CUDA graph (driver API)."""
        from cuda.bindings import driver as drv

        h = self.stream.handle
        h = int(getattr(h, "value", h) or 0)
        hs = drv.CUstream(h)
        _check(drv.cuStreamBeginCapture(
            hs, drv.CUstreamCaptureMode.CU_STREAM_CAPTURE_MODE_THREAD_LOCAL))
        try:
            for _ in range(GRAPH_STEPS):
                self._launch_step()
        finally:
            graph = _check(drv.cuStreamEndCapture(hs))
        exe = _check(drv.cuGraphInstantiate(graph, 0))
        self._graph = (graph, exe, hs, drv)

    def _replay(self, n_graphs: int) -> None:
        _graph, exe, hs, drv = self._graph
        for _ in range(n_graphs):
            _check(drv.cuGraphLaunch(exe, hs))

    def run_steps(self, n_steps: int) -> None:
        sim = self.sim
        a = sim.arrays
        done = 0
        while done < n_steps:
            a["stats"][3] = 0
            self.push("stats")
            remaining = n_steps - done
            launched = 0
            if self.use_graphs and self._graph is None and remaining > GRAPH_STEPS:
                # compile and load every kernel outside the capture, as one ordinary step
                self._launch_step()
                launched += 1
                try:
                    self._capture()
                except Exception as exc:  # fall back to plain launches
                    log.warning("CUDA graph capture failed (%s); using plain launches", exc)
                    self.use_graphs = False
                    self._graph = None
            if self._graph is not None and remaining - launched >= GRAPH_STEPS:
                k = (remaining - launched) // GRAPH_STEPS
                self._replay(k)
                launched += k * GRAPH_STEPS
            for _ in range(remaining - launched):
                self._launch_step()
            launched = remaining
            self._fresh.clear()  # the steps changed the device arrays
            self.pull("stats", "halt")
            executed = int(a["stats"][3])
            done += executed
            if a["halt"][0] != 0:
                self._grow()
            elif executed != launched:
                raise RuntimeError(f"CUDA chunk ran {executed} of {launched} steps")

    def _grow(self) -> None:
        """Grow the neighbour or bucket arrays after an overflow and clear the halt flag."""
        sim = self.sim
        a = sim.arrays
        self.pull(*[n for n in a if n in self.dev])
        need_nb = int(a["stats"][0])
        need_b = int(a["stats"][1])
        cap = a["nb_index_a"].shape[1]
        if need_nb > cap:
            new_cap = int(need_nb * 1.25) + 4
            for side in ("a", "b"):
                old = {k: a[f"{k}_{side}"] for k in ("nb_count", "nb_index", "nb_hist",
                                                     "nb_rhist")}
                sim._alloc_neighbors(side, new_cap)
                a[f"nb_count_{side}"][:] = old["nb_count"]
                a[f"nb_index_{side}"][:, :cap] = old["nb_index"]
                a[f"nb_hist_{side}"][:, :cap] = old["nb_hist"]
                if sim.rolling_model == ROLLING_C:
                    a[f"nb_rhist_{side}"][:, :cap] = old["nb_rhist"]
        if need_b > a["bucket_members"].shape[1]:
            sim._grow_buckets(need_b)
        a["halt"][0] = 0
        a["flag_rebuild"][0] = 1
        a["bucket_count"][:] = 0
        a["stats"][:2] = 0
        self.upload_all()


def _check(result):
    """Unpack a cuda.bindings call result, raising on an error code."""
    err = result[0]
    if int(err) != 0:
        raise RuntimeError(f"CUDA driver error {err}")
    if len(result) == 1:
        return None
    return result[1] if len(result) == 2 else result[1:]
