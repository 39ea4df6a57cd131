"""The CPU's sphere-sphere pass: each pair evaluated once, with the two-sided pass's sums bit
for bit.

The two-sided pass (:func:`demcal.dem.kernels.pair_contacts`, the GPU's: one thread per
sphere) evaluates every contact twice, once from each of its spheres, and sums each sphere's
contacts in the order of its neighbour slots, i.e. by ascending partner index. On the CPU a
thread runs a block of spheres ``lo`` to ``hi - 1``; per block (:func:`demcal.dem.backends.
cpu.force_pass`):

1. the slots whose partner lies *below the block* are evaluated from this side, as in the
   two-sided pass (``pair_contacts(lo, hi, lo, ...)``); they start each sphere's sums;
2. :func:`pair_contacts_half` walks the spheres in index order and evaluates each slot whose
   partner lies *above the sphere* once: the sphere's own side is summed in registers, the
   partner's side (a partner in the block) is added to the partner's sums in memory.

So each sphere sums its partners in ascending index, as the two-sided pass: those below the
block, then those of the block below it (added when they are evaluated, in index order), then
those above it. The same numbers in the same order: the same bits, for any thread count
(``tests/dem/test_half_pairs.py``). A pair inside a block is evaluated once; a pair across two
blocks from both sides, by each block's thread (every thread writes its own spheres' rows
only: no atomics). The benchmark's 1k bed steps ~13-15 % faster than with the two-sided
pass, the `standard` AoR test ~15 % on one thread (docs/engine.md).

Histories: a pair inside a block keeps its tangential (and type-C rolling) history in the
lower sphere's slot; the higher sphere's copy is not updated. :func:`sync_histories` copies
the lower copies into the higher ones at the end of every chunk
(:func:`demcal.dem.backends.cpu.run_chunk`), so that outside a chunk both copies agree as
after the two-sided pass (snapshots, the GPU, another thread count read either). One
exception, never read: a slot whose partner's clump was removed (left the domain) until the
next neighbour build drops it (the two-sided pass zeroes the active sphere's copy and leaves
the removed sphere's; here both take the lower sphere's).
"""

from __future__ import annotations

import math

from numba import njit

from demcal.dem.contact import (
    P_MU_R,
    ROLLING_A,
    ROLLING_C,
    ZERO3,
    contact_forces,
    pair_row,
    rolling_a,
)
from demcal.dem.kernels import ACTIVE, load2, load3, slot_at_least, store2, store3, zero3

__all__ = ["pair_contacts_half", "sync_histories"]


@njit(cache=True)
def _rolling_history(rhist, i, k, use_c):
    """The slot's type-C rolling history (``use_c``), else zeros."""
    if use_c:
        return load3(rhist, i, k)
    return ZERO3


@njit(cache=True)
def _store_rolling(rhist, i, k, value, use_c):
    """Store the slot's new type-C rolling history (``use_c``); nothing else."""
    if use_c:
        store3(rhist, i, k, value)


@njit(cache=True)
def _norm(v):
    """``|v|`` of a 3-tuple, as the two-sided pass takes a sphere's spin rate."""
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


@njit(cache=True, inline="always")
def _pair_response(sep, body_a, body_b, law, hists):
    """One contact of sphere *a* (the lower index) with sphere *b*, with the two-sided pass's
    arithmetic (:func:`demcal.dem.kernels.pair_contacts`) for the side of *a*.

    ``sep`` = ``((ex, ey, ez), dist2, r_a, r_b, r_a + r_b)``: from *a*'s centre to *b*'s (m),
    its square (m^2), the radii (m); ``body_a`` = ``(centre, clump centre, clump velocity,
    spin, spin rate, clump mass)`` of *a* (m, m, m/s, rad/s, rad/s, kg); ``body_b`` =
    ``(clump centre, clump velocity, spin, clump mass)`` of *b*; ``law`` = ``(pair row, dt,
    rolling model)``; ``hists`` = the slot's tangential and type-C rolling histories.

    Returns ``(contact radius, force on b, tangential history, type-A rolling torque on a,
    type-C rolling history, repulsive force, lever of a, lever of b, overlap)`` in the units
    of :func:`~demcal.dem.contact.contact_response`.
    """
    (dx, dy, dz), dist2, ra, rb, rsum = sep
    pos_a, com_a, vel_a, (wax, way, waz), om_a, ma = body_a
    com_b, vel_b, (wbx, wby, wbz), mb = body_b
    params, dt, model = law
    dist = math.sqrt(dist2)
    nx, ny, nz = dx / dist, dy / dist, dz / dist
    overlap = rsum - dist
    reff = ra * rb / rsum
    meff = ma * mb / (ma + mb)
    lever = ra - 0.5 * overlap
    cx, cy, cz = pos_a[0] + nx * lever, pos_a[1] + ny * lever, pos_a[2] + nz * lever
    pax, pay, paz = cx - com_a[0], cy - com_a[1], cz - com_a[2]
    pbx, pby, pbz = cx - com_b[0], cy - com_b[1], cz - com_b[2]
    vx = (vel_b[0] + wby * pbz - wbz * pby) - (vel_a[0] + way * paz - waz * pay)
    vy = (vel_b[1] + wbz * pbx - wbx * pbz) - (vel_a[1] + waz * pax - wax * paz)
    vz = (vel_b[2] + wbx * pby - wby * pbx) - (vel_a[2] + wax * pay - way * pax)
    arad, fb, xi, roll_c, frep = contact_forces(
        overlap, ((nx, ny, nz), (vx, vy, vz), (wbx - wax, wby - way, wbz - waz)), params,
        (reff, meff, dt, model), hists)
    roll_a = ZERO3
    if model == ROLLING_A and arad > 0.0:
        roll_a = rolling_a((wax, way, waz), om_a, (pax, pay, paz), params[P_MU_R], frep)
    return arad, fb, xi, roll_a, roll_c, frep, (pax, pay, paz), (pbx, pby, pbz), overlap


@njit(cache=True)
def _partner_rolling(spin, lever, mu_r, repulsive, model):
    """The type-A rolling torque on the partner (*b*) of a contact, as the two-sided pass takes
    it from *b*'s side (:func:`~demcal.dem.contact.rolling_a`); zeros for another model."""
    if model == ROLLING_A:
        return rolling_a(spin, _norm(spin), lever, mu_r, repulsive)
    return ZERO3


@njit(cache=True)
def _add_side(sums, sgn, fb, lever, rolls):
    """A sphere's sums ``(force, contact torque, type-A rolling torque)`` (9 floats) with one
    contact added as the two-sided pass adds it: ``sgn`` -1 for *a*, +1 for *b* (the force
    ``fb`` acts on *b*), ``lever`` from the sphere's clump centre to the contact point,
    ``rolls`` = ``(type-A torque on the sphere, type-C history, type C?)``."""
    fx, fy, fz, tx, ty, tz, rx, ry, rz = sums
    roll_a, roll_c, use_c = rolls
    px, py, pz = lever
    fix, fiy, fiz = sgn * fb[0], sgn * fb[1], sgn * fb[2]
    fx, fy, fz = fx + fix, fy + fiy, fz + fiz
    tx += py * fiz - pz * fiy
    ty += pz * fix - px * fiz
    tz += px * fiy - py * fix
    rx, ry, rz = rx - roll_a[0], ry - roll_a[1], rz - roll_a[2]
    if use_c:
        tx, ty, tz = tx + sgn * roll_c[0], ty + sgn * roll_c[1], tz + sgn * roll_c[2]
    return fx, fy, fz, tx, ty, tz, rx, ry, rz


@njit(cache=True)
def _store_sums(force, torque, roll, i, sums):
    """Write sphere ``i``'s sums (:func:`_add_side`) to the arrays ``sph.force``, ``torque``,
    ``roll`` (a container per contact would cost a reference count per array)."""
    store2(force, i, sums[0:3])
    store2(torque, i, sums[3:6])
    store2(roll, i, sums[6:9])


@njit(cache=True)
def _sums(force, torque, roll, i):
    """Sphere ``i``'s sums so far from the arrays ``sph.force``, ``torque``, ``roll``."""
    return load2(force, i) + load2(torque, i) + load2(roll, i)


@njit(cache=True)
def pair_contacts_half(lo, hi, st):
    """Step 2 of the module's pass for spheres ``lo`` to ``hi - 1`` (after ``pair_contacts(lo,
    hi, lo, ...)`` wrote their sums of the partners below ``lo``): every slot whose partner
    lies above its sphere, evaluated once; the sphere's side added to its sums, the partner's
    side to the partner's sums when the partner is below ``hi``. Updates the lower sphere's
    copy of each slot's histories. ``st`` = ``(sph, clu, nb, worlds, prm, flags)``.
    """
    sph, clu, nb, worlds, prm, flags = st
    s_pos, s_radius, s_clump, s_material = sph.pos, sph.radius, sph.clump, sph.material
    s_force, s_torque, s_roll = sph.force, sph.torque, sph.roll
    c_pos, c_veval, c_omega, c_mass = clu.pos, clu.veval, clu.omega, clu.mass
    c_state, c_world, w_active, w_dt = clu.state, clu.world, worlds.active, worlds.dt
    partner, found, hist, rhist = nb.partner, nb.found, nb.hist, nb.rhist
    margin, model, pair_params = prm.contact_margin, prm.rolling_model, worlds.pair_params
    overlap_flag, max_overlap = flags.overlap, prm.max_overlap_fraction
    use_c = model == ROLLING_C
    for i in range(lo, hi):
        ci = s_clump[i]
        w = c_world[ci]
        if c_state[ci] != ACTIVE or w_active[w] == 0:
            continue
        spin = load2(c_omega, ci)
        body_i = (load2(s_pos, i), load2(c_pos, ci), load2(c_veval, ci), spin, _norm(spin),
                  c_mass[ci])
        sums = _sums(s_force, s_torque, s_roll, i)
        ri = s_radius[i]
        n_slots = min(found[i], partner.shape[1])
        for k in range(n_slots):
            j = partner[i, k]
            if j < i:  # a partner below: its side came with the partner (or the first step)
                continue
            ex, ey, ez = (s_pos[j, 0] - body_i[0][0], s_pos[j, 1] - body_i[0][1],
                          s_pos[j, 2] - body_i[0][2])
            rj = s_radius[j]
            rsum = ri + rj
            dist2 = ex * ex + ey * ey + ez * ez
            reach = rsum + margin
            cj = s_clump[j] if dist2 < reach * reach else ci
            if dist2 >= reach * reach or c_state[cj] != ACTIVE:
                zero3(hist, i, k)
                if use_c:
                    zero3(rhist, i, k)
                continue
            params = pair_row(pair_params, w, s_material[i], s_material[j])
            body_j = (load2(c_pos, cj), load2(c_veval, cj), load2(c_omega, cj), c_mass[cj])
            arad, fb, xi, roll_a, roll_c, frep, lever_i, lever_j, overlap = _pair_response(
                ((ex, ey, ez), dist2, ri, rj, rsum), body_i, body_j,
                (params, w_dt[w], model),
                (load3(hist, i, k), _rolling_history(rhist, i, k, use_c)))
            if arad <= 0.0:
                zero3(hist, i, k)
                _store_rolling(rhist, i, k, ZERO3, use_c)
                continue
            if overlap > max_overlap * min(ri, rj):
                overlap_flag[w] = 1
            store3(hist, i, k, xi)
            _store_rolling(rhist, i, k, roll_c, use_c)
            sums = _add_side(sums, -1.0, fb, lever_i, (roll_a, roll_c, use_c))
            if j < hi:
                roll_j = _partner_rolling(body_j[2], lever_j, params[P_MU_R], frep, model)
                _store_sums(s_force, s_torque, s_roll, j,
                            _add_side(_sums(s_force, s_torque, s_roll, j), 1.0, fb, lever_j,
                                      (roll_j, roll_c, use_c)))
        _store_sums(s_force, s_torque, s_roll, i, sums)


@njit(cache=True)
def sync_histories(lo, hi, nb, use_c):
    """For spheres ``lo`` to ``hi - 1``: each slot whose partner lies below the sphere takes
    the partner's copy of the pair's histories (type-C rolling ones when ``use_c``), the copy
    :func:`pair_contacts_half` keeps. Writes only these spheres' rows."""
    partner, found, hist, rhist = nb.partner, nb.found, nb.hist, nb.rhist
    cap = partner.shape[1]
    for m in range(lo, hi):
        for k in range(min(found[m], cap)):
            i = partner[m, k]
            if i >= m:
                break
            q = slot_at_least(partner, i, min(found[i], cap), m)  # m is in i's row
            store3(hist, m, k, load3(hist, i, q))
            if use_c:
                store3(rhist, m, k, load3(rhist, i, q))
