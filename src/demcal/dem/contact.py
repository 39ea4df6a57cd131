"""Contact force laws as pure scalar functions (Hertz-Mindlin, JKR, rolling friction).

Every function here takes and returns plain floats (tuples of floats), touches no array and
no global state, and is compiled with ``numba.njit``; the CPU kernels call them directly and
the CUDA kernels compile the same bodies for the GPU. Plain-Python versions are available as
``function.py_func`` for tests.

Conventions (see ``docs/physics.md``):

- overlap ``delta`` > 0 means the bodies interpenetrate, m;
- ``v_n`` is the normal component of the velocity of body *b* relative to body *a*, along the
  unit normal pointing from *a* to *b* (> 0: separating), m/s;
- a positive normal force pushes *b* away from *a* (repulsion), N;
- ``beta`` is EDEM's damping ratio ``ln(e) / sqrt(ln(e)^2 + pi^2)`` (<= 0).

The equivalent properties: ``1/E* = (1-v1^2)/E1 + (1-v2^2)/E2``,
``1/G* = (2-v1)/G1 + (2-v2)/G2``, ``1/R* = 1/R1 + 1/R2``, ``1/m* = 1/m1 + 1/m2``.
"""

from __future__ import annotations

import math

from numba import njit

from demcal.dem._config import JKR_MAX_ITER

__all__ = [
    "DAMPING_FACTOR",
    "beta_from_restitution",
    "effective_radius",
    "hertz_normal",
    "jkr_contact_radius",
    "jkr_critical_contact_radius",
    "jkr_critical_overlap",
    "jkr_force",
    "jkr_normal",
    "jkr_pull_off_force",
    "normal_contact",
    "pair_modulus",
    "pair_shear_modulus",
    "rayleigh_time_step",
    "tangential_contact",
]

#: 2 sqrt(5/6), the prefactor of EDEM's Hertz-Mindlin damping forces.
DAMPING_FACTOR = 2.0 * math.sqrt(5.0 / 6.0)


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

    Solves ``delta = a^2/R* - sqrt(4 pi gamma a / E*)`` by Newton's method on ``s = sqrt(a)``
    from a starting point above the largest root (the function is convex there, so the
    iteration decreases monotonically onto it). Valid for ``delta >= jkr_critical_overlap``.
    """
    c = math.sqrt(4.0 * math.pi * gamma / eff_modulus)
    dpos = delta if delta > 0.0 else 0.0
    s = (eff_radius * dpos) ** 0.25 + (c * eff_radius) ** (1.0 / 3.0)
    for _ in range(JKR_MAX_ITER):
        s2 = s * s
        f = s2 * s2 / eff_radius - c * s - delta
        fp = 4.0 * s2 * s / eff_radius - c
        if fp <= 0.0:
            break
        step = f / fp
        s -= step
        if step <= 1e-15 * s:
            break
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
    if gamma <= 0.0:
        return hertz_normal(delta, v_n, eff_radius, eff_modulus, eff_mass, beta)
    if delta <= jkr_critical_overlap(eff_radius, eff_modulus, gamma):
        return 0.0, 0.0, 0.0
    a = jkr_contact_radius(delta, eff_radius, eff_modulus, gamma)
    repulsive = 4.0 * eff_modulus * a * a * a / (3.0 * eff_radius)
    f = repulsive - 4.0 * math.sqrt(math.pi * gamma * eff_modulus) * a * math.sqrt(a)
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
    # rotate the history into the current tangent plane, keeping its length
    old2 = xi_x * xi_x + xi_y * xi_y + xi_z * xi_z
    dn = xi_x * n_x + xi_y * n_y + xi_z * n_z
    xi_x -= dn * n_x
    xi_y -= dn * n_y
    xi_z -= dn * n_z
    new2 = xi_x * xi_x + xi_y * xi_y + xi_z * xi_z
    if new2 > 0.0 and old2 > new2:
        scale = math.sqrt(old2 / new2)
        xi_x *= scale
        xi_y *= scale
        xi_z *= scale
    xi_x += vt_x * dt
    xi_y += vt_y * dt
    xi_z += vt_z * dt
    kt = 8.0 * eff_shear_modulus * contact_radius
    ct = -DAMPING_FACTOR * beta * math.sqrt(kt * eff_mass)
    fx = -kt * xi_x - ct * vt_x
    fy = -kt * xi_y - ct * vt_y
    fz = -kt * xi_z - ct * vt_z
    fmag = math.sqrt(fx * fx + fy * fy + fz * fz)
    limit = friction * normal_limit
    if limit < 0.0:
        limit = 0.0
    if fmag > limit:
        if fmag > 0.0:
            ratio = limit / fmag
            fx *= ratio
            fy *= ratio
            fz *= ratio
        if kt > 0.0:
            xi_x = -(fx + ct * vt_x) / kt
            xi_y = -(fy + ct * vt_y) / kt
            xi_z = -(fz + ct * vt_z) / kt
        else:
            xi_x = 0.0
            xi_y = 0.0
            xi_z = 0.0
    return xi_x, xi_y, xi_z, fx, fy, fz
