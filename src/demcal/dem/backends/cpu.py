"""CPU backend: numba ``prange`` launchers of the shared kernel bodies and the chunk loop.

:func:`run_chunk` runs many time steps inside one compiled function (no Python per step). Each
parallel loop writes only its own rows, so results are bitwise identical for any thread count.
"""

from __future__ import annotations

# OpenMP's default wait: an idle worker spins briefly (GOMP_SPINCOUNT, 300k spins, a few ms)
# and then sleeps. A step's parallel loops follow each other within microseconds, so the
# workers are still spinning when the next one starts; OMP_WAIT_POLICY=PASSIVE (sleep at once)
# cost ~50 us per loop to wake them (1k bed, 2 threads: 930-1006 vs 790-820 us per step), and
# a worker that spins a few ms after a run takes no core from anything else for long.
from numba import njit, prange

from demcal.dem.kernels import (
    ACTIVE,
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

#: elements per call of a kernel body (amortises the per-call cost of passing ~30 arrays)
BLOCK = 64

STATUS_OK = 0
STATUS_NEIGHBOR_OVERFLOW = 1
STATUS_BUCKET_OVERFLOW = 2


@njit(cache=True)
def bin_spheres(
    s_pos,
    s_clump,
    c_state,
    c_world,
    grid_lo,
    inv_cell,
    bucket_count,
    bucket_members,
    mask,
    s_cellkey,
    s_ref,
):
    """Bin active spheres into the hash grid in index order; return the fullest bucket."""
    bucket_count[:] = 0
    bcap = bucket_members.shape[1]
    fullest = 0
    for i in range(s_pos.shape[0]):
        c = s_clump[i]
        s_ref[i, 0] = s_pos[i, 0]
        s_ref[i, 1] = s_pos[i, 1]
        s_ref[i, 2] = s_pos[i, 2]
        if c_state[c] != ACTIVE:
            s_cellkey[i] = -1
            continue
        w = c_world[c]
        ix, iy, iz = cell_coords(w, s_pos[i, 0], s_pos[i, 1], s_pos[i, 2], grid_lo, inv_cell)
        s_cellkey[i] = cell_key(w, ix, iy, iz)
        b = cell_bucket(w, ix, iy, iz, mask)
        n = bucket_count[b]
        if n < bcap:
            bucket_members[b, n] = i
        bucket_count[b] = n + 1
        if n + 1 > fullest:
            fullest = n + 1
    return fullest


@njit(parallel=True, cache=True)
def search_pass(
    s_pos,
    s_radius,
    s_clump,
    c_state,
    c_world,
    s_cellkey,
    grid_lo,
    inv_cell,
    bucket_count,
    bucket_members,
    mask,
    extra,
    old_count,
    old_index,
    old_hist,
    old_rhist,
    new_count,
    new_index,
    new_hist,
    new_rhist,
    carry_rolling,
):
    """Neighbour search for every sphere; returns the largest neighbour count found."""
    n = s_pos.shape[0]
    n_blocks = (n + BLOCK - 1) // BLOCK
    for blk in prange(n_blocks):
        neighbor_search(
            blk * BLOCK,
            min(blk * BLOCK + BLOCK, n),
            s_pos,
            s_radius,
            s_clump,
            c_state,
            c_world,
            s_cellkey,
            grid_lo,
            inv_cell,
            bucket_count,
            bucket_members,
            mask,
            extra,
            old_count,
            old_index,
            old_hist,
            old_rhist,
            new_count,
            new_index,
            new_hist,
            new_rhist,
            carry_rolling,
        )
    most = 0
    for i in range(n):
        if new_count[i] > most:
            most = new_count[i]
    return most


@njit(parallel=True, cache=True)
def candidates_pass(
    s_pos,
    s_radius,
    s_clump,
    c_state,
    c_world,
    wall_type,
    wall_origin,
    wall_geom,
    extra,
    s_wall_near,
    w_hist,
    w_rhist,
    s_wall_force,
    carry_rolling,
):
    """Wall candidates of every sphere (:func:`~demcal.dem.kernels.wall_candidates`)."""
    n = s_pos.shape[0]
    n_blocks = (n + BLOCK - 1) // BLOCK
    for blk in prange(n_blocks):
        wall_candidates(
            blk * BLOCK,
            min(blk * BLOCK + BLOCK, n),
            s_pos,
            s_radius,
            s_clump,
            c_state,
            c_world,
            wall_type,
            wall_origin,
            wall_geom,
            extra,
            s_wall_near,
            w_hist,
            w_rhist,
            s_wall_force,
            carry_rolling,
        )


@njit(parallel=True, cache=True)
def force_pass(
    s_pos,
    s_radius,
    s_clump,
    s_material,
    c_pos,
    c_veval,
    c_omega,
    c_mass,
    c_world,
    c_state,
    nb_count,
    nb_index,
    nb_hist,
    nb_rhist,
    wall_type,
    wall_origin,
    wall_geom,
    wall_vel,
    wall_material,
    w_hist,
    w_rhist,
    s_wall_near,
    pair_params,
    world_dt,
    world_active,
    rolling_model,
    contact_margin,
    max_overlap_fraction,
    s_force,
    s_torque,
    s_roll,
    s_wall_force,
    flag_overlap,
):
    n = s_pos.shape[0]
    n_blocks = (n + BLOCK - 1) // BLOCK
    for blk in prange(n_blocks):
        sphere_forces(
            blk * BLOCK,
            min(blk * BLOCK + BLOCK, n),
            s_pos,
            s_radius,
            s_clump,
            s_material,
            c_pos,
            c_veval,
            c_omega,
            c_mass,
            c_world,
            c_state,
            nb_count,
            nb_index,
            nb_hist,
            nb_rhist,
            wall_type,
            wall_origin,
            wall_geom,
            wall_vel,
            wall_material,
            w_hist,
            w_rhist,
            s_wall_near,
            pair_params,
            world_dt,
            world_active,
            rolling_model,
            contact_margin,
            max_overlap_fraction,
            s_force,
            s_torque,
            s_roll,
            s_wall_force,
            flag_overlap,
        )


@njit(parallel=True, cache=True)
def clump_pass(
    c_pos,
    c_quat,
    c_vel,
    c_veval,
    c_angmom,
    c_omega,
    c_mass,
    c_inertia,
    c_world,
    c_state,
    c_first,
    c_count,
    s_offset,
    s_pos,
    s_ref,
    s_force,
    s_torque,
    s_roll,
    world_dt,
    world_gravity,
    world_active,
    world_lo,
    world_hi,
    half_skin,
    flag_rebuild,
    flag_nan,
):
    n = c_pos.shape[0]
    n_blocks = (n + BLOCK - 1) // BLOCK
    for blk in prange(n_blocks):
        clump_step(
            blk * BLOCK,
            min(blk * BLOCK + BLOCK, n),
            c_pos,
            c_quat,
            c_vel,
            c_veval,
            c_angmom,
            c_omega,
            c_mass,
            c_inertia,
            c_world,
            c_state,
            c_first,
            c_count,
            s_offset,
            s_pos,
            s_ref,
            s_force,
            s_torque,
            s_roll,
            world_dt,
            world_gravity,
            world_active,
            world_lo,
            world_hi,
            half_skin,
            flag_rebuild,
            flag_nan,
        )


@njit(cache=True)
def run_chunk(
    n_steps,
    parity,
    s_pos,
    s_ref,
    s_radius,
    s_clump,
    s_material,
    s_offset,
    s_cellkey,
    s_force,
    s_torque,
    s_roll,
    s_wall_force,
    c_pos,
    c_quat,
    c_vel,
    c_veval,
    c_angmom,
    c_omega,
    c_mass,
    c_inertia,
    c_world,
    c_state,
    c_first,
    c_count,
    nb_count_a,
    nb_index_a,
    nb_hist_a,
    nb_rhist_a,
    nb_count_b,
    nb_index_b,
    nb_hist_b,
    nb_rhist_b,
    bucket_count,
    bucket_members,
    mask,
    grid_lo,
    inv_cell,
    extra,
    wall_extra,
    half_skin,
    wall_type,
    wall_origin,
    wall_geom,
    wall_vel,
    wall_material,
    w_hist,
    w_rhist,
    s_wall_near,
    wall_ref,
    pair_params,
    world_dt,
    world_gravity,
    world_active,
    world_lo,
    world_hi,
    world_time,
    world_steps,
    rolling_model,
    contact_margin,
    max_overlap_fraction,
    flag_rebuild,
    flag_nan,
    flag_overlap,
    stats,
):
    """Run up to ``n_steps`` steps. Returns ``(steps_done, status, parity)``.

    ``parity`` says which neighbour buffer (a: 0, b: 1) is current. On a neighbour or bucket
    overflow the function returns before the step's forces are computed, with the needed
    size in ``stats`` (0: largest neighbour count, 1: fullest bucket); the host grows the
    arrays and calls again, losing nothing. ``stats[2]`` counts neighbour rebuilds.
    """
    carry_rolling = rolling_model == ROLLING_C
    n_worlds = world_dt.shape[0]
    for step in range(n_steps):
        if flag_rebuild[0] != 0:
            fullest = bin_spheres(
                s_pos,
                s_clump,
                c_state,
                c_world,
                grid_lo,
                inv_cell,
                bucket_count,
                bucket_members,
                mask,
                s_cellkey,
                s_ref,
            )
            if fullest > bucket_members.shape[1]:
                stats[1] = fullest
                return step, STATUS_BUCKET_OVERFLOW, parity
            if parity == 0:
                most = search_pass(
                    s_pos,
                    s_radius,
                    s_clump,
                    c_state,
                    c_world,
                    s_cellkey,
                    grid_lo,
                    inv_cell,
                    bucket_count,
                    bucket_members,
                    mask,
                    extra,
                    nb_count_a,
                    nb_index_a,
                    nb_hist_a,
                    nb_rhist_a,
                    nb_count_b,
                    nb_index_b,
                    nb_hist_b,
                    nb_rhist_b,
                    carry_rolling,
                )
                cap = nb_index_b.shape[1]
            else:
                most = search_pass(
                    s_pos,
                    s_radius,
                    s_clump,
                    c_state,
                    c_world,
                    s_cellkey,
                    grid_lo,
                    inv_cell,
                    bucket_count,
                    bucket_members,
                    mask,
                    extra,
                    nb_count_b,
                    nb_index_b,
                    nb_hist_b,
                    nb_rhist_b,
                    nb_count_a,
                    nb_index_a,
                    nb_hist_a,
                    nb_rhist_a,
                    carry_rolling,
                )
                cap = nb_index_a.shape[1]
            if most > cap:
                stats[0] = most
                return step, STATUS_NEIGHBOR_OVERFLOW, parity
            parity = 1 - parity
            candidates_pass(
                s_pos,
                s_radius,
                s_clump,
                c_state,
                c_world,
                wall_type,
                wall_origin,
                wall_geom,
                wall_extra,
                s_wall_near,
                w_hist,
                w_rhist,
                s_wall_force,
                carry_rolling,
            )
            wall_ref[:] = wall_origin
            flag_rebuild[0] = 0
            stats[2] += 1
        if parity == 0:
            force_pass(
                s_pos,
                s_radius,
                s_clump,
                s_material,
                c_pos,
                c_veval,
                c_omega,
                c_mass,
                c_world,
                c_state,
                nb_count_a,
                nb_index_a,
                nb_hist_a,
                nb_rhist_a,
                wall_type,
                wall_origin,
                wall_geom,
                wall_vel,
                wall_material,
                w_hist,
                w_rhist,
                s_wall_near,
                pair_params,
                world_dt,
                world_active,
                rolling_model,
                contact_margin,
                max_overlap_fraction,
                s_force,
                s_torque,
                s_roll,
                s_wall_force,
                flag_overlap,
            )
        else:
            force_pass(
                s_pos,
                s_radius,
                s_clump,
                s_material,
                c_pos,
                c_veval,
                c_omega,
                c_mass,
                c_world,
                c_state,
                nb_count_b,
                nb_index_b,
                nb_hist_b,
                nb_rhist_b,
                wall_type,
                wall_origin,
                wall_geom,
                wall_vel,
                wall_material,
                w_hist,
                w_rhist,
                s_wall_near,
                pair_params,
                world_dt,
                world_active,
                rolling_model,
                contact_margin,
                max_overlap_fraction,
                s_force,
                s_torque,
                s_roll,
                s_wall_force,
                flag_overlap,
            )
        clump_pass(
            c_pos,
            c_quat,
            c_vel,
            c_veval,
            c_angmom,
            c_omega,
            c_mass,
            c_inertia,
            c_world,
            c_state,
            c_first,
            c_count,
            s_offset,
            s_pos,
            s_ref,
            s_force,
            s_torque,
            s_roll,
            world_dt,
            world_gravity,
            world_active,
            world_lo,
            world_hi,
            half_skin,
            flag_rebuild,
            flag_nan,
        )
        for w in range(n_worlds):
            advance_world(w, world_dt, world_active, world_time, world_steps, wall_origin,
                          wall_vel, wall_ref, half_skin, flag_rebuild)
    return n_steps, STATUS_OK, parity
