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
import warnings

import numpy as np

from demcal.dem.backends import import_numba_cuda
from demcal.dem.containers import alloc_buckets, alloc_neighbors, neighbor_keys, pack
from demcal.dem.kernels import (
    ACTIVE,
    CELL_BITS,
    CELL_MAX,
    advance_world,
    cell_bucket,
    cell_coords,
    cell_key,
    clump_step,
    neighbor_search,
    sphere_forces,
    wall_candidates,
)

cuda = import_numba_cuda()  # numba.cuda, with its import-time fixes

log = logging.getLogger("demcal.dem")


def _simulator() -> bool:
    return os.environ.get("NUMBA_ENABLE_CUDASIM", "0") == "1"


def _unwrapping(fn):
    """Under the CUDA simulator, call the compiled CPU body on the plain numpy arrays.

    The simulator hands kernels wrapped arrays that compiled functions cannot take; the
    per-element bodies are the same code on both targets, so the simulator checks the
    kernels' glue (indexing, flags, atomics, buffers) around them.
    """

    def plain(a):
        if hasattr(a, "_item"):  # an array inside a simulated kernel
            return a._item._ary
        if hasattr(a, "_ary"):  # a simulated device array (a container's field)
            return a._ary
        if isinstance(a, tuple) and hasattr(a, "_fields"):  # a state container
            return type(a)(*[plain(x) for x in a])
        return a

    def call(*args):
        return fn(*[plain(a) for a in args])

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
#: compiled kernels kept in numba's on-disk cache (``__pycache__`` beside this file), so a
#: new process loads them (~3 s to the first steps on an H100) instead of compiling them (~17 s);
#: ``DEMCAL_CUDA_CACHE=0`` turns it off.
#: A register cap is a tuning run: not cached (numba's cache key does not hold it). Stale
#: kernels are purged with the CPU's when an engine source changes (:mod:`demcal.dem._jit_cache`).
_CACHE = os.environ.get("DEMCAL_CUDA_CACHE", "1") != "0" and not _MAXREG


def _build_kernels():
    """Compile (lazily) the CUDA kernels; returns a namespace of them."""
    global _KERNELS
    if _KERNELS is not None:
        return _KERNELS

    @cuda.jit(cache=_CACHE)
    def k_bin(halt, sph, clu, grid, prm, flags):
        if halt[0] != 0 or flags.rebuild[0] == 0:
            return
        i = cuda.grid(1)
        s_pos = sph.pos
        if i >= s_pos.shape[0]:
            return
        sph.ref[i, 0] = s_pos[i, 0]
        sph.ref[i, 1] = s_pos[i, 1]
        sph.ref[i, 2] = s_pos[i, 2]
        c = sph.clump[i]
        if clu.state[c] != ACTIVE:
            sph.cellkey[i] = -1
            return
        w = clu.world[c]
        ix, iy, iz = cell_coords(w, s_pos[i, 0], s_pos[i, 1], s_pos[i, 2], grid.lo, prm.inv_cell)
        sph.cellkey[i] = cell_key(w, ix, iy, iz)
        b = cell_bucket(w, ix, iy, iz, prm.mask)
        n = cuda.atomic.add(grid.bucket_count, b, 1)
        if n < grid.bucket_members.shape[1]:
            grid.bucket_members[b, n] = i
        cuda.atomic.max(flags.stats, 1, n + 1)

    @cuda.jit(cache=_CACHE)
    def k_search(halt, sph, clu, grid, prm, old, new, walls, flags):
        if halt[0] != 0 or flags.rebuild[0] == 0:
            return
        if flags.stats[1] > grid.bucket_members.shape[1]:
            return
        i = cuda.grid(1)
        if i >= sph.pos.shape[0]:
            return
        neighbor_search(i, i + 1, sph, clu, grid, prm, old, new)
        cuda.atomic.max(flags.stats, 0, new.found[i])
        wall_candidates(i, i + 1, sph, clu, walls, prm)

    @cuda.jit(cache=_CACHE)
    def k_commit(halt, flags, bucket_cap, src, dst, sph, grid, prm):
        if halt[0] != 0 or flags.rebuild[0] == 0:
            return
        stats = flags.stats
        cap = dst.partner.shape[1]
        if stats[0] > cap or stats[1] > bucket_cap:
            return
        i = cuda.grid(1)
        if i >= dst.found.shape[0]:
            return
        # empty this sphere's bucket for the next build (idempotent writes of 0)
        key = sph.cellkey[i]
        if key >= 0:
            iz = key & CELL_MAX
            iy = (key >> CELL_BITS) & CELL_MAX
            ix = (key >> (2 * CELL_BITS)) & CELL_MAX
            w = key >> (3 * CELL_BITS)
            grid.bucket_count[cell_bucket(w, ix, iy, iz, prm.mask)] = 0
        n = src.found[i]
        dst.found[i] = n
        for k in range(min(n, cap)):
            dst.partner[i, k] = src.partner[i, k]
            dst.hist[i, k, 0] = src.hist[i, k, 0]
            dst.hist[i, k, 1] = src.hist[i, k, 1]
            dst.hist[i, k, 2] = src.hist[i, k, 2]
            if prm.carry_rolling:
                dst.rhist[i, k, 0] = src.rhist[i, k, 0]
                dst.rhist[i, k, 1] = src.rhist[i, k, 1]
                dst.rhist[i, k, 2] = src.rhist[i, k, 2]

    @cuda.jit(cache=_CACHE)
    def k_finish(halt, flags, nb_cap, bucket_cap, walls):
        if halt[0] != 0 or flags.rebuild[0] == 0:
            return
        if cuda.grid(1) != 0:
            return
        stats = flags.stats
        if stats[0] > nb_cap or stats[1] > bucket_cap:
            halt[0] = 1
        else:
            origin = walls.origin
            for w in range(origin.shape[0]):
                for k in range(origin.shape[1]):
                    walls.ref[w, k, 0] = origin[w, k, 0]
                    walls.ref[w, k, 1] = origin[w, k, 1]
                    walls.ref[w, k, 2] = origin[w, k, 2]
            flags.rebuild[0] = 0
            stats[2] += 1
            stats[0] = 0
            stats[1] = 0

    @cuda.jit(cache=_CACHE, **({"max_registers": _MAXREG} if _MAXREG else {}))
    def k_forces(halt, sph, clu, nb, walls, worlds, prm, flags):
        if halt[0] != 0:
            return
        i = cuda.grid(1)
        if i >= sph.pos.shape[0]:
            return
        sphere_forces(i, i + 1, sph, clu, nb, walls, worlds, prm, flags)

    @cuda.jit(cache=_CACHE)
    def k_clumps(halt, clu, sph, walls, worlds, prm, flags):
        if halt[0] != 0:
            return
        c = cuda.grid(1)
        # the first threads also move their world's walls and clock (read next step only)
        if c == 0:
            flags.stats[3] += 1
        if c < worlds.dt.shape[0]:
            advance_world(c, worlds, walls, prm, flags)
        if c >= clu.pos.shape[0]:
            return
        clump_step(c, c + 1, clu, sph, worlds, prm, flags)

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


def device_layout(arrays: dict, n_spheres: int) -> None:
    """Put the slot arrays (sphere x neighbour/wall slot) in Fortran order, in place.

    A thread walks its own sphere's slots, so slot k of consecutive spheres should be
    adjacent (coalesced). Per-sphere and per-clump vectors stay row-major: their x, y, z
    share a cache line, which matters for the random gathers of neighbour data.
    """
    for name, arr in arrays.items():
        if arr.ndim >= 2 and name.split("_")[0] in ("nb", "w") and arr.shape[0] == n_spheres:
            arrays[name] = np.asfortranarray(arr)


def launch_plan(st, halt, n_clumps: int, n_worlds: int) -> list[tuple]:
    """One time step's kernel launches, in order: ``(kernel name, blocks, threads, args)``.

    Parameters
    ----------
    st : demcal.dem.containers.EngineState
        The packed device arrays (or host arrays in the device layout, to type the kernels).
    halt : array
        The (1,) int32 halt flag.
    n_clumps, n_worlds : int
        Clumps and worlds of the simulation (the clump kernel's threads).
    """
    prm = st.params
    nb = _blocks(st.spheres.pos.shape[0])
    nb_cap = st.nb_a.partner.shape[1]
    bcap = st.grid.bucket_members.shape[1]
    # a: the current neighbour list, b: the scratch one the build fills
    return [
        ("k_bin", nb, THREADS, (halt, st.spheres, st.clumps, st.grid, prm, st.flags)),
        ("k_search", nb, THREADS, (halt, st.spheres, st.clumps, st.grid, prm, st.nb_a,
                                   st.nb_b, st.walls, st.flags)),
        ("k_commit", nb, THREADS, (halt, st.flags, bcap, st.nb_b, st.nb_a, st.spheres,
                                   st.grid, prm)),
        ("k_finish", 1, 32, (halt, st.flags, nb_cap, bcap, st.walls)),
        ("k_forces", nb, THREADS, (halt, st.spheres, st.clumps, st.nb_a, st.walls, st.worlds,
                                   prm, st.flags)),
        ("k_clumps", _blocks(max(n_clumps, n_worlds)), THREADS,
         (halt, st.clumps, st.spheres, st.walls, st.worlds, prm, st.flags)),
    ]


class CudaBackend:
    """Runs a :class:`~demcal.dem.simulation.Simulation` on a CUDA GPU.

    Implements :class:`~demcal.dem.backends.Backend`. Device copies of every array live in
    :attr:`dev`; ``pull``/``push`` copy named arrays between host and device in place (so
    captured graphs stay valid). Buffer "a" is always the current neighbour list and "b" the
    scratch one (:attr:`parity` is always 0): a build fills "b" and ``commit`` copies it back.
    """

    #: the current neighbour list is always buffer "a" on the GPU
    parity = 0
    neighbor_side = "a"

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
        a = sim.arrays
        self._same_capacity()
        a["halt"] = np.zeros(1, dtype=np.int32)
        self._to_device_layout()
        a["bucket_count"][:] = 0
        self.upload_all()

    def _same_capacity(self, cap: int = 0) -> None:
        """Give both neighbour buffers one capacity (at least ``cap``), keeping their slots."""
        sim = self.sim
        a = sim.arrays
        old_caps = {side: a[f"nb_index_{side}"].shape[1] for side in ("a", "b")}
        cap = max(cap, *old_caps.values())
        for side, old_cap in old_caps.items():
            if old_cap == cap:
                continue
            count, index, hist, rhist = (a[k] for k in neighbor_keys(side))
            alloc_neighbors(a, side, sim.n_spheres, cap, sim.carry_rolling)
            a[f"nb_count_{side}"][:] = count
            a[f"nb_index_{side}"][:, :old_cap] = index
            a[f"nb_hist_{side}"][:, :old_cap] = hist
            if sim.carry_rolling:
                a[f"nb_rhist_{side}"][:, :old_cap] = rhist

    def _to_device_layout(self) -> None:
        device_layout(self.sim.arrays, self.sim.n_spheres)

    # ---------------------------------------------------------------- transfers
    def upload_all(self) -> None:
        self._to_device_layout()
        self.dev = {k: self.cuda.to_device(v, stream=self.stream)
                    for k, v in self.sim.arrays.items()}
        self.stream.synchronize()
        self._graph = None
        self._fresh = set(self.dev)

    def push_all(self, parity: int = 0) -> None:
        """The host replaced every array; a snapshot whose current list is "b" (``parity``
        1, from the CPU) has its buffers swapped, as "a" is the current one here."""
        a = self.sim.arrays
        if parity == 1:
            for ka, kb in zip(neighbor_keys("a"), neighbor_keys("b"), strict=True):
                a[ka], a[kb] = a[kb], a[ka]
        self._same_capacity()
        a.setdefault("halt", np.zeros(1, dtype=np.int32))
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
        sim = self.sim
        st = pack(self.dev, sim.params())
        for name, blocks, threads, args in launch_plan(st, self.dev["halt"], sim.n_clumps,
                                                       sim.n_worlds):
            getattr(self.k, name)[blocks, threads, self.stream](*args)

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
        with warnings.catch_warnings():  # once per chunk, not per launch
            # a small batch launches small grids by design (docs/gpu.md): numba's warning for
            # each new grid size would only clutter a user's output
            warnings.filterwarnings("ignore", message=".*will likely result in GPU under-util")
            self._run_steps(n_steps)

    def _run_steps(self, n_steps: int) -> None:
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
                self.grow(neighbors=int(a["stats"][0]), buckets=int(a["stats"][1]))
            elif executed != launched:
                raise RuntimeError(f"CUDA chunk ran {executed} of {launched} steps")

    def grow(self, neighbors: int = 0, buckets: int = 0) -> None:
        """Grow the neighbour or bucket arrays after an overflow (the needed sizes) and clear
        the halt flag; the chunk's remaining steps then run (nothing is lost)."""
        sim = self.sim
        a = sim.arrays
        self.pull(*[n for n in a if n in self.dev])
        if neighbors > a["nb_index_a"].shape[1]:
            self._same_capacity(int(neighbors * 1.25) + 4)
        if buckets > a["bucket_members"].shape[1]:
            alloc_buckets(a, int(buckets * 1.25) + 4)
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
