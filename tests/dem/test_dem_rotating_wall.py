"""Walls that turn about their axis (a drum): analytic checks and the naive reference.

A tube turning about its own axis and a plane turning about its normal stay where they are;
only their surface moves, at ``v + omega x (p - origin)`` (``demcal.dem.walls``). These tests
check that this surface velocity drives the contacts' tangential (and type-C rolling)
relative motion:

- a sled (three spheres in a row, which cannot roll) in a horizontal drum is carried up with
  the wall and slips where friction can no longer hold it: near ``atan(mu)``, exactly at the
  angle a rigid-body balance gives for its two contacts;
- a flat clump set on an end wall that starts turning slides with the acceleration
  ``mu g`` until it moves (and turns) with the wall;
- the engine's forces and histories with turning walls equal the naive reference's;
- a wall turning at zero is bit for bit a wall that cannot turn; batched worlds at different
  rates give each world's results alone.

A single sphere would not do for the first two: free to roll, it is not carried up a drum
(it rolls at the bottom) and on a turning plate it reaches 2/7 of the wall's speed, then
rolls.
"""

from __future__ import annotations

import hashlib
import math

import numpy as np
import pytest
import test_dem_reference as reference
from scipy.optimize import brentq
from test_dem_determinism import digest
from worlds import random_world, table

from demcal.dem import _config
from demcal.dem.materials import Interaction, Material
from demcal.dem.shapes import sphere_template, template_from_spheres
from demcal.dem.simulation import Simulation
from demcal.dem.state import ClumpGroup, World
from demcal.dem.walls import Drum, PlaneWall, TubeWall, surface_velocity
from demcal.errors import InputError

G = 9.81
SOFT = Material("p", density=1000.0, shear_modulus=1.0e6, poisson=0.3)
RADIUS = 4.0e-3  # sphere radius of the sleds, m


# ------------------------------------------------------------------------------- the drum
def drum_slip_angle(mu: float, drum_radius: float, sled: tuple[float, float],
                    omega: float = 0.0) -> float:
    """Angle from the bottom (deg) at which a sled carried up a drum's inner wall slips.

    The sled's two end spheres (``sled`` = their radius and their centres' distance either
    side of its centre of mass, m) touch the wall (radius ``drum_radius``, m) at the angles
    ``theta +/- alpha``; carried round at ``omega`` (rad/s) it is a rigid body in uniform
    circular motion: its forces give the centripetal acceleration, its moment about its
    centre of mass is zero. It slips when both contacts hold a friction of ``mu`` times their
    normal force: three equations (two forces, one moment) for the two normal forces and
    ``theta``. For a sled small against the drum this is ``atan(mu)``; the moment of the
    friction, which acts at the wall and not at the centre of mass, raises it by ~ r / R.
    """
    radius, half_span = sled
    r_centres = drum_radius - radius
    alpha = math.asin(half_span / r_centres)
    r_com = r_centres * math.cos(alpha)

    def radial(phi):  # from the axis outwards; phi from the bottom, rising with the wall
        return np.array([math.sin(phi), -math.cos(phi)])

    def tangent(phi):  # the wall's motion there
        return np.array([math.cos(phi), math.sin(phi)])

    def moment_left(theta):
        phis = (theta - alpha, theta + alpha)
        # per unit normal force: the wall's push inwards and the friction along its motion
        push = [-radial(p) + mu * tangent(p) for p in phis]
        need = np.array([0.0, G]) - omega**2 * r_com * radial(theta)  # per unit mass
        normal = np.linalg.solve(np.column_stack(push), need)
        arms = [drum_radius * radial(p) - r_com * radial(theta) for p in phis]
        return sum(n * (a[0] * f[1] - a[1] * f[0])
                   for n, a, f in zip(normal, arms, push, strict=True))

    return math.degrees(brentq(moment_left, 0.01, 1.5))


def test_the_drum_reference_is_atan_mu_for_a_small_sled():
    sled = (4e-3, 6e-3)
    assert drum_slip_angle(0.5, 1e3, sled) == pytest.approx(math.degrees(math.atan(0.5)),
                                                           abs=1e-3)
    # larger for a sled that is not small against the drum (its friction's moment)
    assert drum_slip_angle(0.5, 0.3, sled) > math.degrees(math.atan(0.5)) + 0.3


def sled_template():
    """Three spheres in a row along x (1.5 radii apart): lying along the wall's motion it
    touches a drum with its two ends and cannot roll."""
    s = 1.5 * RADIUS
    return template_from_spheres([[-s, 0.0, 0.0], [0.0, 0.0, 0.0], [s, 0.0, 0.0]],
                                 [RADIUS] * 3), s


def drum(drum_radius: float) -> Drum:
    """A horizontal drum (axis y, centre at the origin), 4 cm wide."""
    return Drum(centre=np.zeros(3), axis=np.array([0.0, 1.0, 0.0]), radius=drum_radius,
                width=0.04, thickness=0.01)


def drum_world(mu: float, drum_radius: float, mu_r: float = 0.0) -> World:
    """A sled at the bottom of a horizontal drum (walls 0-2), its two end spheres touching
    the shell, its sides clear of the end walls."""
    mats = table(Interaction(0.5, mu), Interaction(0.5, mu, rolling_friction=mu_r),
                 particle=SOFT)
    sled, s = sled_template()
    z = -math.sqrt((drum_radius - RADIUS) ** 2 - s**2) - 1e-6
    group = ClumpGroup(sled, "p", 1, positions=np.array([[0.0, 0.0, z]]))
    lim = drum_radius + 0.1
    return World(mats, [group], walls=drum(drum_radius).walls(), domain_lo=(-lim, -0.1, -lim),
                 domain_hi=(lim, 0.1, lim))


def drum_angles(sim: Simulation, omega: float, duration: float, chunk: int = 10):
    """Turn the drum of world 0 at ``omega`` (rad/s, about +y) and record the sled's angle
    from the bottom (deg), rising with the wall, every ``chunk`` steps."""
    drum(1.0).set_speed(sim, 0, 0, omega)  # walls 0-2 (only the drum's axis matters here)
    angles = []
    for _ in range(int(duration / (float(sim.dt[0]) * chunk))):
        sim.advance(chunk)
        x, _, z = sim.clump_positions(0)[0]
        # +y spin: the bottom moves towards -x, so the sled rises on the -x side
        angles.append(math.degrees(math.atan2(-x, -z)))
    return np.array(angles)


@pytest.mark.parametrize("rolling", ["none", "C"])
def test_a_sled_in_a_turning_drum_slips_at_the_friction_angle(rolling):
    """Carried up at 0.3 rad/s (2.9 rpm) in a 0.3 m drum, the sled slips, swings past the
    slip angle and back like a pendulum about it (still sliding), so the midpoint of its
    highest and the following lowest angle is the slip angle; the swing's amplitude
    (~2.8 deg here) cancels to first order, the speed's effect on the normal forces is in
    the reference. Measured 2026-11-27: 27.010 deg (no rolling friction) and 27.087 deg
    (type C, mu_r 0.1) against 27.035 deg for the rigid sled at this speed; atan(0.5) =
    26.565 deg, the difference being the sled's size against the drum's (r / R = 1.3 %).
    A type-C rolling spring must not resist a sled carried round with the wall (its spin
    relative to the wall is zero then); one that saw the sled's own spin measured 27.14
    deg (type A, which does)."""
    mu, drum_radius, omega = 0.5, 0.3, 0.3
    sim = Simulation([drum_world(mu, drum_radius, 0.1 if rolling == "C" else 0.0)],
                     rolling_friction=rolling)
    sim.run(0.2)  # settle at the bottom
    swing = 2 * math.pi * math.sqrt((drum_radius - RADIUS) / G)  # a pendulum's period
    angles = drum_angles(sim, omega, math.radians(27.0) / omega + swing)
    top = int(np.argmax(angles))
    assert top < len(angles) - 5, "the sled never stopped rising"
    low = top + int(np.argmin(angles[top:]))
    slip = 0.5 * (angles[top] + angles[low])
    want = drum_slip_angle(mu, drum_radius, (RADIUS, 1.5 * RADIUS), omega)
    print(f"rolling {rolling}: highest {angles[top]:.3f} deg, then lowest {angles[low]:.3f}, "
          f"slip angle {slip:.3f} deg; rigid sled {want:.3f}; atan(mu) "
          f"{math.degrees(math.atan(mu)):.3f}")
    assert angles[top] > want + 1.0  # carried to the slip angle and beyond (the swing)
    assert abs(slip - want) < 0.15
    assert abs(slip - math.degrees(math.atan(mu))) < 1.0


@pytest.mark.parametrize(("rolling", "mu_r"), [("C", 0.1), ("A", 0.1), ("none", 0.0)])
def test_a_sphere_rolling_in_a_turning_drum_sits_where_tan_theta_is_mu_r(rolling, mu_r):
    """A single sphere in a drum turning at 1 rad/s (0.1 m drum) is not carried up to the
    friction angle: it rolls on the wall (its spin omega R / r keeps its contact point moving
    with the surface) and sits where the wall's friction, m g sin(theta), turns it against the
    rolling resistance, mu_r r m g cos(theta): tan(theta) = mu_r (the bottom without rolling
    friction). Started there with that spin, its mean angle over the second second: measured
    2026-11-27 5.715 deg (type C), 5.711 deg (type A) against atan(0.1) = 5.711 (swinging
    +-0.006 deg), -0.0001 deg without rolling friction."""
    drum_radius, omega = 0.1, 1.0
    mats = table(Interaction(0.5, 0.5), Interaction(0.5, 0.5, rolling_friction=mu_r),
                 particle=SOFT)
    theta = math.atan(mu_r)
    centre = drum_radius - RADIUS + 2e-6
    group = ClumpGroup(sphere_template(RADIUS), "p", 1,
                       positions=np.array([[-centre * math.sin(theta), 0.0,
                                            -centre * math.cos(theta)]]),
                       angular_velocities=np.array([[0.0, omega * drum_radius / RADIUS, 0.0]]))
    world = World(mats, [group], walls=drum(drum_radius).walls(),
                  domain_lo=(-0.2, -0.1, -0.2), domain_hi=(0.2, 0.1, 0.2))
    sim = Simulation([world], rolling_friction=rolling)
    drum(drum_radius).set_speed(sim, 0, 0, omega)
    sim.run(1.0)
    angles = drum_angles(sim, omega, 1.0, chunk=20)
    spin = sim.arrays["c_omega"][0, 1]
    print(f"rolling {rolling} mu_r {mu_r}: mean angle {angles.mean():.4f} deg "
          f"(+-{angles.std():.4f}), atan(mu_r) {math.degrees(theta):.4f}; spin {spin:.3f} "
          f"rad/s, omega R / r {omega * drum_radius / RADIUS:.3f}")
    assert abs(angles.mean() - math.degrees(theta)) < 0.02
    assert angles.std() < 0.05
    assert spin == pytest.approx(omega * drum_radius / RADIUS, rel=0.01)
    # the drum's drive holds the sphere's weight off the bottom: the contact force's torque
    # on the shell about its axis (y), against the turning, is m g sin(theta) R (the other
    # components are about the shell's origin, its base, off the sphere's plane)
    torque = sim.wall_torques(0)[0]
    hold = float(sim.clump_masses(0)[0]) * G * math.sin(math.radians(angles[-1])) * drum_radius
    print(f"torque on the shell {torque} N m; m g sin(theta) R {hold:.4e}")
    assert -torque[1] == pytest.approx(hold, rel=0.005, abs=1e-8)


# ----------------------------------------------------------------------- the end wall
def end_wall_world(mu: float, x0: float) -> World:
    """A flat clump (three spheres in a triangle) resting on a plane z = 0 that may turn
    about its normal (+z through the origin), at ``x0`` from the axis (m)."""
    mats = table(Interaction(0.5, mu), Interaction(0.5, mu), particle=SOFT)
    side = 1.6 * RADIUS
    h = side / math.sqrt(3.0)
    tri = template_from_spheres([[h, 0.0, 0.0], [-h / 2, side / 2, 0.0],
                                 [-h / 2, -side / 2, 0.0]], [RADIUS] * 3)
    group = ClumpGroup(tri, "p", 1, positions=np.array([[x0, 0.0, RADIUS - 1e-6]]))
    plate = PlaneWall(origin=np.zeros(3), normal=np.array([0.0, 0.0, 1.0]), name="end")
    return World(mats, [group], walls=[plate], domain_lo=(-0.2, -0.2, -0.1),
                 domain_hi=(0.2, 0.2, 0.1))


def test_a_clump_on_a_turning_end_wall_spins_up_at_mu_g():
    """The plate starts turning at 2 rad/s under a clump at rest 5 cm from its axis (surface
    speed 0.1 m/s): the clump slides, accelerated by friction at mu g (gravity presses it on
    the plate: the normal force is m g), until it moves with the surface, then turns with
    the plate (the friction holds its centripetal force, 0.2 of 2.9 m/s^2). While the relative
    speed falls from 95 % to 70 % of the surface speed the acceleration is measured:
    2026-11-27 -0.3 % off mu g (the clump's three contacts slide in slightly different
    directions while its spin lags the plate's, which costs a little of the net friction)."""
    mu, x0, omega = 0.3, 0.05, 2.0
    sim = Simulation([end_wall_world(mu, x0)], rolling_friction="none")
    sim.run(0.2)  # settle
    sim.set_wall_angular_velocity(0, 0, [0.0, 0.0, omega])
    times, vel, pos = [], [], []
    for _ in range(200):
        sim.advance(5)
        times.append(float(sim.time[0]))
        vel.append(sim.clump_velocities(0)[0])
        pos.append(sim.clump_positions(0)[0])
    times, vel, pos = np.array(times), np.array(vel), np.array(pos)
    surface = np.cross([0.0, 0.0, omega], pos)
    slip = np.linalg.norm(surface - vel, axis=1) / (omega * x0)
    i1 = int(np.argmax(slip < 0.95))
    i2 = int(np.argmax(slip < 0.7))
    acc = np.linalg.norm(vel[i2] - vel[i1]) / (times[i2] - times[i1])
    spin = sim.arrays["c_omega"][0]
    print(f"acceleration while sliding {acc:.4f} m/s^2, mu g {mu * G:.4f} "
          f"({acc / (mu * G) - 1:+.2%}); final slip {slip[-1]:.1e} of the surface speed, "
          f"spin {spin[2]:.5f} rad/s")
    assert 0 < i1 < i2
    assert acc == pytest.approx(mu * G, rel=0.005)
    # then it moves and turns with the plate
    assert slip[-1] < 1e-3
    assert spin[2] == pytest.approx(omega, rel=1e-3)
    assert np.hypot(pos[-1, 0], pos[-1, 1]) == pytest.approx(x0, rel=0.05)


def test_a_turning_end_wall_gives_twice_the_kinetic_energy_it_leaves():
    """Energy bookkeeping of the spin-up: the wall's work on the clump (its contact forces
    times the wall's surface velocity at the contact points, step by step) is twice the
    kinetic energy the clump gains, as a belt's on a block it brings up to its speed (the
    impulse m V times V; half of it dissipated by sliding), and that gain plus the sliding
    dissipation (force times slip velocity at the contacts) is the wall's work. Measured
    2026-11-27: work / (2 gain) = 0.999997, (gain + dissipation) / work = 0.997 (the contact
    points taken on the plane, the clump's on-step velocity estimate)."""
    mu, x0, omega = 0.3, 0.05, 2.0
    sim = Simulation([end_wall_world(mu, x0)], rolling_friction="none")
    sim.run(0.2)
    before = sim.kinetic_energy(0)
    sim.set_wall_angular_velocity(0, 0, [0.0, 0.0, omega])
    a = sim.arrays
    dt = float(sim.dt[0])
    work = dissipated = drive = 0.0
    for _ in range(1000):  # 0.086 s: the slip ends after ~0.055 s
        sim.advance(1)
        drive -= omega * float(sim.wall_torques(0)[0, 2]) * dt  # -omega . torque
        force = -a["s_wall_force"][:, 0, :]  # on the clump's spheres
        contact = a["s_pos"].copy()
        contact[:, 2] = 0.0
        surface = np.cross([0.0, 0.0, omega], contact)
        body = a["c_veval"][0] + np.cross(a["c_omega"][0], contact - a["c_pos"][0])
        work += float(np.sum(force * surface)) * dt
        dissipated -= float(np.sum(force * (body - surface))) * dt
    gain = sim.kinetic_energy(0) - before
    print(f"wall's work {work:.5e} J, kinetic energy gained {gain:.5e} J, dissipated "
          f"{dissipated:.5e} J; work / (2 gain) {work / (2 * gain):.6f}, (gain + dissipated) "
          f"/ work {(gain + dissipated) / work:.4f}")
    assert gain == pytest.approx(0.5 * float(sim.clump_masses(0)[0]) * (omega * x0) ** 2,
                                 rel=0.02)
    assert work == pytest.approx(2.0 * gain, rel=1e-3)
    assert drive == pytest.approx(work, rel=1e-9)  # Simulation.wall_torques: the same work
    assert gain + dissipated == pytest.approx(work, rel=0.01)


# ----------------------------------------------------------------------- the reference
@pytest.mark.parametrize(("seed", "rolling"), [(11, "A"), (12, "C"), (13, "none")])
def test_turning_walls_equal_the_naive_reference(seed, rolling):
    """Every wall of the reference's random worlds (a rectangle, an inclined plane, a tube)
    turning about its axis at 60 rad/s (surface speeds ~0.3 m/s, as fast as the particles):
    forces, torques, wall forces, tangential and rolling histories as the reference's."""
    out = reference.compare(seed, rolling, spin=60.0)
    print(seed, rolling, out)
    reference._check(out)


@pytest.mark.parametrize("rolling", ["C"])
def test_turning_walls_under_the_cuda_simulator_equal_the_naive_reference(rolling):
    import json

    out = json.loads(reference._run_cudasim(rolling, spin=60.0))
    print(rolling, out)
    reference._check(out)


@pytest.mark.gpu
@pytest.mark.filterwarnings("ignore:.*will likely result in GPU under-utilization")
@pytest.mark.parametrize("rolling", ["A", "C"])
def test_turning_walls_on_a_gpu_equal_the_naive_reference(rolling):
    from demcal.dem.backends import cuda_available

    if not cuda_available():
        pytest.skip("no CUDA GPU")
    out = reference.compare(6, rolling, "cuda", spin=60.0)
    print(rolling, out)
    for k, v in out.items():  # FMA contraction on the GPU, as in test_dem_reference
        if not k.startswith("n_"):
            assert v < 1e-10, (k, out)


# ------------------------------------------------------------------ nothing else changes
def _random_run(spin: str) -> str:
    """A short crowded run (plane, inclined plane, tube, all moving, type C) whose walls do
    not turn: ``spin`` = "absent" (the default), "zero" (zeros given), "reset" (set turning,
    then back to zero before the first step)."""
    rng = np.random.default_rng(3)
    mats = table(Interaction(0.4, 0.5, 0.1, surface_energy=0.5), Interaction(0.5, 0.6, 0.05))
    world = random_world(rng, mats, 12)
    if spin == "zero":
        for wall in world.walls:
            wall.angular_velocity = np.zeros(3)
    sim = Simulation([world], rolling_friction="C", dt_fraction=0.2)
    if spin == "reset":
        for k in range(len(world.walls)):
            sim.set_wall_angular_velocity(0, k, 5.0 * sim.arrays["wall_geom"][0, k, 0:3])
            sim.set_wall_angular_velocity(0, k, [0.0, 0.0, 0.0])
    saved = _config.MAX_OVERLAP_FRACTION, _config.MAX_SPEED
    _config.MAX_OVERLAP_FRACTION, _config.MAX_SPEED = 10.0, 1e9  # random crowding
    try:
        sim.advance(300)
    finally:
        _config.MAX_OVERLAP_FRACTION, _config.MAX_SPEED = saved
    return digest(sim) + hashlib.sha256(sim.arrays["w_rhist"].tobytes()).hexdigest()


def test_walls_turning_at_zero_are_bitwise_walls_that_do_not_turn():
    """The kernels take a non-turning wall's velocity as before walls could turn (the very
    floats: ``surface_velocity`` and ``spin_relative_to`` return their input), so a run is bit
    for bit the same whether the spin is left out, given as zeros or set and reset. (Before
    and after digests of the determinism bed and of this run, with the code before walls
    could turn, were compared when this was written: identical.)"""
    base = _random_run("absent")
    assert _random_run("zero") == base
    assert _random_run("reset") == base


def test_batched_worlds_turning_at_different_rates_equal_each_alone():
    """A drum at 0.3 rad/s, an end wall at 2 rad/s and a drum at -0.5 rad/s in one
    simulation: each world's state equals its run alone, bit for bit."""
    def worlds():
        return [drum_world(0.5, 0.3), end_wall_world(0.3, 0.05), drum_world(0.4, 0.2)]

    rates = ([0.0, 0.3, 0.0], [0.0, 0.0, 2.0], [0.0, -0.5, 0.0])

    def run(sim, pairs):
        for w, rate in pairs:
            for k in range(len(sim.worlds[w].walls)):  # a drum's three walls, or the plate
                sim.set_wall_angular_velocity(w, k, rate)
        sim.advance(800)

    batch = Simulation(worlds(), rolling_friction="C")
    run(batch, enumerate(rates))
    for w, rate in enumerate(rates):
        alone = Simulation([worlds()[w]], rolling_friction="C")
        run(alone, [(0, rate)])
        assert digest(batch, w) == digest(alone, 0), w
        # the sled moved: the wall's turning reached it
        assert np.linalg.norm(alone.clump_velocities(0)[0]) > 1e-3


def test_a_wall_may_only_turn_about_its_axis():
    world = drum_world(0.5, 0.3)
    world.walls[0].angular_velocity = np.array([0.1, 1.0, 0.0])  # the shell
    with pytest.raises(InputError, match="along its axis"):
        Simulation([world])
    sim = Simulation([end_wall_world(0.3, 0.05)])
    with pytest.raises(InputError, match="along its axis"):
        sim.set_wall_angular_velocity(0, 0, [1.0, 0.0, 0.0])
    sim.set_wall_angular_velocity(0, 0, [0.0, 0.0, -3.0])
    assert list(sim.wall_angular_velocity(0, 0)) == [0.0, 0.0, -3.0]


def test_a_snapshot_keeps_the_walls_spin():
    sim = Simulation([end_wall_world(0.3, 0.05)])
    sim.set_wall_angular_velocity(0, 0, [0.0, 0.0, 1.5])
    sim.advance(10)
    state = sim.state_dict()
    again = Simulation([end_wall_world(0.3, 0.05)])
    again.load_state(state)
    assert list(again.wall_angular_velocity(0, 0)) == [0.0, 0.0, 1.5]
    # a snapshot from before walls could turn: the walls' description's spin (none) stays
    del state["wall_omega"]
    older = Simulation([end_wall_world(0.3, 0.05)])
    older.load_state(state)
    assert list(older.wall_angular_velocity(0, 0)) == [0.0, 0.0, 0.0]
    sim.advance(10)
    older.set_wall_angular_velocity(0, 0, [0.0, 0.0, 1.5])
    older.advance(10)
    assert digest(older, 0) == digest(sim, 0)


def test_a_drums_walls_turn_as_one_rigid_body():
    """The shell and both end walls of a :class:`Drum` (tilted axis, off the origin): the
    surface velocity at points of each is ``omega x (p - centre)``, and the end walls lie
    across the shell's ends."""
    centre = np.array([0.1, -0.2, 0.3])
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    rig = Drum(centre=centre, axis=3.0 * axis, radius=0.2, width=0.1, angular_speed=-1.5)
    shell, low, high = rig.walls()
    omega = -1.5 * axis
    side = np.cross(axis, [1.0, 0.0, 0.0])
    side /= np.linalg.norm(side)
    points = [(shell, centre + 0.2 * side + 0.03 * axis), (low, centre - 0.05 * axis + 0.1 * side),
              (high, centre + 0.05 * axis - 0.07 * side)]
    for wall, p in points:
        origin = wall.base if isinstance(wall, TubeWall) else wall.origin
        got = surface_velocity((0.0, 0.0, 0.0), tuple(wall.angular_velocity), tuple(p - origin))
        np.testing.assert_allclose(got, np.cross(omega, p - centre), atol=1e-15)
    np.testing.assert_allclose(low.origin, shell.base)
    np.testing.assert_allclose(high.origin, shell.base + 0.1 * axis)
    with pytest.raises(InputError, match="radius"):
        Drum(centre=centre, axis=axis, radius=0.0, width=0.1).walls()
