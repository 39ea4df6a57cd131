"""Per-element kernel bodies shared by the CPU and CUDA backends.

Each function here works on ONE element (a sphere or a clump) and writes only that element's
rows, so a launcher may run them in any order or in parallel:

- :func:`sphere_forces` gathers the contact forces on sphere ``i`` from its neighbour slots and
  its world's walls. Each pair is evaluated from both sides with identical arithmetic in a
  canonical order (lower sphere index first), so the two sides agree bitwise and no atomics
  are needed; results do not depend on the thread count. (This is the GPU's pass; the CPU
  evaluates each pair once, :mod:`demcal.dem.half_pairs`, with the same sums bit for bit.)
- :func:`clump_step` sums a clump's sphere forces, integrates it (leapfrog for translation,
  symmetric free-rotor splitting for rotation) and places its spheres, in three parts
  (:func:`clump_kick`, :func:`clump_rotate`, :func:`clump_place`).
- :func:`neighbor_search` fills sphere ``i``'s neighbour slots from the hash grid, sorts them
  by neighbour index and carries the contact history over from the previous list;
  :func:`wall_candidates` marks, at the same builds, the walls each sphere may reach before
  the next build (a Verlet list for walls: the force pass then skips the rest).

Every body takes the state containers of :mod:`demcal.dem.containers` (``sph``: Spheres,
``clu``: Clumps, ``nb``: Neighbors, ``walls``, ``worlds``, ``prm``: Params, ``flags``) and a
range ``lo`` to ``hi - 1`` of elements (the CPU launchers pass blocks, CUDA one element per
thread). The contact laws are in :mod:`demcal.dem.contact`; the launchers live in
:mod:`demcal.dem.backends`.
"""

from __future__ import annotations

import math

from numba import njit

from demcal.dem.contact import (  # noqa: F401 (re-exported: the launchers' imports)
    N_PAIR_FIELDS,
    P_BETA,
    P_ESTAR,
    P_GAMMA,
    P_GSTAR,
    P_MU_R,
    P_MU_S,
    ROLLING_A,
    ROLLING_C,
    ROLLING_NONE,
    ZERO3,
    contact_response,
    pair_row,
)
from demcal.dem.walls import (
    WALL_NONE,
    closest_point,
    spin_relative_to,
    surely_beyond,
    surface_velocity,
)

#: most walls per world: a sphere's wall candidates are the bits of one int64
MAX_WALLS = 64

# clump states
INACTIVE = 0
ACTIVE = 1
REMOVED = 2

# cell-key packing
CELL_BITS = 16
CELL_MAX = (1 << CELL_BITS) - 1


@njit(cache=True)
def quat_rotate(qw, qx, qy, qz, vx, vy, vz):
    """Rotate vector v by unit quaternion q (body -> space)."""
    # t = 2 q_vec x v ; v' = v + w t + q_vec x t
    tx = 2.0 * (qy * vz - qz * vy)
    ty = 2.0 * (qz * vx - qx * vz)
    tz = 2.0 * (qx * vy - qy * vx)
    return (vx + qw * tx + (qy * tz - qz * ty),
            vy + qw * ty + (qz * tx - qx * tz),
            vz + qw * tz + (qx * ty - qy * tx))


@njit(cache=True)
def quat_rotate_inv(qw, qx, qy, qz, vx, vy, vz):
    """Rotate vector v by the inverse of unit quaternion q (space -> body)."""
    return quat_rotate(qw, -qx, -qy, -qz, vx, vy, vz)


@njit(cache=True)
def quat_mul(aw, ax, ay, az, bw, bx, by, bz):
    """Hamilton product a (x) b."""
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


@njit(cache=True)
def _rotor_substep(axis, h, l0, l1, l2, i0, i1, i2, qw, qx, qy, qz):
    """Rotor flow of the term L_k^2/(2 I_k) over time h (body-frame momentum), Cayley form.

    The body turns about its axis k, and its body-frame momentum by the opposite angle, through
    ``phi = 2 atan(theta/2)`` with ``theta = L_k h / I_k`` (``phi = theta + O(theta^3)``). Each
    sub-step is an exact rotation, so the space-frame momentum is conserved exactly and the
    scheme stays time reversible, with two divisions and one square root instead of four
    trigonometric calls.
    """
    if axis == 0:
        t = 0.5 * l0 / i0 * h
    elif axis == 1:
        t = 0.5 * l1 / i1 * h
    else:
        t = 0.5 * l2 / i2 * h
    inv = 1.0 / (1.0 + t * t)
    c = (1.0 - t * t) * inv
    s = 2.0 * t * inv
    hn = 1.0 / math.sqrt(1.0 + t * t)
    hw = hn
    hs = t * hn
    if axis == 0:
        l1, l2 = c * l1 + s * l2, -s * l1 + c * l2
        return l0, l1, l2, *quat_mul(qw, qx, qy, qz, hw, hs, 0.0, 0.0)
    if axis == 1:
        l2, l0 = c * l2 + s * l0, -s * l2 + c * l0
        return l0, l1, l2, *quat_mul(qw, qx, qy, qz, hw, 0.0, hs, 0.0)
    l0, l1 = c * l0 + s * l1, -s * l0 + c * l1
    return l0, l1, l2, *quat_mul(qw, qx, qy, qz, hw, 0.0, 0.0, hs)


@njit(cache=True)
def free_rotation(dt, l0, l1, l2, i0, i1, i2, qw, qx, qy, qz):
    """Advance orientation q and body-frame momentum by a symmetric splitting over dt.

    Sequence x(dt/2) y(dt/2) z(dt) y(dt/2) x(dt/2) of exact single-axis rotor flows
    (Dullweber, Leimkuhler & McLachlan 1997): symplectic, time reversible, conserves the
    space-frame angular momentum exactly.
    """
    h = 0.5 * dt
    l0, l1, l2, qw, qx, qy, qz = _rotor_substep(0, h, l0, l1, l2, i0, i1, i2, qw, qx, qy, qz)
    l0, l1, l2, qw, qx, qy, qz = _rotor_substep(1, h, l0, l1, l2, i0, i1, i2, qw, qx, qy, qz)
    l0, l1, l2, qw, qx, qy, qz = _rotor_substep(2, dt, l0, l1, l2, i0, i1, i2, qw, qx, qy, qz)
    l0, l1, l2, qw, qx, qy, qz = _rotor_substep(1, h, l0, l1, l2, i0, i1, i2, qw, qx, qy, qz)
    l0, l1, l2, qw, qx, qy, qz = _rotor_substep(0, h, l0, l1, l2, i0, i1, i2, qw, qx, qy, qz)
    norm = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
    return l0, l1, l2, qw / norm, qx / norm, qy / norm, qz / norm


@njit(cache=True)
def zero3(arr, i, k):
    """Set ``arr[i, k, 0:3]`` to zero (a slot's 3-vector: history, rolling spring, force)."""
    arr[i, k, 0] = 0.0
    arr[i, k, 1] = 0.0
    arr[i, k, 2] = 0.0


@njit(cache=True)
def load3(arr, i, k):
    """``arr[i, k, 0:3]`` as a tuple (a slot's 3-vector)."""
    return arr[i, k, 0], arr[i, k, 1], arr[i, k, 2]


@njit(cache=True)
def load2(arr, i):
    """``arr[i, 0:3]`` as a tuple."""
    return arr[i, 0], arr[i, 1], arr[i, 2]


@njit(cache=True)
def store2(arr, i, v):
    """Write the 3-vector ``v`` into ``arr[i, 0:3]``."""
    arr[i, 0] = v[0]
    arr[i, 1] = v[1]
    arr[i, 2] = v[2]


@njit(cache=True)
def store3(arr, i, k, v):
    """Write the 3-vector ``v`` into ``arr[i, k, 0:3]``."""
    arr[i, k, 0] = v[0]
    arr[i, k, 1] = v[1]
    arr[i, k, 2] = v[2]


@njit(cache=True)
def slot_at_least(partner, i, n_slots, j):
    """The first of sphere ``i``'s ``n_slots`` neighbour slots (sorted by partner) whose
    partner is ``>= j`` (``n_slots`` if none): binary search in row ``i`` of ``partner``."""
    lo = 0
    hi = n_slots
    while lo < hi:
        mid = (lo + hi) >> 1
        if partner[i, mid] < j:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True, inline="always")  # numba IR inlining: no call per contact
def zero_sums(force, torque, roll, i):
    """Zero sphere ``i``'s force, torque and rolling sums."""
    store2(force, i, ZERO3)
    store2(torque, i, ZERO3)
    store2(roll, i, ZERO3)


@njit(cache=True, inline="always")  # numba IR inlining: no call per contact
def canonical_pair(i, j, radii, e, clumps):
    """Orient the pair (i, j) canonically: a = the lower index, b = the higher.

    ``radii``, ``e`` (from i to j) and ``clumps`` are i's and j's; returns
    ``(a, b, ra, rb, d, ca, cb)`` with d = b - a. It is the same on both sides bitwise
    (x - y == -(y - x) in IEEE arithmetic), so the two sides of a pair see one contact.
    """
    ri, rj = radii
    ci, cj = clumps
    if i < j:
        return i, j, ri, rj, e, ci, cj
    return j, i, rj, ri, (-e[0], -e[1], -e[2]), cj, ci


@njit(cache=True, inline="always")  # numba IR inlining: no call per contact
def relative_velocity(c_pos, c_veval, c_omega, clumps, point):
    """The levers from clumps a and b to the contact ``point`` and the velocity of b's
    material point there relative to a's, m/s: ``(pa, pb, v)``."""
    ca, cb = clumps
    cx, cy, cz = point
    pax = cx - c_pos[ca, 0]
    pay = cy - c_pos[ca, 1]
    paz = cz - c_pos[ca, 2]
    pbx = cx - c_pos[cb, 0]
    pby = cy - c_pos[cb, 1]
    pbz = cz - c_pos[cb, 2]
    wax = c_omega[ca, 0]
    way = c_omega[ca, 1]
    waz = c_omega[ca, 2]
    wbx = c_omega[cb, 0]
    wby = c_omega[cb, 1]
    wbz = c_omega[cb, 2]
    vx = (c_veval[cb, 0] + wby * pbz - wbz * pby) - (c_veval[ca, 0] + way * paz - waz * pay)
    vy = (c_veval[cb, 1] + wbz * pbx - wbx * pbz) - (c_veval[ca, 1] + waz * pax - wax * paz)
    vz = (c_veval[cb, 2] + wbx * pby - wby * pbx) - (c_veval[ca, 2] + wax * pay - way * pax)
    return (pax, pay, paz), (pbx, pby, pbz), (vx, vy, vz)


@njit(cache=True)
def pair_contacts(lo, hi, below, sph, clu, nb, worlds, prm, flags):
    """Sphere-sphere part of :func:`sphere_forces`: for spheres ``lo`` to ``hi - 1``, the
    forces of their neighbour slots with a partner below index ``below``, written to
    ``sph.force``/``torque``/``roll`` (zero for an inactive sphere); updates those slots'
    histories. ``below`` is the sphere count for every slot (the two-sided pass: CUDA), ``lo``
    for the partners below the block (the start of the CPU's one-sided pass,
    :mod:`demcal.dem.half_pairs`).

    Containers are passed per block, never per sphere: numba counts references to each array
    of a container at every call, which per sphere cost more than the contacts.
    """
    worlds_active = worlds.active
    clu_world = clu.world
    sph_force = sph.force
    sph_torque = sph.torque
    sph_roll = sph.roll
    worlds_dt = worlds.dt
    nb_count = nb.found
    flags_overlap = flags.overlap
    s_pos = sph.pos
    s_radius = sph.radius
    s_clump = sph.clump
    s_material = sph.material
    c_pos = clu.pos
    c_veval = clu.veval
    c_omega = clu.omega
    c_mass = clu.mass
    c_state = clu.state
    nb_index = nb.partner
    nb_hist = nb.hist
    nb_rhist = nb.rhist
    pair_params = worlds.pair_params
    contact_margin = prm.contact_margin
    rolling_model = prm.rolling_model
    use_c = rolling_model == ROLLING_C
    cap = nb_index.shape[1]
    if below == 0:  # no partner below index 0 (the CPU's first block): zero sums
        for i in range(lo, hi):
            zero_sums(sph_force, sph_torque, sph_roll, i)
        return
    for i in range(lo, hi):
        ci = s_clump[i]
        # no slot below ``below`` (most spheres of the CPU's blocks), or an inactive sphere
        if (nb_count[i] == 0 or nb_index[i, 0] >= below or c_state[ci] != ACTIVE
                or worlds_active[clu_world[ci]] == 0):
            zero_sums(sph_force, sph_torque, sph_roll, i)
            continue
        w = clu_world[ci]
        dt = worlds_dt[w]
        spin = load2(c_omega, ci)
        oix, oiy, oiz = spin
        om_i = math.sqrt(oix * oix + oiy * oiy + oiz * oiz)
        fx = 0.0
        fy = 0.0
        fz = 0.0
        tx = 0.0
        ty = 0.0
        tz = 0.0
        rx = 0.0
        ry = 0.0
        rz = 0.0
        pix = s_pos[i, 0]
        piy = s_pos[i, 1]
        piz = s_pos[i, 2]
        ri = s_radius[i]
        n_nb = nb_count[i]
        if n_nb > cap:
            n_nb = cap
        for k in range(n_nb):
            j = nb_index[i, k]
            if j >= below:  # the slots are sorted by partner
                break
            # from i to j; most candidates are out of reach and end here
            ex = s_pos[j, 0] - pix
            ey = s_pos[j, 1] - piy
            ez = s_pos[j, 2] - piz
            rj = s_radius[j]
            rsum = ri + rj
            dist2 = ex * ex + ey * ey + ez * ez
            reach = rsum + contact_margin
            cj = s_clump[j] if dist2 < reach * reach else ci
            if dist2 >= reach * reach or c_state[cj] != ACTIVE:
                zero3(nb_hist, i, k)
                if use_c:
                    zero3(nb_rhist, i, k)
                continue
            a, b, ra, rb, (dx, dy, dz), ca, cb = canonical_pair(
                i, j, (ri, rj), (ex, ey, ez), (ci, cj))
            dist = math.sqrt(dist2)
            nx = dx / dist
            ny = dy / dist
            nz = dz / dist
            overlap = rsum - dist
            reff = ra * rb / rsum
            ma = c_mass[ca]
            mb = c_mass[cb]
            meff = ma * mb / (ma + mb)
            # contact point and relative velocity (b w.r.t. a) there
            lever = ra - 0.5 * overlap
            point = (s_pos[a, 0] + nx * lever, s_pos[a, 1] + ny * lever,
                     s_pos[a, 2] + nz * lever)
            pa, pb, vel = relative_velocity(c_pos, c_veval, c_omega, (ca, cb), point)
            # this sphere's side: the force on b acts on i with sign sgn, lever p from i's clump
            sgn = 1.0 if i == b else -1.0
            px, py, pz = pb if i == b else pa
            params = pair_row(pair_params, w, s_material[a], s_material[b])
            arad, fb, xi, roll_a, roll_c = contact_response(
                overlap, (nx, ny, nz), vel, params,
                reff, meff, dt, load3(nb_hist, i, k), rolling_model, spin, om_i, (px, py, pz),
                (c_omega[cb, 0] - c_omega[ca, 0], c_omega[cb, 1] - c_omega[ca, 1],
                 c_omega[cb, 2] - c_omega[ca, 2]),
                load3(nb_rhist, i, k) if use_c else ZERO3)
            if arad <= 0.0:
                zero3(nb_hist, i, k)
                if use_c:
                    zero3(nb_rhist, i, k)
                continue
            if overlap > prm.max_overlap_fraction * min(ra, rb):
                flags_overlap[w] = 1
            store3(nb_hist, i, k, xi)
            fix = sgn * fb[0]
            fiy = sgn * fb[1]
            fiz = sgn * fb[2]
            fx += fix
            fy += fiy
            fz += fiz
            tx += py * fiz - pz * fiy
            ty += pz * fix - px * fiz
            tz += px * fiy - py * fix
            rx -= roll_a[0]
            ry -= roll_a[1]
            rz -= roll_a[2]
            if use_c:
                store3(nb_rhist, i, k, roll_c)
                tx += sgn * roll_c[0]
                ty += sgn * roll_c[1]
                tz += sgn * roll_c[2]
        store2(sph_force, i, (fx, fy, fz))
        store2(sph_torque, i, (tx, ty, tz))
        store2(sph_roll, i, (rx, ry, rz))


@njit(cache=True)
def wall_contacts(lo, hi, sph, clu, walls, worlds, prm, flags):
    """Sphere-wall part of :func:`sphere_forces`, after :func:`pair_contacts`: adds the
    forces of each sphere's candidate walls to ``sph.force``/``torque``/``roll``; updates the
    sphere-wall slots' histories and the forces on the walls (zero for an inactive sphere).
    """
    sph_clump = sph.clump
    clu_state = clu.state
    worlds_active = worlds.active
    clu_world = clu.world
    worlds_dt = worlds.dt
    sph_radius = sph.radius
    sph_pos = sph.pos
    sph_material = sph.material
    clu_pos = clu.pos
    sph_force = sph.force
    sph_torque = sph.torque
    sph_roll = sph.roll
    clu_veval = clu.veval
    clu_mass = clu.mass
    walls_near = walls.near
    flags_overlap = flags.overlap
    wall_type = walls.type
    wall_origin = walls.origin
    wall_geom = walls.geom
    wall_vel = walls.vel
    wall_omega = walls.omega
    wall_material = walls.material
    w_hist = walls.hist
    w_rhist = walls.rhist
    s_wall_force = walls.force
    c_omega = clu.omega
    pair_params = worlds.pair_params
    contact_margin = prm.contact_margin
    rolling_model = prm.rolling_model
    use_c = rolling_model == ROLLING_C
    n_walls = wall_type.shape[1]
    for i in range(lo, hi):
        ci = sph_clump[i]
        if clu_state[ci] != ACTIVE or worlds_active[clu_world[ci]] == 0:
            for k in range(n_walls):
                zero3(s_wall_force, i, k)
            continue
        near = walls_near[i]
        if near == 0:
            # no candidate wall: the sums of pair_contacts stand (most spheres)
            continue
        w = clu_world[ci]
        dt = worlds_dt[w]
        spin = load2(c_omega, ci)
        oix, oiy, oiz = spin
        om_i = math.sqrt(oix * oix + oiy * oiy + oiz * oiz)
        ri = sph_radius[i]
        pix = sph_pos[i, 0]
        piy = sph_pos[i, 1]
        piz = sph_pos[i, 2]
        mat_i = sph_material[i]
        com_ix = clu_pos[ci, 0]
        com_iy = clu_pos[ci, 1]
        com_iz = clu_pos[ci, 2]
        # the sums of pair_contacts go on (bitwise the sums of one pass over all contacts)
        fx, fy, fz = load2(sph_force, i)
        tx, ty, tz = load2(sph_torque, i)
        rx, ry, rz = load2(sph_roll, i)
        # walls of this world: wall = a, sphere = b
        vix = clu_veval[ci, 0]
        viy = clu_veval[ci, 1]
        viz = clu_veval[ci, 2]
        mass_i = clu_mass[ci]
        for k in range(n_walls):
            if ((near >> k) & 1) == 0:
                continue
            wt = wall_type[w, k]  # never WALL_NONE: wall_candidates marks none of those
            zero3(s_wall_force, i, k)
            # most spheres are far from most walls: a bound without square roots skips them
            far = surely_beyond(wt, wall_origin[w, k, 0], wall_origin[w, k, 1],
                                wall_origin[w, k, 2], wall_geom[w, k], pix, piy, piz,
                                ri + contact_margin)
            overlap = -contact_margin
            if not far:
                d, nx, ny, nz, _qx, _qy, _qz = closest_point(
                    wt, wall_origin[w, k, 0], wall_origin[w, k, 1], wall_origin[w, k, 2],
                    wall_geom[w, k], pix, piy, piz)
                overlap = ri - d
            if overlap <= -contact_margin:
                zero3(w_hist, i, k)
                if use_c:
                    zero3(w_rhist, i, k)
                continue
            lever = ri - 0.5 * overlap
            cx = pix - nx * lever
            cy = piy - ny * lever
            cz = piz - nz * lever
            px = cx - com_ix
            py = cy - com_iy
            pz = cz - com_iz
            # the wall's surface velocity at the contact point: its translation plus its
            # spin about its origin (a drum), so that a sphere carried round with a turning
            # wall has no tangential slip and a type-C spring no rolling on it
            wall_spin = load3(wall_omega, w, k)
            wvx, wvy, wvz = surface_velocity(
                load3(wall_vel, w, k), wall_spin,
                (cx - wall_origin[w, k, 0], cy - wall_origin[w, k, 1], cz - wall_origin[w, k, 2]))
            vx = vix + oiy * pz - oiz * py - wvx
            vy = viy + oiz * px - oix * pz - wvy
            vz = viz + oix * py - oiy * px - wvz
            params = pair_row(pair_params, w, wall_material[w, k], mat_i)
            # type A acts on the body's own spin (EDEM's law, as between spheres); type C on
            # the spin relative to the wall
            arad, fb, xi, roll_a, roll_c = contact_response(
                overlap, (nx, ny, nz), (vx, vy, vz), params,
                ri, mass_i, dt, load3(w_hist, i, k), rolling_model, spin, om_i, (px, py, pz),
                spin_relative_to(spin, wall_spin), load3(w_rhist, i, k) if use_c else ZERO3)
            if arad <= 0.0:
                zero3(w_hist, i, k)
                if use_c:
                    zero3(w_rhist, i, k)
                continue
            if overlap > prm.max_overlap_fraction * ri:
                flags_overlap[w] = 1
            store3(w_hist, i, k, xi)
            fix = fb[0]
            fiy = fb[1]
            fiz = fb[2]
            fx += fix
            fy += fiy
            fz += fiz
            tx += py * fiz - pz * fiy
            ty += pz * fix - px * fiz
            tz += px * fiy - py * fix
            s_wall_force[i, k, 0] = -fix
            s_wall_force[i, k, 1] = -fiy
            s_wall_force[i, k, 2] = -fiz
            rx -= roll_a[0]
            ry -= roll_a[1]
            rz -= roll_a[2]
            if use_c:
                store3(w_rhist, i, k, roll_c)
                tx += roll_c[0]
                ty += roll_c[1]
                tz += roll_c[2]
        store2(sph_force, i, (fx, fy, fz))
        store2(sph_torque, i, (tx, ty, tz))
        store2(sph_roll, i, (rx, ry, rz))


@njit(cache=True)
def sphere_forces(lo, hi, sph, clu, nb, walls, worlds, prm, flags):
    """Gather the contact forces and torques acting on spheres ``lo`` to ``hi - 1``.

    Writes ``sph.force[i]`` (N), ``sph.torque[i]`` (contact torque about the clump's centre
    of mass plus type-C rolling torque, N m), ``sph.roll[i]`` (type-A rolling torque, N m,
    applied with a no-reversal limit by :func:`clump_step`), the forces the sphere exerts on
    each of its world's walls ``walls.force[i, k]`` (N), and its contact histories (in the
    current neighbour list ``nb`` and in ``walls``): first the neighbour slots
    (:func:`pair_contacts`), then the walls (:func:`wall_contacts`). Only the walls in the
    sphere's candidate mask ``walls.near[i]`` (bit k: wall k, from :func:`wall_candidates` at
    the last neighbour build) are visited; the slots of the others are zero and stay so until
    the next build. Each contact's response comes from
    :func:`~demcal.dem.contact.contact_response`.
    """
    pair_contacts(lo, hi, sph.pos.shape[0], sph, clu, nb, worlds, prm, flags)
    wall_contacts(lo, hi, sph, clu, walls, worlds, prm, flags)


@njit(cache=True)
def wall_candidates(lo, hi, sph, clu, walls, prm):
    """Mark the walls each sphere may touch before the next neighbour build.

    Bit ``k`` of ``walls.near[i]`` is set when wall ``k`` comes within ``r_i + prm.wall_extra``
    of the sphere's centre (skin + contact margin; a conservative bound, see
    :func:`~demcal.dem.walls.surely_beyond`). The rebuild rule (a sphere or a wall moving half
    the skin since the build) keeps every unmarked wall out of reach until the next build, so
    its slots are zeroed here, as the force pass would zero them at every step, and the force
    pass skips it: the results are bitwise those of visiting every wall at every step.
    """
    clu_world = clu.world
    sph_radius = sph.radius
    walls_hist = walls.hist
    walls_rhist = walls.rhist
    walls_force = walls.force
    s_pos = sph.pos
    s_clump = sph.clump
    c_state = clu.state
    wall_type = walls.type
    wall_origin = walls.origin
    wall_geom = walls.geom
    s_wall_near = walls.near
    extra = prm.wall_extra
    carry_rolling = prm.carry_rolling
    n_walls = wall_type.shape[1]
    for i in range(lo, hi):
        ci = s_clump[i]
        if c_state[ci] != ACTIVE:
            s_wall_near[i] = 0
            continue
        w = clu_world[ci]
        reach = sph_radius[i] + extra
        near = 0
        for k in range(n_walls):
            wt = wall_type[w, k]
            if wt != WALL_NONE and not surely_beyond(
                    wt, wall_origin[w, k, 0], wall_origin[w, k, 1], wall_origin[w, k, 2],
                    wall_geom[w, k], s_pos[i, 0], s_pos[i, 1], s_pos[i, 2], reach):
                near |= 1 << k
                continue
            zero3(walls_hist, i, k)
            if carry_rolling:
                zero3(walls_rhist, i, k)
            zero3(walls_force, i, k)
        s_wall_near[i] = near


@njit(cache=True)
def clump_kick(lo, hi, clu, sph, worlds):
    """Step part 1 of clumps ``lo`` to ``hi - 1`` (see :func:`clump_step`): the contact
    forces and torques summed over each clump's spheres, the leapfrog kick and drift of its
    centre (``clu.vel``, ``clu.pos``, ``clu.veval`` final), and its angular momentum kicked by
    the torques and the limited type-A rolling torque, left in ``clu.scratch`` in the body
    frame with the torque the on-step estimate needs."""
    worlds_active = worlds.active
    clu_first = clu.first
    clu_count = clu.n_spheres
    clu_mass = clu.mass
    c_pos = clu.pos
    c_quat = clu.quat
    c_vel = clu.vel
    c_angmom = clu.angmom
    c_inertia = clu.inertia
    c_world = clu.world
    c_state = clu.state
    s_force = sph.force
    s_torque = sph.torque
    s_roll = sph.roll
    world_dt = worlds.dt
    world_gravity = worlds.gravity
    c_scratch = clu.scratch
    c_veval = clu.veval
    for c in range(lo, hi):
        if c_state[c] != ACTIVE:
            continue
        w = c_world[c]
        if worlds_active[w] == 0:
            continue
        dt = world_dt[w]
        first = clu_first[c]
        last = first + clu_count[c]
        fx = 0.0
        fy = 0.0
        fz = 0.0
        tx = 0.0
        ty = 0.0
        tz = 0.0
        jx = 0.0
        jy = 0.0
        jz = 0.0
        for s in range(first, last):
            fx += s_force[s, 0]
            fy += s_force[s, 1]
            fz += s_force[s, 2]
            tx += s_torque[s, 0]
            ty += s_torque[s, 1]
            tz += s_torque[s, 2]
            jx += s_roll[s, 0]
            jy += s_roll[s, 1]
            jz += s_roll[s, 2]
        m = clu_mass[c]
        ax_ = fx / m + world_gravity[w, 0]
        ay_ = fy / m + world_gravity[w, 1]
        az_ = fz / m + world_gravity[w, 2]
        vx = c_vel[c, 0] + ax_ * dt
        vy = c_vel[c, 1] + ay_ * dt
        vz = c_vel[c, 2] + az_ * dt
        x = c_pos[c, 0] + vx * dt
        y = c_pos[c, 1] + vy * dt
        z = c_pos[c, 2] + vz * dt
        qw = c_quat[c, 0]
        qx = c_quat[c, 1]
        qy = c_quat[c, 2]
        qz = c_quat[c, 3]
        i0 = c_inertia[c, 0]
        i1 = c_inertia[c, 1]
        i2 = c_inertia[c, 2]
        lx = c_angmom[c, 0] + tx * dt
        ly = c_angmom[c, 1] + ty * dt
        lz = c_angmom[c, 2] + tz * dt
        l0, l1, l2 = quat_rotate_inv(qw, qx, qy, qz, lx, ly, lz)
        scale = 0.0
        if jx != 0.0 or jy != 0.0 or jz != 0.0:
            j0, j1, j2 = quat_rotate_inv(qw, qx, qy, qz, jx * dt, jy * dt, jz * dt)
            lal = l0 * l0 / i0 + l1 * l1 / i1 + l2 * l2 / i2
            jal = j0 * l0 / i0 + j1 * l1 / i1 + j2 * l2 / i2
            # the impulse may at most stop the rotation (about the current angular velocity):
            # none if it would speed it up (a stale direction after a reversal or a stop),
            # scaled down if it would overshoot past zero, in full otherwise
            if jal >= 0.0:
                scale = 0.0
            elif lal + jal < 0.0:
                scale = -lal / jal
            else:
                scale = 1.0
            l0 += scale * j0
            l1 += scale * j1
            l2 += scale * j2
        c_veval[c, 0] = vx + 0.5 * dt * ax_
        c_veval[c, 1] = vy + 0.5 * dt * ay_
        c_veval[c, 2] = vz + 0.5 * dt * az_
        c_vel[c, 0] = vx
        c_vel[c, 1] = vy
        c_vel[c, 2] = vz
        c_pos[c, 0] = x
        c_pos[c, 1] = y
        c_pos[c, 2] = z
        c_scratch[c, 0] = l0
        c_scratch[c, 1] = l1
        c_scratch[c, 2] = l2
        c_scratch[c, 3] = tx + scale * jx
        c_scratch[c, 4] = ty + scale * jy
        c_scratch[c, 5] = tz + scale * jz


@njit(cache=True)
def free_rotation_pair(dt_a, dt_b, a, b):
    """:func:`free_rotation` of two bodies at once, bit for bit: ``a`` and ``b`` are
    ``(l0, l1, l2, i0, i1, i2, qw, qx, qy, qz)``. The two chains of divisions and square roots
    are independent, so the processor overlaps them (the clump pass's rotations ~20 % faster
    on one core than one body at a time)."""
    ha = 0.5 * dt_a
    hb = 0.5 * dt_b
    a0, a1, a2, ai0, ai1, ai2, aw, ax, ay, az = a
    b0, b1, b2, bi0, bi1, bi2, bw, bx, by, bz = b
    # the sequence of free_rotation, x y z y x, for both bodies in turn
    a0, a1, a2, aw, ax, ay, az = _rotor_substep(0, ha, a0, a1, a2, ai0, ai1, ai2, aw, ax, ay, az)
    b0, b1, b2, bw, bx, by, bz = _rotor_substep(0, hb, b0, b1, b2, bi0, bi1, bi2, bw, bx, by, bz)
    a0, a1, a2, aw, ax, ay, az = _rotor_substep(1, ha, a0, a1, a2, ai0, ai1, ai2, aw, ax, ay, az)
    b0, b1, b2, bw, bx, by, bz = _rotor_substep(1, hb, b0, b1, b2, bi0, bi1, bi2, bw, bx, by, bz)
    a0, a1, a2, aw, ax, ay, az = _rotor_substep(2, dt_a, a0, a1, a2, ai0, ai1, ai2, aw, ax, ay,
                                                az)
    b0, b1, b2, bw, bx, by, bz = _rotor_substep(2, dt_b, b0, b1, b2, bi0, bi1, bi2, bw, bx, by,
                                                bz)
    a0, a1, a2, aw, ax, ay, az = _rotor_substep(1, ha, a0, a1, a2, ai0, ai1, ai2, aw, ax, ay, az)
    b0, b1, b2, bw, bx, by, bz = _rotor_substep(1, hb, b0, b1, b2, bi0, bi1, bi2, bw, bx, by, bz)
    a0, a1, a2, aw, ax, ay, az = _rotor_substep(0, ha, a0, a1, a2, ai0, ai1, ai2, aw, ax, ay, az)
    b0, b1, b2, bw, bx, by, bz = _rotor_substep(0, hb, b0, b1, b2, bi0, bi1, bi2, bw, bx, by, bz)
    na = math.sqrt(aw * aw + ax * ax + ay * ay + az * az)
    nb = math.sqrt(bw * bw + bx * bx + by * by + bz * bz)
    return ((a0, a1, a2, aw / na, ax / na, ay / na, az / na),
            (b0, b1, b2, bw / nb, bx / nb, by / nb, bz / nb))


@njit(cache=True)
def _rotation_input(sc, inertia, q, c):
    """``(l0, l1, l2, i0, i1, i2, qw, qx, qy, qz)`` of clump ``c`` after its kick (from the
    arrays ``clu.scratch``, ``clu.inertia``, ``clu.quat``)."""
    return (sc[c, 0], sc[c, 1], sc[c, 2], inertia[c, 0], inertia[c, 1], inertia[c, 2],
            q[c, 0], q[c, 1], q[c, 2], q[c, 3])


@njit(cache=True)
def _rotation_output(sc, q, c, r):
    """Store a rotation's result ``(l0, l1, l2, qw, qx, qy, qz)`` for clump ``c`` in
    ``clu.scratch`` and ``clu.quat``."""
    for k in range(3):
        sc[c, k] = r[k]
    for k in range(4):
        q[c, k] = r[3 + k]


@njit(cache=True)
def clump_rotate(lo, hi, clu, worlds):
    """Step part 2 of clumps ``lo`` to ``hi - 1``: the free-rotor splitting of each kicked
    clump (:func:`free_rotation`), two clumps at a time; the new body-frame momentum goes back
    to ``clu.scratch``, the orientation to ``clu.quat``."""
    sc, inertia, q = clu.scratch, clu.inertia, clu.quat
    c_state, c_world, w_active, w_dt = clu.state, clu.world, worlds.active, worlds.dt
    c = lo
    while c < hi:
        w = c_world[c]
        if c_state[c] != ACTIVE or w_active[w] == 0:
            c += 1
            continue
        d = c + 1
        while d < hi and (c_state[d] != ACTIVE or w_active[c_world[d]] == 0):
            d += 1
        if d < hi:
            ra, rb = free_rotation_pair(w_dt[w], w_dt[c_world[d]],
                                        _rotation_input(sc, inertia, q, c),
                                        _rotation_input(sc, inertia, q, d))
            _rotation_output(sc, q, c, ra)
            _rotation_output(sc, q, d, rb)
        else:
            _rotation_output(sc, q, c, free_rotation(w_dt[w], *_rotation_input(sc, inertia, q, c)))
        c = d + 1


@njit(cache=True)
def clump_place(lo, hi, clu, sph, rest):
    """Step part 3 of clumps ``lo`` to ``hi - 1``: angular momentum and velocity from the
    rotated state, the on-step angular velocity estimate, the spheres placed; the rebuild,
    NaN and removal checks (see :func:`clump_step`). ``rest`` is ``(worlds, prm, flags)``."""
    worlds, prm, flags = rest
    c_pos, c_quat, c_vel, c_angmom, c_omega = clu.pos, clu.quat, clu.vel, clu.angmom, clu.omega
    c_inertia, c_world, c_state, c_scratch = clu.inertia, clu.world, clu.state, clu.scratch
    clu_first, clu_count = clu.first, clu.n_spheres
    sph_offset, s_pos, s_ref = sph.offset, sph.pos, sph.ref
    worlds_active, world_dt, world_lo, world_hi = worlds.active, worlds.dt, worlds.lo, worlds.hi
    flags_nan, flag_rebuild = flags.nan, flags.rebuild
    hs2 = prm.half_skin * prm.half_skin
    for c in range(lo, hi):
        w = c_world[c]
        if c_state[c] != ACTIVE or worlds_active[w] == 0:
            continue
        dt = world_dt[w]
        i0, i1, i2 = load2(c_inertia, c)
        qw, qx, qy, qz = c_quat[c, 0], c_quat[c, 1], c_quat[c, 2], c_quat[c, 3]
        x, y, z = load2(c_pos, c)
        vx, vy, vz = load2(c_vel, c)
        lx, ly, lz = quat_rotate(qw, qx, qy, qz, c_scratch[c, 0], c_scratch[c, 1],
                                 c_scratch[c, 2])
        # on-step estimates for the next force evaluation: v(t+dt) ~ v(t+dt/2) + a(t) dt/2
        # (second order; removes the half-step lag of the damping forces)
        ex, ey, ez = (lx + 0.5 * dt * c_scratch[c, 3], ly + 0.5 * dt * c_scratch[c, 4],
                      lz + 0.5 * dt * c_scratch[c, 5])
        e0, e1, e2 = quat_rotate_inv(qw, qx, qy, qz, ex, ey, ez)
        store2(c_angmom, c, (lx, ly, lz))
        store2(c_omega, c, quat_rotate(qw, qx, qy, qz, e0 / i0, e1 / i1, e2 / i2))
        moved = False
        for s in range(clu_first[c], clu_first[c] + clu_count[c]):
            bx, by, bz = quat_rotate(qw, qx, qy, qz, sph_offset[s, 0], sph_offset[s, 1],
                                     sph_offset[s, 2])
            sx, sy, sz = x + bx, y + by, z + bz
            store2(s_pos, s, (sx, sy, sz))
            ddx, ddy, ddz = sx - s_ref[s, 0], sy - s_ref[s, 1], sz - s_ref[s, 2]
            if ddx * ddx + ddy * ddy + ddz * ddz > hs2:
                moved = True
        if moved:
            flag_rebuild[0] = 1
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z) and math.isfinite(vx)
                and math.isfinite(vy) and math.isfinite(vz) and math.isfinite(lx)
                and math.isfinite(ly) and math.isfinite(lz)):
            flags_nan[w] = 1
            c_state[c] = REMOVED
            flag_rebuild[0] = 1
            continue
        if (x < world_lo[w, 0] or y < world_lo[w, 1] or z < world_lo[w, 2] or x > world_hi[w, 0]
                or y > world_hi[w, 1] or z > world_hi[w, 2]):
            c_state[c] = REMOVED
            flag_rebuild[0] = 1


@njit(cache=True)
def clump_step(lo, hi, clu, sph, worlds, prm, flags):
    """Integrate clumps ``lo`` to ``hi - 1`` over one step and place their spheres.

    Translation: leapfrog (velocities at half steps). Rotation: the space-frame angular
    momentum is kicked by the contact torques, then by the type-A rolling torque, limited so
    that rolling resistance can stop the body's rotation but never reverse it; the
    orientation then follows the free-rotor splitting of :func:`free_rotation`. A clump whose
    centre leaves its world's domain box is marked REMOVED; a non-finite state raises the
    world's NaN flag; a sphere that moved more than half the skin since the last neighbour
    build raises the rebuild flag.

    In three passes over the block (:func:`clump_kick`, :func:`clump_rotate`,
    :func:`clump_place`; the per-clump quantities between them in ``clu.scratch``): the
    rotation is a chain of divisions and square roots per clump, and rotating two clumps at
    a time lets the processor overlap the chains (the clump pass ~20 % faster on one core,
    bitwise the same numbers; on CUDA each thread runs the three for its one clump).
    """
    clump_kick(lo, hi, clu, sph, worlds)
    clump_rotate(lo, hi, clu, worlds)
    clump_place(lo, hi, clu, sph, (worlds, prm, flags))


@njit(cache=True)
def advance_world(w, worlds, walls, prm, flags):
    """End world ``w``'s step (if it is active): move its walls by velocity x dt (m), raise the
    rebuild flag for a wall that moved more than half the skin since the last neighbour build
    (its wall candidates must be renewed), and advance its clock (s) and step count."""
    if worlds.active[w] == 0:
        return
    wall_origin = walls.origin
    wall_vel = walls.vel
    wall_ref = walls.ref
    dt = worlds.dt[w]
    hs2 = prm.half_skin * prm.half_skin
    for k in range(wall_origin.shape[1]):
        wall_origin[w, k, 0] += wall_vel[w, k, 0] * dt
        wall_origin[w, k, 1] += wall_vel[w, k, 1] * dt
        wall_origin[w, k, 2] += wall_vel[w, k, 2] * dt
        ddx = wall_origin[w, k, 0] - wall_ref[w, k, 0]
        ddy = wall_origin[w, k, 1] - wall_ref[w, k, 1]
        ddz = wall_origin[w, k, 2] - wall_ref[w, k, 2]
        if ddx * ddx + ddy * ddy + ddz * ddz > hs2:
            flags.rebuild[0] = 1
    worlds.time[w] += dt
    worlds.steps[w] += 1


@njit(cache=True)
def cell_coords(w, x, y, z, grid_lo, inv_cell):
    """Integer cell coordinates of a point in world ``w``'s grid (clamped to the key range)."""
    ix = int(math.floor((x - grid_lo[w, 0]) * inv_cell))  # noqa: RUF046 (float on CUDA)
    iy = int(math.floor((y - grid_lo[w, 1]) * inv_cell))  # noqa: RUF046 (float on CUDA)
    iz = int(math.floor((z - grid_lo[w, 2]) * inv_cell))  # noqa: RUF046 (float on CUDA)
    ix = min(max(ix, 0), CELL_MAX)
    iy = min(max(iy, 0), CELL_MAX)
    iz = min(max(iz, 0), CELL_MAX)
    return ix, iy, iz


@njit(cache=True)
def cell_key(w, ix, iy, iz):
    """Exact packed key of a cell (world and integer coordinates), int64."""
    return (((w << CELL_BITS) | ix) << (2 * CELL_BITS)) | (iy << CELL_BITS) | iz


@njit(cache=True)
def cell_bucket(w, ix, iy, iz, mask):
    """Hash-grid bucket of a cell (Teschner et al. 2003 spatial hash)."""
    h = (ix * 73856093) ^ (iy * 19349663) ^ (iz * 83492791) ^ (w * 2654435761)
    return h & mask


@njit(cache=True)
def neighbor_search(lo, hi, sph, clu, grid, prm, old, new):
    """Fill the neighbour slots of spheres ``lo`` to ``hi - 1`` in list ``new`` and carry
    their contact history over from list ``old``.

    Candidates are spheres of the same world, of another clump, whose centres are closer than
    ``r_i + r_j + prm.extra`` (skin + contact margin). Slots are sorted by neighbour
    index, so the list (and the force summation order) does not depend on the binning order.
    Writes the number of neighbours found to ``new_count[i]``, which may exceed the
    capacity (then only the first ``capacity`` are stored and the host must grow it).
    """
    clu_state = clu.state
    clu_world = clu.world
    s_pos = sph.pos
    s_radius = sph.radius
    s_clump = sph.clump
    s_cellkey = sph.cellkey
    bucket_count = grid.bucket_count
    bucket_members = grid.bucket_members
    mask = prm.mask
    extra = prm.extra
    carry_rolling = prm.carry_rolling
    old_count = old.found
    old_index = old.partner
    old_hist = old.hist
    old_rhist = old.rhist
    new_count = new.found
    new_index = new.partner
    new_hist = new.hist
    new_rhist = new.rhist
    for i in range(lo, hi):
        ci = s_clump[i]
        cap = new_index.shape[1]
        if clu_state[ci] != ACTIVE:
            new_count[i] = 0
            continue
        w = clu_world[ci]
        key = s_cellkey[i]
        iz = key & CELL_MAX
        iy = (key >> CELL_BITS) & CELL_MAX
        ix = (key >> (2 * CELL_BITS)) & CELL_MAX
        pix = s_pos[i, 0]
        piy = s_pos[i, 1]
        piz = s_pos[i, 2]
        ri = s_radius[i]
        bcap = bucket_members.shape[1]
        cnt = 0
        for ddz in range(-1, 2):
            jz = iz + ddz
            if jz < 0 or jz > CELL_MAX:
                continue
            for ddy in range(-1, 2):
                jy = iy + ddy
                if jy < 0 or jy > CELL_MAX:
                    continue
                for ddx in range(-1, 2):
                    jx = ix + ddx
                    if jx < 0 or jx > CELL_MAX:
                        continue
                    want = cell_key(w, jx, jy, jz)
                    bkt = cell_bucket(w, jx, jy, jz, mask)
                    m = bucket_count[bkt]
                    if m > bcap:
                        m = bcap
                    for t in range(m):
                        j = bucket_members[bkt, t]
                        if j == i or s_cellkey[j] != want or s_clump[j] == ci:
                            continue
                        dx = s_pos[j, 0] - pix
                        dy = s_pos[j, 1] - piy
                        dz = s_pos[j, 2] - piz
                        cut = ri + s_radius[j] + extra
                        if dx * dx + dy * dy + dz * dz < cut * cut:
                            if cnt < cap:
                                new_index[i, cnt] = j
                            cnt += 1
        new_count[i] = cnt
        stored = cnt if cnt < cap else cap
        # insertion sort of the stored slots by neighbour index
        for p in range(1, stored):
            v = new_index[i, p]
            q = p - 1
            while q >= 0 and new_index[i, q] > v:
                new_index[i, q + 1] = new_index[i, q]
                q -= 1
            new_index[i, q + 1] = v
        # carry the history over (old slots are sorted too: binary search)
        n_old = old_count[i]
        if n_old > old_index.shape[1]:
            n_old = old_index.shape[1]
        for p in range(stored):
            j = new_index[i, p]
            lo = slot_at_least(old_index, i, n_old, j)
            if lo < n_old and old_index[i, lo] == j:
                new_hist[i, p, 0] = old_hist[i, lo, 0]
                new_hist[i, p, 1] = old_hist[i, lo, 1]
                new_hist[i, p, 2] = old_hist[i, lo, 2]
                if carry_rolling:
                    new_rhist[i, p, 0] = old_rhist[i, lo, 0]
                    new_rhist[i, p, 1] = old_rhist[i, lo, 1]
                    new_rhist[i, p, 2] = old_rhist[i, lo, 2]
            else:
                zero3(new_hist, i, p)
                if carry_rolling:
                    zero3(new_rhist, i, p)
