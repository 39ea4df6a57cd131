"""Slow plain-NumPy reference of the engine's contact forces and torques (tests only).

Written from ``docs/physics.md``, not from :mod:`demcal.dem.kernels`: every pair of
spheres of different active clumps of a world is tested (no neighbour lists), the pair
properties are derived from the :class:`~demcal.dem.materials.Material` and
:class:`~demcal.dem.materials.Interaction` objects (not the engine's packed table), the JKR
contact radius comes from ``scipy.optimize.brentq`` (not Newton) and wall distances from a
separate closest-point routine. Choices that docs/physics.md leaves open are made as the engine
documents them:

- contact point: the middle of the overlap, ``x_a + n (r_a - delta/2)``, for spheres and walls;
- the Coulomb limit and the rolling torque use the elastic (Hertz) / repulsive (JKR) part of
  the normal force, not the damped total;
- on sliding, the history is reset so that spring + damping sit on the Coulomb limit;
- a wall has infinite radius and mass; a tube's curvature is ignored (R* = sphere radius).

Orientation: for a pair, ``a`` is the lower sphere index, ``n`` points from ``a`` to ``b``;
for a wall contact the wall is ``a``. Units SI.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq

DAMP = 2.0 * math.sqrt(5.0 / 6.0)


@dataclass
class PairProps:
    """Equivalent properties of a material pair."""

    estar: float
    gstar: float
    beta: float
    mu_s: float
    mu_r: float
    gamma: float


def pair_props(mat_a, mat_b, inter) -> PairProps:
    """E*, G*, beta, mu_s, mu_r, gamma of two Materials and their Interaction (docs/physics.md)."""
    ea = 2.0 * mat_a.shear_modulus * (1.0 + mat_a.poisson)
    eb = 2.0 * mat_b.shear_modulus * (1.0 + mat_b.poisson)
    estar = 1.0 / ((1.0 - mat_a.poisson**2) / ea + (1.0 - mat_b.poisson**2) / eb)
    gstar = 1.0 / ((2.0 - mat_a.poisson) / mat_a.shear_modulus
                   + (2.0 - mat_b.poisson) / mat_b.shear_modulus)
    e = inter.restitution
    beta = 0.0 if e >= 1.0 else math.log(e) / math.sqrt(math.log(e) ** 2 + math.pi**2)
    return PairProps(estar, gstar, beta, inter.static_friction, inter.rolling_friction,
                     inter.surface_energy)


def jkr_break_overlap(rstar: float, estar: float, gamma: float) -> float:
    """Critical (negative) overlap d_c of the JKR v1 law, m."""
    ac = (9.0 * math.pi * gamma * rstar**2 / (2.0 * estar) * (0.75 - 1.0 / math.sqrt(2.0))) ** (
        1.0 / 3.0)
    return ac**2 / rstar - math.sqrt(4.0 * math.pi * gamma * ac / estar)


def jkr_radius(delta: float, rstar: float, estar: float, gamma: float) -> float:
    """Largest root a of ``delta = a^2/R* - sqrt(4 pi gamma a / E*)`` (brentq), m."""
    c = math.sqrt(4.0 * math.pi * gamma / estar)

    def f(a):
        return a * a / rstar - c * math.sqrt(a) - delta

    # d/da = 0 at a^(3/2) = c R* / 4: the largest root lies to the right of that minimum
    a_min = (c * rstar / 4.0) ** (2.0 / 3.0)
    hi = max(2.0 * a_min, math.sqrt(rstar * abs(delta)) + (c * rstar) ** (2.0 / 3.0) + a_min)
    while f(hi) < 0.0:
        hi *= 2.0
    if f(a_min) >= 0.0:
        return a_min
    return brentq(f, a_min, hi, xtol=1e-300, rtol=4.0 * np.finfo(float).eps, maxiter=500)


def normal_force(delta, vn, rstar, mstar, p: PairProps):
    """Net normal force on b (> 0 repulsive), its elastic/repulsive part, contact radius a.

    Returns None when out of contact.
    """
    if p.gamma > 0.0:
        if delta <= jkr_break_overlap(rstar, p.estar, p.gamma):
            return None
        a = jkr_radius(delta, rstar, p.estar, p.gamma)
        rep = 4.0 * p.estar * a**3 / (3.0 * rstar)
        f = rep - 4.0 * math.sqrt(math.pi * p.gamma * p.estar) * a**1.5
    else:
        if delta <= 0.0:
            return None
        a = math.sqrt(rstar * delta)
        rep = 4.0 / 3.0 * p.estar * math.sqrt(rstar) * delta**1.5
        f = rep
    sn = 2.0 * p.estar * a
    cn = -DAMP * p.beta * math.sqrt(sn * mstar)  # >= 0
    return f - cn * vn, rep, a


def tangential(xi, n, vt, dt, a, mstar, limit, p: PairProps):
    """New history and tangential force on b (Mindlin spring + damping, Coulomb limit)."""
    xi = np.asarray(xi, dtype=float)
    length = np.linalg.norm(xi)
    xi = xi - np.dot(xi, n) * n
    proj = np.linalg.norm(xi)
    if proj > 0.0:
        xi = xi * (length / proj)
    xi = xi + vt * dt
    st = 8.0 * p.gstar * a
    ct = -DAMP * p.beta * math.sqrt(st * mstar)
    f = -st * xi - ct * vt
    cap = max(p.mu_s * limit, 0.0)
    fmag = np.linalg.norm(f)
    sliding = fmag > cap
    if sliding:
        f = f * (cap / fmag) if fmag > 0 else f
        xi = -(f + ct * vt) / st if st > 0 else np.zeros(3)
    return xi, f, sliding


def rolling_epsd(m, n, w_rel, dt, a, rstar, rep, p: PairProps):
    """Type-C (EPSD) rolling spring: new moment on b (also the history), N m."""
    m = np.asarray(m, dtype=float)
    w_t = w_rel - np.dot(w_rel, n) * n
    length = np.linalg.norm(m)
    m = m - np.dot(m, n) * n
    proj = np.linalg.norm(m)
    if proj > 0.0:
        m = m * (length / proj)
    kr = 2.25 * (2.0 * p.estar * a) * p.mu_r**2 * rstar**2
    m = m - kr * w_t * dt
    cap = p.mu_r * rstar * rep
    mag = np.linalg.norm(m)
    if mag > cap and mag > 0:
        m = m * (cap / mag)
    return m


def plane_distance(origin, normal, u, v, hu, hv, x):
    """Distance and unit normal (wall -> x) of a point to a (finite) rectangle."""
    s = x - origin
    cu = np.clip(np.dot(s, u), -hu, hu)
    cv = np.clip(np.dot(s, v), -hv, hv)
    d = x - (origin + cu * u + cv * v)
    dist = np.linalg.norm(d)
    return (dist, d / dist) if dist > 0 else (0.0, normal)


def tube_distance(base, axis, r_in, r_out, length, x):
    """Signed distance and unit normal (wall -> x) of a point to a thick open tube."""
    s = x - base
    z = np.dot(s, axis)
    radial = s - z * axis
    rho = np.linalg.norm(radial)
    e = radial / rho
    if r_in < rho < r_out and 0.0 < z < length:
        faces = [(rho - r_in, -e), (r_out - rho, e), (z, -axis), (length - z, axis)]
        best = min(faces, key=lambda t: t[0])
        return -best[0], best[1]
    rc = min(max(rho, r_in), r_out)
    zc = min(max(z, 0.0), length)
    d = (rho - rc) * e + (z - zc) * axis
    return np.linalg.norm(d), d / np.linalg.norm(d)


@dataclass
class Result:
    """Per-sphere force (N), torque about its clump's centre (N m, incl. type C), type-A
    rolling torque (N m), force exerted on each wall (N) and updated histories."""

    force: np.ndarray
    torque: np.ndarray
    roll: np.ndarray
    wall_force: np.ndarray
    pair_hist: dict = field(default_factory=dict)
    pair_rhist: dict = field(default_factory=dict)
    wall_hist: np.ndarray | None = None
    wall_rhist: np.ndarray | None = None
    stats: dict = field(default_factory=lambda: {"sliding": 0, "sticking": 0, "gap": 0})


def _count(res: Result, sliding: bool, delta: float) -> None:
    res.stats["sliding" if sliding else "sticking"] += 1
    res.stats["gap"] += delta < 0.0


def contact_forces(st: dict, worlds, rolling: str) -> Result:
    """Forces of every contact of a snapshot of the engine's state.

    Parameters
    ----------
    st : dict
        ``s_pos, s_radius, s_clump, c_pos, c_veval (velocity), c_omega, c_mass, c_world,
        c_state, world_dt, s_world_material`` (material name of each sphere), ``walls`` (per
        world: list of dicts with type, origin and geometry, velocity, material), ``hist``
        {(a, b): xi}, ``rhist`` {(a, b): m}, ``w_hist`` and ``w_rhist`` (n_spheres, n_walls, 3).
    worlds : list of World
        For materials and interactions.
    rolling : {"A", "C", "none"}
    """
    pos = st["s_pos"]
    n = len(pos)
    max_walls = st["w_hist"].shape[1]
    res = Result(np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)),
                 np.zeros((n, max_walls, 3)), wall_hist=np.zeros((n, max_walls, 3)),
                 wall_rhist=np.zeros((n, max_walls, 3)))
    clump = st["s_clump"]
    active = st["c_state"][clump] == 1
    cworld = st["c_world"][clump]

    def vel_at(c, point):
        return st["c_veval"][c] + np.cross(st["c_omega"][c], point - st["c_pos"][c])

    def roll_a(i, c, point, rep, mu_r):
        w = st["c_omega"][c]
        wn = np.linalg.norm(w)
        if wn > 0 and mu_r > 0:
            res.roll[i] -= mu_r * rep * np.linalg.norm(point - st["c_pos"][c]) * w / wn

    for a in range(n):
        for b in range(a + 1, n):
            ca, cb = clump[a], clump[b]
            if ca == cb or not (active[a] and active[b]) or cworld[a] != cworld[b]:
                continue
            w = cworld[a]
            tab = worlds[w].materials
            mat_a, mat_b = st["s_material_name"][a], st["s_material_name"][b]
            p = pair_props(tab.material(mat_a), tab.material(mat_b), tab.interaction(mat_a, mat_b))
            ra, rb = st["s_radius"][a], st["s_radius"][b]
            d = pos[b] - pos[a]
            dist = np.linalg.norm(d)
            nrm = d / dist
            delta = ra + rb - dist
            rstar = ra * rb / (ra + rb)
            mstar = 1.0 / (1.0 / st["c_mass"][ca] + 1.0 / st["c_mass"][cb])
            cpt = pos[a] + nrm * (ra - 0.5 * delta)
            vrel = vel_at(cb, cpt) - vel_at(ca, cpt)
            vn = np.dot(vrel, nrm)
            out = normal_force(delta, vn, rstar, mstar, p)
            if out is None:
                continue
            fn, rep, arad = out
            vt = vrel - vn * nrm
            xi, ft, sliding = tangential(st["hist"].get((a, b), np.zeros(3)), nrm, vt,
                                         st["world_dt"][w], arad, mstar, rep, p)
            _count(res, sliding, delta)
            res.pair_hist[(a, b)] = xi
            f_b = fn * nrm + ft
            for i, c, sgn in ((b, cb, 1.0), (a, ca, -1.0)):
                res.force[i] += sgn * f_b
                res.torque[i] += np.cross(cpt - st["c_pos"][c], sgn * f_b)
                if rolling == "A":
                    roll_a(i, c, cpt, rep, p.mu_r)
            if rolling == "C":
                m = rolling_epsd(st["rhist"].get((a, b), np.zeros(3)), nrm,
                                 st["c_omega"][cb] - st["c_omega"][ca], st["world_dt"][w],
                                 arad, rstar, rep, p)
                res.pair_rhist[(a, b)] = m
                res.torque[b] += m
                res.torque[a] -= m
    for i in range(n):
        if not active[i]:
            continue
        w = cworld[i]
        c = clump[i]
        tab = worlds[w].materials
        for k, wall in enumerate(st["walls"][w]):
            if wall["type"] == "plane":
                dist, nrm = plane_distance(wall["origin"], wall["normal"], wall["u"], wall["v"],
                                           wall["hu"], wall["hv"], pos[i])
            else:
                dist, nrm = tube_distance(wall["origin"], wall["axis"], wall["r_in"],
                                          wall["r_out"], wall["length"], pos[i])
            ri = st["s_radius"][i]
            delta = ri - dist
            mat = st["s_material_name"][i]
            p = pair_props(tab.material(wall["material"]), tab.material(mat),
                           tab.interaction(wall["material"], mat))
            cpt = pos[i] - nrm * (ri - 0.5 * delta)
            # the wall's surface velocity there: translation + spin about its origin
            spin = wall.get("omega", np.zeros(3))
            vrel = vel_at(c, cpt) - (wall["velocity"] + np.cross(spin, cpt - wall["origin"]))
            vn = np.dot(vrel, nrm)
            out = normal_force(delta, vn, ri, st["c_mass"][c], p)
            if out is None:
                continue
            fn, rep, arad = out
            vt = vrel - vn * nrm
            xi, ft, sliding = tangential(st["w_hist"][i, k], nrm, vt, st["world_dt"][w], arad,
                                         st["c_mass"][c], rep, p)
            _count(res, sliding, delta)
            res.wall_hist[i, k] = xi
            f = fn * nrm + ft
            res.force[i] += f
            res.torque[i] += np.cross(cpt - st["c_pos"][c], f)
            res.wall_force[i, k] = -f
            if rolling == "A":
                roll_a(i, c, cpt, rep, p.mu_r)
            elif rolling == "C":
                m = rolling_epsd(st["w_rhist"][i, k], nrm, st["c_omega"][c] - spin,
                                 st["world_dt"][w],
                                 arad, ri, rep, p)
                res.wall_rhist[i, k] = m
                res.torque[i] += m
    return res
