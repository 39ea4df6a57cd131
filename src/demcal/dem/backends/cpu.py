"""CPU backend: numba ``prange`` launchers of the shared kernel bodies and the chunk loop.

:func:`run_chunk` runs many time steps inside one compiled function (no Python per step). Each
parallel loop writes only its own rows, so results are bitwise identical for any thread count.
Every launcher takes the state containers of :mod:`demcal.dem.containers`.
"""

from __future__ import annotations

# OpenMP's default wait: an idle worker spins briefly (GOMP_SPINCOUNT, 300k spins, a few ms)
# and then sleeps. A step's parallel loops follow each other within microseconds, so the
# workers are still spinning when the next one starts; OMP_WAIT_POLICY=PASSIVE (sleep at once)
# cost ~50 us per loop to wake them (1k bed, 2 threads: 930-1006 vs 790-820 us per step), and
# a worker that spins a few ms after a run takes no core from anything else for long.
from numba import njit, prange

from demcal.dem.half_pairs import pair_contacts_half, sync_histories
from demcal.dem.kernels import (
    ACTIVE,
    advance_world,
    cell_bucket,
    cell_coords,
    cell_key,
    clump_step,
    neighbor_search,
    pair_contacts,
    wall_candidates,
    wall_contacts,
)

#: fewest elements per call of a kernel body
BLOCK = 64


@njit(cache=True)
def block_size(n, threads):
    """Elements per call of a kernel body: one block per thread (at least ``BLOCK``).

    A call costs several microseconds when it passes the state containers (numba counts
    references to each of their arrays), so a pass makes as few calls as it has threads;
    ``prange`` schedules statically, so the load is shared as with small blocks. Each element
    is independent of the others: the results do not depend on the blocks.
    """
    return max(BLOCK, (n + threads - 1) // threads)

STATUS_OK = 0
STATUS_NEIGHBOR_OVERFLOW = 1
STATUS_BUCKET_OVERFLOW = 2


@njit(cache=True)
def bin_spheres(sph, clu, grid, prm):
    """Bin active spheres into the hash grid in index order (and remember each sphere's
    position of the build in ``sph.ref``); return the fullest bucket's count."""
    bucket_count = grid.bucket_count
    bucket_members = grid.bucket_members
    s_pos = sph.pos
    s_ref = sph.ref
    s_cellkey = sph.cellkey
    bucket_count[:] = 0
    bcap = bucket_members.shape[1]
    fullest = 0
    for i in range(s_pos.shape[0]):
        c = sph.clump[i]
        s_ref[i, 0] = s_pos[i, 0]
        s_ref[i, 1] = s_pos[i, 1]
        s_ref[i, 2] = s_pos[i, 2]
        if clu.state[c] != ACTIVE:
            s_cellkey[i] = -1
            continue
        w = clu.world[c]
        ix, iy, iz = cell_coords(w, s_pos[i, 0], s_pos[i, 1], s_pos[i, 2], grid.lo, prm.inv_cell)
        s_cellkey[i] = cell_key(w, ix, iy, iz)
        b = cell_bucket(w, ix, iy, iz, prm.mask)
        n = bucket_count[b]
        if n < bcap:
            bucket_members[b, n] = i
        bucket_count[b] = n + 1
        if n + 1 > fullest:
            fullest = n + 1
    return fullest


@njit(parallel=True, cache=True)
def search_pass(sph, clu, grid, prm, old, new):
    """Neighbour search for every sphere (list ``new``, history carried over from ``old``);
    returns the largest neighbour count found."""
    n = sph.pos.shape[0]
    size = block_size(n, prm.threads)
    n_blocks = (n + size - 1) // size
    for blk in prange(n_blocks):
        neighbor_search(blk * size, min(blk * size + size, n), sph, clu, grid, prm, old, new)
    most = 0
    for i in range(n):
        if new.found[i] > most:
            most = new.found[i]
    return most


@njit(parallel=True, cache=True)
def candidates_pass(sph, clu, walls, prm):
    """Wall candidates of every sphere (:func:`~demcal.dem.kernels.wall_candidates`)."""
    n = sph.pos.shape[0]
    size = block_size(n, prm.threads)
    n_blocks = (n + size - 1) // size
    for blk in prange(n_blocks):
        wall_candidates(blk * size, min(blk * size + size, n), sph, clu, walls, prm)


@njit(parallel=True, cache=True)
def force_pass(sph, clu, nb, walls, worlds, prm, flags):
    """Contact forces on every sphere: the sums of :func:`~demcal.dem.kernels.sphere_forces`
    bit for bit, with each pair inside a block evaluated once (:mod:`demcal.dem.half_pairs`:
    the partners below the block from this side, those above each sphere once, then the
    walls). The higher sphere's copy of such a pair's histories is left for
    :func:`history_sync_pass`."""
    n = sph.pos.shape[0]
    size = block_size(n, prm.threads)
    n_blocks = (n + size - 1) // size
    for blk in prange(n_blocks):
        lo = blk * size
        hi = min(lo + size, n)
        pair_contacts(lo, hi, lo, sph, clu, nb, worlds, prm, flags)
        pair_contacts_half(lo, hi, (sph, clu, nb, worlds, prm, flags))
        wall_contacts(lo, hi, sph, clu, walls, worlds, prm, flags)


@njit(parallel=True, cache=True)
def history_sync_pass(nb, prm):
    """Both copies of every pair's histories equal again (:func:`~demcal.dem.half_pairs.
    sync_histories`), as after the two-sided pass."""
    n = nb.found.shape[0]
    size = block_size(n, prm.threads)
    n_blocks = (n + size - 1) // size
    for blk in prange(n_blocks):
        sync_histories(blk * size, min(blk * size + size, n), nb, prm.carry_rolling)


@njit(parallel=True, cache=True)
def clump_pass(clu, sph, worlds, prm, flags):
    """One step of every clump (:func:`~demcal.dem.kernels.clump_step`)."""
    n = clu.pos.shape[0]
    size = block_size(n, prm.threads)
    n_blocks = (n + size - 1) // size
    for blk in prange(n_blocks):
        clump_step(blk * size, min(blk * size + size, n), clu, sph, worlds, prm, flags)


@njit(cache=True)
def rebuild(parity, st):
    """Build the neighbour list into the scratch buffer and renew the wall candidates.

    Returns ``(status, parity)``: on an overflow the buffers are left as they were (the
    needed size is in ``stats``), else the scratch buffer becomes the current one.
    """
    sph = st.spheres
    clu = st.clumps
    prm = st.params
    stats = st.flags.stats
    fullest = bin_spheres(sph, clu, st.grid, prm)
    if fullest > st.grid.bucket_members.shape[1]:
        stats[1] = fullest
        return STATUS_BUCKET_OVERFLOW, parity
    # the two buffers swap roles at each build: a -> b when parity is 0, b -> a when 1
    cur = st.nb_a if parity == 0 else st.nb_b
    nxt = st.nb_b if parity == 0 else st.nb_a
    most = search_pass(sph, clu, st.grid, prm, cur, nxt)
    if most > nxt.partner.shape[1]:
        stats[0] = most
        return STATUS_NEIGHBOR_OVERFLOW, parity
    candidates_pass(sph, clu, st.walls, prm)
    st.walls.ref[:] = st.walls.origin
    st.flags.rebuild[0] = 0
    stats[2] += 1
    return STATUS_OK, 1 - parity


@njit(cache=True)
def run_chunk(n_steps, parity, st):
    """Run up to ``n_steps`` steps of the state ``st`` (an
    :class:`~demcal.dem.containers.EngineState`). Returns ``(steps_done, status, parity)``.

    ``parity`` says which neighbour buffer (``st.nb_a``: 0, ``st.nb_b``: 1) is current. On a
    neighbour or bucket overflow the function returns before the step's forces are
    computed, with the needed size in ``stats`` (0: largest neighbour count, 1: fullest
    bucket); the host grows the arrays and calls again, losing nothing. ``stats[2]`` counts
    neighbour rebuilds. Before it returns, both copies of every pair's histories agree
    (:func:`history_sync_pass`): outside a chunk the state is that of the two-sided pass.
    """
    n_worlds = st.worlds.dt.shape[0]
    for step in range(n_steps):
        if st.flags.rebuild[0] != 0:
            status, parity = rebuild(parity, st)
            if status != STATUS_OK:
                history_sync_pass(st.nb_a if parity == 0 else st.nb_b, st.params)
                return step, status, parity
        nb = st.nb_a if parity == 0 else st.nb_b
        force_pass(st.spheres, st.clumps, nb, st.walls, st.worlds, st.params, st.flags)
        clump_pass(st.clumps, st.spheres, st.worlds, st.params, st.flags)
        for w in range(n_worlds):
            advance_world(w, st.worlds, st.walls, st.params, st.flags)
    history_sync_pass(st.nb_a if parity == 0 else st.nb_b, st.params)
    return n_steps, STATUS_OK, parity
