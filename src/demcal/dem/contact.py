"""Contact force laws as pure scalar functions (Hertz-Mindlin, JKR, rolling friction).

Every function here takes and returns plain floats (tuples of floats; the pair parameters as
one row of ``pair_params``), writes no array and touches no global state, and is compiled with
``numba.njit``; the CPU kernels call them directly and
the CUDA kernels compile the same bodies for the GPU. Plain-Python versions are available as
``function.py_func`` for tests.

Conventions (see ``docs/physics.md``):

- overlap ``delta`` > 0 means the bodies interpenetrate, m;
- ``v_n`` is the normal component of the velocity of body *b* relative to body *a*, along the
  unit normal pointing from *a* to *b* (> 0: separating), m/s;
- a positive normal force pushes *b* away from *a* (repulsion), N;
- ``beta`` is EDEM's damping ratio ``ln(e) / sqrt(ln(e)^2 + pi^2)`` (<= 0).

:func:`contact_response` is the one place where a contact's forces are put together (normal,
tangential, rolling type A or C): the sphere-sphere and sphere-wall blocks of
:func:`demcal.dem.kernels.sphere_forces` both call it. A new contact law goes here.

The equivalent properties: ``1/E* = (1-v1^2)/E1 + (1-v2^2)/E2``,
``1/G* = (2-v1)/G1 + (2-v2)/G2``, ``1/R* = 1/R1 + 1/R2``, ``1/m* = 1/m1 + 1/m2``.
"""

from __future__ import annotations

import math

from numba import njit

__all__ = [
    "DAMPING_FACTOR",
    "N_PAIR_FIELDS",
    "P_BETA",
    "P_ESTAR",
    "P_GAMMA",
    "P_GSTAR",
    "P_JKR_C",
    "P_JKR_K",
    "P_MU_R",
    "P_MU_S",
    "ROLLING_A",
    "ROLLING_C",
    "ROLLING_NONE",
    "beta_from_restitution",
    "clip_magnitude",
    "contact_response",
    "effective_radius",
    "hertz_normal",
    "jkr_constants",
    "jkr_contact_radius",
    "jkr_contact_radius_c",
    "jkr_critical_contact_radius",
    "jkr_critical_overlap",
    "jkr_force",
    "jkr_normal",
    "jkr_normal_pair",
    "jkr_pull_off_force",
    "normal_contact",
    "pair_modulus",
    "pair_row",
    "pair_shear_modulus",
    "project_keep_length",
    "rayleigh_time_step",
    "rolling_a",
    "rolling_c",
    "tangential_contact",
]

#: 2 sqrt(5/6), the prefactor of EDEM's Hertz-Mindlin damping forces.
DAMPING_FACTOR = 2.0 * math.sqrt(5.0 / 6.0)

# pair-parameter fields: the last axis of ``pair_params`` (world, material, material, field),
# built by :meth:`demcal.dem.materials.MaterialTable.pair_table`
P_ESTAR = 0  #: equivalent Young's modulus E*, Pa
P_GSTAR = 1  #: equivalent shear modulus G*, Pa
P_BETA = 2  #: damping ratio (<= 0)
P_MU_S = 3  #: static friction coefficient
P_MU_R = 4  #: rolling friction coefficient
P_GAMMA = 5  #: JKR surface energy, J/m^2
P_JKR_C = 6  #: sqrt(4 pi gamma / E*), m^0.5 (see :func:`jkr_constants`)
P_JKR_K = 7  #: 4 sqrt(pi gamma E*), N/m^1.5 (see :func:`jkr_constants`)
N_PAIR_FIELDS = 8

# rolling friction models (``Simulation(rolling_friction=...)``: "none", "A", "C")
ROLLING_NONE = 0  #: no rolling resistance
ROLLING_A = 1  #: constant directional torque (EDEM standard), :func:`rolling_a`
ROLLING_C = 2  #: elastic-plastic spring-dashpot (EPSD), history-dependent, :func:`rolling_c`

#: a zero 3-vector (the response of a rolling model that is off)
ZERO3 = (0.0, 0.0, 0.0)


@njit(cache=True)
def beta_from_restitution(restitution: float) -> float:
    """Damping ratio ``beta = ln(e)/sqrt(ln(e)^2 + pi^2)`` of a restitution ``e`` in (0, 1].

    Returns 0 for ``e = 1`` (no damping).
    """
    if restitution >= 1.0:
        return 0.0
    le = math.log(restitution)
    return le / math.sqrt(le * le + math.pi * math.pi)


@njit(cache=True)
def pair_modulus(e1: float, nu1: float, e2: float, nu2: float) -> float:
    """Equivalent Young's modulus E* of two materials, Pa (``E`` in Pa, ``nu`` Poisson)."""
    return 1.0 / ((1.0 - nu1 * nu1) / e1 + (1.0 - nu2 * nu2) / e2)


@njit(cache=True)
def pair_shear_modulus(g1: float, nu1: float, g2: float, nu2: float) -> float:
    """Equivalent shear modulus G* of two materials, Pa: ``1/G* = (2-v1)/G1 + (2-v2)/G2``."""
    return 1.0 / ((2.0 - nu1) / g1 + (2.0 - nu2) / g2)


@njit(cache=True)
def effective_radius(r1: float, r2: float) -> float:
    """Equivalent radius R* = r1 r2 / (r1 + r2), m. Use ``r2 = inf`` for a flat wall."""
    if math.isinf(r2):
        return r1
    return r1 * r2 / (r1 + r2)


@njit(cache=True)
def rayleigh_time_step(radius: float, density: float, shear_modulus: float, poisson: float):
    """Rayleigh time step ``pi R sqrt(rho/G) / (0.1631 v + 0.8766)``, s."""
    return math.pi * radius * math.sqrt(density / shear_modulus) / (0.1631 * poisson + 0.8766)


@njit(cache=True)
def hertz_normal(delta: float, v_n: float, eff_radius: float, eff_modulus: float,
                 eff_mass: float, beta: float):
    """Hertz-Mindlin normal force with EDEM's damping.

    Parameters
    ----------
    delta : float
        Overlap, m (<= 0 gives no force).
    v_n : float
        Normal relative velocity, m/s (> 0 separating).
    eff_radius, eff_modulus, eff_mass : float
        R* (m), E* (Pa), m* (kg).
    beta : float
        Damping ratio from the restitution coefficient.

    Returns
    -------
    force : float
        Total normal force (elastic + damping), N; > 0 repulsive.
    elastic : float
        Elastic part ``4/3 E* sqrt(R*) delta^1.5``, N (used by the Coulomb and rolling limits).
    contact_radius : float
        ``a = sqrt(R* delta)``, m.
    """
    if delta <= 0.0:
        return 0.0, 0.0, 0.0
    a = math.sqrt(eff_radius * delta)
    elastic = 4.0 / 3.0 * eff_modulus * a * delta
    stiffness = 2.0 * eff_modulus * a
    damping = -DAMPING_FACTOR * beta * math.sqrt(stiffness * eff_mass) * v_n
    return elastic - damping, elastic, a


@njit(cache=True)
def jkr_constants(eff_modulus: float, gamma: float):
    """The pair constants of the JKR law: ``c = sqrt(4 pi gamma / E*)`` (m^0.5) and
    ``k = 4 sqrt(pi gamma E*)`` (N/m^1.5).

    ``MaterialTable.pair_table`` stores them per pair (``P_JKR_C``, ``P_JKR_K``) so that a
    contact does not take their square roots at every step; the laws below compute them the
    same way, so both give the same numbers bit for bit.
    """
    return math.sqrt(4.0 * math.pi * gamma / eff_modulus), 4.0 * math.sqrt(
        math.pi * gamma * eff_modulus)


@njit(cache=True)
def jkr_critical_contact_radius(eff_radius: float, eff_modulus: float, gamma: float) -> float:
    """Contact radius at break-off of EDEM's JKR law (version 1), m.

    ``a_c = [9 pi gamma R*^2 / (2 E*) (3/4 - 1/sqrt(2))]^(1/3)``.
    """
    coef = 0.75 - 1.0 / math.sqrt(2.0)
    return (9.0 * math.pi * gamma * eff_radius * eff_radius / (2.0 * eff_modulus) * coef) ** (
        1.0 / 3.0
    )


@njit(cache=True)
def jkr_critical_overlap(eff_radius: float, eff_modulus: float, gamma: float) -> float:
    """Overlap at break-off ``d_c = a_c^2/R* - sqrt(4 pi gamma a_c / E*)`` (<= 0), m."""
    if gamma <= 0.0:
        return 0.0
    ac = jkr_critical_contact_radius(eff_radius, eff_modulus, gamma)
    return ac * ac / eff_radius - math.sqrt(4.0 * math.pi * gamma * ac / eff_modulus)


@njit(cache=True)
def jkr_contact_radius(delta: float, eff_radius: float, eff_modulus: float, gamma: float):
    """Contact radius ``a`` of the JKR law for an overlap ``delta`` (largest root), m.

    ``delta = a^2/R* - sqrt(4 pi gamma a / E*)`` is, in ``s = sqrt(a)``, the quartic
    ``s^4 - c R* s - R* delta = 0`` with ``c = sqrt(4 pi gamma / E*)``. It is solved in closed
    form (Ferrari): the resolvent cubic ``m^3 + R* delta m - (c R*)^2 / 8 = 0`` has exactly one
    positive root ``m``, and with ``w = sqrt(2 m)`` the largest root is
    ``s = (w + sqrt(2 c R* / w - w^2)) / 2``. Cardano's root is written without the
    difference of two cube roots, so it keeps full precision when Hertz dominates (large
    ``delta``); a negative discriminant (three real roots: trigonometric form) lies below the
    curve's minimum, i.e. beyond break-off. Agrees with a bracketing root finder to ~1e-14
    (tests/dem/test_dem_jkr.py) at less than half the cost of Newton's method. Valid for
    ``delta >= jkr_critical_overlap``.
    """
    return jkr_contact_radius_c(delta, eff_radius, jkr_constants(eff_modulus, gamma)[0])


@njit(cache=True)
def jkr_contact_radius_c(delta: float, eff_radius: float, c: float):
    """:func:`jkr_contact_radius` with ``c = sqrt(4 pi gamma / E*)`` (m^0.5) given, as the
    pair table holds it (``P_JKR_C``), m."""
    cr = c * eff_radius
    p = eff_radius * delta
    q = -0.125 * cr * cr
    disc = 0.25 * q * q + p * p * p / 27.0
    if disc >= 0.0:
        u = (-0.5 * q + math.sqrt(disc)) ** (1.0 / 3.0)
        v = p / (3.0 * u)
        m = -q / (u * u + p / 3.0 + v * v)
    else:
        r = math.sqrt(-p / 3.0)
        m = 2.0 * r * math.cos(math.acos(min(1.0, -0.5 * q / (r * r * r))) / 3.0)
    w = math.sqrt(2.0 * m)
    arg = 2.0 * cr / w - w * w
    s = 0.5 * (w + math.sqrt(arg if arg > 0.0 else 0.0))
    return s * s


@njit(cache=True)
def jkr_force(a: float, eff_radius: float, eff_modulus: float, gamma: float) -> float:
    """JKR force ``-4 sqrt(pi gamma E*) a^1.5 + 4 E* a^3 / (3 R*)`` at contact radius a, N."""
    return -4.0 * math.sqrt(math.pi * gamma * eff_modulus) * a * math.sqrt(a) + (
        4.0 * eff_modulus * a * a * a / (3.0 * eff_radius)
    )


@njit(cache=True)
def jkr_pull_off_force(eff_radius: float, gamma: float) -> float:
    """Magnitude of the largest attraction of the version-1 JKR law, ``3 pi gamma R*``, N."""
    return 3.0 * math.pi * gamma * eff_radius


@njit(cache=True)
def jkr_normal(delta: float, v_n: float, eff_radius: float, eff_modulus: float,
               eff_mass: float, beta: float, gamma: float):
    """Hertz-Mindlin with JKR cohesion (EDEM version 1), normal part.

    The same curve on loading and unloading: the force acts whenever
    ``delta > jkr_critical_overlap`` (also at a small gap, delta < 0) and vanishes beyond.
    Damping uses ``S_n = 2 E* a`` with ``a`` from the JKR solution.

    Returns
    -------
    force : float
        Net normal force (JKR + damping), N; > 0 repulsive.
    repulsive : float
        The repulsive part ``4 E* a^3 / (3 R*)``, N (limits friction and rolling resistance).
    contact_radius : float
        ``a``, m (0 when out of contact).
    """
    c, k = jkr_constants(eff_modulus, gamma)  # (0, 0) without cohesion: Hertz, below
    return jkr_normal_pair(delta, v_n, eff_radius, eff_mass, (eff_modulus, beta, gamma, c, k))


@njit(cache=True)
def jkr_normal_pair(delta: float, v_n: float, eff_radius: float, eff_mass: float, pair):
    """:func:`jkr_normal` with the pair's constants given as
    ``pair = (E*, beta, gamma, c, k)`` (``c``, ``k`` from :func:`jkr_constants`, as the pair
    table holds them). Same returns, bit for bit."""
    eff_modulus, beta, gamma, c, k = pair
    if gamma <= 0.0:
        return hertz_normal(delta, v_n, eff_radius, eff_modulus, eff_mass, beta)
    # d_c <= 0: an overlapping pair is always in contact (skips d_c's cube root)
    if delta <= 0.0 and delta <= jkr_critical_overlap(eff_radius, eff_modulus, gamma):
        return 0.0, 0.0, 0.0
    a = jkr_contact_radius_c(delta, eff_radius, c)
    repulsive = 4.0 * eff_modulus * a * a * a / (3.0 * eff_radius)
    f = repulsive - k * a * math.sqrt(a)
    stiffness = 2.0 * eff_modulus * a
    damping = -DAMPING_FACTOR * beta * math.sqrt(stiffness * eff_mass) * v_n
    return f - damping, repulsive, a


@njit(cache=True)
def normal_contact(delta: float, v_n: float, eff_radius: float, eff_modulus: float,
                   eff_mass: float, beta: float, gamma: float):
    """Normal force of the default model: JKR (version 1) when ``gamma > 0``, else Hertz.

    Same returns as :func:`jkr_normal`.
    """
    return jkr_normal(delta, v_n, eff_radius, eff_modulus, eff_mass, beta, gamma)


@njit(cache=True)
def project_keep_length(x: float, y: float, z: float, n_x: float, n_y: float, n_z: float):
    """Rotate a contact history vector into the current tangent plane, keeping its length.

    The part along the unit normal ``n`` is removed and the rest scaled back to the old
    length (a history that lay along ``n`` stays zero). Used for the tangential spring
    (m) and the type-C rolling spring (N m).
    """
    old2 = x * x + y * y + z * z
    dn = x * n_x + y * n_y + z * n_z
    x -= dn * n_x
    y -= dn * n_y
    z -= dn * n_z
    new2 = x * x + y * y + z * z
    if new2 > 0.0 and old2 > new2:
        scale = math.sqrt(old2 / new2)
        x *= scale
        y *= scale
        z *= scale
    return x, y, z


@njit(cache=True)
def clip_magnitude(x: float, y: float, z: float, limit: float):
    """A vector scaled down onto the magnitude ``limit`` if it is longer.

    Returns the (possibly scaled) ``x, y, z`` and whether it was longer than ``limit`` (a
    tangential force that slides, a rolling torque at its cap).
    """
    mag = math.sqrt(x * x + y * y + z * z)
    if mag > limit:
        if mag > 0.0:
            ratio = limit / mag
            return x * ratio, y * ratio, z * ratio, True
        return x, y, z, True
    return x, y, z, False


@njit(cache=True)
def tangential_contact(xi_x: float, xi_y: float, xi_z: float,
                       n_x: float, n_y: float, n_z: float,
                       vt_x: float, vt_y: float, vt_z: float,
                       dt: float, contact_radius: float, eff_shear_modulus: float,
                       eff_mass: float, beta: float, friction: float, normal_limit: float):
    """Mindlin no-slip tangential spring with damping and the Coulomb limit.

    Parameters
    ----------
    xi_x, xi_y, xi_z : float
        Accumulated tangential displacement of *b* relative to *a* (the contact history), m.
    n_x, n_y, n_z : float
        Unit normal from *a* to *b*.
    vt_x, vt_y, vt_z : float
        Tangential relative velocity of *b* w.r.t. *a* at the contact point, m/s.
    dt : float
        Time step, s.
    contact_radius : float
        ``a`` of the normal model, m (S_t = 8 G* a).
    eff_shear_modulus, eff_mass, beta : float
        G* (Pa), m* (kg), damping ratio.
    friction : float
        Static friction coefficient mu_s.
    normal_limit : float
        Normal force that sets the Coulomb limit ``mu_s * normal_limit`` (the elastic /
        repulsive part), N.

    Returns
    -------
    tuple of 6 floats
        New history (xi_x, xi_y, xi_z), m, and the tangential force on *b* (f_x, f_y, f_z), N.

    Notes
    -----
    The history is first rotated into the current tangent plane (projected, magnitude kept),
    then incremented by ``v_t dt``. The force is ``-S_t xi - c_t v_t`` with
    ``c_t = -2 sqrt(5/6) beta sqrt(S_t m*)``. If its magnitude exceeds the Coulomb limit it is
    scaled onto the limit and the spring is reset to match (``xi = -(F + c_t v_t)/S_t``), so
    the contact slides.
    """
    xi_x, xi_y, xi_z = project_keep_length(xi_x, xi_y, xi_z, n_x, n_y, n_z)
    xi_x += vt_x * dt
    xi_y += vt_y * dt
    xi_z += vt_z * dt
    kt = 8.0 * eff_shear_modulus * contact_radius
    ct = -DAMPING_FACTOR * beta * math.sqrt(kt * eff_mass)
    fx = -kt * xi_x - ct * vt_x
    fy = -kt * xi_y - ct * vt_y
    fz = -kt * xi_z - ct * vt_z
    limit = friction * normal_limit
    if limit < 0.0:
        limit = 0.0
    fx, fy, fz, sliding = clip_magnitude(fx, fy, fz, limit)
    if sliding:
        if kt > 0.0:
            xi_x = -(fx + ct * vt_x) / kt
            xi_y = -(fy + ct * vt_y) / kt
            xi_z = -(fz + ct * vt_z) / kt
        else:
            xi_x = 0.0
            xi_y = 0.0
            xi_z = 0.0
    return xi_x, xi_y, xi_z, fx, fy, fz


@njit(cache=True)
def rolling_a(spin, spin_rate: float, lever, friction: float, normal_limit: float):
    """Type-A rolling resistance (constant directional torque, EDEM standard).

    Parameters
    ----------
    spin : tuple of 3 floats
        Angular velocity of the body the torque acts on, rad/s (space frame).
    spin_rate : float
        Its magnitude ``|spin|``, rad/s.
    lever : tuple of 3 floats
        From the body's centre of mass to the contact point, m.
    friction : float
        Rolling friction coefficient mu_r.
    normal_limit : float
        Repulsive normal force, N.

    Returns
    -------
    tuple of 3 floats
        ``mu_r F_rep |lever| spin / |spin|``, N m: the torque *opposes* the spin, so the caller
        subtracts it (:func:`~demcal.dem.kernels.clump_step` applies it with a no-reversal
        limit). Zero when the body does not spin or mu_r is 0.
    """
    if spin_rate > 0.0 and friction > 0.0:
        arm = math.sqrt(lever[0] * lever[0] + lever[1] * lever[1] + lever[2] * lever[2])
        mag = friction * normal_limit * arm / spin_rate
        return mag * spin[0], mag * spin[1], mag * spin[2]
    return ZERO3


@njit(cache=True)
def rolling_c(m_x: float, m_y: float, m_z: float, n_x: float, n_y: float, n_z: float,
              w_x: float, w_y: float, w_z: float, dt: float, stiff_n: float, eff_radius: float,
              mu_r: float, f_rep: float):
    """EPSD rolling spring (type C): the torque on body *b* and its updated history, N m.

    ``m`` is the spring torque (the history), ``n`` the unit normal from *a* to *b*, ``w`` the
    angular velocity of *b* relative to *a* (rad/s), ``dt`` the step (s), ``stiff_n`` the
    normal stiffness ``S_n = 2 E* a`` (N/m), ``eff_radius`` R* (m), ``f_rep`` the repulsive
    normal force (N). The spring ``k_r = 2.25 S_n mu_r^2 R*^2`` accumulates ``-k_r w_t dt``
    (tangential part of w) and is capped at ``mu_r R* F_rep``. Returns the new ``m`` (3
    floats), which is also the torque on *b*.
    """
    wn = w_x * n_x + w_y * n_y + w_z * n_z
    w_x -= wn * n_x
    w_y -= wn * n_y
    w_z -= wn * n_z
    m_x, m_y, m_z = project_keep_length(m_x, m_y, m_z, n_x, n_y, n_z)
    kr = 2.25 * stiff_n * mu_r * mu_r * eff_radius * eff_radius
    m_x -= kr * w_x * dt
    m_y -= kr * w_y * dt
    m_z -= kr * w_z * dt
    m_x, m_y, m_z, _ = clip_magnitude(m_x, m_y, m_z, mu_r * eff_radius * f_rep)
    return m_x, m_y, m_z


@njit(cache=True)
def pair_row(pair_params, w: int, mat_a: int, mat_b: int):
    """The pair parameters of materials ``mat_a`` and ``mat_b`` in world ``w`` as a tuple of
    :data:`N_PAIR_FIELDS` floats (scalars, not an array view: a view in the contact loop would
    cost a reference count per contact)."""
    return (pair_params[w, mat_a, mat_b, P_ESTAR], pair_params[w, mat_a, mat_b, P_GSTAR],
            pair_params[w, mat_a, mat_b, P_BETA], pair_params[w, mat_a, mat_b, P_MU_S],
            pair_params[w, mat_a, mat_b, P_MU_R], pair_params[w, mat_a, mat_b, P_GAMMA],
            pair_params[w, mat_a, mat_b, P_JKR_C], pair_params[w, mat_a, mat_b, P_JKR_K])


@njit(cache=True, inline="always")
def contact_forces(overlap: float, frame, params, eff, hists):
    """One contact's normal, tangential and type-C rolling response: everything of
    :func:`contact_response` but the type-A rolling torque, which depends on the body it acts
    on (the CPU's one-sided pair pass takes it for both bodies, :mod:`demcal.dem.half_pairs`).

    ``frame`` = ``(normal, velocity, rel_spin)``, ``eff`` = ``(eff_radius, eff_mass, dt,
    rolling_model)``, ``hists`` = ``(hist, rhist)``, each as :func:`contact_response` takes
    it. Returns ``(contact_radius, force, hist, roll_c, repulsive)`` as it does (``roll_c``
    zeros unless type C; nothing is meaningful when ``contact_radius <= 0``). Inlined into
    its callers (numba ``inline="always"``): a call per contact cost the CPU pass ~4 %.
    """
    (nx, ny, nz), (vx, vy, vz), rel_spin = frame
    eff_radius, eff_mass, dt, rolling_model = eff
    hist, rhist = hists
    estar = params[P_ESTAR]
    beta = params[P_BETA]
    mu_r = params[P_MU_R]
    vn = vx * nx + vy * ny + vz * nz
    fn, frep, arad = jkr_normal_pair(overlap, vn, eff_radius, eff_mass,
                                     (estar, beta, params[P_GAMMA], params[P_JKR_C],
                                      params[P_JKR_K]))
    if arad <= 0.0:
        return arad, ZERO3, ZERO3, ZERO3, 0.0
    vtx = vx - vn * nx
    vty = vy - vn * ny
    vtz = vz - vn * nz
    xi0, xi1, xi2, ftx, fty, ftz = tangential_contact(
        hist[0], hist[1], hist[2], nx, ny, nz, vtx, vty, vtz, dt, arad, params[P_GSTAR],
        eff_mass, beta, params[P_MU_S], frep)
    force = (fn * nx + ftx, fn * ny + fty, fn * nz + ftz)
    roll_c = ZERO3
    if rolling_model == ROLLING_C:
        roll_c = rolling_c(rhist[0], rhist[1], rhist[2], nx, ny, nz, rel_spin[0], rel_spin[1],
                           rel_spin[2], dt, 2.0 * estar * arad, eff_radius, mu_r, frep)
    return arad, force, (xi0, xi1, xi2), roll_c, frep


@njit(cache=True)
def contact_response(overlap: float, normal, velocity, params, eff_radius: float,
                     eff_mass: float, dt: float, hist, rolling_model: int, spin, spin_rate: float,
                     lever, rel_spin, rhist):
    """Everything one contact does in one step: normal, tangential and rolling response.

    The sphere-sphere and sphere-wall blocks of :func:`demcal.dem.kernels.sphere_forces` both
    call this (a wall is body *a* with infinite radius and mass: ``eff_radius`` = the sphere's
    radius, ``eff_mass`` = its clump's mass).

    Parameters
    ----------
    overlap : float
        ``delta``, m (> 0 interpenetrating).
    normal : tuple of 3 floats
        Unit normal from *a* to *b*.
    velocity : tuple of 3 floats
        Velocity of *b* relative to *a* at the contact point, m/s.
    params : tuple of N_PAIR_FIELDS floats
        The pair's row of ``pair_params`` (indexed by ``P_ESTAR`` ... ``P_JKR_K``), from
        :func:`pair_row`.
    eff_radius, eff_mass : float
        R* (m) and m* (kg).
    dt : float
        Time step, s.
    hist : tuple of 3 floats
        Tangential history (accumulated displacement of *b* w.r.t. *a*), m.
    rolling_model : int
        ``ROLLING_NONE``, ``ROLLING_A`` or ``ROLLING_C``.
    spin, spin_rate, lever
        Type A: angular velocity (rad/s) and its magnitude of the body the rolling torque
        acts on, and its lever from centre of mass to contact point (m).
    rel_spin : tuple of 3 floats
        Type C: angular velocity of *b* relative to *a*, rad/s.
    rhist : tuple of 3 floats
        Type C: rolling spring torque (the rolling history), N m; zeros otherwise.

    Returns
    -------
    contact_radius : float
        ``a``, m; <= 0 means no contact (then nothing else is meaningful: the caller zeroes
        the contact's histories).
    force : tuple of 3 floats
        Normal + tangential force on *b*, N.
    hist : tuple of 3 floats
        New tangential history, m.
    roll_a : tuple of 3 floats
        Type-A rolling torque magnitude along ``spin`` (to subtract), N m; zeros otherwise.
    roll_c : tuple of 3 floats
        Type C: new rolling history = rolling torque on *b*, N m; zeros otherwise.
    """
    arad, force, xi, roll_c, frep = contact_forces(
        overlap, (normal, velocity, rel_spin), params, (eff_radius, eff_mass, dt, rolling_model),
        (hist, rhist))
    if arad <= 0.0:
        return arad, ZERO3, ZERO3, ZERO3, ZERO3
    roll_a = ZERO3
    if rolling_model == ROLLING_A:
        roll_a = rolling_a(spin, spin_rate, lever, params[P_MU_R], frep)
    return arad, force, xi, roll_a, roll_c
